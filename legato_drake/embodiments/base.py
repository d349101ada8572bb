"""What an embodiment is (data, not code paths) and how one is added to a plant.

An embodiment says which model to load, where it stands, which of its frames holds the LEGATO
gripper (the mount transform: the robot holds the gripper rigidly, as the reference does), its
home posture, its joint PD gains and its IK settings. Everything the policy sees is the gripper;
only this module, the IK and the PD know the robot.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import (
    FixedOffsetFrame,
    Frame,
    Joint,
    JointActuator,
    JointActuatorIndex,
    ModelInstanceIndex,
    PdControllerGains,
    PrismaticJoint,
    RevoluteJoint,
    SpatialInertia,
)

from legato_drake import conventions
from legato_drake.errors import ConfigError


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
    max_joint_speed: float = 2.5
    """Joint speed bound (rad/s or m/s), applied to every controlled joint."""
    max_joint_acceleration: float = 100.0
    """Joint acceleration bound (rad/s^2 or m/s^2) between two IK steps."""
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
    """The joints the whole-body IK drives; empty means every actuated joint. The others get
    their targets from ``add_followers`` (e.g. Spot's legs from the body pose)."""
    add_followers: Callable | None = None
    """``add_followers(builder, plant, robot, ik_desired_state_port) -> (joints, port)``: adds
    the systems that set the joints outside ``ik_joints`` and returns them with the output
    port of their desired state ``[q; v]``."""
    foot_frames: tuple[str, ...] = ()
    """Frames that must stay put on the ground (their drift is reported)."""


@dataclass
class RobotHandles:
    """What ``add_embodiment`` put in the plant: the handles every system needs."""

    embodiment: Embodiment
    robot: ModelInstanceIndex
    gripper: ModelInstanceIndex
    tcp_frame: Frame
    controlled_joints: list[Joint]
    """The joints the IK drives, in actuator order."""
    actuated_joints: list[Joint]
    """Every actuated joint of the robot, in the order of its desired-state input port."""

    @property
    def home_positions(self) -> np.ndarray:
        """Home posture of ``controlled_joints`` in port order."""
        home = {**self.embodiment.home, **base_home(self.embodiment)}
        return np.array([home.get(j.name(), 0.0) for j in self.controlled_joints])


def load_gripper(plant: MultibodyPlant, parser: Parser) -> ModelInstanceIndex:
    """Adds the LEGATO gripper with its finger PD gains; returns its model instance."""
    (gripper,) = parser.AddModels(url=conventions.GRIPPER_MODEL)
    for name in conventions.GRIPPER_FINGER_JOINTS:
        joint = plant.GetJointByName(name, gripper)
        actuator = _actuator_of(plant, joint)
        actuator.set_controller_gains(PdControllerGains(p=2000.0, d=10.0))
    return gripper


def add_embodiment(plant: MultibodyPlant, parser: Parser, emb: Embodiment) -> RobotHandles:
    """Adds the robot and the gripper it holds to an unfinalized plant, with PD gains."""
    models = parser.AddModels(url=emb.model) if "://" in emb.model else \
        parser.AddModels(file_name=emb.model)
    if len(models) != 1:
        raise ConfigError(f"embodiment {emb.name!r}: {emb.model} holds {len(models)} models, "
                          "expected exactly one")
    (robot,) = models
    base = _frame(plant, emb.base_frame, robot, emb, "base_frame")
    if emb.base_type == "fixed":
        plant.WeldFrames(plant.world_frame(), base, emb.base_pose)
    else:
        plant.WeldFrames(_add_virtual_base(plant, robot, emb), base, RigidTransform())
    gripper = load_gripper(plant, parser)
    mount = _frame(plant, emb.mount_frame, robot, emb, "mount_frame")
    plant.WeldFrames(mount, plant.GetFrameByName(conventions.GRIPPER_BASE_BODY, gripper),
                     emb.X_mount_gripper)

    joints = [actuator.joint() for actuator in actuators_of(plant, robot)]
    if not joints:
        raise ConfigError(f"embodiment {emb.name!r}: {emb.model} has no actuated joints "
                          "(add <transmission> elements or SDF actuators)")
    names = {j.name() for j in joints}
    virtual = set(base_home(emb))
    for kind, table in (("home", emb.home), ("pd_gains", emb.pd_gains)):
        unknown = set(table) - names
        if unknown:
            raise ConfigError(f"embodiment {emb.name!r}: {kind} names unknown joint(s) "
                              f"{sorted(unknown)}; actuated joints: {sorted(names)}")
    missing = names - set(emb.pd_gains) - virtual
    if missing:
        raise ConfigError(f"embodiment {emb.name!r}: pd_gains lacks joint(s) {sorted(missing)}")
    for joint in joints:
        if joint.name() in virtual:
            continue
        kp, kd = emb.pd_gains[joint.name()]
        _actuator_of(plant, joint).set_controller_gains(PdControllerGains(p=kp, d=kd))
        if joint.name() in emb.home:
            joint.set_default_positions([emb.home[joint.name()]])
    ik = emb.ik
    for field_name, table in (("posture_joints", ik.posture_joints),
                              ("joint_speed_limits", ik.joint_speed_limits),
                              ("joint_acceleration_limits", ik.joint_acceleration_limits),
                              ("joint_position_limits", ik.joint_position_limits),
                              ("joint_velocity_weights", ik.joint_velocity_weights)):
        unknown = set(table) - names
        if unknown:
            raise ConfigError(f"embodiment {emb.name!r}: ik.{field_name} names unknown "
                              f"joint(s) {sorted(unknown)}; actuated joints: {sorted(names)}")
    bad = {j: w for j, w in ik.joint_velocity_weights.items()
           if not (isinstance(w, int | float) and w > 0.0)}
    if bad:
        raise ConfigError(f"embodiment {emb.name!r}: ik.joint_velocity_weights must be "
                          f"positive, got {bad}")
    unknown = set(emb.ik_joints) - names
    if unknown:
        raise ConfigError(f"embodiment {emb.name!r}: ik_joints names unknown joint(s) "
                          f"{sorted(unknown)}; actuated joints: {sorted(names)}")
    for frame in emb.foot_frames:
        _frame(plant, frame, robot, emb, "foot_frames")
    controlled = [j for j in joints if not emb.ik_joints or j.name() in emb.ik_joints]
    tcp = plant.GetFrameByName(conventions.GRIPPER_TCP_FRAME, gripper)
    return RobotHandles(emb, robot, gripper, tcp, controlled, joints)


BASE_AXES = {"planar": ("x", "y", "yaw"), "floating": ("x", "y", "z", "roll", "pitch", "yaw")}
"""Virtual base joints of each base type, in chain order from the world."""
_UNIT = {"x": [1.0, 0, 0], "y": [0, 1.0, 0], "z": [0, 0, 1.0],
         "roll": [1.0, 0, 0], "pitch": [0, 1.0, 0], "yaw": [0, 0, 1.0]}


def base_home(emb: Embodiment) -> dict[str, float]:
    """Home positions of the virtual base joints: the components of ``base_pose``."""
    xyz = emb.base_pose.translation()
    rpy = RollPitchYaw(emb.base_pose.rotation()).vector()
    values = dict(zip(("x", "y", "z", "roll", "pitch", "yaw"), [*xyz, *rpy], strict=True))
    return {f"base_{axis}": values[axis] for axis in BASE_AXES.get(emb.base_type, ())}


def _add_virtual_base(plant: MultibodyPlant, robot: ModelInstanceIndex,
                      emb: Embodiment) -> Frame:
    """Adds the actuated x/y/(z)/(roll/pitch)/yaw chain of a planar or floating base and
    returns the frame that carries the robot's base frame."""
    if emb.base_type not in BASE_AXES:
        raise ConfigError(f"embodiment {emb.name!r}: base_type {emb.base_type!r}; valid "
                          f"values: fixed, {', '.join(BASE_AXES)}")
    axes = BASE_AXES[emb.base_type]
    parent = plant.world_frame()
    if emb.base_type == "planar":  # height, roll and pitch of base_pose stay fixed
        rpy = RollPitchYaw(emb.base_pose.rotation())
        parent = plant.AddFrame(FixedOffsetFrame(
            "base_plane", parent, RigidTransform(RollPitchYaw(rpy.roll_angle(),
                                                              rpy.pitch_angle(), 0.0),
                                                 [0.0, 0.0, emb.base_pose.translation()[2]]),
            robot))
    home = base_home(emb)
    for axis in axes:
        name = f"base_{axis}"
        body = plant.AddRigidBody(f"{name}_link", robot,
                                  SpatialInertia.SolidSphereWithMass(0.01, 0.01))
        half = emb.base_range.get(axis, np.pi if axis == "yaw" else 0.1)
        low, high = home[name] - half, home[name] + half
        if axis in ("x", "y", "z"):
            joint = PrismaticJoint(name, parent, body.body_frame(), _UNIT[axis], low, high)
            gains, effort = emb.base_gains[0], 1e5
        else:
            joint = RevoluteJoint(name, parent, body.body_frame(), _UNIT[axis], low, high)
            gains, effort = emb.base_gains[1], 1e5
        joint = plant.AddJoint(joint)
        actuator = plant.AddJointActuator(f"{name}_motor", joint, effort)
        actuator.set_controller_gains(PdControllerGains(p=gains[0], d=gains[1]))
        joint.set_default_positions([home[name]])
        parent = body.body_frame()
    return parent


def actuators_of(plant: MultibodyPlant, instance: ModelInstanceIndex) -> list[JointActuator]:
    """The joint actuators of a model instance in index order (also before Finalize, when
    ``plant.GetJointActuatorIndices`` is still empty)."""
    all_actuators = (plant.get_joint_actuator(JointActuatorIndex(i))
                     for i in range(plant.num_actuators()))
    return [a for a in all_actuators if a.model_instance() == instance]


def _actuator_of(plant: MultibodyPlant, joint: Joint) -> JointActuator:
    for actuator in actuators_of(plant, joint.model_instance()):
        if actuator.joint().index() == joint.index():
            return actuator
    raise ConfigError(f"joint {joint.name()!r} has no actuator")


def _frame(plant: MultibodyPlant, name: str, robot: ModelInstanceIndex, emb: Embodiment,
           field_name: str) -> Frame:
    if not plant.HasFrameNamed(name, robot):
        frames = sorted(plant.get_frame(i).name() for i in plant.GetFrameIndices(robot))
        raise ConfigError(f"embodiment {emb.name!r}: {field_name} {name!r} is not a frame of "
                          f"{emb.model}; frames: {', '.join(frames)}")
    return plant.GetFrameByName(name, robot)
