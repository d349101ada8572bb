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
from legato_drake.poses import (
    interpolate,
    pose_delta,
    pose_to_vector,
    rotation_exp,
    vector_to_pose,
)
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
class ExpertNoise:
    """The perturbation of the executed commanded pose (``Scenario.expert_noise``)."""

    position_std: float = 0.0
    """Per-axis standard deviation (m) of the offset's translation."""
    rotation_std: float = 0.0
    """Per-axis standard deviation (rad) of the offset's rotation vector."""
    correlation: float = 0.8
    """Step-to-step correlation of the AR(1) offset."""
    full_speed: float = conventions.EXPERT_NOISE_FULL_SPEED
    """Plan speed (m/s) at and above which the offset has its full size; slower, it shrinks
    in proportion, and it vanishes where the plan holds still. At the default, transit is
    perturbed and the precise, slow moves into a grasp or a release hardly are: there the
    grasp decision depends on arriving, and an offset as large as the last steps would blur
    it (we measured state policies that hover at the handle and never close). Lower, those
    moves are perturbed too (the hold of the grasp itself never is): demonstrations of
    corrections where an image policy arrives a centimetre off."""

    @property
    def enabled(self) -> bool:
        return self.position_std > 0 or self.rotation_std > 0

    def next_offset(self, previous: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The AR(1) step ``rho o + sqrt(1 - rho^2) sigma eps`` of the 6-D offset
        [translation, rotation vector]: stationary with the configured deviations."""
        sigma = np.repeat([self.position_std, self.rotation_std], 3)
        rho = self.correlation
        return rho * previous + np.sqrt(1.0 - rho * rho) * sigma * rng.standard_normal(6)


def offset_pose(X: RigidTransform, offset: np.ndarray) -> RigidTransform:
    """``X`` moved by the 6-D ``offset`` [translation, rotation vector] in its own frame."""
    return X @ RigidTransform(rotation_exp(offset[3:6]), offset[0:3])


@dataclass(frozen=True)
class _Progress:
    script: Script | None
    step: int
    action: tuple[float, ...]
    """What is executed (the commanded pose moves by it)."""
    label: tuple[float, ...] = (0.0,) * 7
    """The expert's own action from where it is (equal to ``action`` without noise)."""
    executed: tuple[float, ...] | None = None
    """The executed commanded pose [xyz, quaternion wxyz] after the last step (None before
    the first)."""
    offset: tuple[float, ...] = (0.0,) * 6
    """The AR(1) drift that, scaled by the plan's speed, perturbs the executed pose."""


class ScriptedDemonstrator(LeafSystem):
    """Outputs exactly what a policy outputs, from the task's privileged state.

    At the first step after ``t_start`` it asks the task for a waypoint plan (randomised by
    ``seed``) and samples it into one commanded TCP pose per step (or, given a ``script``,
    plays that one: e.g. a demonstration recorded on another embodiment); every ``period`` it then
    outputs the delta ``X_{k-1}^-1 X_k`` between consecutive commanded poses (in the previous
    commanded frame) and the grasp command. After the last step it outputs zero deltas and
    keeps the last grasp, and ``done`` turns to 1.

    With ``noise`` (DART-style data collection), the executed commanded pose at step k is the
    plan's pose ``X_k`` moved by a small drifting offset (``ExpertNoise``, seeded by
    ``[seed, 2]``, in proportion to the plan's speed), while ``label`` holds what the expert
    would command from where it is: the delta from the executed pose of step k - 1 back to
    ``X_k`` (with the plan's grasp).
    A dataset recorded from ``label`` so shows the corrections an expert makes off its nominal
    path. Once the script is played out the offset is removed in one step and the expert
    holds still.

    Input ports:
        plant_state: the plant's full state (privileged: object poses).

    Output ports:
        action (7): [dx, dy, dz, droll, dpitch, dyaw, grasp]: what is executed.
        label (7): the expert's corrective action (the same as ``action`` without noise).
        done (1): 1 once the script has been played out.

    State: abstract (the script, the step index, the actions, the executed pose, the offset).
    """

    def __init__(self, plant: MultibodyPlant, task: Task, seed: int,
                 script: Script | None = None,
                 X_start: RigidTransform = conventions.START_POSE,
                 t_start: float = conventions.HOMING_DURATION,
                 period: float = conventions.POLICY_PERIOD,
                 offset: float = conventions.CONTROLLER_OFFSET,
                 noise: ExpertNoise | None = None):
        super().__init__()
        self._plant, self._task = plant, task
        self._noise = noise if noise is not None and noise.enabled else None
        self._plant_context = plant.CreateDefaultContext()
        self._seed, self._X_start, self._period = seed, X_start, period
        self._plant_state = self.DeclareVectorInputPort(
            "plant_state", plant.num_positions() + plant.num_velocities())
        self._progress = self.DeclareAbstractState(
            AbstractValue.Make(_Progress(script, 0, (0.0,) * 7)))
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, t_start + offset, self._step)
        self.DeclareVectorOutputPort("action", 7, self._calc_action, {self.all_state_ticket()})
        self.DeclareVectorOutputPort("label", 7, self._calc_label, {self.all_state_ticket()})
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
        X_prev = (vector_to_pose(np.array(progress.executed)) if progress.executed is not None
                  else self._X_start)
        last = len(script) - 1
        offset = np.zeros(6)
        drift = np.array(progress.offset)
        if k <= last and self._noise is not None:
            drift = self._noise.next_offset(drift, np.random.default_rng([self._seed, 2, k]))
            previous = script.poses[k - 1, :3] if k > 0 else self._X_start.translation()
            speed = np.linalg.norm(script.poses[k, :3] - previous) / self._period
            offset = drift * min(1.0, speed / self._noise.full_speed)
        if last < 0:
            X_plan, plan_vector, grasp = self._X_start, pose_to_vector(self._X_start), 0.0
        else:  # past the end: hold the last pose (and remove the offset)
            X_plan, plan_vector = script.pose(min(k, last)), script.poses[min(k, last)]
            grasp = script.grasps[min(k, last)]
        still = progress.executed is not None and np.array_equal(progress.executed, plan_vector)
        label = ((0.0,) * 6 if still else tuple(pose_delta(X_prev, X_plan))) + (grasp,)
        action, executed = label, plan_vector
        if offset.any():
            X_next = offset_pose(X_plan, offset)
            action = (*pose_delta(X_prev, X_next), grasp)
            executed = pose_to_vector(X_next)
        state.get_mutable_abstract_state(self._progress).set_value(_Progress(
            script, k + 1, tuple(float(a) for a in action), tuple(float(a) for a in label),
            tuple(float(v) for v in executed), tuple(float(o) for o in drift)))

    def _calc_action(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(context.get_abstract_state(self._progress).get_value().action)

    def _calc_label(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(context.get_abstract_state(self._progress).get_value().label)

    def _calc_done(self, context: Context, output: BasicVector) -> None:
        progress = context.get_abstract_state(self._progress).get_value()
        finished = progress.script is not None and progress.step > len(progress.script)
        output.SetFromVector([float(finished)])
