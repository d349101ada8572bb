"""The Diffusion Policy families: representations, the chunk L_invar, training, rollout."""

from __future__ import annotations

import csv
import dataclasses

import numpy as np
import pytest
import torch
from pydrake.math import RigidTransform, RollPitchYaw

from legato_drake.data.derived import observation_sizes
from legato_drake.data.torch_dataset import DemoSequenceDataset
from legato_drake.errors import ConfigError
from legato_drake.learning.checkpoint import Checkpoint, load_checkpoint, save_checkpoint
from legato_drake.learning.diffusion import (
    RANGE_KEY,
    DiffusionPolicy,
    chunk_windows,
    deltas_to_reltraj,
    reltraj_to_deltas,
    training_chunks,
)
from legato_drake.learning.registry import build_policy, observed_steps
from legato_drake.learning.train import train
from legato_drake.poses import apply_delta, pose_delta
from tests.learning_helpers import synthetic_dataset, tiny_config

P = 6


def dp_config(algo: str = "dp_velocity", **changes):
    fields = dict(algo=algo, seq_length=P + 1, pred_horizon=P, action_horizon=3,
                  obs_horizon=2, history=0, unet_dims=[16, 32], unet_kernel=3,
                  diffusion_steps=20, inference_steps=4, invariant_weight=0.0)
    fields.update(changes)
    return tiny_config(**fields)


def _stats(config, rng, batch=None):
    """Normalisation statistics; with ``batch``, its chunks' range (the training data's, as
    in training: its chunks then lie within [-1, 1])."""
    stats = {k: {"mean": rng.normal(0, 0.01, d).astype(np.float32),
                 "std": np.full(d, 0.05, np.float32)} for k, d in observation_sizes(3).items()}
    actions = [rng.normal(0, 0.01, (40, 7))]
    planned = list(actions)
    if batch is not None:
        actions += list(batch["actions"].numpy())
        planned += list(batch["planned_actions"].numpy())
    stats.update(DiffusionPolicy.extra_stats(config, actions, planned))
    return stats


def _batch(rng, B: int = 4):
    L = P + 1
    obs = {k: torch.tensor(rng.normal(0, 0.05, (B, L, d)), dtype=torch.float32)
           for k, d in observation_sizes(3).items()}
    actions = rng.normal(0, 0.01, (B, L, 7))
    actions[..., 6] = rng.integers(0, 2, (B, L))
    planned = actions + rng.normal(0, 0.003, actions.shape) * [1, 1, 1, 1, 1, 1, 0]
    return {"obs": obs, "actions": torch.tensor(actions, dtype=torch.float32),
            "planned_actions": torch.tensor(planned, dtype=torch.float32),
            "pad_mask": torch.ones(B, L, dtype=torch.bool)}


def test_relative_trajectory_round_trip_reaches_the_same_poses():
    rng = np.random.default_rng(1)
    poses = [RigidTransform(RollPitchYaw(rng.uniform(-3, 3, 3)), rng.normal(0, 0.5, 3))]
    for _ in range(P):
        poses.append(poses[-1] @ RigidTransform(RollPitchYaw(rng.normal(0, 0.2, 3)),
                                                rng.normal(0, 0.03, 3)))
    deltas = np.array([[*pose_delta(a, b), k % 2] for k, (a, b)
                       in enumerate(zip(poses[:-1], poses[1:], strict=True))])
    relative = deltas_to_reltraj(deltas)
    for k in range(P):  # pose k + 1 in the frame of the chunk's start
        X = poses[0].inverse() @ poses[k + 1]
        np.testing.assert_allclose(relative[k, :3], X.translation(), atol=1e-12)
        np.testing.assert_allclose(relative[k, 6], deltas[k, 6])
    back = reltraj_to_deltas(relative)
    np.testing.assert_allclose(back, deltas, atol=1e-12)
    X = poses[0]
    for k in range(P):
        X = apply_delta(X, back[k, :6])
        np.testing.assert_allclose(X.GetAsMatrix4(), poses[k + 1].GetAsMatrix4(), atol=1e-12)
    torch.testing.assert_close(reltraj_to_deltas(deltas_to_reltraj(torch.tensor(deltas))),
                               torch.tensor(deltas))


def test_chunk_windows_pad_past_the_end_like_the_dataset():
    actions = np.arange(8, dtype=float).reshape(4, 2).repeat(4, 1)[:, :7]
    windows = chunk_windows(actions, 3)
    assert windows.shape == (4, 3, 7)
    np.testing.assert_array_equal(windows[-1], np.repeat(actions[-1:], 3, 0))
    planned = -actions
    windows = chunk_windows(actions, 3, planned)  # the step's action, then the plan
    np.testing.assert_array_equal(windows[1], [actions[1], planned[2], planned[3]])
    np.testing.assert_array_equal(windows[-1], [actions[-1], planned[-1], planned[-1]])


@pytest.mark.parametrize("targets", ["planned", "actions"])
def test_training_chunks_of_a_batch_are_the_chunk_windows_of_its_demo(tmp_path, targets):
    """The statistics (``chunk_windows``) and the loss (``training_chunks``) see the same
    chunks, padding included."""
    path = synthetic_dataset(tmp_path / "d.hdf5", demos=2, length=12, images=False)
    data = DemoSequenceDataset(path, ["fingers"], P + 1, "all")
    arrays = data._data[data.demos[0]]
    planned = arrays["planned_actions"] + 0.01  # as if the demo were noisy
    windows = chunk_windows(arrays["actions"], P, planned if targets == "planned" else None)
    for start in (0, 5, 11):
        item = data[start]
        batch = {"actions": item["actions"][None],
                 "planned_actions": item["planned_actions"][None] + 0.01}
        chunk = training_chunks(batch, 0, P, targets)[0].numpy()
        np.testing.assert_allclose(chunk, windows[start], atol=1e-7)


@pytest.mark.parametrize("algo", ["dp_velocity", "dp_reltraj"])
def test_the_chunk_invariant_loss_is_zero_on_the_demonstration_and_trains_the_network(algo):
    rng = np.random.default_rng(0)
    config = dp_config(algo, invariant_weight=1.0)
    torch.manual_seed(0)
    batch = _batch(rng)
    policy = build_policy(config, _stats(config, rng, batch)).train()
    losses = policy.losses(batch)
    assert set(losses) == {"mse", "invar", "total"} and losses["invar"] > 0
    losses["invar"].backward()
    grads = [p.grad for p in policy.net["unet"].parameters()]
    assert any(g is not None and g.abs().sum() > 0 for g in grads)

    # A network that predicts the true noise implies the demonstrated chunk exactly.
    x0 = policy._scale(training_chunks(batch, 1, P, "planned"))
    alphas = policy.train_scheduler.alphas_cumprod

    class Oracle(torch.nn.Module):
        def forward(self, noisy, t, cond):
            a = alphas[t][:, None, None].to(noisy)
            return (noisy - a.sqrt() * x0) / (1 - a).sqrt()

    policy.net["unet"] = Oracle()
    exact = policy.losses(batch)
    assert float(exact["invar"]) < 1e-6 and float(exact["mse"]) < 1.0


def test_the_object_loss_of_an_image_diffusion_policy_trains_its_encoders_alone():
    rng = np.random.default_rng(0)
    config = dp_config("dp_reltraj", obs_mode="image", object_aux_weight=3.0)
    torch.manual_seed(0)
    batch = _batch(rng)
    g = torch.Generator().manual_seed(0)
    for key in ("left_gray", "right_gray"):
        batch["obs"][key] = torch.rand(4, P + 1, 1, 16, 16, generator=g)
    batch["pad_mask"][0, 0] = False  # an observation step the loss must leave out
    policy = build_policy(config, _stats(config, rng, batch)).train()
    assert policy.loss_terms == ("mse", "invar", "aux", "total")
    losses = policy.losses(batch)
    value = {k: float(v.detach()) for k, v in losses.items()}
    assert value["aux"] > 0
    assert value["total"] == pytest.approx(value["mse"] + 3.0 * value["aux"], rel=1e-5)
    losses["aux"].backward()
    encoder = policy.net["conditioner"].encoders["left_gray"]
    assert encoder.trunk[0].weight.grad.abs().sum() > 0
    assert policy.object_head.linear.weight.grad.abs().sum() > 0
    assert all(p.grad is None for p in policy.net["unet"].parameters())  # not its business
    # It regresses the observation steps' poses: the right ones everywhere but the masked
    # step score 0, however wrong that step is.
    norm = policy.object_head.normalizer
    with torch.no_grad():
        policy.object_head.linear.weight.zero_()
        policy.object_head.linear.bias.copy_(-norm.mean / norm.std)
    posed = torch.zeros_like(batch["obs"]["object_in_tcp"])
    posed[0, 0] = 5.0
    zero = {**batch, "obs": {**batch["obs"], "object_in_tcp": posed}}
    assert float(policy.losses(zero)["aux"].detach()) == pytest.approx(0.0, abs=1e-6)
    # The diagnostic estimate, in raw units: the head set to answer the normalised zero pose
    # answers zero; with weights, it reads the rollout's (EMA) encoders and not the trained.
    estimate = policy.estimate_objects(batch["obs"])
    assert estimate.shape == batch["obs"]["object_in_tcp"].shape
    torch.testing.assert_close(estimate, torch.zeros_like(estimate), atol=1e-6, rtol=0)
    with torch.no_grad():
        policy.object_head.linear.weight.normal_(generator=g)
        before = policy.estimate_objects(batch["obs"])
        for module in (policy.net, policy.ema):
            module["conditioner"].encoders["left_gray"].linear.bias.add_(1.0)
            after = policy.estimate_objects(batch["obs"])
            assert torch.equal(after, before) == (module is policy.net)
    plain = build_policy(dp_config("dp_reltraj", obs_mode="image"), _stats(config, rng, batch))
    assert "aux" not in plain.train().losses(batch) and plain.object_head is None
    with pytest.raises(ValueError, match="no object head"):
        plain.estimate_objects(batch["obs"])


def test_the_chunk_invariant_loss_stays_bounded_at_the_last_noise_level():
    """At the last level sqrt(a_t) is nearly 0: the clean chunk is clipped to [-1, 1] as the
    sampler clips it, or one such sample's L_invar (and its gradient) swamps the batch."""
    rng = np.random.default_rng(0)
    config = dp_config("dp_reltraj", invariant_weight=1.0)
    torch.manual_seed(0)
    policy = build_policy(config, _stats(config, rng)).train()
    batch = _batch(rng)

    def invar_at(level: int) -> float:
        levels = torch.full((len(batch["actions"]),), level)
        return float(policy.losses(batch, levels)["invar"].detach())

    assert float(policy.train_scheduler.alphas_cumprod[-1]) < 1e-3  # the division's scale
    assert invar_at(config.diffusion_steps - 1) < 10 * invar_at(0)


def test_min_snr_weighting_fades_the_chunk_invariant_loss_out_at_the_noisy_levels():
    """invariant_snr_clip weighs a sample at level t by min(SNR_t, clip) / clip: the clean
    levels (SNR above the clip) keep their whole L_invar, the noisiest almost nothing."""
    rng = np.random.default_rng(0)
    config = dp_config("dp_reltraj", invariant_weight=1.0)
    torch.manual_seed(0)
    policy = build_policy(config, _stats(config, rng)).eval()  # the same noise every call
    batch = _batch(rng)

    def invar(level: int, snr_clip: float) -> float:
        policy.config = dataclasses.replace(config, invariant_snr_clip=snr_clip)
        levels = torch.full((len(batch["actions"]),), level)
        return float(policy.losses(batch, levels)["invar"].detach())

    a = policy.train_scheduler.alphas_cumprod
    snr = a / (1 - a)
    clean_level, last = int(torch.nonzero(snr > 5).max()), config.diffusion_steps - 1
    assert invar(clean_level, 5.0) == pytest.approx(invar(clean_level, 0.0), rel=1e-6)
    assert invar(last, 5.0) == pytest.approx(invar(last, 0.0) * float(snr[last]) / 5,
                                             rel=1e-4)
    assert invar(last, 5.0) < 1e-5 * invar(last, 0.0)


def test_configs_that_cannot_hold_a_window_are_refused():
    rng = np.random.default_rng(0)
    config = dp_config(seq_length=P)
    with pytest.raises(ConfigError, match="seq_length must be at least"):
        build_policy(config, _stats(config, rng))
    with pytest.raises(ConfigError, match="action_horizon must be at most pred_horizon"):
        dp_config(action_horizon=P + 1)


def test_a_diffusion_policy_trains_and_its_loss_goes_down(tmp_path):
    data = synthetic_dataset(tmp_path / "d.hdf5", demos=6, length=30, images=False)
    config = dp_config(steps=400, lr=3e-3, batch_size=16, valid_every=100,
                       checkpoint_every=100, state_keys=["fingers", "object_in_tcp"])
    train(config, data, tmp_path / "run", progress=False)
    with open(tmp_path / "run" / "log.csv", newline="") as f:
        totals = [float(r["total"]) for r in csv.DictReader(f)]
    assert len(totals) == 400
    assert np.mean(totals[-50:]) < 0.7 * np.mean(totals[:50]), (totals[:5], totals[-5:])
    ckpt = load_checkpoint(tmp_path / "run" / "last.pt")
    assert isinstance(ckpt.policy, DiffusionPolicy) and RANGE_KEY in ckpt.stats
    # the average weights moved away from the initial ones and differ from the last ones
    net, ema = ckpt.policy.net.state_dict(), ckpt.policy.ema.state_dict()
    assert any(not torch.equal(net[k], ema[k]) for k in net)


def test_an_image_diffusion_policy_trains_on_the_images_of_its_observation_steps(tmp_path):
    data = synthetic_dataset(tmp_path / "d.hdf5", demos=4, length=20)
    config = dp_config("dp_reltraj", obs_mode="image", object_aux_weight=1.0, steps=30,
                       batch_size=4, valid_every=10, checkpoint_every=10, image_resize=8)
    assert observed_steps(config) == config.obs_horizon == 2
    assert observed_steps(tiny_config(obs_mode="image")) == 5  # LEGATO: its whole window
    train(config, data, tmp_path / "run", progress=False)
    with open(tmp_path / "run" / "log.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 30 and {"mse", "aux", "valid_aux"} <= set(rows[0])
    assert all(np.isfinite(float(r["total"])) for r in rows)
    ckpt = load_checkpoint(tmp_path / "run" / "last.pt")
    assert ckpt.policy.object_head is not None


@pytest.mark.slow
def test_an_image_diffusion_policy_drives_the_diagram_from_the_cameras(tmp_path):
    """Evaluation of an image chunk policy: the diagram turns its cameras into the window of
    observed images, and the policy plans a chunk from them (a new one every
    ``action_horizon`` steps)."""
    from legato_drake.diagram import build_diagram
    from legato_drake.episode import simulate
    from legato_drake.scenario import Scenario

    data = synthetic_dataset(tmp_path / "d.hdf5", demos=4, length=20)
    config = dp_config("dp_reltraj", obs_mode="image", object_aux_weight=1.0, steps=2,
                       batch_size=4, image_resize=8)
    train(config, data, tmp_path / "run", progress=False)
    scenario = Scenario(embodiment="abstract", controller="policy", duration=0.45,
                        checkpoint=str(tmp_path / "run" / "last.pt"))
    scenario.camera.width = scenario.camera.height = 32
    built = build_diagram(scenario.validate())
    simulator, result = simulate(built)
    state = built.controller.policy_state(built.controller.GetMyContextFromRoot(
        simulator.get_context()))
    assert state.step == 5 and state.policy.decisions == 2  # chunks at steps 0 and 3
    assert len(state.policy.window) == config.obs_horizon
    assert state.policy.window[-1]["left_gray"].shape[-2:] == (32, 32)
    assert result.episode_time == pytest.approx(0.45, abs=0.01)


def test_rollout_is_deterministic_and_executes_part_of_each_chunk(tmp_path, abstract_plant):
    from pydrake.systems.analysis import Simulator

    from legato_drake import conventions
    from legato_drake.diagram import object_bodies
    from legato_drake.systems.episode_recorder import EpisodeRecorder
    from legato_drake.systems.policy_controller import PolicyController

    rng = np.random.default_rng(0)
    config = dp_config("dp_reltraj", state_keys=["fingers"])
    torch.manual_seed(0)
    path = tmp_path / "dp.pt"
    stats = _stats(config, rng)
    save_checkpoint(path, Checkpoint(config, stats, build_policy(config, stats)))
    plant, _, robot, _ = abstract_plant
    features = EpisodeRecorder(plant, robot.tcp_frame, images=False,
                               object_bodies=object_bodies(plant, robot))
    controller = PolicyController(path, features)

    def run():
        context = controller.CreateDefaultContext()
        controller.get_plant_state_input_port().FixValue(
            context, plant.GetPositionsAndVelocities(plant.CreateDefaultContext()))
        controller.get_commanded_pose_input_port().FixValue(context, [0, 0, 0.8, 1, 0, 0, 0])
        simulator = Simulator(controller, context)
        actions, decisions = [], []
        for k in range(7):
            simulator.AdvanceTo(conventions.HOMING_DURATION + k * conventions.POLICY_PERIOD
                                + 0.0015)
            actions.append(controller.GetOutputPort("action").Eval(context).copy())
            decisions.append(controller.policy_state(context).policy.decisions)
        return np.array(actions), decisions, controller.policy_state(context).policy

    actions, decisions, state = run()
    assert decisions == [1, 1, 1, 2, 2, 2, 3]  # a new chunk every action_horizon steps
    assert len(state.window) == config.obs_horizon
    assert set(np.unique(actions[:, 6])) <= {0.0, 1.0} and np.isfinite(actions).all()
    again, _, _ = run()  # a fresh context starts afresh: the same actions
    np.testing.assert_array_equal(actions, again)
    scene = PolicyController(path, features, scene_seed=7)  # the scene's seed reaches it
    assert scene.policy_state(scene.CreateDefaultContext()).policy.scene_seed == 7


def test_a_shipped_checkpoint_keeps_the_ema_alone_and_acts_the_same(tmp_path):
    """``rollout_only`` drops the trained copy (half the file) and the policy it loads
    denoises exactly the chunk the full checkpoint does."""
    rng = np.random.default_rng(1)
    config = dp_config("dp_reltraj", state_keys=["fingers"])
    stats = _stats(config, rng)
    policy = build_policy(config, stats)
    with torch.no_grad():  # an EMA that differs from the trained weights
        for p in policy.net.parameters():
            p.add_(torch.randn_like(p) * 0.1)
    full, shipped = tmp_path / "full.pt", tmp_path / "shipped.pt"
    save_checkpoint(full, Checkpoint(config, stats, policy))
    save_checkpoint(shipped, Checkpoint(config, stats, policy, rollout_only=True))
    assert shipped.stat().st_size < 0.6 * full.stat().st_size
    a, b = load_checkpoint(full), load_checkpoint(shipped)
    assert b.rollout_only and not a.rollout_only and b.optimizer is None
    assert not any(k.startswith("net.") for k in torch.load(shipped)["model"])
    obs = {k: torch.tensor(v["mean"][None]) for k, v in stats.items() if k == "fingers"}
    chunk_a, _ = a.policy.act(obs, a.policy.initial_state())
    chunk_b, _ = b.policy.act(obs, b.policy.initial_state())
    torch.testing.assert_close(chunk_a, chunk_b, rtol=0, atol=0)


def test_the_sample_seed_alone_sets_the_rollout_noise():
    """``sample_seed`` (a rollout field: ``evaluate --set``) replaces the training seed as the
    seed of each decision's initial noise; unset, the training seed draws it."""
    from legato_drake.learning.config import apply_rollout_overrides

    rng = np.random.default_rng(2)
    config = dp_config("dp_reltraj", state_keys=["fingers"], seed=3)
    stats = _stats(config, rng)
    policy = build_policy(config, stats).eval()
    obs = {"fingers": torch.tensor(stats["fingers"]["mean"][None])}

    def chunk(cfg):
        policy.config = cfg
        return policy.act(obs, policy.initial_state())[0]

    same = apply_rollout_overrides(config, ["sample_seed=3"])
    other = apply_rollout_overrides(config, ["sample_seed=4"])
    torch.testing.assert_close(chunk(config), chunk(same), rtol=0, atol=0)
    assert not torch.equal(chunk(config), chunk(other))


def test_scene_rollout_noise_draws_each_scene_its_own_noise():
    """``rollout_noise: policy`` starts every scene's k-th chunk from the same noise;
    ``scene`` draws it from the scene's seed as well: the same scene, the same chunk;
    ``zero`` denoises from zeros, whatever the seeds."""
    from legato_drake.learning.config import apply_rollout_overrides

    rng = np.random.default_rng(3)
    config = dp_config("dp_reltraj", state_keys=["fingers"])
    stats = _stats(config, rng)
    policy = build_policy(config, stats).eval()
    obs = {"fingers": torch.tensor(stats["fingers"]["mean"][None])}

    def chunk(cfg, scene):
        policy.config = cfg
        return policy.act(obs, policy.initial_state(scene))[0]

    torch.testing.assert_close(chunk(config, 1), chunk(config, 2), rtol=0, atol=0)
    per_scene = apply_rollout_overrides(config, ["rollout_noise=scene"])
    torch.testing.assert_close(chunk(per_scene, 1), chunk(per_scene, 1), rtol=0, atol=0)
    assert not torch.equal(chunk(per_scene, 1), chunk(per_scene, 2))
    zero = apply_rollout_overrides(config, ["rollout_noise=zero"])
    other = apply_rollout_overrides(zero, ["sample_seed=9"])
    torch.testing.assert_close(chunk(zero, 1), chunk(other, 2), rtol=0, atol=0)
    assert not torch.equal(chunk(zero, 1), chunk(config, 1))
    with pytest.raises(ConfigError, match="rollout_noise"):
        apply_rollout_overrides(config, ["rollout_noise=trial"])


def test_the_noise_scale_is_a_sampling_temperature_from_zeros_to_the_full_draw():
    """``noise_scale`` multiplies each chunk's initial noise: 1 is the full draw, 0 the same
    chunk as ``rollout_noise: zero``, and in between the chunk moves from one toward the
    other; outside [0, 1] is an error naming the field."""
    from legato_drake.learning.config import apply_rollout_overrides

    rng = np.random.default_rng(4)
    config = apply_rollout_overrides(dp_config("dp_reltraj", state_keys=["fingers"]),
                                     ["rollout_noise=scene"])
    stats = _stats(config, rng)
    policy = build_policy(config, stats).eval()
    obs = {"fingers": torch.tensor(stats["fingers"]["mean"][None])}

    def chunk(*overrides):
        policy.config = apply_rollout_overrides(config, list(overrides))
        return policy.act(obs, policy.initial_state(7))[0]

    full, zero = chunk(), chunk("rollout_noise=zero")
    torch.testing.assert_close(chunk("noise_scale=1"), full, rtol=0, atol=0)
    torch.testing.assert_close(chunk("noise_scale=0"), zero, rtol=0, atol=0)
    distances = [float((chunk(f"noise_scale={s}") - zero)[..., :6].norm())
                 for s in (0.25, 0.5, 1.0)]
    assert 0 < distances[0] < distances[1] < distances[2]
    for bad in ("noise_scale=1.5", "noise_scale=-0.1", "noise_scale=nan"):
        with pytest.raises(ConfigError, match="noise_scale"):
            apply_rollout_overrides(config, [bad])
