"""What a robot is, as data: the types that robot definitions and the systems that drive them share.

An ``Embodiment`` (model, frames, home, PD gains, ``IkSettings``, an optional ``LegFollower``)
is written by ``embodiments/`` (one module per robot, or a YAML file) and read by the systems
(the whole-body IK, the tracking monitor, the leg IK) through the ``RobotHandles`` that
``embodiments.add_embodiment`` returns. This module holds only those types: it imports
neither ``embodiments/`` nor ``systems/`` (both import it), so that a robot stays data and a
system stays a system.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.tree import Frame, Joint, ModelInstanceIndex

from legato_drake.leg_kinematics import LegGeometry


@dataclass(frozen=True)
class OrientationTask:
    """A secondary IK task: keep a frame of the robot at its home orientation (e.g. GR-1's
    head level and looking forward while the waist moves)."""

    frame: str
    """Frame of the robot model."""
    gain: float = 20.0
    """Gain (1/s) on its orientation error."""
    weight: float = 0.05
    """Weight relative to the posture term; the gripper task comes strictly first."""


@dataclass(frozen=True)
class IkSettings:
    """Gains and limits of the whole-body differential IK (SPEC §5)."""

    tracking_gain: float = 24.0
    """Gain (1/s) on the gripper pose error (position and rotation vector)."""
    posture_gain: float = 2.0
    """Gain (1/s) pulling the posture joints toward home, inside the task's null space."""
    posture_joints: tuple[str, ...] = ()
    """Joints the posture term acts on; empty means all controlled joints."""
    posture_weight: float = 0.01
    """Weight of the posture term relative to the orientation tasks, in the IK's second
    stage (the null space of the gripper task)."""
    posture_task_weight: float = 0.0
    """Weight of the posture term in the gripper task's own stage, relative to tracking:
    where joints are at their bounds, how much tracking the posture may cost (0: none,
    strict priority). While no bound is active it costs none, whatever this weight."""
    damping: float = 1e-6
    """Damping lambda of the gripper stage (damped least squares, ``lambda |v|^2`` in the
    metric W). Where the joints that are not at a bound can hardly move the gripper the way
    the target asks (a target at the edge of the workspace), the undamped step asks them for
    large velocities that the acceleration bound then turns into a chattering limit cycle:
    a DP policy drove GR-1's wrist roll and pitch to their limits with the lid in hand, the
    shoulder then swung at up to 7 rad/s and shook the lid off (lid, scene 10027).
    ``1e-3`` removes that and leaves the scripted experts' success and tracking as they
    were (within 0.1 mm RMS), but the project's measured results are at the default."""
    max_joint_speed: float = 2.5
    """Joint speed bound (rad/s or m/s), applied to every controlled joint."""
    max_joint_acceleration: float = 100.0
    """Joint acceleration bound (rad/s^2 or m/s^2) between two IK steps."""
    max_following_error: float = 0.1
    """How far (rad or m) a commanded joint position may lead the measured one: the IK's
    integrator stops there (anti-windup). Tracking is 0.001-0.007 on every robot; only a
    robot blocked by contact gets near, and without the bound a gripper pressed into the
    table for seconds wound its targets 2 rad ahead and, once it slipped free, the arm
    swung at 60 rad/s (20 times its speed limit) and threw the lid off the table."""
    joint_speed_limits: dict[str, float] = field(default_factory=dict)
    """Per-joint speed bounds that override ``max_joint_speed``."""
    joint_acceleration_limits: dict[str, float] = field(default_factory=dict)
    """Per-joint acceleration bounds that override ``max_joint_acceleration``."""
    joint_velocity_weights: dict[str, float] = field(default_factory=dict)
    """Per-joint weights (default 1) of the joint-space metric that resolves redundancy: the
    IK picks the velocity of smallest weighted norm that tracks the target, so a joint with
    weight 10 moves only where the others cannot do the job as cheaply (e.g. a slow mobile
    base behind a fast arm). Tracking keeps priority; only the split between joints changes."""
    joint_position_limits: dict[str, tuple[float, float]] = field(default_factory=dict)
    """Per-joint position ranges, tighter than the model's (e.g. to keep a mobile base off
    the table); the model's limits still apply."""
    orientation_tasks: tuple[OrientationTask, ...] = ()
    """Secondary orientation tasks."""


@dataclass(frozen=True)
class LegFollower:
    """Legs that follow the body: their joint targets are the analytic leg IK of the body's
    desired pose (from the whole-body IK) with the feet fixed on the ground, tracked by the
    legs' PD (``systems/spot_legs.py``; the diagram adds it for an embodiment that has one).

    The body's six joints must be driven by the whole-body IK and their positions must be the
    body frame's world pose: x, y, z, then roll, pitch, yaw with R_WB = Rx(roll) Ry(pitch)
    Rz(yaw) (Spot's ``body_*`` joints, or a ``floating`` base's ``base_*`` joints). The feet
    stand below the hip-y joints at the body's home pose, at height ``ground_z``.
    """

    body_joints: tuple[str, ...]
    """The body's 6 joints in the order x, y, z, roll, pitch, yaw."""
    leg_joints: tuple[str, ...]
    """The 12 leg joints, legs in the order fl, fr, hl, hr (``leg_kinematics.LEGS``), each
    ``hip_x, hip_y, knee``; the IK does not drive them."""
    geometry: LegGeometry = LegGeometry()
    """The legs' kinematics and joint limits."""
    ground_z: float = 0.0
    """World height (m) of the foot points the legs stand on."""


@dataclass(frozen=True)
class Embodiment:
    """A robot that holds the LEGATO gripper."""

    name: str
    """Registry name, e.g. ``panda``."""
    model: str
    """Model URL (``package://legato_drake/...``) or file path (URDF/SDF)."""
    base_frame: str
    """Frame of the model that is welded to the world at ``base_pose``."""
    base_pose: RigidTransform
    """Pose of ``base_frame`` in the world."""
    mount_frame: str
    """Frame of the model to which the gripper base is welded."""
    X_mount_gripper: RigidTransform
    """Pose of the gripper's base frame in ``mount_frame``."""
    home: dict[str, float]
    """Joint positions of the home posture (joints not named stay at zero)."""
    pd_gains: dict[str, tuple[float, float]]
    """(kp, kd) of each actuated joint's PD, run by the plant at the physics rate."""
    ik: IkSettings = field(default_factory=IkSettings)
    description: str = ""
    base_type: str = "fixed"
    """``fixed``: ``base_frame`` is welded at ``base_pose``. ``planar`` (x, y, yaw) or
    ``floating`` (x, y, z, roll, pitch, yaw): actuated virtual joints named ``base_<axis>``
    carry ``base_frame``, with home at ``base_pose`` and ranges ``base_range`` around it.
    (A model may also carry its own virtual base joints and use ``fixed``.)"""
    base_range: dict[str, float] = field(default_factory=dict)
    """Half-range of each virtual base joint around its home (m or rad), by axis name."""
    base_gains: tuple[tuple[float, float], tuple[float, float]] = ((20000.0, 2000.0),
                                                                   (5000.0, 500.0))
    """(kp, kd) of the virtual base joints: translational, then rotational."""
    ik_joints: tuple[str, ...] = ()
    """The joints the whole-body IK drives; empty means every actuated joint that no
    follower drives."""
    leg_follower: LegFollower | None = None
    """Legs whose targets follow the body (e.g. Spot's), outside the IK; None: no follower."""
    foot_frames: tuple[str, ...] = ()
    """Frames that must stay put on the ground (their drift is reported)."""

    def follower_joints(self) -> tuple[str, ...]:
        """The joints whose targets come from a follower, not from the IK."""
        return self.leg_follower.leg_joints if self.leg_follower is not None else ()


BASE_AXES = {"planar": ("x", "y", "yaw"), "floating": ("x", "y", "z", "roll", "pitch", "yaw")}
"""Virtual base joints of each base type, in chain order from the world."""


def base_home(emb: Embodiment) -> dict[str, float]:
    """Home positions of the virtual base joints: the components of ``base_pose``."""
    xyz = emb.base_pose.translation()
    rpy = RollPitchYaw(emb.base_pose.rotation()).vector()
    values = dict(zip(("x", "y", "z", "roll", "pitch", "yaw"), [*xyz, *rpy], strict=True))
    return {f"base_{axis}": values[axis] for axis in BASE_AXES.get(emb.base_type, ())}


@dataclass
class RobotHandles:
    """What ``embodiments.add_embodiment`` put in the plant: the handles every system needs."""

    embodiment: Embodiment
    robot: ModelInstanceIndex
    gripper: ModelInstanceIndex
    tcp_frame: Frame
    controlled_joints: list[Joint]
    """The joints the IK drives, in actuator order."""
    actuated_joints: list[Joint]
    """Every actuated joint of the robot, in the order of its desired-state input port."""

    @property
    def home(self) -> dict[str, float]:
        """Home position of each joint by name (the embodiment's home and its virtual base
        joints'; joints not named home at zero)."""
        return {**self.embodiment.home, **base_home(self.embodiment)}

    @property
    def home_positions(self) -> np.ndarray:
        """Home posture of ``controlled_joints`` in port order."""
        home = self.home
        return np.array([home.get(j.name(), 0.0) for j in self.controlled_joints])
