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
from legato_drake.embodiments.base import RobotHandles
from legato_drake.poses import rotation_log


@dataclass
class IkStep:
    """One IK solve: the joint velocity chosen and how it was found."""

    v: np.ndarray
    status: str
    """``unconstrained`` (the optimum is inside the bounds), ``qp`` (OSQP solved the bounded
    problem), ``hold`` (non-finite target: decelerate and stop) or ``failed`` (solver failure:
    decelerate and stop)."""


class WholeBodyIK(LeafSystem):
    """Retargets the gripper TCP target onto the robot's actuated joints every ``period``.

    Each step solves the QP (SPEC §5)::

        min_v |J v - V*|^2 + w |P (v - v_posture)|^2 + eps |v|^2
        s.t.  lb <= v <= ub

    with ``V* = V_ff + K [rotvec(R_des R^T); p_des - p]`` (the commanded TCP spatial velocity:
    feed-forward plus the tracking gain times the pose error), ``P`` the null-space projector
    of ``J``, ``v_posture = k (q_home - q)`` on the posture joints, and ``lb, ub`` the tightest
    of the position limits (distance / dt), the speed limits, the braking distance
    ``sqrt(2 a_max |distance|)``, and the acceleration limit around the previous velocity.
    Secondary orientation tasks (``IkSettings.orientation_tasks``) add weighted terms
    ``w |J_w v - k rotvec(R_home R^T)|^2`` that hold a frame (e.g. a head) at its home
    orientation.
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

        self._prog = MathematicalProgram()
        v = self._prog.NewContinuousVariables(n, "v")
        self._cost = self._prog.AddQuadraticCost(np.eye(n), np.zeros(n), v, is_convex=True)
        self._bounds = self._prog.AddBoundingBoxConstraint(-np.ones(n), np.ones(n), v)
        self._solver = OsqpSolver()
        self._options = SolverOptions()
        for key, value in (("verbose", 0), ("polishing", 1), ("eps_abs", 1e-7),
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
        J = self._plant.CalcJacobianSpatialVelocity(
            self._plant_context, JacobianWrtVariable.kV, self._frame, np.zeros(3),
            self._plant.world_frame(), self._plant.world_frame())[:, self._v_index]
        k = self._settings.tracking_gain
        error = np.concatenate([rotation_log(X_des.rotation() @ X.rotation().inverse()),
                                X_des.translation() - X.translation()])
        V = V_ff + k * error

        # Null-space projector of J (damped pseudo-inverse keeps it sane near singularities).
        JJt = J @ J.T + 1e-6 * np.eye(6)
        P = np.eye(self._n) - J.T @ np.linalg.solve(JJt, J)
        v_posture = self._settings.posture_gain * self._posture_mask * (self._q_home - q)
        w = self._settings.posture_weight
        H = J.T @ J + w * P.T @ P + 1e-6 * np.eye(self._n)
        g = J.T @ V + w * P.T @ P @ v_posture
        for frame, R_home, gain, weight in self._orientation_tasks:
            J_w = self._plant.CalcJacobianSpatialVelocity(
                self._plant_context, JacobianWrtVariable.kV, frame, np.zeros(3),
                self._plant.world_frame(), self._plant.world_frame())[:3, self._v_index]
            R = frame.CalcPoseInWorld(self._plant_context).rotation()
            w_des = gain * rotation_log(R_home @ R.inverse())
            H += weight * J_w.T @ J_w
            g += weight * J_w.T @ w_des

        v = np.linalg.solve(H, g)
        if np.all(v >= lb) and np.all(v <= ub):
            return IkStep(v, "unconstrained")
        self._cost.evaluator().UpdateCoefficients(2.0 * H, -2.0 * g)
        self._bounds.evaluator().set_bounds(lb, ub)
        result = self._solver.Solve(self._prog, None, self._options)
        if not result.is_success():
            return IkStep(np.clip(np.zeros(self._n), lb, ub), "failed")
        return IkStep(np.clip(result.GetSolution(), lb, ub), "qp")

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
