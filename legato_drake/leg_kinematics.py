"""Analytic inverse kinematics of four legs laid out as Spot's: the feet stay on fixed world
points while the body moves (SPEC §4). Pure numpy: the embodiment (Spot's home posture) and
the leg-follower system (``systems/spot_legs.py``) both use it.

The body's pose is six joints whose positions are the body frame's world position and
orientation (Spot: the virtual joints ``body_x, body_y, body_z`` (prismatic) then
``body_roll, body_pitch, body_yaw`` (revolute about x, y, z, in that chain order) from
``spot_world_anchor``, welded at the world origin)

    p_WB = (x, y, z),    R_WB = Rx(roll) Ry(pitch) Rz(yaw).

Each leg (``fl, fr, hl, hr``; front = +x, left = +y) is a 3-DoF chain in the body frame:
``hip_x`` (about x) at (+-0.29785, +-0.055, 0), ``hip_y`` (about y) at (0, +-0.110945, 0) from
the hip link, ``knee`` (about y) at (0.025, 0, -0.3205) from the upper leg, and the foot 0.33
along the lower leg's -z (Spot's numbers: ``dimensions.py``, ``LegGeometry``). Given the foot
in the body frame, the hip abduction comes from the lateral (y-z) geometry with the hip-y
offset, and the thigh and knee angles from the law of cosines in the leg's sagittal plane
(knee bent backwards: negative knee angles).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from legato_drake.dimensions import (
    SPOT_HIP_X,
    SPOT_HIP_X_LIMITS,
    SPOT_HIP_Y,
    SPOT_HIP_Y_LIMITS,
    SPOT_KNEE,
    SPOT_KNEE_LIMITS,
    SPOT_LEG_SIGNS,
    SPOT_LOWER_LEG,
    SPOT_NOMINAL_BODY_POSE,
)

LEG_SIGNS = SPOT_LEG_SIGNS
"""Leg name: (front +1 / hind -1, left +1 / right -1)."""
LEGS = tuple(LEG_SIGNS)
"""Leg order of every leg array: front-left, front-right, hind-left, hind-right. The 12 leg
joints go leg by leg, each ``hip_x, hip_y, knee`` ("leg-joint order")."""
NOMINAL_BODY_POSE = np.array(SPOT_NOMINAL_BODY_POSE)
"""Spot's home body pose [x, y, z, roll, pitch, yaw] (SPEC §4)."""


@dataclass(frozen=True)
class LegGeometry:
    """Kinematics and joint limits of four 3-DoF legs laid out as Spot's (defaults: Spot's,
    ``dimensions.py``, as in ``models/spot.urdf``): per leg ``hip_x`` (about x) on the body,
    ``hip_y`` (about y) offset sideways from it, ``knee`` (about y) on the upper leg, and the
    foot along the lower leg's -z. Legs ``fl, fr, hl, hr``: front = +x, left = +y."""

    hip_x_offset: tuple[float, float, float] = SPOT_HIP_X
    """Hip-x joint in the body frame for the front-left leg; the others mirror x and/or y."""
    hip_y_offset: float = SPOT_HIP_Y
    """Lateral offset (m) of the hip-y joint from the hip-x joint (+y left legs, -y right)."""
    knee_offset: tuple[float, float] = SPOT_KNEE
    """Knee joint (x, z) in the upper-leg frame."""
    lower_leg_length: float = SPOT_LOWER_LEG
    """Foot distance (m) along the lower leg's -z from the knee."""
    hip_x_limits: tuple[float, float] = SPOT_HIP_X_LIMITS
    hip_y_limits: tuple[float, float] = SPOT_HIP_Y_LIMITS
    knee_limits: tuple[float, float] = SPOT_KNEE_LIMITS

    def hip_x_position(self, leg: str) -> np.ndarray:
        """The hip-x joint of ``leg`` in the body frame."""
        front, side = LEG_SIGNS[leg]
        x, y, z = self.hip_x_offset
        return np.array([front * x, side * y, z])

    def hip_y_position(self, leg: str) -> np.ndarray:
        """The hip-y joint of ``leg`` in the body frame at zero hip abduction."""
        return self.hip_x_position(leg) + [0.0, LEG_SIGNS[leg][1] * self.hip_y_offset, 0.0]

    @property
    def lower_limits(self) -> np.ndarray:
        """Lower limits of the 12 leg joints in leg-joint order."""
        return np.tile([self.hip_x_limits[0], self.hip_y_limits[0], self.knee_limits[0]], 4)

    @property
    def upper_limits(self) -> np.ndarray:
        """Upper limits of the 12 leg joints in leg-joint order."""
        return np.tile([self.hip_x_limits[1], self.hip_y_limits[1], self.knee_limits[1]], 4)


SPOT_LEG_GEOMETRY = LegGeometry()
"""Spot's legs (every default of ``LegGeometry``)."""


def body_rotation(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """R_WB of Spot's virtual joint chain (roll about x, then pitch about y, then yaw about z,
    each in the frame the previous joint moved): Rx(roll) Ry(pitch) Rz(yaw)."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    Ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    Rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    return Rx @ Ry @ Rz


_FAR = 10.0
"""Foot offsets (m) beyond this are scaled down to it (the leg stretches toward them)."""


def _wrap(angle: float) -> float:
    """``angle`` wrapped to [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def single_leg_ik(leg: str, p_BF: np.ndarray,
                  geometry: LegGeometry = LegGeometry()) -> np.ndarray:
    """[hip_x, hip_y, knee] that put ``leg``'s foot at ``p_BF`` (body frame).

    Exact when the point is reachable within the joint limits. Otherwise every angle is
    clamped to its limits and the leg stretches (or folds) toward the point; the result is
    always finite.
    """
    g = geometry
    side = LEG_SIGNS[leg][1]
    lateral = side * g.hip_y_offset
    d = np.asarray(p_BF, dtype=float) - g.hip_x_position(leg)
    if not np.all(np.isfinite(d)):
        d = g.hip_y_position(leg) - g.hip_x_position(leg) + [0.0, 0.0, -0.4]  # stand
    reach = float(np.max(np.abs(d)))
    if reach > _FAR:  # far out of reach: same direction, no overflow in the squares below
        d = d * (_FAR / reach)

    # Hip abduction: in the hip-x frame the foot is at (X, lateral, Z), Z < 0; rotating it by
    # hip_x about x gives d. Its y-z part keeps its length: lateral^2 + Z^2 = d_y^2 + d_z^2.
    Z = -math.sqrt(max(d[1] ** 2 + d[2] ** 2 - lateral**2, 0.0))
    hip_x = _wrap(math.atan2(d[2], d[1]) - math.atan2(Z, lateral))
    hip_x = min(max(hip_x, g.hip_x_limits[0]), g.hip_x_limits[1])

    # The foot in the hip-x link frame (exactly (X, lateral, Z) unless hip_x was clamped).
    c1, s1 = math.cos(hip_x), math.sin(hip_x)
    X, Z = d[0], -s1 * d[1] + c1 * d[2]

    # Sagittal plane (x, z) of the upper leg, from the hip-y joint: foot = a + Ry(knee) b with
    # a = knee offset, b = (0, -L). |foot|^2 = |a|^2 + L^2 + 2 |a| L cos(knee + phi).
    ax, az = g.knee_offset
    la, lb = math.hypot(ax, az), g.lower_leg_length
    phi = math.atan2(ax, -az)
    cos_knee = (X * X + Z * Z - la * la - lb * lb) / (2.0 * la * lb)
    knee = -math.acos(min(max(cos_knee, -1.0), 1.0)) - phi
    knee = min(max(knee, g.knee_limits[0]), g.knee_limits[1])

    # Thigh: rotate the foot (at this knee angle) onto the target direction about y.
    px, pz = ax - lb * math.sin(knee), az - lb * math.cos(knee)
    hip_y = _wrap(math.atan2(X, Z) - math.atan2(px, pz))
    hip_y = min(max(hip_y, g.hip_y_limits[0]), g.hip_y_limits[1])
    return np.array([hip_x, hip_y, knee])


def leg_ik(body_pose: np.ndarray, foot_positions: np.ndarray,
           geometry: LegGeometry = LegGeometry()) -> np.ndarray:
    """The 12 leg joint angles (leg-joint order) that keep the feet at ``foot_positions``
    (4 x 3, world, ``LEGS`` order) with the body at ``body_pose`` [x, y, z, roll, pitch, yaw].

    A non-finite body pose is replaced by ``NOMINAL_BODY_POSE`` (the result stays finite).
    """
    pose = np.asarray(body_pose, dtype=float)
    if pose.shape != (6,) or not np.all(np.isfinite(pose)):
        pose = NOMINAL_BODY_POSE
    R_WB = body_rotation(*pose[3:])
    feet_B = (np.asarray(foot_positions, dtype=float) - pose[:3]) @ R_WB  # rows: R_WB^T p
    return np.concatenate([single_leg_ik(leg, feet_B[i], geometry)
                           for i, leg in enumerate(LEGS)])


def standing_foot_positions(body_pose: np.ndarray = NOMINAL_BODY_POSE,
                            geometry: LegGeometry = LegGeometry(),
                            ground_z: float = 0.0) -> np.ndarray:
    """Feet (4 x 3, world) directly below each leg's hip-y joint, on z = ``ground_z``, for the
    body at ``body_pose`` (the foot points are the foot spheres' centres)."""
    pose = np.asarray(body_pose, dtype=float)
    R_WB = body_rotation(*pose[3:])
    feet = np.array([pose[:3] + R_WB @ geometry.hip_y_position(leg) for leg in LEGS])
    feet[:, 2] = ground_z
    return feet


def standing_leg_angles(body_pose: np.ndarray = NOMINAL_BODY_POSE,
                        foot_positions: np.ndarray | None = None,
                        geometry: LegGeometry = LegGeometry()) -> np.ndarray:
    """Leg joint angles (leg-joint order) with the body at ``body_pose`` and the feet at
    ``foot_positions`` (default: below the hips at the nominal body pose, on z = 0): the home
    posture of the legs."""
    if foot_positions is None:
        foot_positions = standing_foot_positions(NOMINAL_BODY_POSE, geometry)
    return leg_ik(body_pose, foot_positions, geometry)
