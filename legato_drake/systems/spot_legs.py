"""Analytic leg IK of Spot: the feet stay on fixed world points while the body moves (SPEC §4).

Spot's body pose is six controlled virtual joints (``models/spot.urdf``): ``body_x, body_y,
body_z`` (prismatic) then ``body_roll, body_pitch, body_yaw`` (revolute about x, y, z, in that
chain order) from ``spot_world_anchor``, welded at the world origin. Their positions are
therefore the body frame's world position and orientation

    p_WB = (x, y, z),    R_WB = Rx(roll) Ry(pitch) Rz(yaw).

Each leg (``fl, fr, hl, hr``; front = +x, left = +y) is a 3-DoF chain in the body frame:
``hip_x`` (about x) at (+-0.29785, +-0.055, 0), ``hip_y`` (about y) at (0, +-0.110945, 0) from
the hip link, ``knee`` (about y) at (0.025, 0, -0.3205) from the upper leg, and the foot 0.33
along the lower leg's -z. Given the foot in the body frame, the hip abduction comes from the
lateral (y-z) geometry with the 0.110945 offset, and the thigh and knee angles from the law of
cosines in the leg's sagittal plane (knee bent backwards: negative knee angles).

Idealised, and said so in the docs: the body is held by its stiff virtual joints, not by the
legs; the legs only follow it so that the feet stay where they stand.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pydrake.systems.framework import BasicVector, Context, LeafSystem

LEGS = ("fl", "fr", "hl", "hr")
"""Leg order of every array here: front-left, front-right, hind-left, hind-right."""
LEG_SIGNS = {"fl": (1.0, 1.0), "fr": (1.0, -1.0), "hl": (-1.0, 1.0), "hr": (-1.0, -1.0)}
"""Leg name: (front +1 / hind -1, left +1 / right -1)."""
LEG_JOINTS = tuple(f"{leg}_{j}" for leg in LEGS for j in ("hip_x", "hip_y", "knee"))
"""The 12 leg joints in output order."""
BODY_JOINTS = ("body_x", "body_y", "body_z", "body_roll", "body_pitch", "body_yaw")
"""The body's virtual joints in input order."""
NOMINAL_BODY_POSE = np.array([-0.2, 0.0, 0.4, 0.0, 0.0, 0.0])
"""Home body pose [x, y, z, roll, pitch, yaw] (SPEC §4)."""


@dataclass(frozen=True)
class SpotLegGeometry:
    """Leg kinematics and joint limits (defaults: SPEC §4, as in ``models/spot.urdf``)."""

    hip_x_offset: tuple[float, float, float] = (0.29785, 0.055, 0.0)
    """Hip-x joint in the body frame for the front-left leg; the others mirror x and/or y."""
    hip_y_offset: float = 0.110945
    """Lateral offset (m) of the hip-y joint from the hip-x joint (+y left legs, -y right)."""
    knee_offset: tuple[float, float] = (0.025, -0.3205)
    """Knee joint (x, z) in the upper-leg frame."""
    lower_leg_length: float = 0.33
    """Foot distance (m) along the lower leg's -z from the knee."""
    hip_x_limits: tuple[float, float] = (-0.7854, 0.7854)
    hip_y_limits: tuple[float, float] = (-0.8988, 2.2951)
    knee_limits: tuple[float, float] = (-2.7929, -0.2471)

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
        """Lower limits of the 12 leg joints in output order."""
        return np.tile([self.hip_x_limits[0], self.hip_y_limits[0], self.knee_limits[0]], 4)

    @property
    def upper_limits(self) -> np.ndarray:
        """Upper limits of the 12 leg joints in output order."""
        return np.tile([self.hip_x_limits[1], self.hip_y_limits[1], self.knee_limits[1]], 4)


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
                  geometry: SpotLegGeometry = SpotLegGeometry()) -> np.ndarray:
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
           geometry: SpotLegGeometry = SpotLegGeometry()) -> np.ndarray:
    """The 12 leg joint angles (``LEG_JOINTS`` order) that keep the feet at ``foot_positions``
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
                            geometry: SpotLegGeometry = SpotLegGeometry(),
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
                        geometry: SpotLegGeometry = SpotLegGeometry()) -> np.ndarray:
    """Leg joint angles (``LEG_JOINTS`` order) with the body at ``body_pose`` and the feet at
    ``foot_positions`` (default: below the hips at the nominal body pose, on z = 0): the home
    posture of the legs."""
    if foot_positions is None:
        foot_positions = standing_foot_positions(NOMINAL_BODY_POSE, geometry)
    return leg_ik(body_pose, foot_positions, geometry)


class SpotLegIK(LeafSystem):
    """Turns the body's desired state into the legs' desired state, feet fixed on the ground.

    Stateless and direct-feedthrough: the leg positions are ``leg_ik`` of the desired body
    pose; the leg velocities are the central difference of ``leg_ik`` along the desired body
    velocity over one ``period`` (the leg motion that follows the body over one IK step):
    ``(leg_ik(q + v period/2) - leg_ik(q - v period/2)) / period``. Outputs are clamped to the
    leg joint limits and always finite (a non-finite input holds the nominal stance at rest).

    Input ports:
        body_desired_state (12): [x, y, z, roll, pitch, yaw] of the body joints, then their 6
        velocities (the body part of the whole-body IK's desired state).

    Output ports:
        leg_desired_state (24): the 12 leg joint positions in ``LEG_JOINTS`` order
        (fl_hip_x, fl_hip_y, fl_knee, fr_..., hl_..., hr_...), then their 12 velocities.
    """

    def __init__(self, foot_positions: np.ndarray | None = None,
                 geometry: SpotLegGeometry = SpotLegGeometry(), period: float = 0.01):
        super().__init__()
        if foot_positions is None:
            foot_positions = standing_foot_positions(NOMINAL_BODY_POSE, geometry)
        feet = np.array(foot_positions, dtype=float)
        if feet.shape != (4, 3) or not np.all(np.isfinite(feet)):
            raise ValueError(f"foot_positions must be a finite 4 x 3 array, got {feet!r}")
        if not period > 0.0:
            raise ValueError(f"period must be positive, got {period}")
        self._feet, self._geometry, self._period = feet, geometry, float(period)
        self._lower, self._upper = geometry.lower_limits, geometry.upper_limits
        self._input = self.DeclareVectorInputPort("body_desired_state", 12)
        self._output = self.DeclareVectorOutputPort("leg_desired_state", 24, self._calc,
                                                    {self.all_input_ports_ticket()})

    @property
    def foot_positions(self) -> np.ndarray:
        """The fixed feet (4 x 3, world, ``LEGS`` order)."""
        return self._feet.copy()

    def get_body_desired_state_input_port(self):
        return self._input

    def get_leg_desired_state_output_port(self):
        return self._output

    def leg_state(self, body_state: np.ndarray) -> np.ndarray:
        """The 24-vector output for a 12-vector body desired state (no context needed)."""
        x = np.asarray(body_state, dtype=float)
        if x.shape != (12,) or not np.all(np.isfinite(x)):
            return np.concatenate([leg_ik(NOMINAL_BODY_POSE, self._feet, self._geometry),
                                   np.zeros(12)])
        q, v = x[:6], x[6:]
        h = 0.5 * self._period
        positions = leg_ik(q, self._feet, self._geometry)
        velocities = (leg_ik(q + h * v, self._feet, self._geometry)
                      - leg_ik(q - h * v, self._feet, self._geometry)) / self._period
        return np.concatenate([np.clip(positions, self._lower, self._upper), velocities])

    def _calc(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self.leg_state(self._input.Eval(context)))
