"""Whole-body differential IK (pi_L): gripper target pose -> joint targets, a QP at 100 Hz."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.systems.framework import BasicVector, Context, DiscreteValues, LeafSystem

from legato_drake import conventions
from legato_drake.poses import rotation_log, spatial_error
from legato_drake.robot_types import RobotHandles
from legato_drake.systems.box_qp import solve_box_qp

_HOLD_WEIGHT = 1e6
"""Stage 2's weight on keeping stage 1's gripper velocity (relative to its own, O(1))."""


@dataclass
class IkStep:
    """One IK solve: the joint velocity chosen and how it was found."""

    v: np.ndarray
    status: str
    """``unconstrained`` (both stages' optima are inside the bounds), ``qp`` (``box_qp``
    solved a stage with bounds active) or ``hold`` (non-finite target: decelerate, stop)."""
    active: np.ndarray | None = None
    """Both stages' active sets (2n: -1 lower bound, +1 upper, 0 free), the next solve's
    warm start; None on ``hold``."""


class WholeBodyIK(LeafSystem):
    """Retargets the gripper TCP target onto the robot's actuated joints every ``period``.

    Each step solves a prioritised velocity IK (SPEC §5) in two stages, both within the
    joint velocity bounds ``lb <= v <= ub``::

        1. gripper:    v_1 = argmin |J v - V*|^2 + c_p |P (v - v_posture)|^2 + lambda |v|^2
        2. the rest:   v   = argmin sum_i c_i |J_i v - w_i*|^2 + w |v - v_posture|^2
                             s.t. J v = J v_1

    with ``V* = V_ff + K [rotvec(R_des R^T); p_des - p]`` (the commanded TCP spatial velocity:
    feed-forward plus the tracking gain times the pose error), ``P`` the null-space projector
    of ``J``, the secondary orientation tasks ``J_i, w_i* = k_i rotvec(R_home R^T)``
    (``IkSettings.orientation_tasks``, weights ``c_i``, e.g. a head held level),
    ``v_posture = k (q_home - q)`` on the posture joints (zero on the others), and ``lb, ub``
    the tightest of the position limits (distance / dt), the speed limits, the braking
    distance ``sqrt(2 a_max |distance|)``, and the acceleration limit around the previous
    velocity, and ``lambda`` a damping (``IkSettings.damping``). Stage 2 only moves in the null
    space of ``J``: the orientation tasks never cost gripper tracking. The posture cannot
    either while no bound is active (``P``); where the robot is saturated, ``c_p``
    (``IkSettings.posture_task_weight``) sets how much tracking it may cost: none by default
    (strict priority), a little on Spot, where it keeps the arm out of a twisted branch it
    would otherwise follow into a joint limit.
    Each stage is a linear solve where its optimum is inside the bounds and, where not, a box
    QP solved exactly by ``box_qp`` (a dense active-set method warm started from the last
    step's active set); stage 2 holds ``J v = J v_1`` by a penalty 1e6 times its own weights,
    which keeps it a box QP and the gripper's velocity within 1e-6 of stage 1's.
    Redundancy is resolved in the metric ``W`` (``IkSettings.joint_velocity_weights``,
    diagonal, 1 by default: ``|v|^2`` above is ``v^T W v``), so heavily weighted joints (a
    slow mobile base) move only where the others cannot do the job.
    The commanded joint positions are integrated (``q += v dt``) and clamped to the limits, so
    they never leave them, and, where the plant's state is connected, to within
    ``IkSettings.max_following_error`` of the measured positions (anti-windup: a robot
    blocked by contact does not wind its targets up while it is held). A NaN or infinite
    target makes the robot decelerate within its acceleration limit and hold.

    Input ports:
        X_WG_desired (RigidTransform): TCP target pose in the world.
        V_WG_desired (6): TCP target spatial velocity [w; v] in the world (feed-forward).
        plant_state (optional): the plant's state [q; v], for the following-error bound;
            unconnected, the commanded positions are integrated open loop.

    Output ports:
        desired_state (2n): [q_cmd; v_cmd] of the robot's actuated joints, for the joint PD.

    State: discrete [q_cmd (n), v_cmd (n), active (2n)]: the commanded joint state and both
    QP stages' last active sets (a warm start: they change the speed of the solve, not its
    result).
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

        # Constants of the solve, computed once.
        self._inv_scale = 1.0 / self._scale
        self._two_a = 2.0 * self._a_max
        self._a_dt = self._a_max * period
        self._posture_gain = settings.posture_gain * self._posture_mask / self._scale
        self._eye = np.eye(n)
        self._eps6 = 1e-6 * np.eye(6)
        self._damping = settings.damping * self._eye
        self._stage2_H = (settings.posture_weight + 1e-6) * self._eye
        self._origin = np.zeros(3)

        self._X_input = self.DeclareAbstractInputPort(
            "X_WG_desired", AbstractValue.Make(RigidTransform()))
        self._V_input = self.DeclareVectorInputPort("V_WG_desired", 6)
        self._plant_state = self.DeclareVectorInputPort(
            "plant_state", plant.num_multibody_states())
        self._max_error = settings.max_following_error
        self._state = self.DeclareDiscreteState(np.concatenate([self._q_home, np.zeros(3 * n)]))
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        self.DeclareVectorOutputPort("desired_state", 2 * n, self._calc_desired_state,
                                     {self.xd_ticket()})

    # -- ports and state ------------------------------------------------------------------
    def get_desired_pose_input_port(self):
        return self._X_input

    def get_desired_velocity_input_port(self):
        return self._V_input

    def get_plant_state_input_port(self):
        return self._plant_state

    def set_joint_positions(self, context: Context, q: np.ndarray) -> None:
        """Sets the commanded joint positions (e.g. to match a non-home initial posture)."""
        context.SetDiscreteState(self._state, np.concatenate([q, np.zeros(3 * self._n)]))

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
        dt = self._dt
        m_low = np.minimum(self._q_min - q, 0.0)
        m_up = np.maximum(self._q_max - q, 0.0)
        lb = np.maximum(np.maximum(m_low / dt, -self._v_max), -np.sqrt(self._two_a * -m_low))
        ub = np.minimum(np.minimum(m_up / dt, self._v_max), np.sqrt(self._two_a * m_up))
        lb_acc = np.maximum(lb, v_prev - self._a_dt)
        ub_acc = np.minimum(ub, v_prev + self._a_dt)
        # Where the acceleration bound cannot be met inside the position bounds, the position
        # bounds win: brake as hard as they require.
        bad = lb_acc > ub_acc
        if bad.any():
            stop = np.clip(v_prev, lb, ub)
            lb_acc, ub_acc = np.where(bad, stop, lb_acc), np.where(bad, stop, ub_acc)
        return lb_acc, ub_acc

    def solve(self, q: np.ndarray, v_prev: np.ndarray, X_des: RigidTransform,
              V_ff: np.ndarray, active: np.ndarray | None = None) -> IkStep:
        """One IK step from commanded state (q, v_prev) toward the target; see the class doc.
        ``active`` is a previous step's ``IkStep.active`` (a warm start: it changes how fast
        the QPs are solved, not their solution)."""
        n = self._n
        active = np.zeros(2 * n) if active is None else active
        lb, ub = self.velocity_bounds(q, v_prev)
        # A sum is finite only if every term is: one test for NaN and infinity.
        if not (math.isfinite(X_des.GetAsMatrix34().sum()) and math.isfinite(V_ff.sum())):
            return IkStep(np.clip(np.zeros(self._n), lb, ub), "hold")
        self._set_q(q)
        X = self._frame.CalcPoseInWorld(self._plant_context)
        # Everything below is written in u = v / scale, where the metric W is the identity.
        world = self._plant.world_frame()
        J = self._plant.CalcJacobianSpatialVelocity(
            self._plant_context, JacobianWrtVariable.kV, self._frame, self._origin, world,
            world)[:, self._v_index] * self._scale
        V = V_ff + self._settings.tracking_gain * spatial_error(X, X_des)
        lb_u, ub_u = lb * self._inv_scale, ub * self._inv_scale
        u_posture = self._posture_gain * (self._q_home - q)

        # Stage 1: the gripper task within the bounds, with the posture term (projected on the
        # null space of J, so it only costs tracking where bounds are active) at weight c_p.
        c_p = self._settings.posture_task_weight
        H1, g1 = J.T @ J + self._damping, J.T @ V
        if c_p > 0.0:
            P = self._eye - J.T @ np.linalg.solve(J @ J.T + self._eps6, J)
            PtP = c_p * P.T @ P
            H1 += PtP
            g1 += PtP @ u_posture
        u_task = np.linalg.solve(H1, g1)
        saturated = bool((u_task < lb_u).any() or (u_task > ub_u).any())
        active_task = np.zeros(n)
        if saturated:
            stage = solve_box_qp(H1, g1, lb_u, ub_u, u_task, active=active[:n])
            u_task, active_task = stage.x, stage.active

        # Stage 2: secondary tasks and posture, in what leaves J u = J u_task unchanged.
        w = self._settings.posture_weight
        H, g = self._stage2_H.copy(), w * u_posture
        for frame, R_home, gain, weight in self._orientation_tasks:
            J_w = self._plant.CalcJacobianSpatialVelocity(
                self._plant_context, JacobianWrtVariable.kV, frame, self._origin, world,
                world)[:3, self._v_index] * self._scale
            R = frame.CalcPoseInWorld(self._plant_context).rotation()
            H += weight * J_w.T @ J_w
            g += weight * J_w.T @ (gain * rotation_log(R_home @ R.inverse()))
        # J u = J u_task is held by a penalty a million times the stage's own weights: the
        # gripper moves within 1e-6 of stage 1's velocity (1e-8 m per step), the stage stays a
        # box QP, and where no bound is active it is one linear solve.
        JtJ = _HOLD_WEIGHT * (J.T @ J)
        H += JtJ
        g += JtJ @ u_task
        u = np.linalg.solve(H, g)
        if not ((u < lb_u).any() or (u > ub_u).any()):
            return IkStep(self._scale * u, "qp" if saturated else "unconstrained",
                          np.concatenate([active_task, np.zeros(n)]))
        stage = solve_box_qp(H, g, lb_u, ub_u, u_task, active=active[n:])
        return IkStep(self._scale * stage.x, "qp", np.concatenate([active_task, stage.active]))

    def _set_q(self, q: np.ndarray) -> None:
        self._q_full[self._q_index] = q
        self._plant.SetPositions(self._plant_context, self._q_full)

    # -- events and outputs ---------------------------------------------------------------
    def _update(self, context: Context, discrete_state: DiscreteValues) -> None:
        x = context.get_discrete_state(self._state).get_value()
        n = self._n
        q, v_prev, active = x[:n], x[n:2 * n], x[2 * n:]
        X_des, V_ff = self._X_input.Eval(context), self._V_input.Eval(context)
        start = time.perf_counter()
        step = self.solve(q, v_prev, X_des, V_ff, active)
        if self.solve_times is not None:
            self.solve_times.append(time.perf_counter() - start)
        q_next = np.clip(q + step.v * self._dt, self._q_min, self._q_max)
        if self._plant_state.HasValue(context):
            measured = self._plant_state.Eval(context)[self._q_index]
            q_next = np.clip(q_next, measured - self._max_error, measured + self._max_error)
        active = active if step.active is None else step.active
        discrete_state.set_value(self._state, np.concatenate([q_next, step.v, active]))

    def _calc_desired_state(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(context.get_discrete_state(self._state).get_value()[:2 * self._n])
