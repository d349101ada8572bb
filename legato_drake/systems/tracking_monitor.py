"""Accumulates how well the gripper follows its target: RMS and max position/rotation error."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import BasicVector, Context, DiscreteValues, LeafSystem

from legato_drake import conventions
from legato_drake.poses import pose_error
from legato_drake.robot_types import RobotHandles


@dataclass
class TrackingStats:
    """Gripper tracking error over an episode (from ``t_start`` on)."""

    samples: int
    rms_mm: float
    max_mm: float
    rms_deg: float
    max_deg: float
    min_limit_margin: float
    """Smallest distance (rad or m) of any controlled joint from its position limits."""
    max_foot_drift_mm: float = 0.0
    """Largest distance of any foot frame from where it stood at home (0 without feet)."""

    @classmethod
    def from_vector(cls, x: np.ndarray) -> TrackingStats:
        n = max(int(x[0]), 1)
        return cls(int(x[0]), float(1e3 * np.sqrt(x[1] / n)), float(1e3 * x[3]),
                   float(np.degrees(np.sqrt(x[2] / n))), float(np.degrees(x[4])),
                   float(x[5]), float(1e3 * x[6]))


class TrackingMonitor(LeafSystem):
    """Compares the TCP pose with the IK's target every ``period`` from ``t_start`` on, and
    tracks how close the robot's joints come to their position limits and how far its feet
    (``Embodiment.foot_frames``) drift from where they stood at home.

    Input ports:
        X_WG_target (RigidTransform): the target the IK tracks.
        plant_state: the plant's full state.

    Output ports:
        stats (6): [samples, sum of squared position errors (m^2), sum of squared rotation
        errors (rad^2), max position error (m), max rotation error (rad), smallest joint-limit
        margin (rad or m), max foot drift (m)].

    State: discrete, the same 7 numbers.
    """

    def __init__(self, plant: MultibodyPlant, robot: RobotHandles,
                 t_start: float = conventions.HOMING_DURATION,
                 period: float = conventions.IK_PERIOD):
        super().__init__()
        self._plant, self._frame = plant, robot.tcp_frame
        joints = robot.controlled_joints
        self._q_index = np.array([j.position_start() for j in joints])
        self._q_min = np.array([j.position_lower_limits()[0] for j in joints])
        self._q_max = np.array([j.position_upper_limits()[0] for j in joints])
        self._plant_context = plant.CreateDefaultContext()
        self._feet = [plant.GetFrameByName(name, robot.robot)
                      for name in robot.embodiment.foot_frames]
        self._feet_home = [f.CalcPoseInWorld(self._plant_context).translation()
                           for f in self._feet]
        self._target = self.DeclareAbstractInputPort(
            "X_WG_target", AbstractValue.Make(RigidTransform()))
        self._plant_state = self.DeclareVectorInputPort(
            "plant_state", plant.num_positions() + plant.num_velocities())
        self._state = self.DeclareDiscreteState(np.array([0, 0, 0, 0, 0, np.inf, 0]))
        self.DeclarePeriodicDiscreteUpdateEvent(period, t_start, self._accumulate)
        self.DeclareVectorOutputPort("stats", 7, self._calc, {self.xd_ticket()})

    def _accumulate(self, context: Context, discrete_state: DiscreteValues) -> None:
        q = self._plant_state.Eval(context)[:self._plant.num_positions()]
        self._plant.SetPositions(self._plant_context, q)
        X = self._frame.CalcPoseInWorld(self._plant_context)
        dp, dr = pose_error(X, self._target.Eval(context))
        q_robot = q[self._q_index]
        margin = float(np.min(np.minimum(q_robot - self._q_min, self._q_max - q_robot)))
        drift = max((float(np.linalg.norm(f.CalcPoseInWorld(self._plant_context).translation()
                                          - home))
                     for f, home in zip(self._feet, self._feet_home, strict=True)), default=0.0)
        n, sp, sr, mp, mr, mm, md = context.get_discrete_state(self._state).get_value()
        discrete_state.set_value(self._state, [n + 1, sp + dp * dp, sr + dr * dr, max(mp, dp),
                                               max(mr, dr), min(mm, margin), max(md, drift)])

    def _calc(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(context.get_discrete_state(self._state).get_value())
