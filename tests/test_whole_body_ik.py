"""WholeBodyIK alone, on the Panda and Abstract plants: tracking, limits, NaN and reach."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.analysis import Simulator

from legato_drake.poses import pose_error
from legato_drake.systems.whole_body_ik import WholeBodyIK


def _ik(plant_tuple):
    plant, _, robot, _ = plant_tuple
    return WholeBodyIK(plant, robot)


def _run(ik, X_des, t, V=None, q0=None):
    V = np.zeros(6) if V is None else V
    context = ik.CreateDefaultContext()
    if q0 is not None:
        ik.set_joint_positions(context, q0)
    ik.get_desired_pose_input_port().FixValue(context, X_des)
    ik.get_desired_velocity_input_port().FixValue(context, V)
    q_history = []
    simulator = Simulator(ik, context)
    for t_k in np.arange(0.005, t, 0.05):  # sample between IK events
        simulator.AdvanceTo(t_k)
        q_history.append(context.get_discrete_state_vector().get_value()[:ik.num_joints].copy())
    simulator.AdvanceTo(t)
    x = context.get_discrete_state_vector().get_value()
    return x[:ik.num_joints], x[ik.num_joints:], np.array(q_history)


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
