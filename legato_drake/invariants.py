"""DHB motion invariants of gripper motion (LEGATO appendix A) and the loss L_invar.

phi maps a window of gripper motion to 10 values per step (appendix A; the printed vector
repeats sin th1_r by a typo and drops m_r)::

    (m_p, sin th1_p, sin 2 th1_p, sin th2_p, sin 2 th2_p,
     m_r, sin th1_r, sin 2 th1_r, sin th2_r, sin 2 th2_r)

Every function here takes numpy arrays or torch tensors (any leading batch dims, dtype and
device taken from the input) and returns the same kind. The math is written once against the
part of the numpy and torch APIs the two share, so the numpy and torch results agree to
rounding; the torch path is differentiable end to end.

Choices where the appendix is loose (each is tested in ``tests/test_invariants.py``):

* **Windows are deltas.** The appendix's ``u_k`` are the dataset's actions: pose deltas
  ``[dx, dy, dz, droll, dpitch, dyaw]``, each ``T_k^-1 T_{k+1}`` expressed in the previous
  gripper frame, angles as Drake's RollPitchYaw (``R = Rz(yaw) Ry(pitch) Rx(roll)``).
* **Delta p** is segment k's translation expressed in the gripper frame at the window's first
  step (``p_k`` relative to the first pose, as the appendix says). Using the initial frame,
  not the world, makes every step of phi, fallback axes included, exactly invariant to one
  rigid transform of the world applied to the whole trajectory.
* **Delta r** is the local relative rotation ``log(R_k^T R_{k+1})`` (a rotation vector, in
  gripper frame k), like the reference implementation. The appendix's ``r_{k+1} - r_k`` of
  rotation vectors is not a motion quantity: rotation vectors are a chart of SO(3), their
  difference depends on where on SO(3) the gripper is, its norm is not the angle turned, and
  it jumps where the chart wraps at pi. ``log(R_k^T R_{k+1})`` has the angle turned as its norm,
  is what the action stores (its rpy part is ``R_k^T R_{k+1}``), and does not depend on the
  world frame.
* **Index range.** N deltas (N + 1 poses) give N - 2 rows, k = 0 .. N-3: row k needs
  ``x_k, x_{k+1}, x_{k+2}`` because ``th2_k`` compares ``y_k`` with ``y_{k+1} = x_{k+1} x x_{k+2}``.
  With the appendix's T + 1 deltas ``u_{t-T} .. u_t`` this is its length T - 1 (k = t-T .. t-2)
  and needs T >= 2; counted as T + 1 *poses* the last listed row would need one pose beyond
  the window, and we drop it (truncation, never padding). So the last delta of a window
  enters phi only through ``th2`` of the last row; its magnitude does not enter at all.
* **The loss's tail.** That makes the appendix's L_invar nearly blind to a single predicted
  action: with the dataset's history of 2, the window has 3 deltas and one row, and only
  ``th2`` (2 of the 10 values, direction out of the plane of the last two steps) depends on
  the prediction; predicting 3 times the demonstrated action costs nothing. ``invariant_loss``
  can therefore also compare the window's *tail*, what the window does define past its last
  full row: ``m`` and ``th1`` of segment N-2 (the turn into the last segment) and ``m`` of the
  last segment, per block (8 values), with ``tail=True``. They are built from the same axes,
  so they keep every property tested for phi (invariance, continuity, finite gradients). The
  default stays the appendix's loss: in our state-based lid runs the tail did not help.
* **Continuous axes.** ``x_k`` is never sign-flipped (a reversal is real motion). ``y_0`` has
  the sign of ``x_0 x x_1`` (so ``th1_0 >= 0``); every later ``y_k`` is flipped when it would
  point against ``y_{k-1}`` (``y_k . y_{k-1} < 0``), so the frame follows the curve through
  inflections: ``th1`` becomes a signed turning angle that passes smoothly through 0, and
  ``|th2| <= pi/2``. The remaining jump (the osculating plane turning by 90 degrees in one
  step) changes ``sin th2`` but not ``sin 2 th2``, which is pi-periodic; that is why the
  appendix keeps both.
* **No motion, collinear segments.** A segment of (almost) no motion keeps the previous x axis
  and (almost) collinear segments keep the previous y axis, faded in smoothly rather than
  switched at a threshold: ``axis_k = h_k / |h_k|`` with ``h_k = u_k + lam_k h_{k-1}``,
  ``u_k = raw_k / sqrt(|raw_k|^2 + eps^2)`` and ``lam_k = eps^2 / (|raw_k|^2 + eps^2)``
  (``raw`` is the segment for x, and ``x_k x x_{k+1}``, the sine of the turn, for y, where
  ``turn_eps`` takes eps's place). At rest ``h_k = h_{k-1}``; on a
  well-defined step the axis moves by only ``O((eps / |raw_k|)^2)``. The recurrence is linear,
  so all steps are computed at once (no Python loop over time). Before the first segment the
  x axis is the gripper's x axis at the window's start and the y axis
  ``normalize(x_0 x (1, 1, 1))``, both fixed in the initial frame. Norms are
  ``sqrt(. + eps^2)``-regularised (``m = |v|^2 / sqrt(|v|^2 + eps^2)``, smooth and 0 at
  rest), sines come from ``s / sqrt(s^2 + c^2 + turn_eps^2)`` instead of
  ``sin(atan2(s, c))``, and the rotation-vector maps switch to Taylor series near 0 with both
  branches kept finite, so values and gradients are finite everywhere, also at rest and on
  straight lines. ``eps`` (default 1e-6, in metres and radians per step) is the motion
  resolution: raise it to treat sensor jitter as rest; gradients w.r.t. an action scale like
  1 / max(|action|, eps). ``turn_eps`` (default 1e-6, no unit) is the turn resolution.
* **Resolution against precision.** At the defaults phi resolves micrometres, and a straight
  move has no plane: ``th2`` of a straight segment follows the rounding of its deltas. For
  windows that are only known to a precision (a network's estimate), set ``eps`` to that
  precision and ``turn_eps`` to the sine of the smallest turn that counts; below them, a
  segment is rest and a turn is none, and phi keeps its previous axes there.
* **Loss.** ``invariant_loss`` is the squared L2 distance between phi (and its tail) of the
  history with the predicted action(s) appended and of the history with the demonstrated
  action(s) appended, summed over rows and values per sample, then averaged over the batch
  (the reference's ``MSELoss`` pair averaged over the 5 values of each block instead, i.e.
  1/5 of this for one row). m_p and m_r are in metres and radians per step and so weigh
  little next to the sines, as in the paper.
* **GMM policies.** The reference applied L_invar to ``dist.sample()``, which has no gradient,
  so the term trained nothing. Feed it ``gmm_mean_of_most_likely_mode(logits, means)`` (the
  project's default: the mean of the most likely component, the low-noise action used at
  evaluation; differentiable w.r.t. the means) or ``gmm_rsample`` (a reparameterised sample of
  one component).
"""

from __future__ import annotations

import math
from types import ModuleType
from typing import Literal, TypeVar

import numpy as np
import torch

Array = TypeVar("Array", np.ndarray, torch.Tensor)

DEFAULT_EPS = 1e-6
"""Motion resolution (metres and radians per step) of the smooth fallbacks."""

DEFAULT_TURN_EPS = 1e-6
"""Turn resolution (the sine of the angle between consecutive segments, no unit) of the
binormal's fallback."""

INVARIANT_NAMES = (
    "m_p", "sin_th1_p", "sin_2th1_p", "sin_th2_p", "sin_2th2_p",
    "m_r", "sin_th1_r", "sin_2th1_r", "sin_th2_r", "sin_2th2_r",
)
"""Names of the 10 values of phi, in order along the last axis."""

_TINY2 = 1e-30  # added under square roots of quantities that are (almost) never near 0
_SMALL_ANGLE2 = 1e-12  # squared angle below which the rotation-vector maps use Taylor series

__all__ = [
    "DEFAULT_EPS",
    "DEFAULT_TURN_EPS",
    "INVARIANT_NAMES",
    "deltas_to_poses",
    "gmm_mean_of_most_likely_mode",
    "gmm_rsample",
    "history_from_observations",
    "invariant_loss",
    "invariants_from_deltas",
    "invariants_from_poses",
    "invariants_from_segments",
    "matrix_to_quaternion",
    "matrix_to_rpy",
    "poses_to_deltas",
    "quaternion_multiply",
    "quaternion_to_matrix",
    "quaternion_to_rotation_vector",
    "rotation_vector_to_quaternion",
    "rpy_to_matrix",
    "rpy_to_quaternion",
]


# ---------------------------------------------------------------------------------------------
# numpy / torch plumbing


def _xp(x: Array) -> ModuleType:
    """The array module (numpy or torch) that owns ``x``."""
    return torch if isinstance(x, torch.Tensor) else np


def _as_float(x: Array | list) -> Array:
    """``x`` as a floating array: tensors keep their dtype and device, the rest become numpy."""
    if isinstance(x, torch.Tensor):
        return x if x.is_floating_point() else x.to(torch.get_default_dtype())
    x = np.asarray(x)
    return x if np.issubdtype(x.dtype, np.floating) else x.astype(np.float64)


def _const(values: object, like: Array) -> Array:
    """A constant with the dtype (and device) of ``like``."""
    if isinstance(like, torch.Tensor):
        return torch.as_tensor(values, dtype=like.dtype, device=like.device)
    return np.asarray(values, dtype=like.dtype)


def _dot(a: Array, b: Array) -> Array:
    return (a * b).sum(-1)


def _cross(a: Array, b: Array) -> Array:
    if isinstance(a, torch.Tensor):
        return torch.linalg.cross(*torch.broadcast_tensors(a, b))
    return np.cross(a, b)


def _normalize(a: Array) -> Array:
    """``a / |a|`` that stays finite (value and gradient) at ``a = 0``."""
    return a / _xp(a).sqrt(_dot(a, a)[..., None] + _TINY2)


def _transpose(m: Array) -> Array:
    return _xp(m).swapaxes(m, -1, -2)


def _mat_vec(m: Array, v: Array) -> Array:
    return (m @ v[..., None])[..., 0]


def _as_matrix(rotations: Array) -> Array:
    """Rotation matrices from (..., 3, 3) matrices or (..., 4) (w, x, y, z) quaternions."""
    if rotations.shape[-1] == 4:
        return quaternion_to_matrix(rotations)
    if rotations.shape[-2:] != (3, 3):
        raise ValueError(f"rotations must be (..., 3, 3) or (..., 4), got {rotations.shape}")
    return rotations


# ---------------------------------------------------------------------------------------------
# rotation conversions


def rpy_to_matrix(rpy: Array) -> Array:
    """(..., 3) roll-pitch-yaw to (..., 3, 3) ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (Drake's)."""
    rpy = _as_float(rpy)
    xp = _xp(rpy)
    cr, cp, cy = xp.cos(rpy[..., 0]), xp.cos(rpy[..., 1]), xp.cos(rpy[..., 2])
    sr, sp, sy = xp.sin(rpy[..., 0]), xp.sin(rpy[..., 1]), xp.sin(rpy[..., 2])
    rows = [[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr]]
    return xp.stack([xp.stack(row, -1) for row in rows], -2)


def matrix_to_rpy(matrix: Array) -> Array:
    """(..., 3, 3) rotation matrices to (..., 3) roll-pitch-yaw, pitch in [-pi/2, pi/2].

    Inverse of ``rpy_to_matrix`` away from gimbal lock (|pitch| = pi/2), where roll and yaw
    are not separable.
    """
    m = _as_float(matrix)
    xp = _xp(m)
    cos_pitch = xp.sqrt(m[..., 0, 0] ** 2 + m[..., 1, 0] ** 2 + _TINY2)
    return xp.stack([xp.arctan2(m[..., 2, 1], m[..., 2, 2]),
                     xp.arctan2(-m[..., 2, 0], cos_pitch),
                     xp.arctan2(m[..., 1, 0], m[..., 0, 0])], -1)


def rpy_to_quaternion(rpy: Array) -> Array:
    """(..., 3) roll-pitch-yaw to (..., 4) unit quaternions (w, x, y, z) of the same rotation."""
    rpy = _as_float(rpy)
    xp = _xp(rpy)
    cr, cp, cy = (xp.cos(rpy[..., i] / 2) for i in range(3))
    sr, sp, sy = (xp.sin(rpy[..., i] / 2) for i in range(3))
    return xp.stack([cr * cp * cy + sr * sp * sy,
                     sr * cp * cy - cr * sp * sy,
                     cr * sp * cy + sr * cp * sy,
                     cr * cp * sy - sr * sp * cy], -1)


def quaternion_to_matrix(quaternion: Array) -> Array:
    """(..., 4) quaternions (w, x, y, z), normalised first, to (..., 3, 3) rotation matrices."""
    q = _normalize(_as_float(quaternion))
    xp = _xp(q)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    rows = [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]
    return xp.stack([xp.stack(row, -1) for row in rows], -2)


def matrix_to_quaternion(matrix: Array) -> Array:
    """(..., 3, 3) rotation matrices to (..., 4) unit quaternions (w, x, y, z) with w >= 0.

    Uses whichever of the four standard formulas has the largest denominator, so it is
    accurate for every rotation (including angles near pi); all four stay finite.
    """
    m = _as_float(matrix)
    xp = _xp(m)
    m00, m01, m02 = m[..., 0, 0], m[..., 0, 1], m[..., 0, 2]
    m10, m11, m12 = m[..., 1, 0], m[..., 1, 1], m[..., 1, 2]
    m20, m21, m22 = m[..., 2, 0], m[..., 2, 1], m[..., 2, 2]
    four_sq = [1 + m00 + m11 + m22, 1 + m00 - m11 - m22,  # 4w^2, 4x^2,
               1 - m00 + m11 - m22, 1 - m00 - m11 + m22]  # 4y^2, 4z^2
    candidates = [(four_sq[0], m21 - m12, m02 - m20, m10 - m01),
                  (m21 - m12, four_sq[1], m10 + m01, m02 + m20),
                  (m02 - m20, m10 + m01, four_sq[2], m12 + m21),
                  (m10 - m01, m02 + m20, m12 + m21, four_sq[3])]
    best, best_sq = None, None
    for sq, cand in zip(four_sq, candidates, strict=True):
        q = xp.stack(cand, -1) / (2 * xp.sqrt(sq.clip(min=0.1)))[..., None]
        if best is None:
            best, best_sq = q, sq
        else:
            better = sq > best_sq
            best = xp.where(better[..., None], q, best)
            best_sq = xp.where(better, sq, best_sq)
    best = xp.where(best[..., :1] < 0, -best, best)
    return _normalize(best)


def quaternion_multiply(a: Array, b: Array) -> Array:
    """Hamilton product ``a * b`` of (..., 4) quaternions (w, x, y, z)."""
    xp = _xp(a)
    aw, av, bw, bv = a[..., :1], a[..., 1:], b[..., :1], b[..., 1:]
    return xp.concatenate([aw * bw - _dot(av, bv)[..., None],
                           aw * bv + bw * av + _cross(av, bv)], -1)


def quaternion_to_rotation_vector(quaternion: Array) -> Array:
    """(..., 4) quaternions (w, x, y, z) to (..., 3) rotation vectors (angle in [0, pi])."""
    q = _normalize(_as_float(quaternion))
    xp = _xp(q)
    q = xp.where(q[..., :1] < 0, -q, q)
    w, v = q[..., 0], q[..., 1:]
    s2 = _dot(v, v)
    small = s2 < _SMALL_ANGLE2
    s = xp.sqrt(xp.where(small, 1.0, s2))
    w_small = xp.where(small, w, 1.0)
    # angle / sin(angle / 2) = 2 atan2(s, w) / s, and its series (2 / w)(1 - s^2 / (3 w^2)).
    scale = xp.where(small, 2 / w_small * (1 - s2 / (3 * w_small**2)), 2 * xp.arctan2(s, w) / s)
    return v * scale[..., None]


def rotation_vector_to_quaternion(rotation_vector: Array) -> Array:
    """(..., 3) rotation vectors to (..., 4) unit quaternions (w, x, y, z)."""
    rv = _as_float(rotation_vector)
    xp = _xp(rv)
    a2 = _dot(rv, rv)
    small = a2 < _SMALL_ANGLE2
    a = xp.sqrt(xp.where(small, 1.0, a2))
    w = xp.where(small, 1 - a2 / 8, xp.cos(a / 2))
    half_sinc = xp.where(small, 0.5 - a2 / 48, xp.sin(a / 2) / a)
    return xp.concatenate([w[..., None], rv * half_sinc[..., None]], -1)


# ---------------------------------------------------------------------------------------------
# deltas <-> poses


def _orientations(deltas: Array) -> Array:
    """Rotations (..., N+1, 3, 3) of the frames reached by (..., N, 6) deltas, relative to the
    first: ``R_0 = I``, ``R_{k+1} = R_k R(rpy_k)``; a log-depth prefix product over the steps."""
    xp = _xp(deltas)
    prefix = rpy_to_matrix(deltas[..., 3:6])
    shift = 1
    while shift < prefix.shape[-3]:  # Hillis-Steele scan: prefix[k] = D_0 ... D_k
        prefix = xp.concatenate([prefix[..., :shift, :, :],
                                 prefix[..., :-shift, :, :] @ prefix[..., shift:, :, :]], -3)
        shift *= 2
    first = xp.zeros_like(prefix[..., :1, :, :]) + _const(np.eye(3), deltas)
    return xp.concatenate([first, prefix], -3)


def deltas_to_poses(deltas: Array) -> tuple[Array, Array]:
    """Compose (..., N, 6) deltas into N + 1 poses relative to the first one.

    Returns positions (..., N+1, 3) and rotation matrices (..., N+1, 3, 3); pose 0 is the
    identity and ``T_{k+1} = T_k [R(rpy_k), dp_k]``.
    """
    deltas = _as_float(deltas)
    xp = _xp(deltas)
    rotations = _orientations(deltas)
    steps = xp.cumsum(_mat_vec(rotations[..., :-1, :, :], deltas[..., :3]), -2)
    positions = xp.concatenate([xp.zeros_like(steps[..., :1, :]), steps], -2)
    return positions, rotations


def poses_to_deltas(positions: Array, rotations: Array) -> Array:
    """(..., N+1, 3) positions and (..., N+1, 3, 3) matrices or (..., N+1, 4) quaternions
    (w, x, y, z) to (..., N, 6) deltas ``T_k^-1 T_{k+1}`` = [dx, dy, dz, droll, dpitch, dyaw]."""
    positions = _as_float(positions)
    xp = _xp(positions)
    rot = _as_matrix(_as_float(rotations))
    prev_t = _transpose(rot[..., :-1, :, :])
    dp = _mat_vec(prev_t, positions[..., 1:, :] - positions[..., :-1, :])
    return xp.concatenate([dp, matrix_to_rpy(prev_t @ rot[..., 1:, :, :])], -1)


def history_from_observations(delta_positions: Array, delta_eulers: Array) -> Array:
    """The dataset's flat observations (..., 3T) ``delta_positions`` and ``delta_eulers``
    (oldest first) as a (..., T, 6) history of deltas."""
    xp = _xp(delta_positions)
    shape = tuple(delta_positions.shape[:-1]) + (-1, 3)
    return xp.concatenate([delta_positions.reshape(shape), delta_eulers.reshape(shape)], -1)


# ---------------------------------------------------------------------------------------------
# phi


def _carried_directions(raw: Array, eps2: float, start: Array) -> Array:
    """``h_k = u_k + lam_k h_{k-1}`` along axis -2, from ``h_{-1} = start``.

    ``u_k = raw_k / sqrt(|raw_k|^2 + eps2)`` is ``raw_k``'s direction while it is well defined
    and fades to 0 where ``raw_k`` vanishes, while ``lam_k = eps2 / (|raw_k|^2 + eps2)``
    (``= 1 - |u_k|^2``) fades the previous direction in. The recurrence is linear, so all steps
    come at once: ``h_k = sum_{j<=k} exp(L_k - L_j) u_j + exp(L_k) start``, ``L = cumsum(log lam)``.
    """
    xp = _xp(raw)
    n2 = _dot(raw, raw)
    u = raw / xp.sqrt(n2 + eps2)[..., None]
    log_lam = xp.cumsum(math.log(eps2) - xp.log(n2 + eps2), -1)  # non-increasing
    n = raw.shape[-2]
    # exp of a log-weight clipped to [-60, 0]: weights below 1e-26 are that small (keeps exp
    # off the slow underflow path), above the diagonal 1 and masked to 0.
    gaps = (log_lam[..., :, None] - log_lam[..., None, :]).clip(min=-60.0, max=0.0)
    weights = xp.exp(gaps) * _const(np.tril(np.ones((n, n))), raw)
    return weights @ u + xp.exp(log_lam.clip(min=-60.0))[..., None] * start[..., None, :]


def _sin_sin2(s: Array, c: Array, eps2: float) -> tuple[Array, Array]:
    """sin(th) and sin(2 th) of ``th = atan2(s, c)`` without atan2; 0 and finite at s = c = 0."""
    r2 = s * s + c * c + eps2
    return s / _xp(s).sqrt(r2), 2 * s * c / r2


def _dhb_block(v: Array, eps: float, turn_eps: float) -> tuple[Array, Array]:
    """The rows (..., N-2, 5) of values (m, sin th1, sin 2th1, sin th2, sin 2th2) of (..., N, 3)
    segments, and the tail (..., 4): (m_{N-2}, sin th1_{N-2}, sin 2th1_{N-2}, m_{N-1})."""
    xp = _xp(v)
    eps2, turn_eps2 = eps * eps, turn_eps * turn_eps
    x = _normalize(_carried_directions(v, eps2, _const([1.0, 0.0, 0.0], v)))
    raw_y = _cross(x[..., :-1, :], x[..., 1:, :])  # |raw_y| = sin(turn between segments)
    y_start = _normalize(_cross(x[..., 0, :], _const([1.0, 1.0, 1.0], v)))
    h_y = _carried_directions(raw_y, turn_eps2, y_start)
    # flip y_k wherever it would point against y_{k-1}: signs multiply up along the window
    one = _const(1.0, v)
    flips = xp.where(_dot(h_y[..., 1:, :], h_y[..., :-1, :]) < 0, -one, one)
    signs = xp.concatenate([xp.ones_like(flips[..., :1]), xp.cumprod(flips, -1)], -1)
    y = _normalize(h_y) * signs[..., None]
    x_k, x_k1 = x[..., :-2, :], x[..., 1:-1, :]
    y_k, y_k1 = y[..., :-1, :], y[..., 1:, :]
    sin1, sin21 = _sin_sin2(_dot(raw_y[..., :-1, :], y_k), _dot(x_k, x_k1), turn_eps2)
    sin2, sin22 = _sin_sin2(_dot(_cross(y_k, y_k1), x_k1), _dot(y_k, y_k1), turn_eps2)
    n2 = _dot(v, v)
    magnitude = n2 / xp.sqrt(n2 + eps2)
    rows = xp.stack([magnitude[..., :-2], sin1, sin21, sin2, sin22], -1)
    # What the window defines past its last full row: th1 between the last two segments and
    # the magnitudes of both (th2 there would need one segment more).
    tail_sin1, tail_sin21 = _sin_sin2(_dot(raw_y[..., -1, :], y[..., -1, :]),
                                      _dot(x[..., -2, :], x[..., -1, :]), turn_eps2)
    tail = xp.stack([magnitude[..., -2], tail_sin1, tail_sin21, magnitude[..., -1]], -1)
    return rows, tail


def invariants_from_segments(linear: Array, angular: Array, eps: float = DEFAULT_EPS,
                             turn_eps: float = DEFAULT_TURN_EPS) -> Array:
    """phi of N segments given as vectors: (..., N, 3) each -> (..., N-2, 10).

    ``linear[k]`` is segment k's translation in the window's initial frame and ``angular[k]``
    its rotation vector ``log(R_k^T R_{k+1})``; the front ends below build them.
    """
    if linear.shape[-2] < 3 or linear.shape != angular.shape or linear.shape[-1] != 3:
        raise ValueError("need (..., N, 3) linear and angular segments with N >= 3, got "
                         f"{tuple(linear.shape)} and {tuple(angular.shape)}")
    return _rows_and_tail(linear, angular, eps, turn_eps)[0]


def _rows_and_tail(linear: Array, angular: Array, eps: float, turn_eps: float
                   ) -> tuple[Array, Array]:
    """phi (..., N-2, 10) of N segments and its tail (..., 8): (m_p, sin th1_p, sin 2th1_p)
    at row N-2, m_p of segment N-1, then the same 4 of the angular block."""
    xp = _xp(linear)
    # both blocks in one pass
    rows, tail = _dhb_block(xp.stack([linear, angular], -3), eps, turn_eps)
    return (xp.concatenate([rows[..., 0, :, :], rows[..., 1, :, :]], -1),
            xp.concatenate([tail[..., 0, :], tail[..., 1, :]], -1))


def _segments_from_deltas(deltas: Array) -> tuple[Array, Array]:
    """(..., N, 6) pose deltas -> the segments' linear parts in the window's initial frame and
    their rotation vectors, (..., N, 3) each."""
    deltas = _as_float(deltas)
    if deltas.shape[-1] != 6:
        raise ValueError(f"deltas must be (..., N, 6), got {tuple(deltas.shape)}")
    linear = _mat_vec(_orientations(deltas)[..., :-1, :, :], deltas[..., :3])
    angular = quaternion_to_rotation_vector(rpy_to_quaternion(deltas[..., 3:6]))
    return linear, angular


def invariants_from_deltas(deltas: Array, eps: float = DEFAULT_EPS,
                           turn_eps: float = DEFAULT_TURN_EPS) -> Array:
    """phi of (..., N, 6) pose deltas [dx, dy, dz, droll, dpitch, dyaw] -> (..., N-2, 10)."""
    return invariants_from_segments(*_segments_from_deltas(deltas), eps, turn_eps)


def invariants_from_poses(positions: Array, rotations: Array, eps: float = DEFAULT_EPS,
                          turn_eps: float = DEFAULT_TURN_EPS) -> Array:
    """phi of N + 1 absolute poses -> (..., N-2, 10).

    ``positions`` (..., N+1, 3); ``rotations`` (..., N+1, 3, 3) matrices or (..., N+1, 4)
    quaternions (w, x, y, z), Drake's order; either sign of a quaternion is fine.
    """
    positions, rotations = _as_float(positions), _as_float(rotations)
    if rotations.shape[-1] == 4:
        q = _normalize(rotations)
        first = quaternion_to_matrix(q[..., 0, :])
        conj = q[..., :-1, :] * _const([1.0, -1.0, -1.0, -1.0], q)
        relative = quaternion_multiply(conj, q[..., 1:, :])
    else:
        rot = _as_matrix(rotations)
        first = rot[..., 0, :, :]
        relative = matrix_to_quaternion(_transpose(rot[..., :-1, :, :]) @ rot[..., 1:, :, :])
    step = positions[..., 1:, :] - positions[..., :-1, :]
    linear = _mat_vec(_transpose(first)[..., None, :, :], step)
    return invariants_from_segments(linear, quaternion_to_rotation_vector(relative), eps,
                                    turn_eps)


# ---------------------------------------------------------------------------------------------
# loss and GMM helpers


def invariant_loss(history: Array, predicted: Array, demonstrated: Array, *,
                   reduction: Literal["mean", "sum", "none"] = "mean",
                   eps: float = DEFAULT_EPS, turn_eps: float = DEFAULT_TURN_EPS,
                   tail: bool = False) -> Array:
    """L_invar: ``|phi(history + predicted) - phi(history + demonstrated)|^2``.

    ``history`` (..., T, 6) deltas, oldest first. ``predicted`` and ``demonstrated`` are one
    action (..., 6) (appendix A, needs T >= 2) or a chunk (..., P+1, 6) (appendix B); history
    and demonstration are converted to the prediction's kind, dtype and device. The
    squared distance is summed over rows and values per sample; ``reduction`` then takes the
    mean or sum over the batch dims, or returns them ("none"). The default is the appendix's
    rows alone, in which a single predicted action enters through th2 only and its magnitude
    not at all; with ``tail`` the window's tail (m and th1 past the last full row, see the
    module docstring) is compared too.
    """
    predicted = _as_float(predicted)  # the others follow its kind, dtype and device
    history, demonstrated = _const(history, predicted), _const(demonstrated, predicted)
    if predicted.shape != demonstrated.shape:
        raise ValueError(f"predicted {tuple(predicted.shape)} and demonstrated "
                         f"{tuple(demonstrated.shape)} differ")
    if predicted.ndim == history.ndim - 1:
        predicted, demonstrated = predicted[..., None, :], demonstrated[..., None, :]
    if predicted.ndim != history.ndim or predicted.shape[:-2] != history.shape[:-2]:
        raise ValueError(f"history {tuple(history.shape)} does not fit actions "
                         f"{tuple(predicted.shape)}")
    xp = _xp(predicted)
    windows = xp.stack([xp.concatenate([history, predicted], -2),
                        xp.concatenate([history, demonstrated], -2)], 0)
    rows, ends = _rows_and_tail(*_segments_from_deltas(windows), eps, turn_eps)
    per_sample = ((rows[0] - rows[1]) ** 2).sum((-2, -1))
    if tail:
        per_sample = per_sample + ((ends[0] - ends[1]) ** 2).sum(-1)
    if reduction == "none":
        return per_sample
    if reduction == "sum":
        return per_sample.sum()
    if reduction == "mean":
        return per_sample.mean()
    raise ValueError(f"unknown reduction {reduction!r}")


def _gather_component(values: torch.Tensor, index: torch.Tensor) -> torch.Tensor:
    """values (..., K, D) at component index (...,) -> (..., D)."""
    index = index[..., None, None].expand(*index.shape, 1, values.shape[-1])
    return values.gather(-2, index).squeeze(-2)


def gmm_mean_of_most_likely_mode(logits: torch.Tensor, means: torch.Tensor) -> torch.Tensor:
    """Mean of the most likely component of a GMM: logits (..., K), means (..., K, D) -> (..., D).

    The project's default action to feed ``invariant_loss``: the low-noise action of
    evaluation (robomimic's low-noise mode still draws the component; this takes the most
    likely one, which is deterministic). The argmax is a selection without gradient; the
    result is differentiable w.r.t. ``means``. For robomimic's ``MixtureSameFamily`` pass
    ``dist.mixture_distribution.logits`` and ``dist.component_distribution.base_dist.loc``.
    """
    return _gather_component(means, logits.argmax(-1))


def gmm_rsample(logits: torch.Tensor, means: torch.Tensor, scales: torch.Tensor) -> torch.Tensor:
    """A reparameterised GMM sample: logits (..., K), means and scales (..., K, D) -> (..., D).

    The component is drawn from the mixture weights (no gradient), then its Normal is
    sampled with ``rsample``, differentiable w.r.t. ``means`` and ``scales``.
    """
    index = torch.distributions.Categorical(logits=logits).sample()
    normal = torch.distributions.Normal(_gather_component(means, index),
                                        _gather_component(scales, index))
    return normal.rsample()

