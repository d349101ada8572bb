"""Whole-body differential IK (pi_L): gripper target pose -> joint targets, a QP at 100 Hz."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.solvers import MathematicalProgram, OsqpSolver, SolverOptions
from pydrake.systems.framework import BasicVector, Context, DiscreteValues, LeafSystem

from legato_drake import conventions
from legato_drake.poses import rotation_log
from legato_drake.robot_types import RobotHandles


@dataclass
class IkStep:
    """One IK solve: the joint velocity chosen and how it was found."""

    v: np.ndarray
    status: str
    """``unconstrained`` (both stages' optima are inside the bounds), ``qp`` (OSQP solved a
    stage with bounds active), ``hold`` (non-finite target: decelerate and stop) or
    ``failed`` (solver failure: decelerate and stop)."""


class WholeBodyIK(LeafSystem):
    """Retargets the gripper TCP target onto the robot's actuated joints every ``period``.

    Each step solves a prioritised velocity IK (SPEC §5) in two stages, both within the
    joint velocity bounds ``lb <= v <= ub``::

        1. gripper:    v_1 = argmin |J v - V*|^2 + c_p |P (v - v_posture)|^2
        2. the rest:   v   = argmin sum_i c_i |J_i v - w_i*|^2 + w |v - v_posture|^2
                             s.t. J v = J v_1

    with ``V* = V_ff + K [rotvec(R_des R^T); p_des - p]`` (the commanded TCP spatial velocity:
    feed-forward plus the tracking gain times the pose error), ``P`` the null-space projector
    of ``J``, the secondary orientation tasks ``J_i, w_i* = k_i rotvec(R_home R^T)``
    (``IkSettings.orientation_tasks``, weights ``c_i``, e.g. a head held level),
    ``v_posture = k (q_home - q)`` on the posture joints (zero on the others), and ``lb, ub``
    the tightest of the position limits (distance / dt), the speed limits, the braking
    distance ``sqrt(2 a_max |distance|)``, and the acceleration limit around the previous
    velocity. Stage 2 only moves in the null space of ``J``: the orientation tasks never
    cost gripper tracking. The posture cannot either while no bound is active (``P``); where
    the robot is saturated, ``c_p`` (``IkSettings.posture_task_weight``) sets how much
    tracking it may cost: none by default (strict priority), a little on Spot, where it keeps
    the arm out of a twisted branch it would otherwise follow into a joint limit. Each stage
    is a linear solve where its optimum is inside the bounds and an OSQP QP where not.
    Redundancy is resolved in the metric ``W`` (``IkSettings.joint_velocity_weights``,
    diagonal, 1 by default: ``|v|^2`` above is ``v^T W v``), so heavily weighted joints (a
    slow mobile base) move only where the others cannot do the job.
    The commanded joint positions are integrated (``q += v dt``) and clamped to the limits, so
    they never leave them. A NaN or infinite target, or a solver failure, makes the robot
    decelerate within its acceleration limit and hold.

    Input ports:
        X_WG_desired (RigidTransform): TCP target pose in the world.
        V_WG_desired (6): TCP target spatial velocity [w; v] in the world (feed-forward).

    Output ports:
        desired_state (2n): [q_cmd; v_cmd] of the robot's actuated joints, for the joint PD.

    State: discrete [q_cmd (n), v_cmd (n)].
    """

    def __init__(self, plant: MultibodyPlant, robot: RobotHandles,
                 period: float = conventions.IK_PERIOD):
        super().__init__()
        self._plant = plant
        self._frame = robot.tcp_frame
        self._dt = period
        settings = robot.embodiment.ik
        self._settings = settings
        joints = robot.controlled_joints
        self._n = n = len(joints)
        self._q_index = np.array([j.position_start() for j in joints])
        self._v_index = np.array([j.velocity_start() for j in joints])
        tighter = settings.joint_position_limits
        self._q_min = np.array([max(j.position_lower_limits()[0],
                                    tighter.get(j.name(), (-np.inf, np.inf))[0]) for j in joints])
        self._q_max = np.array([min(j.position_upper_limits()[0],
                                    tighter.get(j.name(), (-np.inf, np.inf))[1]) for j in joints])
        speed = np.array([settings.joint_speed_limits.get(j.name(), settings.max_joint_speed)
                          for j in joints])
        plant_speed = np.array([j.velocity_upper_limits()[0] for j in joints])
        self._v_max = np.minimum(speed, plant_speed)
        self._a_max = np.array([settings.joint_acceleration_limits.get(
            j.name(), settings.max_joint_acceleration) for j in joints])
        self._q_home = robot.home_positions
        weights = np.array([settings.joint_velocity_weights.get(j.name(), 1.0) for j in joints])
        self._scale = 1.0 / np.sqrt(weights)
        """``v = scale * u``: the QP is solved for ``u``, where the metric W is the identity."""
        names = set(settings.posture_joints) or {j.name() for j in joints}
        self._posture_mask = np.array([j.name() in names for j in joints], dtype=float)

        self._plant_context = plant.CreateDefaultContext()
        self._q_full = plant.GetPositions(self._plant_context).copy()
        self._orientation_tasks = []
        for task in settings.orientation_tasks:
            frame = plant.GetFrameByName(task.frame, robot.robot)
            self._set_q(self._q_home)
            R_home = frame.CalcPoseInWorld(self._plant_context).rotation()
            self._orientation_tasks.append((frame, R_home, task.gain, task.weight))
        self.solve_times: list[float] | None = None
        """Set to a list to profile: the wall time of every solve is appended (benchmarks
        only; it is not part of the context and changes nothing the system computes)."""

        # Stage 1: the gripper task within the bounds. Stage 2: the rest, the gripper held.
        self._prog = MathematicalProgram()
        v = self._prog.NewContinuousVariables(n, "v")
        self._cost = self._prog.AddQuadraticCost(np.eye(n), np.zeros(n), v, is_convex=True)
        self._bounds = self._prog.AddBoundingBoxConstraint(-np.ones(n), np.ones(n), v)
        self._posture_prog = MathematicalProgram()
        v = self._posture_prog.NewContinuousVariables(n, "v")
        self._posture_cost = self._posture_prog.AddQuadraticCost(np.eye(n), np.zeros(n), v,
                                                                 is_convex=True)
        self._task_hold = self._posture_prog.AddLinearEqualityConstraint(
            np.zeros((6, n)), np.zeros(6), v)
        self._posture_bounds = self._posture_prog.AddBoundingBoxConstraint(
            -np.ones(n), np.ones(n), v)
        self._solver = OsqpSolver()
        # No polishing: where it finds no active set OSQP prints "Polishing not needed" on
        # stdout whatever the verbosity; the tolerances below are tight enough without it.
        self._options = SolverOptions()
        for key, value in (("verbose", 0), ("polishing", 0), ("eps_abs", 1e-7),
                           ("eps_rel", 1e-7), ("max_iter", 4000)):
            self._options.SetOption(OsqpSolver.id(), key, value)

        self._X_input = self.DeclareAbstractInputPort(
            "X_WG_desired", AbstractValue.Make(RigidTransform()))
        self._V_input = self.DeclareVectorInputPort("V_WG_desired", 6)
        self._state = self.DeclareDiscreteState(np.concatenate([self._q_home, np.zeros(n)]))
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        self.DeclareVectorOutputPort("desired_state", 2 * n, self._calc_desired_state,
                                     {self.xd_ticket()})

    # -- ports and state ------------------------------------------------------------------
    def get_desired_pose_input_port(self):
        return self._X_input

    def get_desired_velocity_input_port(self):
        return self._V_input

    def set_joint_positions(self, context: Context, q: np.ndarray) -> None:
        """Sets the commanded joint positions (e.g. to match a non-home initial posture)."""
        context.SetDiscreteState(self._state, np.concatenate([q, np.zeros(self._n)]))

    @property
    def num_joints(self) -> int:
        return self._n

    # -- the solve ------------------------------------------------------------------------
    def tcp_pose(self, q: np.ndarray) -> RigidTransform:
        """Forward kinematics of the TCP at joint positions ``q`` (port order)."""
        self._set_q(q)
        return self._frame.CalcPoseInWorld(self._plant_context)

    def velocity_bounds(self, q: np.ndarray, v_prev: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Joint velocity bounds from position, speed, braking and acceleration limits."""
        dt, a = self._dt, self._a_max
        m_low = np.minimum(self._q_min - q, 0.0)
        m_up = np.maximum(self._q_max - q, 0.0)
        lb = np.maximum.reduce([m_low / dt, -self._v_max, -np.sqrt(2 * a * -m_low)])
        ub = np.minimum.reduce([m_up / dt, self._v_max, np.sqrt(2 * a * m_up)])
        lb_acc = np.maximum(lb, v_prev - a * dt)
        ub_acc = np.minimum(ub, v_prev + a * dt)
        # Where the acceleration bound cannot be met inside the position bounds, the position
        # bounds win: brake as hard as they require.
        bad = lb_acc > ub_acc
        stop = np.clip(v_prev, lb, ub)
        return np.where(bad, stop, lb_acc), np.where(bad, stop, ub_acc)

    def solve(self, q: np.ndarray, v_prev: np.ndarray, X_des: RigidTransform,
              V_ff: np.ndarray) -> IkStep:
        """One IK step from commanded state (q, v_prev) toward the target; see the class doc."""
        lb, ub = self.velocity_bounds(q, v_prev)
        target_ok = (np.all(np.isfinite(X_des.GetAsMatrix34())) and np.all(np.isfinite(V_ff)))
        if not target_ok:
            return IkStep(np.clip(np.zeros(self._n), lb, ub), "hold")
        self._set_q(q)
        X = self._frame.CalcPoseInWorld(self._plant_context)
        # Everything below is written in u = v / scale, where the metric W is the identity.
        world = self._plant.world_frame()
        J = self._plant.CalcJacobianSpatialVelocity(
            self._plant_context, JacobianWrtVariable.kV, self._frame, np.zeros(3), world,
            world)[:, self._v_index] * self._scale
        k = self._settings.tracking_gain
        error = np.concatenate([rotation_log(X_des.rotation() @ X.rotation().inverse()),
                                X_des.translation() - X.translation()])
        V = V_ff + k * error
        eps = 1e-6 * np.eye(self._n)
        lb_u, ub_u = lb / self._scale, ub / self._scale

        u_posture = (self._settings.posture_gain * self._posture_mask * (self._q_home - q)
                     / self._scale)

        # Stage 1: the gripper task within the bounds, with the posture term (projected on the
        # null space of J, so it only costs tracking where bounds are active) at weight c_p.
        c_p = self._settings.posture_task_weight
        H1, g1 = J.T @ J + eps, J.T @ V
        if c_p > 0.0:
            P = np.eye(self._n) - J.T @ np.linalg.solve(J @ J.T + 1e-6 * np.eye(6), J)
            H1 += c_p * P.T @ P
            g1 += c_p * P.T @ P @ u_posture
        u_task = np.linalg.solve(H1, g1)
        saturated = bool(np.any(u_task < lb_u) or np.any(u_task > ub_u))
        if saturated:
            self._cost.evaluator().UpdateCoefficients(2.0 * H1, -2.0 * g1)
            self._bounds.evaluator().set_bounds(lb_u, ub_u)
            result = self._solver.Solve(self._prog, None, self._options)
            if not result.is_success():
                return IkStep(np.clip(np.zeros(self._n), lb, ub), "failed")
            u_task = np.clip(result.GetSolution(), lb_u, ub_u)

        # Stage 2: secondary tasks and posture, in what leaves J u = J u_task unchanged.
        w = self._settings.posture_weight
        H, g = w * np.eye(self._n) + eps, w * u_posture
        for frame, R_home, gain, weight in self._orientation_tasks:
            J_w = self._plant.CalcJacobianSpatialVelocity(
                self._plant_context, JacobianWrtVariable.kV, frame, np.zeros(3), world,
                world)[:3, self._v_index] * self._scale
            R = frame.CalcPoseInWorld(self._plant_context).rotation()
            H += weight * J_w.T @ J_w
            g += weight * J_w.T @ (gain * rotation_log(R_home @ R.inverse()))
        _, sigma, Vt = np.linalg.svd(J)
        N = Vt[int(np.sum(sigma > 1e-9 * max(sigma[0], 1e-12))):].T  # null-space basis of J
        u = u_task + N @ np.linalg.solve(N.T @ H @ N, N.T @ (g - H @ u_task))
        if np.all(u >= lb_u) and np.all(u <= ub_u):
            return IkStep(self._scale * u, "qp" if saturated else "unconstrained")
        self._posture_cost.evaluator().UpdateCoefficients(2.0 * H, -2.0 * g)
        self._task_hold.evaluator().UpdateCoefficients(J, J @ u_task)
        self._posture_bounds.evaluator().set_bounds(lb_u, ub_u)
        result = self._solver.Solve(self._posture_prog, u_task, self._options)
        u = np.clip(result.GetSolution(), lb_u, ub_u) if result.is_success() else u_task
        return IkStep(self._scale * u, "qp")

    def _set_q(self, q: np.ndarray) -> None:
        self._q_full[self._q_index] = q
        self._plant.SetPositions(self._plant_context, self._q_full)

    # -- events and outputs ---------------------------------------------------------------
    def _update(self, context: Context, discrete_state: DiscreteValues) -> None:
        x = context.get_discrete_state(self._state).get_value()
        q, v_prev = x[:self._n], x[self._n:]
        X_des, V_ff = self._X_input.Eval(context), self._V_input.Eval(context)
        start = time.perf_counter()
        step = self.solve(q, v_prev, X_des, V_ff)
        if self.solve_times is not None:
            self.solve_times.append(time.perf_counter() - start)
        q_next = np.clip(q + step.v * self._dt, self._q_min, self._q_max)
        discrete_state.set_value(self._state, np.concatenate([q_next, step.v]))

    def _calc_desired_state(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(context.get_discrete_state(self._state).get_value())
