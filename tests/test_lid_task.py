"""The lid task's success predicate on hand-built states, and its randomization ranges."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.math import SpatialVelocity
from pydrake.systems.analysis import Simulator

from legato_drake import conventions
from legato_drake.systems.success_monitor import SuccessMonitor
from legato_drake.tasks.lid import LID_HALF_THICKNESS


def _state(plant_tuple, lid_offset=(0.0, 0.0, 0.0), lid_rpy=(0.0, 0.0, 0.0), fingers=0.05,
           lid_velocity=0.0, seed=0):
    """A plant context with the lid placed relative to the resting pose on the pot."""
    plant, _, _, task = plant_tuple
    context = plant.CreateDefaultContext()
    task.set_initial_state(plant, context, np.random.default_rng(seed))
    rim = task.pot_rim.CalcPoseInWorld(context).translation()
    p = rim + [0.0, 0.0, LID_HALF_THICKNESS] + np.asarray(lid_offset)
    plant.SetFreeBodyPose(context, task.lid, RigidTransform(RollPitchYaw(lid_rpy), p))
    if lid_velocity:
        plant.SetFreeBodySpatialVelocity(context, task.lid, SpatialVelocity(
            np.zeros(3), [lid_velocity, 0.0, 0.0]))
    for name in conventions.GRIPPER_FINGER_JOINTS:
        plant.GetJointByName(name).set_translation(context, fingers)
    return plant, task, context


def test_lid_resting_on_the_pot_succeeds(panda_plant):
    plant, task, context = _state(panda_plant, lid_offset=(0.01, -0.01, 0.0))
    report = task.evaluate(plant, context)
    assert report.success, report.reason
    assert report.metrics["center_offset"] == pytest.approx(np.sqrt(2) * 0.01)


@pytest.mark.parametrize("kwargs, words", [
    (dict(lid_offset=(0.0, -0.25, -0.1)), "from the pot axis"),      # dropped beside the pot
    (dict(lid_offset=(0.0, -0.6, -1.5)), "lid fell off the table"),  # off the edge
    (dict(lid_offset=(0.035, 0.0, 0.0)), "from the pot axis"),       # just outside 3 cm
    (dict(lid_rpy=(0.5, 0.0, 0.0)), "tilted"),                       # tilted over
    (dict(lid_offset=(0.0, 0.0, 0.05)), "from resting on the rim"),  # still in the air
    (dict(fingers=0.01), "still held"),                              # fingers closed on it
    (dict(lid_velocity=0.2), "still moving"),                        # sliding
])
def test_near_misses_fail_with_the_reason(panda_plant, kwargs, words):
    plant, task, context = _state(panda_plant, **kwargs)
    report = task.evaluate(plant, context)
    assert not report.success
    assert words in report.reason


def test_initial_state_is_a_failure_and_randomized_within_spec(panda_plant):
    plant, _, _, task = panda_plant
    seen = []
    for seed in range(20):
        context = plant.CreateDefaultContext()
        task.set_initial_state(plant, context, np.random.default_rng(seed))
        assert not task.evaluate(plant, context).success
        stove = plant.EvalBodyPoseInWorld(context, task.stove).translation()
        lid = plant.EvalBodyPoseInWorld(context, task.lid)
        assert 0.67 <= stove[0] <= 0.69 and -0.05 <= stove[1] <= 0.05
        dx, dy = lid.translation()[:2] - stove[:2]
        assert -0.07 <= dx <= -0.04 and -0.28 <= dy <= -0.22
        assert RollPitchYaw(lid.rotation()).yaw_angle() == pytest.approx(np.pi / 2)
        seen.append(stove[:2])
    assert np.ptp(np.array(seen), axis=0).min() > 0.005  # it really varies


def test_success_monitor_reports_the_predicate(panda_plant):
    plant, _, _, task = panda_plant
    monitor = SuccessMonitor(plant, task)
    for offset, expected in (((0.0, 0.0, 0.0), True), ((0.0, -0.25, -0.1), False)):
        _, _, plant_context = _state(panda_plant, lid_offset=offset)
        context = monitor.CreateDefaultContext()
        monitor.get_plant_state_input_port().FixValue(
            context, plant.GetPositionsAndVelocities(plant_context))
        assert monitor.evaluate(context).success is expected
        Simulator(monitor, context).AdvanceTo(conventions.HOMING_DURATION + 0.05)
        assert monitor.GetOutputPort("success").Eval(context)[0] == float(expected)
        first = monitor.GetOutputPort("first_success_time").Eval(context)[0]
        assert (first == pytest.approx(conventions.HOMING_DURATION)) if expected \
            else np.isnan(first)
