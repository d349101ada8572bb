"""Integrates 10 Hz gripper pose deltas into a smooth gripper target pose for the IK."""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import Frame
from pydrake.systems.framework import BasicVector, Context, DiscreteValues, LeafSystem

from legato_drake import conventions
from legato_drake.poses import (
    apply_delta,
    interpolate,
    pose_to_vector,
    rotation_log,
    vector_to_pose,
)


class GripperTargetIntegrator(LeafSystem):
    """Turns the policy's pose deltas into the gripper TCP target the IK tracks.

    Before ``t_start`` (homing) the target is a cosine blend over ``t_start`` seconds from
    ``X_home`` (the TCP at the robot's home posture) to ``X_start``, and deltas are ignored.
    From ``t_start`` on, every ``period`` the commanded pose is composed with the latest delta
    (``X_next = X_prev * delta``, the delta expressed in the previous commanded frame, SPEC §7)
    and the target moves from the previous to the new commanded pose at constant velocity
    over the period, so the IK sees a continuous target and a feed-forward velocity.

    With ``max_lead`` > 0 (metres) and the ``tcp`` frame of ``plant``, the commanded position
    never leads the measured TCP by more than ``max_lead``: a new commanded pose further away
    is pulled back along the line from the measured TCP to it (the orientation as commanded).
    Without it, a robot that cannot follow lets the target run away while a closed-loop policy
    keeps commanding steps towards a goal it does not reach.

    Input ports:
        delta (6): [dx, dy, dz, droll, dpitch, dyaw]. A non-finite delta is ignored (the
        commanded pose holds).
        plant_state (only with ``max_lead``): the plant's full state.

    Output ports:
        X_WG_target (RigidTransform): target TCP pose in the world.
        V_WG_target (6): its spatial velocity [w; v] in the world.
        X_WG_commanded (7): the latest commanded pose [xyz, quaternion wxyz].

    State: discrete [X_prev (7), X_next (7), t_k (1)].
    """

    def __init__(self, X_home: RigidTransform, X_start: RigidTransform = conventions.START_POSE,
                 t_start: float = conventions.HOMING_DURATION,
                 period: float = conventions.POLICY_PERIOD,
                 offset: float = conventions.TARGET_OFFSET, max_lead: float = 0.0,
                 plant: MultibodyPlant | None = None, tcp: Frame | None = None):
        super().__init__()
        self._X_home, self._X_start = X_home, X_start
        self._t_start, self._period = t_start, period
        self._decoded: tuple[bytes, RigidTransform, RigidTransform] | None = None
        self._delta = self.DeclareVectorInputPort("delta", 6)
        self._max_lead = max_lead
        if max_lead > 0:
            if plant is None or tcp is None:
                raise ValueError("max_lead needs the plant and its TCP frame")
            self._plant, self._tcp = plant, tcp
            self._plant_context = plant.CreateDefaultContext()
            self._plant_state = self.DeclareVectorInputPort(
                "plant_state", plant.num_positions() + plant.num_velocities())
        start = pose_to_vector(X_start)
        self._state = self.DeclareDiscreteState(np.concatenate([start, start, [t_start]]))
        self.DeclarePeriodicDiscreteUpdateEvent(period, t_start + offset, self._step)
        # The target is a function of time and the commanded poses alone: without these
        # tickets Drake would recompute it whenever any input (the plant's state) changes.
        timed = {self.time_ticket(), self.xd_ticket()}
        self.DeclareAbstractOutputPort(
            "X_WG_target", lambda: AbstractValue.Make(RigidTransform()), self._calc_pose,
            timed)
        self.DeclareVectorOutputPort("V_WG_target", 6, self._calc_velocity, timed)
        self.DeclareVectorOutputPort("X_WG_commanded", 7, self._calc_commanded,
                                     {self.xd_ticket()})

    def get_delta_input_port(self):
        return self._delta

    def get_plant_state_input_port(self):
        return self._plant_state

    def _bounded(self, context: Context, X: RigidTransform) -> RigidTransform:
        """``X`` with its position pulled back to within ``max_lead`` of the measured TCP."""
        q = self._plant_state.Eval(context)[:self._plant.num_positions()]
        self._plant.SetPositions(self._plant_context, q)
        measured = self._tcp.CalcPoseInWorld(self._plant_context).translation()
        lead = X.translation() - measured
        distance = float(np.linalg.norm(lead))
        if distance <= self._max_lead:
            return X
        return RigidTransform(X.rotation(), measured + lead * (self._max_lead / distance))

    def _step(self, context: Context, discrete_state: DiscreteValues) -> None:
        x = context.get_discrete_state(self._state).get_value()
        delta = self._delta.Eval(context)
        X_next = vector_to_pose(x[7:14])
        X_new = apply_delta(X_next, delta) if np.all(np.isfinite(delta)) else X_next
        if self._max_lead > 0:
            X_new = self._bounded(context, X_new)
        discrete_state.set_value(self._state, np.concatenate(
            [pose_to_vector(X_next), pose_to_vector(X_new), [context.get_time()]]))

    def _blend(self, t: float) -> tuple[float, float]:
        """Cosine-blend fraction s(t) and its rate ds/dt during homing."""
        T = self._t_start
        if T <= 0.0 or t >= T:
            return 1.0, 0.0
        return 0.5 * (1.0 - np.cos(np.pi * t / T)), 0.5 * np.pi / T * np.sin(np.pi * t / T)

    def _segment(self, context: Context) -> tuple[RigidTransform, RigidTransform, float, float]:
        """(X0, X1, s, ds/dt) of the segment the target is on at the context's time."""
        t = context.get_time()
        if t < self._t_start:
            s, ds = self._blend(t)
            return self._X_home, self._X_start, s, ds
        x = context.get_discrete_state(self._state).get_value()
        X0, X1 = self._poses(x)
        alpha = (t - x[14]) / self._period
        if alpha >= 1.0:
            return X1, X1, 1.0, 0.0
        return X0, X1, max(alpha, 0.0), 1.0 / self._period

    def _poses(self, x: np.ndarray) -> tuple[RigidTransform, RigidTransform]:
        """The segment's end poses decoded from the state ``x``; remembered for the state
        they came from (the state changes at 10 Hz, the outputs are read at 100 Hz and more),
        so this is a cache of a pure function, not state."""
        key = x[:14].tobytes()
        if self._decoded is None or self._decoded[0] != key:
            self._decoded = (key, vector_to_pose(x[0:7]), vector_to_pose(x[7:14]))
        return self._decoded[1], self._decoded[2]

    def _calc_pose(self, context: Context, output: AbstractValue) -> None:
        X0, X1, s, _ = self._segment(context)
        output.set_value(interpolate(X0, X1, s))

    def _calc_velocity(self, context: Context, output: BasicVector) -> None:
        X0, X1, _, ds = self._segment(context)
        w = X0.rotation() @ rotation_log(X0.rotation().inverse() @ X1.rotation())
        v = X1.translation() - X0.translation()
        output.SetFromVector(ds * np.concatenate([w, v]))

    def _calc_commanded(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(context.get_discrete_state(self._state).get_value()[7:14])
