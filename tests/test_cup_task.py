"""The cup task's success predicate on hand-built states, its randomization ranges, and its
scripted expert (slow)."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.math import SpatialVelocity
from pydrake.systems.framework import DiagramBuilder

from legato_drake import conventions
from legato_drake.diagram import build_plant
from legato_drake.scenario import Scenario
from legato_drake.tasks.cup import (
    CUP_X,
    CUP_Y,
    CUP_YAW,
    SHELF_FLOOR,
    SHELF_X,
    SHELF_Y,
    SHELF_YAW,
    CupTask,
)


@pytest.fixture(scope="module")
def cup_plant():
    """(plant, scene_graph, robot handles, task) of the Abstract cup scene."""
    return build_plant(Scenario(embodiment="abstract", task="cup"), DiagramBuilder())


def _state(plant_tuple, cup_in_shelf=(0.0, 0.01, 0.0), cup_rpy=(0.0, 0.0, 0.0),
           fingers=0.05, cup_velocity=0.0, seed=0):
    """A plant context with the cup placed in the shelf's frame (z from the shelf's floor)."""
    plant, _, _, task = plant_tuple
    context = plant.CreateDefaultContext()
    task.set_initial_state(plant, context, np.random.default_rng(seed))
    X_WS = plant.EvalBodyPoseInWorld(context, task.shelf)
    p_SC = np.asarray(cup_in_shelf) + [0.0, 0.0, SHELF_FLOOR]
    plant.SetFreeBodyPose(context, task.cup, X_WS @ RigidTransform(RollPitchYaw(cup_rpy), p_SC))
    if cup_velocity:
        plant.SetFreeBodySpatialVelocity(context, task.cup, SpatialVelocity(
            np.zeros(3), [cup_velocity, 0.0, 0.0]))
    for name in conventions.GRIPPER_FINGER_JOINTS:
        plant.GetJointByName(name).set_translation(context, fingers)
    return plant, task, context


def test_cup_standing_in_the_shelf_succeeds(cup_plant):
    plant, task, context = _state(cup_plant, cup_in_shelf=(0.05, 0.0, 0.005))
    report = task.evaluate(plant, context)
    assert report.success, report.reason
    assert report.metrics["inset"] == pytest.approx(0.13 - 0.0)  # 13 cm from the back wall
    assert report.metrics["rest_height"] == pytest.approx(0.005)


@pytest.mark.parametrize("kwargs, words", [
    (dict(cup_in_shelf=(0.0, 0.45, -0.035)), "inside the shelf's interior"),  # beside it
    (dict(cup_in_shelf=(0.0, 0.45, -1.005)), "cup fell off the table (97 cm below"),  # off it
    (dict(cup_in_shelf=(0.0, 0.10, 0.0)), "inside the shelf's interior"),     # half out
    (dict(cup_in_shelf=(0.19, 0.0, 0.0)), "inside the shelf's interior"),     # in the wall
    (dict(cup_in_shelf=(0.0, 0.0, 0.05)), "from the shelf's floor"),          # in the air
    (dict(cup_rpy=(0.6, 0.0, 0.0)), "tilted"),                                # tilted over
    (dict(fingers=0.006), "still held"),                         # fingers closed on the bar
    (dict(cup_velocity=0.2), "still moving"),                                 # sliding
])
def test_near_misses_fail_with_the_reason(cup_plant, kwargs, words):
    plant, task, context = _state(cup_plant, **kwargs)
    report = task.evaluate(plant, context)
    assert not report.success
    assert words in report.reason


def test_thresholds_are_part_of_the_api():
    assert CupTask.min_inset == 0.06 and CupTask.max_tilt_deg == 20.0
    assert CupTask.rest_height_band == (-0.01, 0.02) and CupTask.max_speed == 0.05


def test_initial_state_is_a_failure_and_randomized_within_range(cup_plant):
    plant, _, _, task = cup_plant
    seen = []
    for seed in range(20):
        context = plant.CreateDefaultContext()
        task.set_initial_state(plant, context, np.random.default_rng(seed))
        report = task.evaluate(plant, context)
        assert not report.success and "interior" in report.reason
        shelf = plant.EvalBodyPoseInWorld(context, task.shelf)
        cup = plant.EvalBodyPoseInWorld(context, task.cup)
        for X, xs, ys, yaws in ((shelf, SHELF_X, SHELF_Y, SHELF_YAW), (cup, CUP_X, CUP_Y, CUP_YAW)):
            x, y, z = X.translation()
            assert xs[0] <= x <= xs[1] and ys[0] <= y <= ys[1]
            assert z == pytest.approx(0.626)
            assert yaws[0] <= RollPitchYaw(X.rotation()).yaw_angle() <= yaws[1]
        seen.append([*shelf.translation()[:2], *cup.translation()[:2]])
    assert np.ptp(np.array(seen), axis=0).min() > 0.01  # it really varies
    assert CUP_X == (0.5425, 0.5825) and CUP_Y == (0.08, 0.12)  # SPEC
    np.testing.assert_allclose(CUP_YAW, (0.65 * np.pi, 0.85 * np.pi))
    assert np.ptp(SHELF_X) == pytest.approx(0.075) and np.ptp(SHELF_Y) == pytest.approx(0.2)
    np.testing.assert_allclose(SHELF_YAW, (0.3 * np.pi, 0.4 * np.pi))
