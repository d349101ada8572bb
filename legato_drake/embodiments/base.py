"""How an embodiment is added to a plant: ``add_embodiment``.

An embodiment (``robot_types.Embodiment``: data, not code paths) says which model to load,
where it stands, which of its frames holds the LEGATO gripper (the mount transform: the robot
holds the gripper rigidly, as the reference does), its home posture, its joint PD gains, its
IK settings and its followers. Everything the policy sees is the gripper; only the
embodiments, the IK, the followers and the PD know the robot. The types are re-exported here
from ``legato_drake.robot_types``, where the systems read them.
"""

from __future__ import annotations

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
from legato_drake.leg_kinematics import LEGS
from legato_drake.robot_types import (
    BASE_AXES,
    Embodiment,
    IkSettings,
    LegFollower,
    OrientationTask,
    RobotHandles,
    base_home,
)

__all__ = ["BASE_AXES", "Embodiment", "IkSettings", "LegFollower", "OrientationTask",
           "RobotHandles", "actuators_of", "add_embodiment", "base_home", "load_gripper"]


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
    followed = set(emb.follower_joints())
    ik_joints = set(emb.ik_joints) or names - followed
    if emb.leg_follower is not None:
        _check_leg_follower(emb, emb.leg_follower, names, ik_joints)
    driven_by_both = sorted(ik_joints & followed)
    if driven_by_both:
        raise ConfigError(f"embodiment {emb.name!r}: joint(s) {driven_by_both} are in "
                          "ik_joints and driven by the leg follower; a joint has one driver")
    undriven = sorted(names - ik_joints - followed)
    if undriven:
        raise ConfigError(f"embodiment {emb.name!r}: joint(s) {undriven} are driven by "
                          "neither the IK (ik_joints) nor a follower")
    controlled = [j for j in joints if j.name() in ik_joints]
    tcp = plant.GetFrameByName(conventions.GRIPPER_TCP_FRAME, gripper)
    return RobotHandles(emb, robot, gripper, tcp, controlled, joints)


_UNIT = {"x": [1.0, 0, 0], "y": [0, 1.0, 0], "z": [0, 0, 1.0],
         "roll": [1.0, 0, 0], "pitch": [0, 1.0, 0], "yaw": [0, 0, 1.0]}


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


def _check_leg_follower(emb: Embodiment, follower: LegFollower, names: set[str],
                        ik_joints: set[str]) -> None:
    """The follower's joints exist and have the roles it needs (ConfigError otherwise)."""
    where = f"embodiment {emb.name!r}: leg_follower"
    for field_name, joints, count in (("body_joints", follower.body_joints, 6),
                                      ("leg_joints", follower.leg_joints, 3 * len(LEGS))):
        if len(joints) != count or len(set(joints)) != count:
            raise ConfigError(f"{where}.{field_name}: expected {count} distinct joint names, "
                              f"got {list(joints)}")
        unknown = sorted(set(joints) - names)
        if unknown:
            raise ConfigError(f"{where}.{field_name} names unknown joint(s) {unknown}; "
                              f"actuated joints: {sorted(names)}")
    not_ik = sorted(set(follower.body_joints) - ik_joints)
    if not_ik:
        raise ConfigError(f"{where}.body_joints {not_ik} are not driven by the IK (the legs "
                          "follow the IK's body targets): add them to ik_joints")
    shared = sorted(set(follower.body_joints) & set(follower.leg_joints))
    if shared:
        raise ConfigError(f"{where}: joint(s) {shared} are both body_joints and leg_joints")


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
