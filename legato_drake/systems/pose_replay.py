"""A controller that replays a recorded 6-DoF gripper pose stream as 10 Hz policy actions."""

from __future__ import annotations

import numpy as np
from pydrake.math import RigidTransform
from pydrake.systems.framework import BasicVector, Context, DiscreteValues, LeafSystem

from legato_drake import conventions
from legato_drake.data.pose_stream import PoseStream, stream_to_actions


class PoseStreamReplay(LeafSystem):
    """Outputs what a policy outputs, read from a recorded pose stream (a drop-in replacement
    of ``ScriptedDemonstrator``: same output ports, no input port).

    The stream is resampled at ``period`` (lerp + slerp, nearest grasp), expressed relative to
    its first pose and re-anchored at ``X_start``: the stream's first pose maps onto the start
    pose (see ``legato_drake.data.pose_stream.stream_to_actions``). At step k (from ``t_start``
    on) the action is the delta between the re-anchored poses k and k + 1, in the frame of pose
    k, with the grasp of sample k + 1. After the last step it outputs zero deltas and keeps the
    last grasp, and ``done`` turns to 1 (as the scripted demonstrator does).

    Output ports:
        action (7): [dx, dy, dz, droll, dpitch, dyaw, grasp].
        done (1): 1 once the stream has been played out.

    State: discrete [steps taken].
    """

    def __init__(self, stream: PoseStream, X_start: RigidTransform = conventions.START_POSE,
                 t_start: float = conventions.HOMING_DURATION,
                 period: float = conventions.POLICY_PERIOD,
                 offset: float = conventions.CONTROLLER_OFFSET,
                 X_TG: RigidTransform | None = None):
        super().__init__()
        self._stream = stream
        self._actions, self._poses = stream_to_actions(stream, X_start, period, X_TG)
        self._step = self.DeclareDiscreteState(1)
        self.DeclarePeriodicDiscreteUpdateEvent(period, t_start + offset, self._advance)
        self.DeclareVectorOutputPort("action", 7, self._calc_action, {self.xd_ticket()})
        self.DeclareVectorOutputPort("done", 1, self._calc_done, {self.xd_ticket()})

    @property
    def stream(self) -> PoseStream:
        """The stream being replayed."""
        return self._stream

    @property
    def actions(self) -> np.ndarray:
        """(K, 7) the actions of the K steps of the replay."""
        return self._actions.copy()

    @property
    def commanded_poses(self) -> np.ndarray:
        """(K + 1, 7) the commanded poses the actions reach, [xyz, quaternion wxyz], starting
        at the start pose."""
        return self._poses.copy()

    def _advance(self, context: Context, discrete_state: DiscreteValues) -> None:
        step = context.get_discrete_state(self._step).get_value()[0]
        discrete_state.set_value(self._step, [step + 1.0])

    def _calc_action(self, context: Context, output: BasicVector) -> None:
        step = int(context.get_discrete_state(self._step).get_value()[0])
        if step == 0:
            output.SetFromVector(np.zeros(7))
        elif step <= len(self._actions):
            output.SetFromVector(self._actions[step - 1])
        else:
            last = self._actions[-1, 6] if len(self._actions) else 0.0
            output.SetFromVector([0.0] * 6 + [last])

    def _calc_done(self, context: Context, output: BasicVector) -> None:
        step = int(context.get_discrete_state(self._step).get_value()[0])
        output.SetFromVector([float(step > len(self._actions))])
