"""The PolicyController alone, with its own context and fixed inputs."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from pydrake.systems.analysis import Simulator

from legato_drake import conventions
from legato_drake.data.derived import object_in_tcp, observation_sizes
from legato_drake.diagram import object_bodies
from legato_drake.learning.checkpoint import Checkpoint, load_checkpoint, save_checkpoint
from legato_drake.learning.policies import RecurrentGMMPolicy
from legato_drake.systems.episode_recorder import EpisodeRecorder
from legato_drake.systems.policy_controller import PolicyController
from tests.learning_helpers import tiny_config

T0 = conventions.HOMING_DURATION


def _checkpoint(tmp_path, mode: str, **changes):
    torch.manual_seed(0)
    config = tiny_config(obs_mode=mode, **changes)
    rng = np.random.default_rng(0)
    dims = observation_sizes(3)
    stats = {k: {"mean": rng.normal(0, 0.01, d).astype(np.float32),
                 "std": np.full(d, 0.05, np.float32)} for k, d in dims.items()}
    path = tmp_path / f"{mode}.pt"
    save_checkpoint(path, Checkpoint(config, stats, RecurrentGMMPolicy(config, stats)))
    return path


def _expected_actions(policy, observe, steps: int, reset: int) -> np.ndarray:
    """Runs the policy step by step as training sees sequences: history from its own
    actions, RNN state reset every ``reset`` steps."""
    history, hidden, actions = np.zeros((2, 6)), None, []
    for k in range(steps):
        if k % reset == 0:
            hidden = None
        obs = {"delta_positions": torch.tensor(history[:, :3].reshape(1, 6)).float(),
               "delta_eulers": torch.tensor(history[:, 3:].reshape(1, 6)).float(),
               **observe()}
        with torch.no_grad():
            out, hidden = policy({k: v[:, None] for k, v in obs.items()}, hidden)
        action = policy.mode_action(out)[:, 0]
        actions.append(action[0].numpy().astype(float))
        history = np.concatenate([history[1:], action[0, None, :6].numpy()])
    return np.array(actions)


def _run(controller, context, steps: int) -> list[np.ndarray]:
    simulator = Simulator(controller, context)
    actions = []
    for k in range(steps):
        simulator.AdvanceTo(T0 + k * conventions.POLICY_PERIOD + 0.0015)
        actions.append(controller.GetOutputPort("action").Eval(context).copy())
    return actions


def test_state_policy_steps_resets_and_carries_its_history(tmp_path, abstract_plant):
    plant, _, robot, _ = abstract_plant
    keys = ["tcp_commanded", "object", "object_in_tcp", "fingers"]
    path = _checkpoint(tmp_path, "state", seq_length=4, state_keys=keys)
    features = EpisodeRecorder(plant, robot.tcp_frame, images=False,
                               object_bodies=object_bodies(plant, robot))
    controller = PolicyController(path, features)
    context = controller.CreateDefaultContext()
    x = plant.GetPositionsAndVelocities(plant.CreateDefaultContext())
    controller.get_plant_state_input_port().FixValue(context, x)
    commanded = np.array([0.1, -0.3, 0.8, 1.0, 0.0, 0.0, 0.0])
    controller.get_commanded_pose_input_port().FixValue(context, commanded)
    assert np.all(controller.GetOutputPort("action").Eval(context) == 0)

    steps = 10
    actions = _run(controller, context, steps)
    state = controller.policy_state(context)
    assert state.step == steps
    np.testing.assert_allclose(state.history, np.array(actions[-2:])[:, :6])
    assert controller.GetOutputPort("done").Eval(context)[0] == 0.0

    # The same features as the recorder's samples (its own code computes them), and the
    # derived ones as the Dataset derives them.
    log_context = features.CreateDefaultContext()
    features.get_action_input_port().FixValue(log_context, np.zeros(7))
    features.get_plant_state_input_port().FixValue(log_context, x)
    features.get_commanded_pose_input_port().FixValue(log_context, commanded)
    sample = features.sample(log_context)
    obs = controller.observation(context, np.zeros((2, 6)))
    for key in ("tcp_commanded", "object", "fingers"):
        np.testing.assert_allclose(obs[key].numpy()[0], sample[key].astype(np.float32))
    np.testing.assert_allclose(obs["object_in_tcp"].numpy()[0],
                               object_in_tcp(sample["tcp_measured"], sample["object"]),
                               rtol=1e-6, atol=1e-6)
    assert obs["object"].shape == (1, 21) and obs["object_in_tcp"].shape == (1, 27)

    policy = load_checkpoint(path).policy
    expected = _expected_actions(policy, lambda: {k: obs[k] for k in keys}, steps, reset=4)
    np.testing.assert_allclose(np.array(actions), expected, rtol=1e-5, atol=1e-6)
    no_reset = _expected_actions(policy, lambda: {k: obs[k] for k in keys}, steps,
                                 reset=1000)
    assert not np.allclose(no_reset[4:], expected[4:])


def test_image_policy_reads_both_cameras(tmp_path):
    path = _checkpoint(tmp_path, "image")
    controller = PolicyController(path)
    assert [p.get_name() for p in controller.get_image_input_ports()] == \
        ["left_gray", "right_gray"]
    context = controller.CreateDefaultContext()
    rng = np.random.default_rng(3)
    images = {k: rng.integers(0, 256, (16, 16, 1), dtype=np.uint8)
              for k in ("left_gray", "right_gray")}
    for port in controller.get_image_input_ports():
        port.FixValue(context, images[port.get_name()])
    actions = _run(controller, context, 3)
    from legato_drake.data.torch_dataset import image_to_tensor

    expected = _expected_actions(load_checkpoint(path).policy,
                                 lambda: {k: image_to_tensor(v)[None] for k, v in images.items()},
                                 3, reset=20)
    np.testing.assert_allclose(np.array(actions), expected, rtol=1e-5, atol=1e-6)


def test_state_policy_needs_features(tmp_path):
    with pytest.raises(ValueError, match="EpisodeRecorder"):
        PolicyController(_checkpoint(tmp_path, "state"))
