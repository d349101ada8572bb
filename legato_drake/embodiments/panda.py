"""Franka Panda holding the LEGATO gripper on its flange (SPEC §4)."""

from __future__ import annotations

import numpy as np
from pydrake.math import RigidTransform, RotationMatrix

from legato_drake.robot_types import Embodiment, IkSettings

_JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))
_HOME = np.array([-0.125, 0.2, -0.125, -0.7, 0.75, 0.5, -0.666]) * np.pi
_GAINS = [(9000.0, 225.0)] * 2 + [(6000.0, 150.0)] * 2 + [(4000.0, 100.0)] * 3

# Gripper approach (+x) along the flange's +z, rolled about it so that the gripper is upright
# (camera side up, like the start pose) at the home posture.
_R_FLANGE_GRIPPER = RotationMatrix(np.array([[0.0, 0.0, -1.0],
                                             [0.0, 1.0, 0.0],
                                             [1.0, 0.0, 0.0]])) @ RotationMatrix.MakeXRotation(2.5)

PANDA = Embodiment(
    name="panda",
    model="package://legato_drake/panda.urdf",
    base_frame="panda_link0",
    base_pose=RigidTransform([-0.2, 0.0, 0.7]),
    mount_frame="panda_link8",
    X_mount_gripper=RigidTransform(_R_FLANGE_GRIPPER, [0.0, 0.0, 0.0]),
    home=dict(zip(_JOINTS, _HOME, strict=True)),
    pd_gains=dict(zip(_JOINTS, _GAINS, strict=True)),
    ik=IkSettings(tracking_gain=24.0, posture_gain=2.0, posture_joints=_JOINTS[:4],
                  max_joint_speed=2.5, max_joint_acceleration=100.0),
    description="Franka Emika Panda, 7-DoF arm on a fixed base",
)
