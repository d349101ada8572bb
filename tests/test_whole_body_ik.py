"""WholeBodyIK alone, on the Panda and Abstract plants: tracking, limits, NaN and reach."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.analysis import Simulator

from legato_drake.poses import pose_error, spatial_error
from legato_drake.systems.whole_body_ik import WholeBodyIK


def _ik(plant_tuple):
    plant, _, robot, _ = plant_tuple
    return WholeBodyIK(plant, robot)


def _run(ik, X_des, t, V=None, q0=None, plant_state=None):
    V = np.zeros(6) if V is None else V
    context = ik.CreateDefaultContext()
    if q0 is not None:
        ik.set_joint_positions(context, q0)
    ik.get_desired_pose_input_port().FixValue(context, X_des)
    ik.get_desired_velocity_input_port().FixValue(context, V)
    if plant_state is not None:
        ik.get_plant_state_input_port().FixValue(context, plant_state)
    q_history = []
    simulator = Simulator(ik, context)
    for t_k in np.arange(0.005, t, 0.05):  # sample between IK events
        simulator.AdvanceTo(t_k)
        q_history.append(context.get_discrete_state_vector().get_value()[:ik.num_joints].copy())
    simulator.AdvanceTo(t)
    x = context.get_discrete_state_vector().get_value()
    n = ik.num_joints
    return x[:n], x[n:2 * n], np.array(q_history)


@pytest.mark.parametrize("name", ["panda_plant", "abstract_plant"])
def test_converges_to_a_reachable_target(name, request):
    ik = _ik(request.getfixturevalue(name))
    X0 = ik.tcp_pose(ik._q_home)
    X_des = RigidTransform(X0.rotation() @ RotationMatrix.MakeZRotation(0.3),
                           X0.translation() + [-0.05, 0.05, -0.08])
    q, v, _ = _run(ik, X_des, 1.5)
    dp, dr = pose_error(ik.tcp_pose(q), X_des)
    assert dp < 1e-4 and dr < 1e-3


def test_unreachable_target_never_violates_joint_limits(panda_plant):
    ik = _ik(panda_plant)
    X_des = RigidTransform([3.0, -2.0, 0.2])  # far out of reach
    q, _, history = _run(ik, X_des, 3.0)
    assert np.all(history >= ik._q_min - 1e-12) and np.all(history <= ik._q_max + 1e-12)
    assert np.all(np.isfinite(q))
    # It got as close as it could: the TCP moved toward the target.
    start = np.linalg.norm(ik.tcp_pose(ik._q_home).translation() - X_des.translation())
    assert np.linalg.norm(ik.tcp_pose(q).translation() - X_des.translation()) < start - 0.25


def test_speed_and_acceleration_limits_hold(panda_plant):
    ik = _ik(panda_plant)
    X0 = ik.tcp_pose(ik._q_home)
    X_des = RigidTransform(X0.translation() + [0.3, 0.3, -0.3])
    _, _, history = _run(ik, X_des, 1.0)
    v = np.diff(history, axis=0) / 0.05
    assert np.all(np.abs(v) <= ik._v_max + 1e-9)


def test_a_blocked_robot_does_not_wind_its_targets_up(panda_plant):
    """With the plant's state connected, the commanded positions stay within
    ``max_following_error`` of the measured ones (a robot held at home while the target is
    40 cm away); without it they integrate open loop to the target."""
    plant = panda_plant[0]
    ik = _ik(panda_plant)
    X0 = ik.tcp_pose(ik._q_home)
    X_des = RigidTransform(X0.translation() + [0.0, 0.2, -0.35])
    held = np.zeros(plant.num_multibody_states())
    held[ik._q_index] = ik._q_home
    q, _, history = _run(ik, X_des, 1.0, plant_state=held)
    bound = ik._settings.max_following_error
    assert np.abs(history - ik._q_home).max() <= bound + 1e-12
    assert np.abs(q - ik._q_home).max() == pytest.approx(bound)  # it pushes, at the bound
    free, _, _ = _run(ik, X_des, 1.0)
    assert np.abs(free - ik._q_home).max() > 3 * bound


def test_nan_target_holds_still(panda_plant):
    ik = _ik(panda_plant)
    X_bad = RigidTransform()
    X_bad.set_translation([np.nan, 0.0, 0.0])
    q, v, _ = _run(ik, X_bad, 0.5)
    np.testing.assert_allclose(q, ik._q_home, atol=1e-12)
    assert np.all(v == 0)


def test_velocity_bounds_brake_before_the_limit(panda_plant):
    ik = _ik(panda_plant)
    q = ik._q_home.copy()
    q[0] = ik._q_max[0] - 1e-3  # 1 mrad from the upper limit of joint 1
    lb, ub = ik.velocity_bounds(q, np.zeros(ik.num_joints))
    assert ub[0] <= 1e-3 / ik._dt + 1e-12
    assert np.all(lb <= ub)
    # Moving fast toward the limit: the acceleration bound may not be met, braking wins.
    v_prev = np.zeros(ik.num_joints)
    v_prev[0] = ik._v_max[0]
    lb, ub = ik.velocity_bounds(q, v_prev)
    assert ub[0] <= 1e-3 / ik._dt + 1e-12 and lb[0] <= ub[0]


def test_qp_is_used_and_agrees_with_bounds(panda_plant):
    ik = _ik(panda_plant)
    X0 = ik.tcp_pose(ik._q_home)
    q = ik._q_home
    step = ik.solve(q, np.zeros(ik.num_joints),
                    RigidTransform(X0.translation() + [0.5, 0, 0]), np.zeros(6))
    lb, ub = ik.velocity_bounds(q, np.zeros(ik.num_joints))
    assert step.status == "qp"
    assert np.all(step.v >= lb - 1e-12) and np.all(step.v <= ub + 1e-12)
    small = ik.solve(q, np.zeros(ik.num_joints),
                     RigidTransform(X0.rotation(), X0.translation() + [1e-4, 0, 0]), np.zeros(6))
    assert small.status == "unconstrained"


def _with_ik(plant_tuple, **settings):
    """A WholeBodyIK of the same robot with some ``IkSettings`` fields replaced."""
    import dataclasses

    plant, _, robot, _ = plant_tuple
    embodiment = dataclasses.replace(
        robot.embodiment, ik=dataclasses.replace(robot.embodiment.ik, **settings))
    return WholeBodyIK(plant, dataclasses.replace(robot, embodiment=embodiment))


def _tcp_twist(ik, q, v):
    """The TCP spatial velocity J(q) v that joint velocity ``v`` produces."""
    from pydrake.multibody.tree import JacobianWrtVariable

    ik._set_q(q)
    plant, world = ik._plant, ik._plant.world_frame()
    J = plant.CalcJacobianSpatialVelocity(ik._plant_context, JacobianWrtVariable.kV, ik._frame,
                                          np.zeros(3), world, world)[:, ik._v_index]
    return J @ v


def test_strict_posture_never_costs_tracking_when_saturated(google_plant, capfd):
    """With the slow base at its acceleration bound and ``posture_task_weight`` 0 (the
    default), the posture term changes how the arm moves but not the TCP velocity: strict
    priority. A positive weight lets it cost some. The solver prints nothing."""
    ik = _ik(google_plant)
    no_posture = _with_ik(google_plant, posture_gain=0.0)
    q = ik._q_home.copy()
    q[3:7] += [0.3, -0.2, 0.3, -0.4]  # arm away from home: the posture term pulls
    X = ik.tcp_pose(q)
    X_des = RigidTransform(X.rotation(), X.translation() + [0.01, -0.006, 0.004])
    V_ff = np.zeros(6)
    step = ik.solve(q, np.zeros(ik.num_joints), X_des, V_ff)
    plain = no_posture.solve(q, np.zeros(ik.num_joints), X_des, V_ff)
    assert step.status == plain.status == "qp"
    lb, ub = ik.velocity_bounds(q, np.zeros(ik.num_joints))
    assert np.all(step.v >= lb - 1e-12) and np.all(step.v <= ub + 1e-12)
    assert np.any(np.isclose(np.abs(step.v[:3]), 1e-3))  # the base at its acceleration bound
    assert np.max(np.abs(step.v - plain.v)) > 0.05  # the posture did change the joints
    np.testing.assert_allclose(_tcp_twist(ik, q, step.v), _tcp_twist(ik, q, plain.v),
                               atol=1e-7)
    soft = _with_ik(google_plant, posture_task_weight=0.05).solve(
        q, np.zeros(ik.num_joints), X_des, V_ff)
    assert np.max(np.abs(_tcp_twist(ik, q, soft.v) - _tcp_twist(ik, q, plain.v))) > 1e-4
    assert capfd.readouterr().out == ""


def test_velocity_weights_move_motion_to_the_light_joints(panda_plant):
    """A heavily weighted joint takes a smaller share of the same TCP motion."""
    plain = _ik(panda_plant)
    heavy = _with_ik(panda_plant, joint_velocity_weights={"panda_joint1": 100.0})
    q = plain._q_home
    X = plain.tcp_pose(q)
    X_des = RigidTransform(X.rotation(), X.translation() + [0.0, 2e-4, 0.0])
    a = plain.solve(q, np.zeros(plain.num_joints), X_des, np.zeros(6))
    b = heavy.solve(q, np.zeros(plain.num_joints), X_des, np.zeros(6))
    assert a.status == b.status == "unconstrained"
    assert abs(b.v[0]) < 0.2 * abs(a.v[0])
    np.testing.assert_allclose(_tcp_twist(plain, q, b.v), _tcp_twist(plain, q, a.v),
                               atol=1e-7)


def test_damping_shortens_the_gripper_step_as_damped_least_squares_does(panda_plant):
    """``IkSettings.damping`` is the lambda of stage 1: unsaturated, the TCP moves at
    J (J^T J + lambda I)^-1 J^T V* instead of V*."""
    plain, damped = _ik(panda_plant), _with_ik(panda_plant, damping=0.05)
    q = plain._q_home
    X = plain.tcp_pose(q)
    X_des = RigidTransform(X.rotation() @ RotationMatrix.MakeXRotation(2e-4),
                           X.translation() + [0.0, 2e-4, -1e-4])
    a = plain.solve(q, np.zeros(plain.num_joints), X_des, np.zeros(6))
    b = damped.solve(q, np.zeros(plain.num_joints), X_des, np.zeros(6))
    assert a.status == b.status == "unconstrained"
    V = plain._settings.tracking_gain * spatial_error(X, X_des)
    J = np.column_stack([_tcp_twist(plain, q, e) for e in np.eye(plain.num_joints)])
    dls = J @ np.linalg.solve(J.T @ J + 0.05 * np.eye(plain.num_joints), J.T @ V)
    np.testing.assert_allclose(_tcp_twist(plain, q, a.v), V, atol=1e-5 * np.abs(V).max())
    np.testing.assert_allclose(_tcp_twist(plain, q, b.v), dls, atol=1e-6 * np.abs(V).max())
    assert np.linalg.norm(dls) < 0.95 * np.linalg.norm(V)  # measurably shorter (0.91)


def test_gr1_head_stays_level_while_the_waist_reaches(gr1_plant):
    """The head-orientation task (stage 2) keeps the head at its home orientation with the
    head joints while the gripper, which comes first, is tracked exactly."""
    from pydrake.math import RollPitchYaw

    ik, headless = _ik(gr1_plant), _with_ik(gr1_plant, orientation_tasks=())
    R_home = ik._orientation_tasks[0][1]

    def head_tilt(q):
        ik._set_q(q)
        R = ik._plant.GetFrameByName("head").CalcPoseInWorld(ik._plant_context).rotation()
        return np.degrees(np.linalg.norm(RollPitchYaw(R_home.inverse() @ R).vector()))

    X0 = ik.tcp_pose(ik._q_home)
    X_des = RigidTransform(X0.rotation(), X0.translation() + [0.15, 0.10, -0.10])
    q, _, _ = _run(ik, X_des, 2.0)
    q_free, _, _ = _run(headless, X_des, 2.0)
    for joints in (q, q_free):
        dp, dr = pose_error(ik.tcp_pose(joints), X_des)
        assert dp < 1e-3 and dr < 1e-2
    assert head_tilt(q_free) > 5.0  # the waist moved and tilted the head ...
    assert head_tilt(q) < 0.5       # ... which the head task corrects


def test_the_warm_start_changes_nothing_the_ik_commands(gr1_plant):
    """The active sets kept in the state speed the next solve up; a cold solve of the same
    step gives the same joint velocities, to the precision of the second stage's penalized
    problem (its terms reach 1e7: 1e-6 rad/s, 1e-8 rad per step)."""
    ik = _ik(gr1_plant)
    q, v, active = ik._q_home.copy(), np.zeros(ik.num_joints), None
    X0 = ik.tcp_pose(q)
    X_des = RigidTransform(X0.rotation() @ RotationMatrix.MakeZRotation(0.4),
                           X0.translation() + [0.15, -0.1, 0.1])
    saturated = 0
    for _ in range(40):
        warm = ik.solve(q, v, X_des, np.zeros(6), active)
        cold = ik.solve(q, v, X_des, np.zeros(6))
        np.testing.assert_allclose(warm.v, cold.v, atol=1e-6)
        saturated += warm.status == "qp"
        q, v, active = q + warm.v * ik._dt, warm.v, warm.active
    assert saturated > 10
