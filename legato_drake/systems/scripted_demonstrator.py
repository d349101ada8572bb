"""The scripted expert: a task's waypoint plan played out as 10 Hz policy actions."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import BasicVector, Context, LeafSystem, State

from legato_drake import conventions
from legato_drake.poses import interpolate, pose_delta, pose_to_vector, vector_to_pose
from legato_drake.tasks.base import Task, Waypoint

ANGULAR_SPEED = 0.8
"""Cruise angular speed (rad/s) of scripted moves."""


@dataclass(frozen=True)
class Script:
    """The commanded TCP pose and grasp at every policy step of a demonstration."""

    poses: np.ndarray
    """(N, 7): [xyz, quaternion wxyz] of the commanded TCP pose at each step."""
    grasps: np.ndarray
    """(N,): grasp command at each step."""

    def __len__(self) -> int:
        return len(self.grasps)

    def pose(self, k: int) -> RigidTransform:
        """The commanded TCP pose at step ``k``."""
        return vector_to_pose(self.poses[k])


def min_jerk(s: float) -> float:
    """Minimum-jerk time scaling: 0 -> 0, 1 -> 1, zero velocity and acceleration at both ends."""
    return s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)


PROFILES = {"min_jerk": min_jerk, "stop": lambda s: s}
"""Time scalings of a move (``Waypoint.profile``)."""


def script_from_waypoints(X_start: RigidTransform, waypoints: list[Waypoint],
                          period: float = conventions.POLICY_PERIOD) -> Script:
    """Samples straight-line moves through ``waypoints`` every ``period`` (each with its
    waypoint's time scaling, minimum-jerk by default)."""
    poses: list[RigidTransform] = []
    grasps: list[float] = []
    X_prev = X_start
    for wp in waypoints:
        distance = float(np.linalg.norm(wp.pose.translation() - X_prev.translation()))
        angle = (X_prev.rotation().inverse() @ wp.pose.rotation()).ToAngleAxis().angle()
        duration = max(distance / wp.speed, angle / ANGULAR_SPEED)
        steps = math.ceil(duration / period - 1e-9)
        scaling = PROFILES[wp.profile]
        for k in range(1, steps + 1):
            poses.append(interpolate(X_prev, wp.pose, scaling(k / steps)))
            grasps.append(float(wp.grasp))
        for _ in range(round(wp.hold / period)):
            poses.append(wp.pose)
            grasps.append(float(wp.grasp))
        X_prev = wp.pose
    return Script(np.array([pose_to_vector(X) for X in poses]).reshape(-1, 7),
                  np.array(grasps))


@dataclass(frozen=True)
class _Progress:
    script: Script | None
    step: int
    action: tuple[float, ...]


class ScriptedDemonstrator(LeafSystem):
    """Outputs exactly what a policy outputs, from the task's privileged state.

    At the first step after ``t_start`` it asks the task for a waypoint plan (randomised by
    ``seed``) and samples it into one commanded TCP pose per step (or, given a ``script``,
    plays that one: e.g. a demonstration recorded on another embodiment); every ``period`` it then
    outputs the delta ``X_{k-1}^-1 X_k`` between consecutive commanded poses (in the previous
    commanded frame) and the grasp command. After the last step it outputs zero deltas and
    keeps the last grasp, and ``done`` turns to 1.

    Input ports:
        plant_state: the plant's full state (privileged: object poses).

    Output ports:
        action (7): [dx, dy, dz, droll, dpitch, dyaw, grasp].
        done (1): 1 once the script has been played out.

    State: abstract (the script, the step index and the current action).
    """

    def __init__(self, plant: MultibodyPlant, task: Task, seed: int,
                 script: Script | None = None,
                 X_start: RigidTransform = conventions.START_POSE,
                 t_start: float = conventions.HOMING_DURATION,
                 period: float = conventions.POLICY_PERIOD,
                 offset: float = conventions.CONTROLLER_OFFSET):
        super().__init__()
        self._plant, self._task = plant, task
        self._plant_context = plant.CreateDefaultContext()
        self._seed, self._X_start, self._period = seed, X_start, period
        self._plant_state = self.DeclareVectorInputPort(
            "plant_state", plant.num_positions() + plant.num_velocities())
        self._progress = self.DeclareAbstractState(
            AbstractValue.Make(_Progress(script, 0, (0.0,) * 7)))
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, t_start + offset, self._step)
        self.DeclareVectorOutputPort("action", 7, self._calc_action, {self.all_state_ticket()})
        self.DeclareVectorOutputPort("done", 1, self._calc_done, {self.all_state_ticket()})

    def get_plant_state_input_port(self):
        return self._plant_state

    def script(self, context: Context) -> Script | None:
        """The script being played (None before the first step)."""
        return context.get_abstract_state(self._progress).get_value().script

    def _step(self, context: Context, state: State) -> None:
        progress = context.get_abstract_state(self._progress).get_value()
        script = progress.script
        if script is None:
            self._plant.SetPositionsAndVelocities(self._plant_context,
                                                  self._plant_state.Eval(context))
            rng = np.random.default_rng([self._seed, 1])
            waypoints = self._task.plan_demonstration(self._plant, self._plant_context, rng)
            script = script_from_waypoints(self._X_start, waypoints, self._period)
        k = progress.step
        if k < len(script):
            X_prev = script.pose(k - 1) if k > 0 else self._X_start
            action = (*pose_delta(X_prev, script.pose(k)), script.grasps[k])
        else:
            action = (0.0,) * 6 + (script.grasps[-1] if len(script) else 0.0,)
        state.get_mutable_abstract_state(self._progress).set_value(
            _Progress(script, k + 1, tuple(float(a) for a in action)))

    def _calc_action(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(context.get_abstract_state(self._progress).get_value().action)

    def _calc_done(self, context: Context, output: BasicVector) -> None:
        progress = context.get_abstract_state(self._progress).get_value()
        finished = progress.script is not None and progress.step > len(progress.script)
        output.SetFromVector([float(finished)])
