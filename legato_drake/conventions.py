"""Rates, event phases and frames that every embodiment and task shares (SPEC §2).

Within one policy period the 10 Hz events fire in a fixed order, a few milliseconds apart, so
that each stage reads what the previous stage produced in the same period:

====================  ==========  ===========================================================
event                 offset      reads
====================  ==========  ===========================================================
stereo camera         0 ms        plant geometry at t_k
controller (policy)   1 ms        the images rendered at t_k and the privileged plant state
target integrator     2 ms        the action computed at t_k + 1 ms
====================  ==========  ===========================================================
"""

from __future__ import annotations

from pydrake.math import RigidTransform

from legato_drake import dimensions

PHYSICS_DT = 0.002
"""Plant time step (s); the joint PD runs inside the plant at this rate (500 Hz)."""

IK_PERIOD = 0.01
"""Whole-body IK period (s), 100 Hz."""

POLICY_PERIOD = 0.1
"""Camera, policy and demonstrator period (s), 10 Hz."""

CAMERA_OFFSET = 0.0
CONTROLLER_OFFSET = 0.001
TARGET_OFFSET = 0.002

HOMING_DURATION = 3.0
"""Length (s) of the cosine blend from the home posture to the start pose. Objects settle
during it; the controller takes over at the end of it (episode time zero)."""

EXPERT_NOISE_FULL_SPEED = 0.15
"""Plan speed (m/s) at and above which a noisy scripted expert's offset has its full size
(``ExpertNoiseConfig.full_speed``'s default)."""

START_POSE = RigidTransform([0.1, -0.3, 0.8])
"""Pose of the gripper's TCP frame in the world when the controller takes over."""

GRIPPER_MODEL = "package://legato_drake/legato_gripper.sdf"
GRIPPER_TCP_FRAME = "gripper_tcp"
GRIPPER_BASE_BODY = "gripper_base"
GRIPPER_FINGER_JOINTS = ("left_finger_joint", "right_finger_joint")
GRIPPER_OPEN = dimensions.GRIPPER_OPEN
"""Finger joint position (m from the centre plane) when fully open: pad gap 0.104 m (the
model's finger limit, ``dimensions.GRIPPER_OPEN``)."""
