"""GripperTargetIntegrator alone: homing blend, delta composition, interpolation, NaN hold."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.systems.analysis import Simulator

from legato_drake import conventions
from legato_drake.poses import apply_delta, pose_error
from legato_drake.systems.target_integrator import GripperTargetIntegrator

X_HOME = RigidTransform(RollPitchYaw(0.2, -0.1, 0.3), [0.4, -0.2, 0.9])
T0 = conventions.HOMING_DURATION


def _run(delta, t):
    system = GripperTargetIntegrator(X_HOME)
    context = system.CreateDefaultContext()
    system.get_delta_input_port().FixValue(context, np.asarray(delta, dtype=float))
    simulator = Simulator(system, context)
    simulator.AdvanceTo(t)
    pose = system.GetOutputPort("X_WG_target").Eval(context)
    velocity = system.GetOutputPort("V_WG_target").Eval(context)
    return pose, velocity


def test_homing_blends_from_home_to_start():
    start, _ = _run(np.zeros(6), 0.0)
    assert pose_error(start, X_HOME) < (1e-9, 1e-9)
    middle, v = _run(np.zeros(6), T0 / 2)
    assert np.linalg.norm(middle.translation() - 0.5 * (X_HOME.translation() +
                          conventions.START_POSE.translation())) < 1e-9
    assert np.linalg.norm(v) > 0
    end, v = _run(np.zeros(6), T0 - 1e-3)
    assert pose_error(end, conventions.START_POSE)[0] < 1e-5


def test_deltas_compose_in_the_previous_commanded_frame():
    delta = np.array([0.01, 0.0, 0.0, 0.0, 0.0, 0.05])  # forward 1 cm, yaw 0.05 rad per step
    steps = 5
    pose, v = _run(delta, T0 + conventions.TARGET_OFFSET + (steps - 1) * 0.1 + 0.1 - 1e-6)
    expected = conventions.START_POSE
    for _ in range(steps):
        expected = apply_delta(expected, delta)
    dp, dr = pose_error(pose, expected)
    assert dp < 1e-6 and dr < 1e-6
    # Yawing while moving forward in the gripper frame curves the path to the left (+y).
    assert pose.translation()[1] > conventions.START_POSE.translation()[1]


def test_target_moves_smoothly_between_commands():
    delta = np.array([0.02, 0, 0, 0, 0, 0])
    t = T0 + conventions.TARGET_OFFSET + 0.05  # half way through the first period
    pose, v = _run(delta, t)
    assert abs(pose.translation()[0] - (conventions.START_POSE.translation()[0] + 0.01)) < 1e-6
    np.testing.assert_allclose(v, [0, 0, 0, 0.2, 0, 0], atol=1e-9)


def test_nan_delta_holds_the_commanded_pose():
    pose, v = _run([np.nan, 0, 0, 0, 0, 0], T0 + 1.0)
    assert pose_error(pose, conventions.START_POSE) < (1e-9, 1e-9)
    assert np.all(v == 0)


def test_a_bounded_target_stays_within_its_lead_of_the_measured_gripper(abstract_plant):
    """With ``max_lead`` the commanded position never leads the measured TCP by more than the
    bound (here the robot never moves: its plant state is fixed), along the line to where
    the deltas aimed it, with the commanded orientation; without it, it runs away."""
    plant, _, robot, _ = abstract_plant
    X_measured = robot.tcp_frame.CalcPoseInWorld(plant.CreateDefaultContext())
    delta = np.array([0.02, 0.0, 0.0, 0.0, 0.0, 0.05])
    end = T0 + conventions.TARGET_OFFSET + 9 * 0.1 + 0.05  # ten steps
    commanded = {}
    for lead in (0.0, 0.03):
        system = GripperTargetIntegrator(X_measured, max_lead=lead, plant=plant,
                                         tcp=robot.tcp_frame)
        context = system.CreateDefaultContext()
        system.get_delta_input_port().FixValue(context, delta)
        if lead:
            system.get_plant_state_input_port().FixValue(
                context, plant.GetPositionsAndVelocities(plant.CreateDefaultContext()))
        Simulator(system, context).AdvanceTo(end)
        commanded[lead] = system.GetOutputPort("X_WG_commanded").Eval(context)
    unbounded = commanded[0.0][:3] - X_measured.translation()
    bounded = commanded[0.03][:3] - X_measured.translation()
    assert np.linalg.norm(unbounded) > 0.15
    assert np.linalg.norm(bounded) == pytest.approx(0.03, abs=1e-9)
    # the orientation is what the deltas commanded: ten yaw steps of 0.05 rad
    start_yaw = RollPitchYaw(conventions.START_POSE.rotation()).yaw_angle()
    bounded_yaw = RollPitchYaw(Quaternion(commanded[0.03][3:7] / np.linalg.norm(
        commanded[0.03][3:7]))).yaw_angle()
    assert np.isclose(np.angle(np.exp(1j * (bounded_yaw - start_yaw))), 0.5, atol=1e-6)
    with pytest.raises(ValueError, match="plant"):
        GripperTargetIntegrator(X_measured, max_lead=0.03)
