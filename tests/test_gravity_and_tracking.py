"""GravityCompensation and TrackingMonitor, each alone with its own context."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from legato_drake import conventions
from legato_drake.embodiments import add_embodiment, get_embodiment
from legato_drake.models import add_package
from legato_drake.systems.gravity_compensation import GravityCompensation
from legato_drake.systems.tracking_monitor import TrackingMonitor, TrackingStats


def _panda_holding_home(compensate: bool) -> float:
    """Max joint error (rad) after 1 s of PD at the home posture, with or without gravity
    compensation."""
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=conventions.PHYSICS_DT), builder)
    robot = add_embodiment(plant, add_package(Parser(plant)), get_embodiment("panda"))
    plant.Finalize()
    n = len(robot.controlled_joints)
    desired = builder.AddSystem(ConstantVectorSource(
        np.concatenate([robot.home_positions, np.zeros(n)])))
    builder.Connect(desired.get_output_port(), plant.get_desired_state_input_port(robot.robot))
    fingers = builder.AddSystem(ConstantVectorSource([0.05, 0.05, 0.0, 0.0]))
    builder.Connect(fingers.get_output_port(), plant.get_desired_state_input_port(robot.gripper))
    if compensate:
        gravity = builder.AddSystem(GravityCompensation(plant, robot.controlled_joints))
        builder.Connect(desired.get_output_port(), gravity.get_desired_state_input_port())
        builder.Connect(gravity.GetOutputPort("actuation"),
                        plant.get_actuation_input_port(robot.robot))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(1.0)
    context = plant.GetMyContextFromRoot(simulator.get_context())
    q = np.array([j.GetOnePosition(context) for j in robot.controlled_joints])
    return float(np.max(np.abs(q - robot.home_positions)))


def test_gravity_compensation_removes_the_sag():
    sag = _panda_holding_home(compensate=False)
    held = _panda_holding_home(compensate=True)
    assert sag > 1e-3
    assert held < 0.05 * sag


def test_gravity_compensation_output_matches_the_plant(panda_plant):
    plant, _, robot, _ = panda_plant
    system = GravityCompensation(plant, robot.controlled_joints)
    context = system.CreateDefaultContext()
    q = robot.home_positions + 0.1
    system.get_desired_state_input_port().FixValue(context, np.concatenate([q, 0 * q]))
    plant_context = plant.CreateDefaultContext()
    for joint, value in zip(robot.controlled_joints, q, strict=True):
        joint.set_angle(plant_context, value)
    tau = plant.CalcGravityGeneralizedForces(plant_context)
    expected = -tau[[j.velocity_start() for j in robot.controlled_joints]]
    np.testing.assert_allclose(system.GetOutputPort("actuation").Eval(context), expected)
    assert np.abs(expected).max() > 1.0  # gravity really loads the arm


def test_tracking_monitor_measures_the_offset(panda_plant):
    plant, _, robot, _ = panda_plant
    system = TrackingMonitor(plant, robot, t_start=0.0)
    context = system.CreateDefaultContext()
    plant_context = plant.CreateDefaultContext()
    X = robot.tcp_frame.CalcPoseInWorld(plant_context)
    system.GetInputPort("X_WG_target").FixValue(
        context, RigidTransform(X.rotation(), X.translation() + [0.0, 0.003, 0.004]))
    system.GetInputPort("plant_state").FixValue(
        context, plant.GetPositionsAndVelocities(plant_context))
    Simulator(system, context).AdvanceTo(0.095)
    stats = TrackingStats.from_vector(system.GetOutputPort("stats").Eval(context))
    assert stats.samples == 10
    assert stats.rms_mm == pytest.approx(5.0) and stats.max_mm == pytest.approx(5.0)
    assert stats.rms_deg == pytest.approx(0.0, abs=1e-6)
    q = robot.home_positions
    limits = [(j.position_lower_limits()[0], j.position_upper_limits()[0])
              for j in robot.controlled_joints]
    expected = min(min(v - lo, hi - v) for v, (lo, hi) in zip(q, limits, strict=True))
    assert stats.min_limit_margin == pytest.approx(expected)
