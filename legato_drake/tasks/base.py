"""What a task is: scene models, initial randomization, a success predicate, a scripted plan.

A task object is bound to one plant: ``add_to_plant`` records its model instances, and the
other methods read or write that plant's context. Tasks know nothing about robots: the
scripted plan is a list of gripper TCP waypoints in the world.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass, field

import numpy as np
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import RigidBody
from pydrake.systems.framework import Context

from legato_drake import conventions
from legato_drake.dimensions import STOVE_SIZE


@dataclass
class SuccessReport:
    """The verdict of a task's success predicate on one plant state."""

    success: bool
    reason: str
    """Empty on success; otherwise the first condition that failed, in words and numbers."""
    metrics: dict[str, float] = field(default_factory=dict)
    """The measured quantities the predicate compared against its thresholds."""


@dataclass
class Waypoint:
    """One target of a scripted demonstration: move the TCP there, then hold.

    Plans are imitated, so every change of grasp must follow something a policy observes:
    grasp and release on arrival (the motion ending), not after a hold in an unchanging
    scene; a policy cannot tell the held steps apart and, taking the most likely grasp, never
    lets go. A hold while the fingers move is fine: the fingers are observed. The moves that
    end in a grasp or a release are ``stop``-profiled (constant speed to the end): then
    stopping and closing (or opening) happen together in the data, and a policy that stops
    near the goal acts, where a minimum-jerk ending's creeping last steps (all "keep
    moving") would teach it to hover. We measured both: lids placed but never released, and
    grippers hovering at the handle, never closing."""

    pose: RigidTransform
    """Target pose of the gripper TCP in the world."""
    grasp: bool
    """Grasp command while moving to this waypoint and holding at it."""
    speed: float = 0.15
    """Cruise speed (m/s) of the move to this waypoint."""
    hold: float = 0.0
    """Seconds to stay at the waypoint after reaching it."""
    profile: str = "min_jerk"
    """Time scaling of the move: ``min_jerk`` (smooth start and stop) or ``stop`` (constant
    speed, stopping at once: the move before a grasp or a release)."""


class Task(abc.ABC):
    """Base class of the tasks: subclasses fill in the scene, the predicate and the plan."""

    name: str = ""
    description: str = ""
    demo_version: int = 1
    """The version of the scripted expert's demonstrations: raised by every change to
    ``plan_demonstration`` that changes what it records. A collection records it and does
    not resume a dataset of another version; an experiment grid keys its datasets by it, so
    an experiment folder never reuses demos the expert no longer makes."""

    @abc.abstractmethod
    def add_to_plant(self, plant: MultibodyPlant, parser: Parser) -> None:
        """Adds the scene's models to an unfinalized plant and remembers their handles."""

    @abc.abstractmethod
    def set_initial_state(self, plant: MultibodyPlant, context: Context,
                          rng: np.random.Generator) -> None:
        """Places the objects at a random initial configuration (SPEC §6) in ``context``."""

    @abc.abstractmethod
    def evaluate(self, plant: MultibodyPlant, context: Context) -> SuccessReport:
        """The success predicate on the plant state in ``context``."""

    @abc.abstractmethod
    def plan_demonstration(self, plant: MultibodyPlant, context: Context,
                           rng: np.random.Generator) -> list[Waypoint]:
        """Scripted-expert waypoints from the privileged state in ``context``."""


def tilt_angle(R: RotationMatrix) -> float:
    """Angle (rad) between a body's +z axis and the world's +z axis."""
    return float(np.arccos(np.clip(R.matrix()[2, 2], -1.0, 1.0)))


def uniform(rng: np.random.Generator, low: float, high: float) -> float:
    """One uniform draw as a Python float."""
    return float(rng.uniform(low, high))


def finger_opening(plant: MultibodyPlant, context: Context) -> float:
    """The smaller of the two fingers' openings (m from the gripper's centre plane)."""
    return float(min(plant.GetJointByName(n).GetOnePosition(context)
                     for n in conventions.GRIPPER_FINGER_JOINTS))


def body_speed(plant: MultibodyPlant, context: Context, body) -> float:
    """The translational speed (m/s) of a body's origin in the world."""
    return float(np.linalg.norm(
        plant.EvalBodySpatialVelocityInWorld(context, body).translational()))


FALLEN_BELOW_TABLE = 0.05
"""How far (m) below the table's top an object counts as fallen off the table."""


def on_table_check(what: str, z: float, table_height: float) -> tuple[bool, str]:
    """The "still on the table" condition, checked first: the scenes have no floor, so an
    object knocked off the table falls for the rest of the trial, and the other checks'
    distances would only say how far it fell."""
    return (z >= table_height - FALLEN_BELOW_TABLE,
            f"{what} fell off the table ({(table_height - z) * 100:.0f} cm below its top)")


def release_check(what: str, fingers: float, half_width: float, margin: float
                  ) -> tuple[bool, str]:
    """The "released" condition: both fingers open wider than the grasped part's half width
    plus ``margin``."""
    needed = half_width + margin
    return (fingers >= needed, f"{what} still held: the fingers are open "
                               f"{fingers * 1000:.0f} mm (min {needed * 1000:.0f} mm)")


def verdict(checks: list[tuple[bool, str]], metrics: dict[str, float]) -> SuccessReport:
    """The report of a predicate: success if every check holds, else the first failed one's
    reason."""
    for ok, reason in checks:
        if not ok:
            return SuccessReport(False, reason, metrics)
    return SuccessReport(True, "", metrics)


TABLE_CENTER_X = 0.95
"""The 1.3 m table spans x from 0.3 to 1.6: every robot's base and shoulder stay clear of it."""


def add_table(plant: MultibodyPlant, parser: Parser, height: float) -> None:
    """Welds the shared table model with its top surface at ``height`` (SPEC §6)."""
    (table,) = parser.AddModels(url="package://legato_drake/table.sdf")
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("table_top", table),
                     RigidTransform([TABLE_CENTER_X, 0.0, height]))


DROP = 0.001
"""Free objects start this far above their support and settle while the robot homes."""
STOVE_HALF_HEIGHT = STOVE_SIZE[2] / 2


def add_stove_and_pot(plant: MultibodyPlant, parser: Parser) -> tuple[RigidBody, RigidBody]:
    """Adds the free stove and pot of the lid and ladle scenes; returns their bodies."""
    (stove,) = parser.AddModels(url="package://legato_drake/stove.sdf")
    (pot,) = parser.AddModels(url="package://legato_drake/pot.sdf")
    return plant.GetBodyByName("stove", stove), plant.GetBodyByName("pot", pot)


def place_stove_and_pot(plant: MultibodyPlant, context: Context, stove: RigidBody,
                        pot: RigidBody, stove_xy: np.ndarray, table_height: float
                        ) -> np.ndarray:
    """Sets the stove on the table at ``stove_xy`` and the pot on the stove, each ``DROP``
    above its support; returns the centre of the stove's top face."""
    stove_z = table_height + STOVE_HALF_HEIGHT + DROP
    plant.SetFreeBodyPose(context, stove, RigidTransform([*stove_xy, stove_z]))
    top = np.array([*stove_xy, stove_z + STOVE_HALF_HEIGHT])
    plant.SetFreeBodyPose(context, pot, RigidTransform(top + [0.0, 0.0, DROP]))
    return top
