"""ScriptedDemonstrator alone: its actions replay the script, determinism per seed."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from legato_drake import conventions
from legato_drake.diagram import build_plant
from legato_drake.poses import apply_delta, pose_error
from legato_drake.scenario import Scenario
from legato_drake.systems.scripted_demonstrator import (
    ExpertNoise,
    ScriptedDemonstrator,
    min_jerk,
    script_from_waypoints,
)
from legato_drake.tasks.base import Waypoint


def _demonstrator(plant_tuple, seed, noise=None):
    plant, _, _, task = plant_tuple
    system = ScriptedDemonstrator(plant, task, seed, noise=noise)
    context = system.CreateDefaultContext()
    plant_context = plant.CreateDefaultContext()
    task.set_initial_state(plant, plant_context, np.random.default_rng(seed))
    system.get_plant_state_input_port().FixValue(
        context, plant.GetPositionsAndVelocities(plant_context))
    return system, context


def _actions(system, context, steps):
    simulator = Simulator(system, context)
    actions = []
    for k in range(steps):
        simulator.AdvanceTo(conventions.HOMING_DURATION + conventions.CONTROLLER_OFFSET
                            + k * conventions.POLICY_PERIOD + 0.01)
        actions.append(system.GetOutputPort("action").Eval(context).copy())
    return np.array(actions)


def _both(system, context, steps):
    """(executed actions, labels) of the first ``steps`` steps."""
    simulator = Simulator(system, context)
    executed, labels = [], []
    for k in range(steps):
        simulator.AdvanceTo(conventions.HOMING_DURATION + conventions.CONTROLLER_OFFSET
                            + k * conventions.POLICY_PERIOD + 0.01)
        executed.append(system.GetOutputPort("action").Eval(context).copy())
        labels.append(system.GetOutputPort("label").Eval(context).copy())
    return np.array(executed), np.array(labels)


def test_min_jerk_profile():
    assert min_jerk(0.0) == 0.0 and min_jerk(1.0) == 1.0
    assert abs(min_jerk(0.5) - 0.5) < 1e-12


def test_script_reaches_every_waypoint():
    X0 = conventions.START_POSE
    wps = [Waypoint(RigidTransform([0.3, -0.3, 0.8]), grasp=False, speed=0.2),
           Waypoint(RigidTransform([0.3, -0.3, 0.8]), grasp=True, hold=0.5)]
    script = script_from_waypoints(X0, wps)
    assert len(script) == 10 + 5
    assert pose_error(script.pose(9), wps[0].pose) < (1e-12, 1e-12)
    np.testing.assert_array_equal(script.grasps, [0.0] * 10 + [1.0] * 5)


def test_actions_integrate_to_the_script(panda_plant):
    system, context = _demonstrator(panda_plant, seed=3)
    n = 40
    actions = _actions(system, context, n)
    script = system.script(context)
    X = conventions.START_POSE
    for k in range(n):
        X = apply_delta(X, actions[k, :6])
    dp, dr = pose_error(X, script.pose(n - 1))
    assert dp < 1e-9 and dr < 1e-9
    assert set(np.unique(actions[:, 6])) <= {0.0, 1.0}


def test_same_seed_same_actions_other_seed_other_actions(panda_plant):
    a = _actions(*_demonstrator(panda_plant, seed=5), 20)
    b = _actions(*_demonstrator(panda_plant, seed=5), 20)
    c = _actions(*_demonstrator(panda_plant, seed=6), 20)
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)


def test_done_after_the_script(panda_plant):
    system, context = _demonstrator(panda_plant, seed=0)
    assert system.GetOutputPort("done").Eval(context)[0] == 0.0
    Simulator(system, context).AdvanceTo(conventions.HOMING_DURATION + 60.0)
    assert system.GetOutputPort("done").Eval(context)[0] == 1.0
    np.testing.assert_array_equal(system.GetOutputPort("action").Eval(context)[:6], 0.0)


@pytest.mark.parametrize("task_name", ["lid", "cup", "ladle"])
def test_every_grasp_change_follows_the_end_of_a_motion(task_name):
    """What a policy can imitate: the grasp closes and opens on the step right after the
    gripper stopped moving from full speed (an observable event), never after a hold in an
    unchanging scene or a minimum-jerk creep (the Waypoint rule)."""
    plant, _, _, task = build_plant(Scenario(embodiment="abstract", task=task_name),
                                    DiagramBuilder())
    for seed in range(3):
        context = plant.CreateDefaultContext()
        task.set_initial_state(plant, context, np.random.default_rng(seed))
        plan = task.plan_demonstration(plant, context, np.random.default_rng([seed, 1]))
        script = script_from_waypoints(conventions.START_POSE, plan)
        releases = np.flatnonzero((script.grasps[:-1] > 0.5) & (script.grasps[1:] < 0.5)) + 1
        grasps = np.flatnonzero((script.grasps[:-1] < 0.5) & (script.grasps[1:] > 0.5)) + 1
        assert len(releases) == 1 and len(grasps) == 1
        for k in (*grasps, *releases):
            moved = np.linalg.norm(script.poses[k - 1, :3] - script.poses[k - 2, :3])
            assert moved > 0.004, f"{task_name} seed {seed}: step {k} after a hold or a creep"
            np.testing.assert_allclose(script.poses[k], script.poses[k - 1])  # stopped


def test_without_noise_the_label_is_the_action(panda_plant):
    executed, labels = _both(*_demonstrator(panda_plant, seed=3), 30)
    np.testing.assert_array_equal(executed, labels)


def test_noisy_expert_labels_correct_back_to_the_plan(panda_plant):
    """DART-style collection: the executed poses wander off the plan by the configured
    offset, and each label leads from the executed pose of the previous step back onto the
    plan (so a dataset of labels teaches the corrections)."""
    noise = ExpertNoise(position_std=0.005, rotation_std=np.radians(2.0), correlation=0.8)
    system, context = _demonstrator(panda_plant, seed=3, noise=noise)
    n = 110
    executed, labels = _both(system, context, n)
    script = system.script(context)
    assert len(script) >= n
    X = conventions.START_POSE
    offsets = []
    for k in range(n):
        on_plan = apply_delta(X, labels[k, :6])
        dp, dr = pose_error(on_plan, script.pose(k))
        assert dp < 1e-9 and dr < 1e-9, f"step {k}: the label does not lead back to the plan"
        X = apply_delta(X, executed[k, :6])
        offsets.append(pose_error(X, script.pose(k))[0])
        assert executed[k, 6] == labels[k, 6] == script.grasps[k]
        if k > 0 and np.array_equal(script.poses[k], script.poses[k - 1]):
            assert offsets[-1] < 1e-9, f"step {k}: perturbed where the plan holds still"
    offsets = np.array(offsets)
    transit = offsets[5:40]  # the fast move to the pre-grasp pose
    assert 0.002 < transit.mean() < 0.02 and offsets.max() < 0.05  # about sqrt(3) * 5 mm
    assert (offsets < 1e-9).sum() >= 5  # the grasp hold
    again = _both(*_demonstrator(panda_plant, seed=3, noise=noise), n)
    np.testing.assert_array_equal(again[0], executed)  # seeded


def test_noisy_expert_removes_its_offset_when_done(panda_plant):
    noise = ExpertNoise(position_std=0.005, rotation_std=0.02)
    system, context = _demonstrator(panda_plant, seed=1, noise=noise)
    Simulator(system, context).AdvanceTo(conventions.HOMING_DURATION + 60.0)
    np.testing.assert_array_equal(system.GetOutputPort("action").Eval(context)[:6], 0.0)
    np.testing.assert_array_equal(system.GetOutputPort("label").Eval(context)[:6], 0.0)


def test_a_lower_full_speed_perturbs_the_slow_moves_too(panda_plant):
    """``full_speed``: with the default the slow final move into the grasp is hardly
    perturbed; at a lower full speed the same drift perturbs it fully, and the hold of the
    grasp itself still never is."""
    n = 110

    def offsets(noise: ExpertNoise) -> tuple[np.ndarray, np.ndarray]:
        system, context = _demonstrator(panda_plant, seed=3, noise=noise)
        executed, _ = _both(system, context, n)
        script = system.script(context)
        X, out = conventions.START_POSE, []
        for k in range(n):
            X = apply_delta(X, executed[k, :6])
            out.append(pose_error(X, script.pose(k))[0])
        speed = np.linalg.norm(np.diff(script.poses[: n + 1, :3], axis=0), axis=1) \
            / conventions.POLICY_PERIOD
        speed = np.concatenate([[np.inf], speed[: n - 1]])  # the plan's speed into step k
        return np.array(out), speed

    default, speed = offsets(ExpertNoise(position_std=0.005))
    low, _ = offsets(ExpertNoise(position_std=0.005, full_speed=0.02))
    slow = (speed > 0.02) & (speed < 0.1)  # e.g. the final 0.06 m/s move into the grasp
    assert slow.sum() >= 5
    assert low[slow].mean() > 1.5 * default[slow].mean()
    held = speed < 1e-9
    assert held.sum() >= 5 and low[held].max() < 1e-9 and default[held].max() < 1e-9
