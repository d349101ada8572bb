"""Fourier GR-1 humanoid, standing, holding the LEGATO gripper in its right hand (SPEC §4).

The legs are held (fixed to the pelvis, which is welded at (-0.1, 0, 0.88)): the idealisation
is that the humanoid's balance controller keeps the pelvis still. The IK moves the waist (3),
the right arm (7) and the head (3), with a head-orientation task (gain 20) that keeps the
head level and looking forward while the waist moves, and a posture bias on the waist.
"""

from __future__ import annotations

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw

from legato_drake.dimensions import GR1_PELVIS_HEIGHT
from legato_drake.robot_types import Embodiment, IkSettings, OrientationTask

_WAIST = ("waist_yaw", "waist_pitch", "waist_roll")
_ARM = ("r_shoulder_pitch", "r_shoulder_roll", "r_shoulder_yaw", "r_elbow_pitch",
        "r_wrist_yaw", "r_wrist_roll", "r_wrist_pitch")
_HEAD = ("head_yaw", "head_pitch", "head_roll")
# SPEC's home ([0, -0.16, 0.33, -0.16, -0.16, 0, 0] pi) put the downward-mounted gripper into
# the table; this one is the nearest posture (Drake InverseKinematics, waist kept upright) with
# the TCP at the start position, pitched 35 deg down.
_ARM_HOME = np.array([0.145, -0.866, 1.083, -1.439, -0.559, -0.241, 0.402])

GR1 = Embodiment(
    name="gr1",
    model="package://legato_drake/gr1.urdf",
    base_frame="pelvis",
    base_pose=RigidTransform([-0.1, 0.0, GR1_PELVIS_HEIGHT]),  # the soles on the floor
    mount_frame="r_hand_tool",
    # The gripper faces +x pitched 35 deg down at the home posture: the wrist's roll and
    # pitch (+-0.61 rad) then cover both the level start pose and the downward grasps.
    X_mount_gripper=RigidTransform(RollPitchYaw(np.radians([5.19, 49.11, -30.73])),
                                   [0.0, 0.0, 0.0]),
    home=dict(zip(_ARM, _ARM_HOME, strict=True)),
    pd_gains={j: (1000.0, 50.0) for j in _WAIST + _ARM + _HEAD},
    ik=IkSettings(tracking_gain=100.0, posture_gain=2.0, posture_joints=_WAIST,
                  max_joint_speed=25.0, max_joint_acceleration=100.0,
                  orientation_tasks=(OrientationTask("head", gain=20.0, weight=0.05),)),
    description="Fourier GR-1: waist (3) + right arm (7) + head (3), legs held",
)
