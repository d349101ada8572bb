"""The ladle task's success predicate on hand-built states, its randomization ranges, and its
scripted expert (slow)."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.multibody.math import SpatialVelocity
from pydrake.systems.framework import DiagramBuilder

from legato_drake import conventions
from legato_drake.diagram import build_plant
from legato_drake.scenario import Scenario
from legato_drake.tasks.ladle import (
    CASE_X,
    CASE_Y,
    CASE_YAW,
    LADLE_OFFSET,
    STOVE_X,
    STOVE_Y,
    LadleTask,
)


@pytest.fixture(scope="module")
def ladle_plant():
    """(plant, scene_graph, robot handles, task) of the Abstract ladle scene."""
    return build_plant(Scenario(embodiment="abstract", task="ladle"), DiagramBuilder())


def _state(plant_tuple, com_in_case=(0.0, 0.0, 0.02), ladle_rpy=(0.0, 0.0, 0.0),
           fingers=0.05, ladle_velocity=0.0, seed=0):
    """A plant context with the ladle lying along the case's long side, its centre of mass at
    ``com_in_case`` in the case floor's frame, then turned by ``ladle_rpy`` about it."""
    plant, _, _, task = plant_tuple
    context = plant.CreateDefaultContext()
    task.set_initial_state(plant, context, np.random.default_rng(seed))
    X_WF = task.case_floor.CalcPoseInWorld(context)
    R = X_WF.rotation() @ RotationMatrix(RollPitchYaw(ladle_rpy)) \
        @ RotationMatrix.MakeZRotation(np.pi / 2)
    p_LC = task.ladle.CalcCenterOfMassInBodyFrame(context)
    p_com = X_WF @ np.asarray(com_in_case, dtype=float)
    plant.SetFreeBodyPose(context, task.ladle, RigidTransform(R, p_com - R @ p_LC))
    if ladle_velocity:
        plant.SetFreeBodySpatialVelocity(context, task.ladle, SpatialVelocity(
            np.zeros(3), [0.0, ladle_velocity, 0.0]))
    for name in conventions.GRIPPER_FINGER_JOINTS:
        plant.GetJointByName(name).set_translation(context, fingers)
    return plant, task, context


def test_ladle_lying_in_the_case_succeeds(ladle_plant):
    plant, task, context = _state(ladle_plant, com_in_case=(0.02, -0.03, 0.02))
    report = task.evaluate(plant, context)
    assert report.success, report.reason
    assert report.metrics["inset"] == pytest.approx(0.06)
    assert report.metrics["com_height"] == pytest.approx(0.02)
    # Leaning on a wall (tilted 15 deg, centre of mass 4 cm up) still counts.
    plant, task, context = _state(ladle_plant, com_in_case=(0.0, 0.0, 0.04),
                                  ladle_rpy=(0.26, 0.0, 0.0))
    assert task.evaluate(plant, context).success


@pytest.mark.parametrize("kwargs, words", [
    (dict(com_in_case=(0.0, 0.25, 0.0)), "inside the case's walls"),   # dropped beside it
    (dict(com_in_case=(0.0, 0.25, -1.0)), "ladle fell off the table"),  # off the edge
    (dict(com_in_case=(0.075, 0.0, 0.02)), "inside the case's walls"),  # on the long wall
    (dict(com_in_case=(0.0, 0.0, 0.12)), "above the case's floor"),     # held above it
    (dict(com_in_case=(0.0, 0.0, 0.12), ladle_rpy=(0.0, 0.9, 0.0)),    # tilted, hanging
     "above the case's floor"),
    (dict(fingers=0.019), "still held"),                       # fingers closed on the handle
    (dict(ladle_velocity=0.2), "still moving"),                         # sliding
])
def test_near_misses_fail_with_the_reason(ladle_plant, kwargs, words):
    plant, task, context = _state(ladle_plant, **kwargs)
    report = task.evaluate(plant, context)
    assert not report.success
    assert words in report.reason


def test_thresholds_are_part_of_the_api():
    assert LadleTask.min_inset == 0.01 and LadleTask.height_band == (-0.01, 0.06)
    assert LadleTask.release_margin == 0.008 and LadleTask.max_speed == 0.05


def test_initial_state_is_a_failure_and_randomized_within_spec(ladle_plant):
    plant, _, _, task = ladle_plant
    seen = []
    for seed in range(20):
        context = plant.CreateDefaultContext()
        task.set_initial_state(plant, context, np.random.default_rng(seed))
        report = task.evaluate(plant, context)
        assert not report.success and "case's walls" in report.reason
        stove = plant.EvalBodyPoseInWorld(context, task.stove).translation()
        pot = plant.EvalBodyPoseInWorld(context, task.pot).translation()
        case = plant.EvalBodyPoseInWorld(context, task.case)
        ladle = plant.EvalBodyPoseInWorld(context, task.ladle)
        assert stove[0] == pytest.approx(STOVE_X) and STOVE_Y[0] <= stove[1] <= STOVE_Y[1]
        np.testing.assert_allclose(pot[:2], stove[:2])
        top = stove + [0.0, 0.0, 0.01]
        np.testing.assert_allclose(ladle.translation()[:2] - top[:2], LADLE_OFFSET[:2])
        assert ladle.translation()[2] - top[2] == pytest.approx(LADLE_OFFSET[2], abs=0.015)
        rpy = RollPitchYaw(ladle.rotation())
        assert rpy.pitch_angle() == pytest.approx(np.pi / 4)
        assert rpy.yaw_angle() == pytest.approx(np.pi / 4)
        assert case.translation()[0] == pytest.approx(CASE_X)
        assert CASE_Y[0] <= case.translation()[1] <= CASE_Y[1]
        assert CASE_YAW[0] <= RollPitchYaw(case.rotation()).yaw_angle() <= CASE_YAW[1]
        seen.append([stove[1], case.translation()[1]])
    assert np.ptp(np.array(seen), axis=0).min() > 0.01  # it really varies
    assert STOVE_Y == (0.18, 0.42) and CASE_Y == (-0.42, -0.38)
    np.testing.assert_allclose(CASE_YAW, (0.5 * np.pi - np.pi / 8, 0.5 * np.pi + np.pi / 8))
