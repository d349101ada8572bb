"""The Abstract embodiment: the LEGATO gripper alone on six virtual joints (x, y, z, roll,
pitch, yaw), as in the paper's simulated demonstrations.

Unlike the reference (weak PD, no gravity compensation, a 4 cm sag), ours is gravity-
compensated and starts at exactly the same start pose as every robot. The gripper's TCP sits
at the origin of the last virtual link, so the joint positions *are* the TCP pose (xyz + rpy).
The roll-pitch-yaw chain is singular at pitch = ±90°: the demonstrators keep away from it.
"""

from __future__ import annotations

from pydrake.math import RigidTransform, RollPitchYaw

from legato_drake import conventions
from legato_drake.dimensions import GRIPPER_TCP_X
from legato_drake.robot_types import Embodiment, IkSettings

_JOINTS = ("abstract_x", "abstract_y", "abstract_z",
           "abstract_roll", "abstract_pitch", "abstract_yaw")
_start = conventions.START_POSE
_rpy = RollPitchYaw(_start.rotation()).vector()

ABSTRACT = Embodiment(
    name="abstract",
    model="package://legato_drake/abstract.urdf",
    base_frame="abstract_root",
    base_pose=RigidTransform(),
    mount_frame="abstract_mount",
    # The TCP is 0.14 m in front of the gripper base: put it on the joints' origin.
    X_mount_gripper=RigidTransform([-GRIPPER_TCP_X, 0.0, 0.0]),
    home=dict(zip(_JOINTS, [*_start.translation(), *_rpy], strict=True)),
    pd_gains={**{j: (3000.0, 120.0) for j in _JOINTS[:3]},
              **{j: (60.0, 2.0) for j in _JOINTS[3:]}},
    ik=IkSettings(tracking_gain=30.0, posture_gain=0.0, max_joint_speed=2.0,
                  max_joint_acceleration=100.0),
    description="LEGATO gripper on six gravity-compensated virtual joints",
)
