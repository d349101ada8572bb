"""Binary grasp command -> finger position targets that move at the gripper's speed."""

from __future__ import annotations

import math

import numpy as np
from pydrake.systems.framework import BasicVector, Context, DiscreteValues, LeafSystem

from legato_drake import conventions


class GripperActuation(LeafSystem):
    """Moves the two finger targets toward closed (grasp >= 0.5) or open at a fixed speed.

    The real gripper's fingers move at about 1 rad/s, a full stroke in about 0.8 s (SPEC §3);
    our prismatic fingers cover their 0.052 m stroke in ``stroke_time`` seconds. The plant's
    joint PD tracks the target; closing on an object squeezes it with kp times the remaining
    distance (clamped by the finger effort limit).

    Input ports:
        grasp (1): 1 closes, 0 opens; a non-finite command holds the current target.

    Output ports:
        desired_state (4): [q_left, q_right, v_left, v_right] for the gripper's PD.

    State: discrete [finger target position (m), finger target velocity (m/s)].
    """

    def __init__(self, period: float = conventions.IK_PERIOD, stroke_time: float = 0.8,
                 open_position: float = conventions.GRIPPER_OPEN):
        super().__init__()
        self._period = period
        self._open = open_position
        self._speed = open_position / stroke_time
        self._grasp = self.DeclareVectorInputPort("grasp", 1)
        self._state = self.DeclareDiscreteState(np.array([open_position, 0.0]))
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._step)
        self.DeclareVectorOutputPort("desired_state", 4, self._calc, {self.xd_ticket()})

    def get_grasp_input_port(self):
        return self._grasp

    def _step(self, context: Context, discrete_state: DiscreteValues) -> None:
        q = float(context.get_discrete_state(self._state).get_value()[0])
        command = float(self._grasp.Eval(context)[0])
        if not math.isfinite(command):
            discrete_state.set_value(self._state, [q, 0.0])
            return
        goal = 0.0 if command >= 0.5 else self._open
        limit = self._speed * self._period
        step = min(max(goal - q, -limit), limit)
        discrete_state.set_value(self._state, [q + step, step / self._period])

    def _calc(self, context: Context, output: BasicVector) -> None:
        q, v = context.get_discrete_state(self._state).get_value()
        output.SetFromVector([q, q, v, v])
