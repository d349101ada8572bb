"""Tests of legato_drake.invariants: phi (DHB motion invariants) and L_invar."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from legato_drake import invariants as inv

FAST = settings(max_examples=25, deadline=None)


# ---------------------------------------------------------------------------------------------
# test data and an independent reference


def rodrigues(rotation_vector: np.ndarray) -> np.ndarray:
    """Rotation matrix of one rotation vector (written independently of the module)."""
    angle = np.linalg.norm(rotation_vector)
    if angle < 1e-12:
        return np.eye(3)
    k = rotation_vector / angle
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * kx + (1 - np.cos(angle)) * kx @ kx


def log_so3(rotation: np.ndarray) -> np.ndarray:
    """Rotation vector of a rotation matrix with angle < pi (independent of the module)."""
    angle = np.arccos(np.clip((np.trace(rotation) - 1) / 2, -1, 1))
    vee = np.array([rotation[2, 1] - rotation[1, 2], rotation[0, 2] - rotation[2, 0],
                    rotation[1, 0] - rotation[0, 1]]) / 2
    return vee if angle < 1e-12 else vee * angle / np.sin(angle)


def smooth_trajectory(seed: int, n_poses: int, dt: float = 0.1,
                      speed: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Poses sampled at 10 Hz from a random smooth curve (sums of sinusoids plus drift) for the
    position and the rotation vector: positions (n, 3) and rotation matrices (n, 3, 3)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n_poses)[:, None] * dt * speed

    def curve(drift: float, amplitude: float) -> np.ndarray:
        out = t * rng.normal(size=3) * drift
        for _ in range(3):
            omega, phase = rng.uniform(1.0, 3.0), rng.uniform(0, 2 * np.pi, size=3)
            out = out + amplitude * rng.normal(size=3) * np.sin(omega * t + phase)
        return out

    positions = curve(0.1, 0.05) + rng.normal(size=3)
    rotation_vectors = curve(0.5, 0.3)
    return positions, np.stack([rodrigues(r) for r in rotation_vectors])


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    return rodrigues(rng.normal(size=3) * 2.0)


def reference_phi(positions: np.ndarray, rotations: np.ndarray) -> np.ndarray:
    """Appendix A transcribed literally (atan2, exact normalisation, y flipped to agree with
    the previous y), one pose sequence at a time. Only valid for well-conditioned motion."""
    n = len(positions) - 1
    linear = [rotations[0].T @ (positions[k + 1] - positions[k]) for k in range(n)]
    angular = [log_so3(rotations[k].T @ rotations[k + 1]) for k in range(n)]

    def block(v: list[np.ndarray]) -> np.ndarray:
        x = [vk / np.linalg.norm(vk) for vk in v]
        y = []
        for k in range(n - 1):
            yk = np.cross(x[k], x[k + 1])
            yk = yk / np.linalg.norm(yk)
            if k > 0 and yk @ y[-1] < 0:
                yk = -yk
            y.append(yk)
        rows = []
        for k in range(n - 2):
            th1 = np.arctan2(np.cross(x[k], x[k + 1]) @ y[k], x[k] @ x[k + 1])
            th2 = np.arctan2(np.cross(y[k], y[k + 1]) @ x[k + 1], y[k] @ y[k + 1])
            rows.append([np.linalg.norm(v[k]), np.sin(th1), np.sin(2 * th1), np.sin(th2),
                         np.sin(2 * th2)])
        return np.array(rows)

    return np.concatenate([block(linear), block(angular)], -1)


def well_conditioned(positions: np.ndarray, rotations: np.ndarray) -> bool:
    """Segments that move, turn, and whose osculating planes do not jump by ~90 degrees."""
    linear = np.diff(positions, axis=0)
    angular = np.stack([log_so3(rotations[k].T @ rotations[k + 1]) for k in range(len(linear))])
    for v in (linear, angular):
        x = v / np.linalg.norm(v, axis=-1, keepdims=True)
        y = np.cross(x[:-1], x[1:])
        turn = np.linalg.norm(y, axis=-1)
        if np.linalg.norm(v, axis=-1).min() < 1e-4 or turn.min() < 0.02:
            return False
        y = y / turn[:, None]
        if np.abs((y[:-1] * y[1:]).sum(-1)).min() < 0.3:
            return False
    return True


trajectories = st.builds(lambda seed, n: smooth_trajectory(seed, n),
                         st.integers(0, 2**31 - 1), st.integers(4, 12))


def rigidly_moved(positions: np.ndarray, rotations: np.ndarray,
                  seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    q, t = random_rotation(rng), rng.normal(size=3) * 3
    return positions @ q.T + t, q @ rotations


# ---------------------------------------------------------------------------------------------
# conversions


def test_rpy_matrix_round_trip_and_convention() -> None:
    rng = np.random.default_rng(0)
    rpy = rng.uniform([-3, -1.5, -3], [3, 1.5, 3], size=(50, 3))
    matrices = inv.rpy_to_matrix(rpy)
    np.testing.assert_allclose(inv.matrix_to_rpy(matrices), rpy, atol=1e-9)
    r, p, y = 0.3, -0.4, 1.1  # R = Rz(yaw) Ry(pitch) Rx(roll), Drake's RollPitchYaw
    rz = rodrigues(np.array([0, 0, y]))
    ry = rodrigues(np.array([0, p, 0]))
    rx = rodrigues(np.array([r, 0, 0]))
    np.testing.assert_allclose(inv.rpy_to_matrix(np.array([r, p, y])), rz @ ry @ rx, atol=1e-12)
    np.testing.assert_allclose(inv.quaternion_to_matrix(inv.rpy_to_quaternion(rpy)), matrices,
                               atol=1e-12)


def test_conventions_match_drake() -> None:
    drake_math = pytest.importorskip("pydrake.math")
    rng = np.random.default_rng(6)
    for rpy in rng.uniform([-3, -1.5, -3], [3, 1.5, 3], size=(20, 3)):
        drake_rpy = drake_math.RollPitchYaw(rpy)
        matrix = drake_rpy.ToRotationMatrix().matrix()
        np.testing.assert_allclose(inv.rpy_to_matrix(rpy), matrix, atol=1e-12)
        wxyz = drake_rpy.ToQuaternion().wxyz()
        wxyz = wxyz * np.sign(wxyz[0])  # the sign with w >= 0
        ours = inv.rpy_to_quaternion(rpy)
        np.testing.assert_allclose(ours * np.sign(ours[0]), wxyz, atol=1e-12)
        np.testing.assert_allclose(inv.matrix_to_quaternion(matrix), wxyz, atol=1e-12)
        drake_back = drake_math.RollPitchYaw(drake_math.RotationMatrix(matrix)).vector()
        np.testing.assert_allclose(inv.matrix_to_rpy(matrix), drake_back, atol=1e-9)


def test_quaternion_matrix_round_trip_including_angles_near_pi() -> None:
    rng = np.random.default_rng(1)
    axes = rng.normal(size=(200, 3))
    axes /= np.linalg.norm(axes, axis=-1, keepdims=True)
    angles = np.concatenate([rng.uniform(0, np.pi, 150), np.pi - rng.uniform(0, 1e-6, 50)])
    rotation_vectors = axes * angles[:, None]
    matrices = np.stack([rodrigues(r) for r in rotation_vectors])
    q = inv.matrix_to_quaternion(matrices)
    assert (q[:, 0] >= 0).all()
    np.testing.assert_allclose(inv.quaternion_to_matrix(q), matrices, atol=1e-10)
    q_direct = inv.rotation_vector_to_quaternion(rotation_vectors)
    np.testing.assert_allclose(np.abs((q * q_direct).sum(-1)), 1, atol=1e-10)
    small = rotation_vectors[:150]
    np.testing.assert_allclose(
        inv.quaternion_to_rotation_vector(inv.rotation_vector_to_quaternion(small)), small,
        atol=1e-9)
    tiny = rng.normal(size=(5, 3)) * 1e-9
    np.testing.assert_allclose(
        inv.quaternion_to_rotation_vector(inv.rotation_vector_to_quaternion(tiny)), tiny,
        atol=1e-20)


@FAST
@given(trajectories)
def test_deltas_poses_round_trip(trajectory: tuple[np.ndarray, np.ndarray]) -> None:
    positions, rotations = trajectory
    deltas = inv.poses_to_deltas(positions, rotations)
    assert deltas.shape == (len(positions) - 1, 6)
    rel_p, rel_r = inv.deltas_to_poses(deltas)
    np.testing.assert_allclose(rel_p, (positions - positions[0]) @ rotations[0], atol=1e-10)
    np.testing.assert_allclose(rel_r, rotations[0].T @ rotations, atol=1e-10)
    quats = inv.matrix_to_quaternion(rotations)
    np.testing.assert_allclose(inv.poses_to_deltas(positions, quats), deltas, atol=1e-10)


def test_history_from_observations() -> None:
    dp = torch.arange(6.0).reshape(1, 6)
    de = 10 + torch.arange(6.0).reshape(1, 6)
    history = inv.history_from_observations(dp, de)
    assert history.shape == (1, 2, 6)
    assert history[0, 1].tolist() == [3, 4, 5, 13, 14, 15]


# ---------------------------------------------------------------------------------------------
# phi: values, properties


def test_shapes_and_index_range() -> None:
    deltas = np.random.default_rng(2).normal(size=(7, 6)) * 0.1
    assert inv.invariants_from_deltas(deltas).shape == (5, 10)  # N deltas -> N - 2 rows
    assert inv.invariants_from_deltas(deltas[:3]).shape == (1, 10)  # appendix T = 2
    positions, rotations = inv.deltas_to_poses(deltas)
    assert inv.invariants_from_poses(positions, rotations).shape == (5, 10)
    with pytest.raises(ValueError):
        inv.invariants_from_deltas(deltas[:2])
    # Row k depends on deltas k .. k+2 only: changing the last delta leaves rows < N-3 alone.
    changed = deltas.copy()
    changed[-1] += 0.3
    a, b = inv.invariants_from_deltas(deltas), inv.invariants_from_deltas(changed)
    np.testing.assert_array_equal(a[:-1], b[:-1])
    assert np.abs(a[-1] - b[-1]).max() > 1e-3


def test_known_curves() -> None:
    # planar circle at constant orientation: turning angle alpha per step, no torsion
    alpha, n = 0.2, 8
    angles = alpha * np.arange(n + 1)
    positions = 0.5 * np.stack([np.cos(angles), np.sin(angles), 0 * angles], -1)
    rotations = np.broadcast_to(np.eye(3), (n + 1, 3, 3))
    phi = inv.invariants_from_poses(positions, rotations)
    chord = 2 * 0.5 * np.sin(alpha / 2)
    expected = [chord, np.sin(alpha), np.sin(2 * alpha), 0, 0, 0, 0, 0, 0, 0]
    np.testing.assert_allclose(phi, np.broadcast_to(expected, phi.shape), atol=1e-9)
    # helix, and steps of rotation whose axis precesses steadily: every row is the same
    helix = np.stack([np.cos(angles), np.sin(angles), 0.05 * angles], -1)
    spin = [np.eye(3)]
    for k in range(n):
        spin.append(spin[-1] @ rodrigues(rodrigues(np.array([0, 0, 0.3 * k])) @ [0.05, 0, 0.02]))
    phi = inv.invariants_from_poses(helix, np.stack(spin))
    np.testing.assert_allclose(phi, np.broadcast_to(phi[0], (n - 2, 10)), atol=1e-9)
    assert abs(phi[0, 3]) > 1e-3 and abs(phi[0, 8]) > 1e-3  # both have torsion
    # planar S-curve: y_k is flipped to stay continuous, so th1 changes sign at the inflection
    # and th2 stays 0 (unflipped, th1 would stay >= 0 and th2 would jump to pi there)
    t = np.linspace(-1.5, 1.5, 12)
    s_curve = np.stack([t, 0.3 * np.sin(2 * t), 0 * t], -1)
    phi = inv.invariants_from_poses(s_curve, np.broadcast_to(np.eye(3), (12, 3, 3)))
    assert phi[0, 1] > 0.05 and phi[-1, 1] < -0.05
    np.testing.assert_allclose(phi[:, 3:5], 0, atol=1e-9)
    # straight line, no rotation: only m_p is nonzero
    line = np.outer(np.arange(n + 1), [0.01, 0.02, -0.01])
    phi = inv.invariants_from_poses(line, rotations)
    np.testing.assert_allclose(phi[:, 0], np.linalg.norm([0.01, 0.02, -0.01]), rtol=1e-8)
    np.testing.assert_allclose(phi[:, 1:], 0, atol=1e-8)  # the fade-in bias (eps/|v|)^2


@FAST
@given(trajectories)
def test_matches_appendix_transcription(trajectory: tuple[np.ndarray, np.ndarray]) -> None:
    assume(well_conditioned(*trajectory))
    reference = reference_phi(*trajectory)
    # the smooth fallbacks move well-defined values by O((eps / |segment|)^2) only
    np.testing.assert_allclose(inv.invariants_from_poses(*trajectory), reference, atol=1e-5)
    np.testing.assert_allclose(inv.invariants_from_poses(*trajectory, eps=1e-9), reference,
                               atol=1e-9)


@FAST
@given(trajectories, st.integers(0, 2**31 - 1))
def test_invariant_to_rigid_transform_of_world(trajectory: tuple[np.ndarray, np.ndarray],
                                               seed: int) -> None:
    assume(well_conditioned(*trajectory))
    positions, rotations = trajectory
    phi = inv.invariants_from_poses(positions, rotations)
    moved_p, moved_r = rigidly_moved(positions, rotations, seed)
    np.testing.assert_allclose(inv.invariants_from_poses(moved_p, moved_r), phi, atol=1e-8)
    # quaternion form, with arbitrary quaternion signs
    signs = np.random.default_rng(seed).choice([-1.0, 1.0], size=(len(positions), 1))
    quats = inv.matrix_to_quaternion(moved_r) * signs
    np.testing.assert_allclose(inv.invariants_from_poses(moved_p, quats), phi, atol=1e-8)


@FAST
@given(trajectories)
def test_changes_when_the_motion_changes(trajectory: tuple[np.ndarray, np.ndarray]) -> None:
    assume(well_conditioned(*trajectory))
    positions, rotations = trajectory
    phi = inv.invariants_from_poses(positions, rotations)
    slow = inv.invariants_from_poses(positions, rotations, eps=1e-9)
    faster = inv.invariants_from_poses(2 * positions, rotations, eps=1e-9)
    np.testing.assert_allclose(faster[:, 0], 2 * slow[:, 0], rtol=1e-9)  # m_p scales
    np.testing.assert_allclose(faster[:, 1:], slow[:, 1:], atol=1e-9)  # the shape does not
    bent = inv.invariants_from_poses(positions * [1.0, 3.0, 0.3], rotations)
    assert np.abs(bent[:, 1:5] - phi[:, 1:5]).max() > 1e-3  # a different curve
    rotation_vectors = np.stack([log_so3(r) for r in rotations])
    spun = np.stack([rodrigues(1.5 * r) for r in rotation_vectors])
    assert np.abs(inv.invariants_from_poses(positions, spun)[:, 5:] - phi[:, 5:]).max() > 1e-3


@FAST
@given(trajectories)
def test_delta_and_pose_forms_agree(trajectory: tuple[np.ndarray, np.ndarray]) -> None:
    positions, rotations = trajectory
    deltas = inv.poses_to_deltas(positions, rotations)
    phi = inv.invariants_from_poses(positions, rotations)
    np.testing.assert_allclose(inv.invariants_from_deltas(deltas), phi, atol=1e-8)
    rel_p, rel_r = inv.deltas_to_poses(deltas)
    np.testing.assert_allclose(inv.invariants_from_poses(rel_p, rel_r), phi, atol=1e-8)


@FAST
@given(trajectories, st.integers(0, 2**31 - 1))
def test_numpy_and_torch_agree(trajectory: tuple[np.ndarray, np.ndarray], seed: int) -> None:
    positions, rotations = trajectory
    deltas = inv.poses_to_deltas(positions, rotations)
    phi = inv.invariants_from_deltas(deltas)
    phi_t = inv.invariants_from_deltas(torch.from_numpy(deltas))
    assert isinstance(phi, np.ndarray) and phi_t.dtype == torch.float64
    np.testing.assert_allclose(phi_t.numpy(), phi, atol=1e-6)
    quats = inv.matrix_to_quaternion(rotations)
    for rot in (rotations, quats):
        np.testing.assert_allclose(
            inv.invariants_from_poses(torch.from_numpy(positions), torch.from_numpy(rot)).numpy(),
            inv.invariants_from_poses(positions, rot), atol=1e-6)
    noise = np.random.default_rng(seed).normal(size=6) * 0.02
    history, demo = deltas[:-1], deltas[-1]
    loss_np = inv.invariant_loss(history, demo + noise, demo)
    loss_t = inv.invariant_loss(*(torch.from_numpy(a) for a in (history, demo + noise, demo)))
    np.testing.assert_allclose(loss_t.item(), loss_np, atol=1e-6)


def test_float32_and_batch_dims() -> None:
    rng = np.random.default_rng(3)
    deltas = rng.normal(size=(2, 3, 6, 6)) * 0.05
    phi64 = inv.invariants_from_deltas(torch.from_numpy(deltas))
    assert phi64.shape == (2, 3, 4, 10)
    for i in range(2):
        for j in range(3):
            torch.testing.assert_close(phi64[i, j], inv.invariants_from_deltas(
                torch.from_numpy(deltas[i, j])), rtol=0, atol=1e-12)
    phi32 = inv.invariants_from_deltas(torch.from_numpy(deltas).float())
    assert phi32.dtype == torch.float32
    torch.testing.assert_close(phi32.double(), phi64, rtol=0, atol=1e-4)
    phi32_np = inv.invariants_from_deltas(deltas.astype(np.float32))
    assert phi32_np.dtype == np.float32
    np.testing.assert_allclose(phi32_np, phi64.numpy(), atol=1e-4)
    # a float32 prediction with float64 numpy data: the data follows the prediction
    action = torch.from_numpy(deltas[..., -1, :]).float().requires_grad_()
    loss = inv.invariant_loss(deltas[..., :-1, :], action, deltas[..., -1, :] + 0.01)
    assert loss.dtype == torch.float32 and loss.shape == ()
    loss.backward()
    assert action.grad.shape == (2, 3, 6) and torch.isfinite(action.grad).all()


def test_constants_follow_the_input_device() -> None:
    # the meta device fails on any CPU constant mixed in, so this stands in for CUDA here
    deltas = torch.randn(2, 6, 6, device="meta")
    assert inv.invariants_from_deltas(deltas).device.type == "meta"
    positions, rotations = inv.deltas_to_poses(deltas)
    quats = inv.matrix_to_quaternion(rotations)
    assert inv.invariants_from_poses(positions, quats).device.type == "meta"
    assert inv.invariant_loss(deltas[:, :3], deltas[:, 3:], deltas[:, 3:]).device.type == "meta"


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA")
def test_cuda_matches_cpu() -> None:
    deltas = torch.randn(4, 6, 6, dtype=torch.float64) * 0.05
    cpu = inv.invariants_from_deltas(deltas)
    gpu = inv.invariants_from_deltas(deltas.cuda())
    assert gpu.device.type == "cuda"
    torch.testing.assert_close(gpu.cpu(), cpu)
    prediction = deltas[:, -1].cuda().requires_grad_()
    inv.invariant_loss(deltas[:, :-1].cuda(), prediction, deltas[:, -1].cuda() + 0.01).backward()
    assert torch.isfinite(prediction.grad).all()


# ---------------------------------------------------------------------------------------------
# gradients, degenerate motion


def test_gradcheck_generic_inputs() -> None:
    gen = torch.Generator().manual_seed(4)
    deltas = (torch.randn(2, 5, 6, generator=gen, dtype=torch.float64) * 0.1).requires_grad_()
    assert torch.autograd.gradcheck(inv.invariants_from_deltas, (deltas,))
    positions, rotations = inv.deltas_to_poses(deltas.detach())
    quats = inv.matrix_to_quaternion(rotations).requires_grad_()
    positions.requires_grad_()
    assert torch.autograd.gradcheck(inv.invariants_from_poses, (positions, quats))
    history = deltas.detach()[:, :3]
    action = deltas.detach()[:, 3].clone().requires_grad_()
    demo = deltas.detach()[:, 3] + 0.02
    assert torch.autograd.gradcheck(lambda a: inv.invariant_loss(history, a, demo), (action,))
    chunk = deltas.detach()[:, 2:].clone().requires_grad_()
    demo_chunk = chunk.detach() + 0.02
    assert torch.autograd.gradcheck(
        lambda c: inv.invariant_loss(deltas.detach()[:, :2], c, demo_chunk), (chunk,))


def degenerate_windows() -> torch.Tensor:
    """Windows at rest, with resting segments, straight lines, fixed axes and reversals."""
    moving = torch.tensor([0.01, 0.0, 0.0, 0.0, 0.0, 0.02], dtype=torch.float64)
    turning = torch.tensor([0.0, 0.01, 0.003, 0.01, -0.02, 0.0], dtype=torch.float64)
    zero = torch.zeros(6, dtype=torch.float64)
    return torch.stack([
        torch.stack([zero] * 5),  # at rest
        torch.stack([zero, zero, moving, zero, turning]),  # starts and pauses
        torch.stack([moving] * 5),  # straight line, fixed rotation axis
        torch.stack([moving, -moving, moving, -moving, moving]),  # reversals
        torch.stack([moving, moving, turning, turning, zero]),  # stops at the end
        torch.stack([moving * 1e-9, turning * 1e-9, moving, turning, moving * 1e-12]),
    ])


@pytest.mark.parametrize("dtype", [torch.float64, torch.float32])
def test_degenerate_motion_is_finite(dtype: torch.dtype) -> None:
    windows = degenerate_windows().to(dtype).requires_grad_()
    phi = inv.invariants_from_deltas(windows)
    assert torch.isfinite(phi).all()
    assert phi[0].abs().max() < 1e-6  # at rest: no motion, no angles (up to rounding)
    phi.sum().backward()
    assert torch.isfinite(windows.grad).all()
    positions, rotations = inv.deltas_to_poses(windows.detach())
    quats = inv.matrix_to_quaternion(rotations).requires_grad_()
    positions.requires_grad_()
    for rot in (rotations.clone().requires_grad_(), quats):
        phi = inv.invariants_from_poses(positions, rot)
        assert torch.isfinite(phi).all()
        phi.sum().backward()
        assert torch.isfinite(positions.grad).all() and torch.isfinite(rot.grad).all()
    history = windows.detach()[:, :4]
    action = torch.zeros(len(history), 6, dtype=dtype, requires_grad=True)
    loss = inv.invariant_loss(history, action, windows.detach()[:, 4])
    loss.backward()
    assert torch.isfinite(loss) and torch.isfinite(action.grad).all()


def test_turn_eps_keeps_the_binormal_of_a_straight_move() -> None:
    """A straight move has no plane of its own: at the default turn resolution th2 follows
    sub-micrometre noise; with turn_eps above the noise's turning angle it stays put, while a
    real turn still shows."""
    gen = torch.Generator().manual_seed(3)
    straight = torch.zeros(64, 12, 6, dtype=torch.float64)
    straight[..., 0] = 0.005  # 5 mm a step along x, no rotation
    noisy = straight + 1e-7 * torch.randn(straight.shape, generator=gen, dtype=torch.float64)
    th2 = slice(3, 5)
    for turn_eps, bound in ((inv.DEFAULT_TURN_EPS, None), (0.1, 1e-2)):
        clean_phi = inv.invariants_from_deltas(straight, eps=1e-3, turn_eps=turn_eps)
        noisy_phi = inv.invariants_from_deltas(noisy, eps=1e-3, turn_eps=turn_eps)
        change = (noisy_phi - clean_phi)[..., th2].abs().max().item()
        if bound is None:
            assert change > 0.1  # 1e-7 m of noise moves th2 by O(1)
        else:
            assert change < bound
    turned = straight.clone()
    turned[:, 6:, 1] = 0.005  # a 45 degree turn in the xy plane halfway
    phi = inv.invariants_from_deltas(turned, eps=1e-3, turn_eps=0.1)
    torch.testing.assert_close(phi[:, 5, 1], torch.full((64,), 0.6936, dtype=torch.float64),
                               atol=1e-3, rtol=0)  # sin th1 of the turn: about sin 45 degrees


# ---------------------------------------------------------------------------------------------
# the loss


def test_chunk_loss_zero_positive_and_differentiable() -> None:
    gen = torch.Generator().manual_seed(5)
    history = torch.randn(8, 3, 6, generator=gen, dtype=torch.float64) * 0.05
    demo = torch.randn(8, 4, 6, generator=gen, dtype=torch.float64) * 0.05  # P = 3
    assert inv.invariant_loss(history, demo.clone(), demo).item() == 0.0
    predicted = (demo + 0.02 * torch.randn(8, 4, 6, generator=gen, dtype=torch.float64))
    predicted.requires_grad_()
    per_sample = inv.invariant_loss(history, predicted, demo, reduction="none")
    assert per_sample.shape == (8,) and (per_sample > 0).all()
    loss = inv.invariant_loss(history, predicted, demo)
    torch.testing.assert_close(loss, per_sample.mean())
    torch.testing.assert_close(inv.invariant_loss(history, predicted, demo, reduction="sum"),
                               per_sample.sum())
    loss.backward()
    assert torch.isfinite(predicted.grad).all() and predicted.grad.abs().sum() > 0
    # appendix B: phi over history + chunk, compared as a whole
    phi_p = inv.invariants_from_deltas(torch.cat([history, predicted.detach()], -2))
    phi_d = inv.invariants_from_deltas(torch.cat([history, demo], -2))
    torch.testing.assert_close(per_sample.detach(), ((phi_p - phi_d) ** 2).sum((-2, -1)))
    with_tail = inv.invariant_loss(history, predicted.detach(), demo, reduction="none",
                                   tail=True)
    assert (with_tail > per_sample.detach()).all()
    # one action is the chunk with P = 0
    torch.testing.assert_close(
        inv.invariant_loss(history, predicted.detach()[:, 0], demo[:, 0], reduction="none"),
        inv.invariant_loss(history, predicted.detach()[:, :1], demo[:, :1], reduction="none"))
    with pytest.raises(ValueError):
        inv.invariant_loss(history, predicted[:, :2], demo)
    with pytest.raises(ValueError):
        inv.invariant_loss(history, predicted, demo, reduction="max")


def test_the_tail_makes_a_single_action_count() -> None:
    """With the dataset's history of 2, the appendix's rows see a single predicted action
    only through th2: moving 3 times as far costs nothing. The tail compares its turn (th1)
    and magnitude too."""
    gen = torch.Generator().manual_seed(9)
    history = torch.randn(16, 2, 6, generator=gen, dtype=torch.float64) * 0.01
    demo = torch.randn(16, 6, generator=gen, dtype=torch.float64) * 0.01
    scaled = torch.cat([3.0 * demo[:, :3], demo[:, 3:]], -1)  # 3 times as far, same turn
    assert inv.invariant_loss(history, scaled, demo).item() < 1e-20
    assert inv.invariant_loss(history, scaled, demo, tail=True).item() > 1e-6
    turned = torch.cat([demo[:, 1:3], demo[:, :1], demo[:, 3:]], -1)  # the same magnitude
    assert inv.invariant_loss(history, turned, demo, tail=True).item() > \
        inv.invariant_loss(history, turned, demo).item()
    action = scaled.clone().requires_grad_()
    inv.invariant_loss(history, action, demo, tail=True).backward()
    assert (action.grad[:, :3].abs().sum(0) > 0).all()


def windows_for_training(count: int, history: int) -> tuple[torch.Tensor, torch.Tensor]:
    deltas = np.stack([inv.poses_to_deltas(*smooth_trajectory(seed, history + 2))
                       for seed in range(count)])
    deltas = torch.from_numpy(deltas).float()
    return deltas[:, :-1], deltas[:, -1]


def test_network_trained_on_invariant_loss_alone_reduces_it() -> None:
    torch.manual_seed(0)
    history, demo = windows_for_training(64, 4)
    net = torch.nn.Sequential(torch.nn.Flatten(), torch.nn.Linear(24, 64), torch.nn.Tanh(),
                              torch.nn.Linear(64, 6))
    optimizer = torch.optim.Adam(net.parameters(), lr=3e-3)
    losses = []
    for _ in range(600):
        loss = inv.invariant_loss(history, 0.05 * net(history / 0.05), demo)
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        losses.append(loss.item())
    final = inv.invariant_loss(history, 0.05 * net(history / 0.05), demo).item()
    assert np.isfinite(losses).all()
    assert final < 0.5 * losses[0], (losses[0], final)


def test_gradients_reach_the_policy_through_the_gmm_helpers() -> None:
    torch.manual_seed(1)
    history, demo = windows_for_training(16, 2)
    modes, dims = 5, 6
    trunk = torch.nn.Sequential(torch.nn.Flatten(), torch.nn.Linear(12, 32), torch.nn.Tanh())
    mean_head = torch.nn.Linear(32, modes * dims)
    logit_head = torch.nn.Linear(32, modes)
    scale_head = torch.nn.Linear(32, modes * dims)
    features = trunk(history / 0.05)
    means = 0.05 * mean_head(features).view(-1, modes, dims)
    logits = logit_head(features)
    scales = torch.nn.functional.softplus(scale_head(features)).view(-1, modes, dims) + 1e-4

    action = inv.gmm_mean_of_most_likely_mode(logits, means)
    assert action.shape == (16, 6)
    torch.testing.assert_close(
        action, means[torch.arange(16), logits.argmax(-1)])
    inv.invariant_loss(history, action, demo).backward(retain_graph=True)
    for param in [*mean_head.parameters(), *trunk.parameters()]:
        assert param.grad is not None and torch.isfinite(param.grad).all()
        assert param.grad.abs().sum() > 0

    for module in (trunk, mean_head, scale_head):
        module.zero_grad()
    sample = inv.gmm_rsample(logits, means, scales)
    assert sample.shape == (16, 6)
    inv.invariant_loss(history, sample, demo).backward()
    for param in [*mean_head.parameters(), *scale_head.parameters()]:
        assert param.grad is not None and torch.isfinite(param.grad).all()
        assert param.grad.abs().sum() > 0
