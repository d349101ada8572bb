"""Writes the primitive-geometry model files of this folder.

Run: ``python models/generate_models.py`` (``--out DIR`` writes them elsewhere, e.g. to diff).

The files it writes (``legato_gripper.sdf``, ``abstract.urdf``, ``panda.urdf``, ``spot.urdf``,
``google_robot.urdf``, ``gr1.urdf``, ``table.sdf``, ``stove.sdf``, ``pot.sdf``, ``lid.sdf``,
``shelf.sdf``, ``cup.sdf``, ``ladle.sdf``, ``case.sdf``) are committed; this script only
documents how their numbers were made and regenerates them.
Masses are spread over a body's shapes in proportion to their volume (unless a shape names its
own mass), and every inertia is the exact composite of the solid primitives (computed with
Drake's ``SpatialInertia`` helpers), so it is positive definite and physically valid by
construction.

The dimensions that the code also needs (the gripper's opening, Spot's leg geometry, the pot's
height, the handles' widths, the case's interior ...) come from ``legato_drake/dimensions.py``,
which the tasks, systems and embodiments read too: change them there and rerun this script.

Shapes are tuples ``(kind, dims, xyz, rpy, role, colour, mass)``:
kind is box (dims = sizes), cyl / cap (dims = radius, length along the shape's z), sph (radius);
role is "both", "visual", "collision" or "none" (mass only); mass None means "by volume".
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from pydrake.math import RollPitchYaw, RotationMatrix
from pydrake.multibody.tree import SpatialInertia

from legato_drake.dimensions import (
    CASE_BASE,
    CASE_INTERIOR,
    CASE_WALL,
    CASE_WALL_H,
    CUP_BASE,
    CUP_H,
    CUP_HANDLE,
    CUP_HANDLE_R,
    CUP_HANDLE_Z,
    CUP_R_IN,
    CUP_R_OUT,
    GR1_PELVIS_HEIGHT,
    GRIPPER_OPEN,
    GRIPPER_TCP_X,
    LADLE_HANDLE,
    LADLE_SCOOP,
    LADLE_STICK,
    LID_HANDLE_BAR,
    LID_HANDLE_Z,
    LID_RADIUS,
    LID_THICKNESS,
    POT_HEIGHT,
    SHELF_BACK,
    SHELF_BOARD,
    SHELF_SIDE,
    SHELF_SIZE,
    SPOT_BODY_HALF_RANGE,
    SPOT_HIP_X,
    SPOT_HIP_X_LIMITS,
    SPOT_HIP_Y,
    SPOT_HIP_Y_LIMITS,
    SPOT_KNEE,
    SPOT_KNEE_LIMITS,
    SPOT_LEG_SIGNS,
    SPOT_LOWER_LEG,
    SPOT_NOMINAL_BODY_POSE,
    STOVE_SIZE,
)

HERE = Path(__file__).resolve().parent
PI = math.pi


@dataclass
class Shape:
    kind: str
    dims: tuple
    xyz: tuple = (0.0, 0.0, 0.0)
    rpy: tuple = (0.0, 0.0, 0.0)
    role: str = "both"
    colour: str | None = None
    mass: float | None = None
    inertial: bool = True  # False: the shape has no mass (pads, thin decorations)
    # Geometry name (default: <body>_visual_<i> / <body>_collision_<i>).
    name: str | None = None

    def volume(self) -> float:
        if self.kind == "box":
            return float(np.prod(self.dims))
        if self.kind == "cyl":
            r, length = self.dims
            return PI * r * r * length
        if self.kind == "cap":
            r, length = self.dims
            return PI * r * r * length + 4.0 / 3.0 * PI * r**3
        if self.kind == "sph":
            return 4.0 / 3.0 * PI * self.dims[0] ** 3
        raise ValueError(self.kind)

    def spatial_inertia(self, mass: float) -> SpatialInertia:
        z = np.array([0.0, 0.0, 1.0])
        if self.kind == "box":
            m = SpatialInertia.SolidBoxWithMass(mass, *self.dims)
        elif self.kind == "cyl":
            m = SpatialInertia.SolidCylinderWithMass(mass, self.dims[0], self.dims[1], z)
        elif self.kind == "cap":
            m = SpatialInertia.SolidCapsuleWithMass(mass, self.dims[0], self.dims[1], z)
        else:
            m = SpatialInertia.SolidSphereWithMass(mass, self.dims[0])
        R_BS = RotationMatrix(RollPitchYaw(*self.rpy))
        # About the shape centre S, expressed in B, then shifted to the body origin Bo.
        return m.ReExpress(R_BS).Shift(-np.asarray(self.xyz, dtype=float))


@dataclass
class Body:
    name: str
    mass: float
    shapes: list[Shape] = field(default_factory=list)
    mu: float | None = None
    extra_collision_mu: dict = field(default_factory=dict)  # index of shape -> mu

    def inertia(self):
        """Returns (com, 3x3 rotational inertia about the com in body axes)."""
        carriers = [s for s in self.shapes if s.inertial]
        fixed = sum(s.mass for s in carriers if s.mass is not None)
        free_vol = sum(s.volume() for s in carriers if s.mass is None)
        total = None
        for s in carriers:
            m = s.mass if s.mass is not None else (self.mass - fixed) * s.volume() / free_vol
            si = s.spatial_inertia(m)
            if total is None:
                total = si
            else:
                total += si
        assert abs(total.get_mass() - self.mass) < 1e-9, self.name
        com = total.get_com()
        about_com = total.Shift(com)
        inertia = about_com.CalcRotationalInertia().CopyToFullMatrix3()
        assert np.all(np.linalg.eigvalsh(inertia) > 0), self.name
        return com, inertia


def capsule_between(p0, p1, r, **kw) -> Shape:
    """A capsule (or cylinder with kind='cyl') whose segment runs from p0 to p1."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    d = p1 - p0
    length = float(np.linalg.norm(d))
    u = d / length
    # Rz(yaw) Ry(pitch) takes the shape's z axis to u.
    pitch = math.acos(max(-1.0, min(1.0, float(u[2]))))
    yaw = math.atan2(float(u[1]), float(u[0])) if math.hypot(u[0], u[1]) > 1e-12 else 0.0
    rpy = (0.0, pitch, yaw)
    kind = kw.pop("kind", "cap")
    return Shape(kind, (r, length), tuple(float(c) for c in (p0 + p1) / 2), rpy, **kw)


def f(x: float) -> str:
    """Formats a number compactly, round-tripping to within 1e-15 (relative)."""
    if abs(x) < 1e-13:
        return "0"
    s = f"{x:.12g}"
    if abs(float(s) - x) > 1e-15 * max(1.0, abs(x)):
        s = repr(float(x))  # keep angles such as pi/2 exact to the last bit
    return s


def fv(v) -> str:
    return " ".join(f(float(x)) for x in v)


def fc(x: float) -> str:
    """Formats a computed physical quantity (centre of mass, inertia) to 10 significant digits
    after rounding to 1e-12: their last bits differ between machines' floating-point
    libraries, and the committed files must not."""
    x = round(float(x), 12)
    return "0" if x == 0 else f"{x:.10g}"


def fcv(v) -> str:
    return " ".join(fc(x) for x in v)


# --------------------------------------------------------------------------------- colours

COLOURS = {
    # rgba; luma (0.299 R + 0.587 G + 0.114 B) noted so the grayscale camera can tell them apart
    "wood": (0.80, 0.66, 0.45, 1.0),  # 0.68
    "wood_dark": (0.45, 0.33, 0.20, 1.0),  # 0.35
    "stove": (0.29, 0.29, 0.31, 1.0),  # 0.29
    "burner": (0.50, 0.06, 0.04, 1.0),  # 0.19
    "pot": (0.52, 0.53, 0.55, 1.0),  # 0.53
    "pot_handle": (0.22, 0.22, 0.22, 1.0),  # 0.22
    "lid": (0.93, 0.93, 0.88, 1.0),  # 0.93
    "lid_handle": (0.08, 0.08, 0.08, 1.0),  # 0.08
    "gripper": (0.12, 0.12, 0.13, 1.0),  # 0.12
    "finger": (0.24, 0.24, 0.26, 1.0),  # 0.24
    "pad": (0.88, 0.86, 0.78, 1.0),  # 0.86
    "camera": (0.04, 0.04, 0.05, 1.0),  # 0.04
    "panda_white": (0.95, 0.95, 0.95, 1.0),
    "panda_grey": (0.72, 0.73, 0.75, 1.0),
    "panda_dark": (0.20, 0.20, 0.22, 1.0),
    "marker": (0.90, 0.45, 0.10, 1.0),
    # Spot, Google Robot, GR-1 (no luma constraint: the robots are not task objects)
    "spot_yellow": (0.96, 0.78, 0.08, 1.0),
    "spot_dark": (0.16, 0.16, 0.17, 1.0),
    "google_white": (0.93, 0.93, 0.91, 1.0),
    "google_grey": (0.62, 0.63, 0.65, 1.0),
    "google_dark": (0.15, 0.15, 0.16, 1.0),
    "gr1_silver": (0.78, 0.79, 0.81, 1.0),
    "gr1_dark": (0.20, 0.20, 0.22, 1.0),
    # cup and ladle scenes
    "shelf": (0.55, 0.62, 0.70, 1.0),  # 0.61
    "cup": (0.20, 0.45, 0.85, 1.0),  # 0.42
    "ladle": (0.90, 0.85, 0.30, 1.0),  # 0.80
    "ladle_handle": (0.15, 0.10, 0.08, 1.0),  # 0.11
    "case": (0.35, 0.55, 0.35, 1.0),  # 0.47
}


# --------------------------------------------------------------------------------- SDF output


def sdf_geometry(s: Shape, ind: str) -> str:
    if s.kind == "box":
        g = f"<box><size>{fv(s.dims)}</size></box>"
    elif s.kind == "cyl":
        g = f"<cylinder><radius>{f(s.dims[0])}</radius><length>{f(s.dims[1])}</length></cylinder>"
    elif s.kind == "cap":
        g = f"<capsule><radius>{f(s.dims[0])}</radius><length>{f(s.dims[1])}</length></capsule>"
    else:
        g = f"<sphere><radius>{f(s.dims[0])}</radius></sphere>"
    return f"{ind}<geometry>{g}</geometry>\n"


def sdf_body(b: Body, pose: str | None = None) -> str:
    com, inertia = b.inertia()
    out = [f'    <link name="{b.name}">\n']
    if pose:
        out.append(f"      <pose{pose}</pose>\n")
    out.append(
        "      <inertial>\n"
        f"        <pose>{fcv(com)} 0 0 0</pose>\n"
        f"        <mass>{f(b.mass)}</mass>\n"
        "        <inertia>\n"
        f"          <ixx>{fc(inertia[0, 0])}</ixx><ixy>{fc(inertia[0, 1])}</ixy>"
        f"<ixz>{fc(inertia[0, 2])}</ixz>\n"
        f"          <iyy>{fc(inertia[1, 1])}</iyy><iyz>{fc(inertia[1, 2])}</iyz>"
        f"<izz>{fc(inertia[2, 2])}</izz>\n"
        "        </inertia>\n"
        "      </inertial>\n"
    )
    for i, s in enumerate(b.shapes):
        if s.role in ("both", "visual"):
            rgba = fv(COLOURS[s.colour])
            out.append(
                f'      <visual name="{s.name or f"{b.name}_visual_{i}"}">\n'
                f"        <pose>{fv(s.xyz)} {fv(s.rpy)}</pose>\n"
                + sdf_geometry(s, "        ")
                + f"        <material><diffuse>{rgba}</diffuse><ambient>{rgba}</ambient>"
                "</material>\n"
                "      </visual>\n"
            )
        if s.role in ("both", "collision"):
            mu = b.extra_collision_mu.get(i, b.mu)
            out.append(
                f'      <collision name="{s.name or f"{b.name}_collision_{i}"}">\n'
                f"        <pose>{fv(s.xyz)} {fv(s.rpy)}</pose>\n"
                + sdf_geometry(s, "        ")
                + "        <drake:proximity_properties>\n"
                f"          <drake:mu_dynamic>{f(mu)}</drake:mu_dynamic>\n"
                f"          <drake:mu_static>{f(mu)}</drake:mu_static>\n"
                "        </drake:proximity_properties>\n"
                "      </collision>\n"
            )
    out.append("    </link>\n")
    return "".join(out)


def sdf_file(model: str, comment: str, body_xml: str) -> str:
    return (
        '<?xml version="1.0"?>\n'
        f"<!-- {comment}\n"
        "     Generated by models/generate_models.py; primitive geometry only. -->\n"
        '<sdf version="1.9" xmlns:drake="http://drake.mit.edu">\n'
        f'  <model name="{model}">\n'
        f"{body_xml}"
        "  </model>\n"
        "</sdf>\n"
    )


# --------------------------------------------------------------------------------- URDF output


def urdf_geometry(s: Shape) -> str:
    if s.kind == "box":
        return f'<box size="{fv(s.dims)}"/>'
    if s.kind == "cyl":
        return f'<cylinder radius="{f(s.dims[0])}" length="{f(s.dims[1])}"/>'
    if s.kind == "cap":
        return f'<capsule radius="{f(s.dims[0])}" length="{f(s.dims[1])}"/>'
    return f'<sphere radius="{f(s.dims[0])}"/>'


def urdf_link(b: Body, inertia_override=None) -> str:
    if inertia_override is None:
        com, inertia = b.inertia()
    else:
        com, inertia = inertia_override
    out = [
        (
            f'  <link name="{b.name}">\n'
            "    <inertial>\n"
            f'      <origin xyz="{fcv(com)}" rpy="0 0 0"/>\n'
            f'      <mass value="{f(b.mass)}"/>\n'
            f'      <inertia ixx="{fc(inertia[0, 0])}" ixy="{fc(inertia[0, 1])}" '
            f'ixz="{fc(inertia[0, 2])}" iyy="{fc(inertia[1, 1])}" iyz="{fc(inertia[1, 2])}" '
            f'izz="{fc(inertia[2, 2])}"/>\n'
            "    </inertial>\n"
        )
    ]
    for s in b.shapes:
        if s.role in ("both", "visual"):
            out.append(
                "    <visual>\n"
                f'      <origin xyz="{fv(s.xyz)}" rpy="{fv(s.rpy)}"/>\n'
                f"      <geometry>{urdf_geometry(s)}</geometry>\n"
                f'      <material name="{s.colour}"/>\n'
                "    </visual>\n"
            )
        if s.role in ("both", "collision"):
            out.append(
                "    <collision>\n"
                f'      <origin xyz="{fv(s.xyz)}" rpy="{fv(s.rpy)}"/>\n'
                f"      <geometry>{urdf_geometry(s)}</geometry>\n"
                "      <drake:proximity_properties>\n"
                f'        <drake:mu_dynamic value="{f(b.mu)}"/>\n'
                f'        <drake:mu_static value="{f(b.mu)}"/>\n'
                "      </drake:proximity_properties>\n"
                "    </collision>\n"
            )
    out.append("  </link>\n")
    return "".join(out)


def urdf_materials(names) -> str:
    return "".join(
        f'  <material name="{n}"><color rgba="{fv(COLOURS[n])}"/></material>\n' for n in names
    )


def urdf_transmission(joint: str, actuator: str) -> str:
    return (
        f'  <transmission name="{joint}_transmission">\n'
        "    <type>transmission_interface/SimpleTransmission</type>\n"
        f'    <joint name="{joint}">\n'
        "      <hardwareInterface>hardware_interface/EffortJointInterface</hardwareInterface>\n"
        "    </joint>\n"
        f'    <actuator name="{actuator}">\n'
        "      <mechanicalReduction>1</mechanicalReduction>\n"
        "    </actuator>\n"
        "  </transmission>\n"
    )


# ================================================================================ the gripper

PAD_RADIUS = 0.004
PAD_XS = (0.045, 0.065, 0.085)
PAD_ZS = (-0.01, 0.01)
CAMERA_RPY = "-1.5707963267948966 0 -1.5707963267948966"


def finger(name: str, side: float) -> Body:
    """side = +1 (left, pads face -y) or -1 (right, pads face +y)."""
    shapes = [Shape("box", (0.09, 0.012, 0.03), (0.045, side * 0.006, 0.0), colour="finger")]
    # Light visual pad plate on the inner face (1 mm thick, inside the finger box: no mass).
    shapes.append(
        Shape(
            "box",
            (0.05, 0.001, 0.028),
            (0.065, side * 0.0004, 0.0),
            role="visual",
            colour="pad",
            inertial=False,
            name=f"{name}_pad_visual",
        )
    )
    mu = {}
    for x in PAD_XS:
        for z in PAD_ZS:
            mu[len(shapes)] = 0.7
            shapes.append(
                Shape(
                    "sph",
                    (PAD_RADIUS,),
                    (x, side * 0.003, z),
                    role="collision",
                    inertial=False,
                    name=f"{name}_pad_{len(mu) - 1}",
                )
            )
    return Body(name, 0.095, shapes, mu=0.7, extra_collision_mu=mu)


def gripper_sdf() -> str:
    base = Body(
        "gripper_base",
        0.16,
        [
            Shape("box", (0.07, 0.13, 0.05), (0.035, 0.0, 0.0), colour="gripper"),
            # Camera bar (the T265): visual only, massless. Its front face is 2 mm behind the
            # optical centres (x = 0.02) so that the cameras do not look out of its inside.
            Shape(
                "box",
                (0.018, 0.09, 0.035),
                (0.009, 0.0, 0.0425),
                role="visual",
                colour="camera",
                inertial=False,
            ),
        ],
        mu=0.7,
    )
    left = finger("left_finger", +1.0)
    right = finger("right_finger", -1.0)

    def joint(name, child, axis):
        return (
            f'    <joint name="{name}" type="prismatic">\n'
            '      <pose relative_to="gripper_base">0.07 0 0 0 0 0</pose>\n'
            "      <parent>gripper_base</parent>\n"
            f"      <child>{child}</child>\n"
            "      <axis>\n"
            f'        <xyz expressed_in="gripper_base">{axis}</xyz>\n'
            f"        <limit><lower>0</lower><upper>{f(GRIPPER_OPEN)}</upper>"
            "<effort>40</effort><velocity>0.2</velocity></limit>\n"
            "        <dynamics><damping>0.1</damping></dynamics>\n"
            "      </axis>\n"
            "    </joint>\n"
        )

    def frame(name, pose):
        return (
            f'    <frame name="{name}" attached_to="gripper_base">\n'
            f'      <pose relative_to="gripper_base">{pose}</pose>\n'
            "    </frame>\n"
        )

    body = (
        sdf_body(base)
        + sdf_body(left, ' relative_to="gripper_base">0.07 0 0 0 0 0')
        + sdf_body(right, ' relative_to="gripper_base">0.07 0 0 0 0 0')
        + joint("left_finger_joint", "left_finger", "0 1 0")
        + joint("right_finger_joint", "right_finger", "0 -1 0")
        + frame("gripper_tcp", f"{f(GRIPPER_TCP_X)} 0 0 0 0 0")
        + frame("left_camera_optical", f"0.02 0.032 0.0525 {CAMERA_RPY}")
        + frame("right_camera_optical", f"0.02 -0.032 0.0525 {CAMERA_RPY}")
        + '    <drake:collision_filter_group name="gripper_self">\n'
        "      <drake:member>gripper_base</drake:member>\n"
        "      <drake:member>left_finger</drake:member>\n"
        "      <drake:member>right_finger</drake:member>\n"
        "      <drake:ignored_collision_filter_group>gripper_self"
        "</drake:ignored_collision_filter_group>\n"
        "    </drake:collision_filter_group>\n"
    )
    comment = (
        "LEGATO Gripper, prismatic two-finger model (SPEC section 3).\n"
        "     Frame: +x approach (fingers), +z up (camera side), +y left. gripper_base's origin\n"
        "     is the mount point at the back. Finger joint q = distance of a pad's inner face\n"
        "     from the x-z plane: q = 0 closed, q = 0.052 open (inner pad gap 0.104 m).\n"
        "     Pad contact spheres protrude 1 mm past the inner faces. Total mass 0.35 kg."
    )
    return sdf_file("legato_gripper", comment, body)


# ================================================================================ abstract


def abstract_urdf() -> str:
    links = [
        "abstract_root",
        "abstract_x_link",
        "abstract_y_link",
        "abstract_z_link",
        "abstract_roll_link",
        "abstract_pitch_link",
        "abstract_mount",
    ]
    joints = [
        ("abstract_x", "prismatic", "1 0 0", -2.0, 2.0),
        ("abstract_y", "prismatic", "0 1 0", -2.0, 2.0),
        ("abstract_z", "prismatic", "0 0 1", 0.0, 2.0),
        ("abstract_roll", "revolute", "1 0 0", -3.14159, 3.14159),
        ("abstract_pitch", "revolute", "0 1 0", -1.5, 1.5),
        ("abstract_yaw", "revolute", "0 0 1", -3.14159, 3.14159),
    ]
    inertia = (np.zeros(3), np.eye(3) * 1e-5)
    out = [
        (
            '<?xml version="1.0"?>\n'
            "<!-- The 'Abstract' embodiment (SPEC section 4): six virtual joints (x, y, z\n"
            "     prismatic, then roll, pitch, yaw revolute) carrying abstract_mount, where the\n"
            "     gripper is welded. The code welds abstract_root to the world.\n"
            "     Generated by models/generate_models.py. -->\n"
            '<robot name="abstract" xmlns:drake="http://drake.mit.edu">\n'
        ),
        urdf_materials(["marker"]),
    ]
    for name in links:
        shapes = []
        if name == "abstract_mount":
            shapes = [Shape("sph", (0.01,), role="visual", colour="marker")]
        out.append(urdf_link(Body(name, 0.01, shapes), inertia_override=inertia))
    for (name, kind, axis, lo, hi), parent, child in zip(
        joints, links[:-1], links[1:], strict=True
    ):
        out.append(
            f'  <joint name="{name}" type="{kind}">\n'
            f'    <parent link="{parent}"/>\n'
            f'    <child link="{child}"/>\n'
            '    <origin xyz="0 0 0" rpy="0 0 0"/>\n'
            f'    <axis xyz="{axis}"/>\n'
            f'    <limit lower="{f(lo)}" upper="{f(hi)}" effort="1000" velocity="2"/>\n'
            "  </joint>\n"
        )
    for name, *_ in joints:
        out.append(urdf_transmission(name, f"{name}_motor"))
    out.append("</robot>\n")
    return "".join(out)


# ================================================================================ panda

H = PI / 2


def panda_bodies() -> list[Body]:
    """Links in their own frames; shapes follow where the joint origins lie (SPEC section 4).

    At q = 0: link1 at z 0.333 (world-aligned), link2 same point with y = -world z,
    link3 at z 0.649 (world-aligned), link4 (elbow) at x 0.0825 with y = world z,
    link5 at (0, 0, 1.033) world-aligned, link6 same point with y = world z, link7 at
    x 0.088 with z = -world z, link8 (flange) 0.107 further along link7 z.
    """
    W, G, D = "panda_white", "panda_grey", "panda_dark"
    return [
        Body(
            "panda_link0",
            4.0,
            [
                Shape("cyl", (0.09, 0.14), (-0.02, 0.0, 0.07), colour=W),
                Shape("box", (0.12, 0.15, 0.10), (-0.13, 0.0, 0.05), colour=W),
                Shape(
                    "cyl",
                    (0.07, 0.05),
                    (0.0, 0.0, 0.165),
                    colour=D,
                    role="visual",
                    inertial=False,
                ),
            ],
        ),
        Body(
            "panda_link1",
            4.0,
            [
                capsule_between((0, 0, -0.19), (0, 0, -0.02), 0.062, colour=W),
            ],
        ),
        Body(
            "panda_link2",
            3.0,
            [
                Shape("cyl", (0.062, 0.13), (0, 0, 0), colour=G),
                capsule_between((0, 0, 0), (0, -0.20, 0), 0.058, colour=W),
            ],
        ),
        Body(
            "panda_link3",
            3.0,
            [
                capsule_between((0, 0, -0.13), (0, 0, -0.01), 0.058, colour=W),
                capsule_between((0, 0, -0.02), (0.0825, 0, -0.02), 0.055, colour=W),
            ],
        ),
        Body(
            "panda_link4",
            2.0,
            [
                Shape("cyl", (0.056, 0.12), (0, 0, 0), colour=G),
                capsule_between((0, 0, 0), (-0.0825, 0.10, 0), 0.052, colour=W),
            ],
        ),
        Body(
            "panda_link5",
            2.0,
            [
                capsule_between((0, 0.02, -0.27), (0, 0.0, -0.04), 0.054, colour=W),
                Shape(
                    "cyl",
                    (0.05, 0.03),
                    (0, 0, -0.035),
                    colour=D,
                    role="visual",
                    inertial=False,
                ),
            ],
        ),
        Body(
            "panda_link6",
            2.0,
            [
                Shape("cyl", (0.055, 0.12), (0, 0, 0), colour=G),
                capsule_between((0.0, 0, 0), (0.088, 0, 0), 0.048, colour=W),
            ],
        ),
        Body(
            "panda_link7",
            1.5,
            [
                Shape("cyl", (0.05, 0.11), (0, 0, 0.035), colour=W),
                Shape(
                    "box",
                    (0.06, 0.05, 0.04),
                    (0.035, 0.035, 0.06),
                    rpy=(0, 0, PI / 4),
                    colour=G,
                ),
            ],
        ),
        Body(
            "panda_link8",
            0.1,
            [
                Shape("cyl", (0.035, 0.017), (0, 0, -0.0085), colour=D),
            ],
        ),
    ]


PANDA_JOINTS = [
    # name, xyz, rpy, lower, upper, effort, velocity
    ("panda_joint1", (0, 0, 0.333), (0, 0, 0), -2.8973, 2.8973, 87, 2.175),
    ("panda_joint2", (0, 0, 0), (-H, 0, 0), -1.7628, 1.7628, 87, 2.175),
    ("panda_joint3", (0, -0.316, 0), (H, 0, 0), -2.8973, 2.8973, 87, 2.175),
    ("panda_joint4", (0.0825, 0, 0), (H, 0, 0), -3.0718, -0.0698, 87, 2.175),
    ("panda_joint5", (-0.0825, 0.384, 0), (-H, 0, 0), -2.8973, 2.8973, 12, 2.61),
    ("panda_joint6", (0, 0, 0), (H, 0, 0), -0.0175, 3.7525, 12, 2.61),
    ("panda_joint7", (0.088, 0, 0), (H, 0, 0), -2.8973, 2.8973, 12, 2.61),
]


def panda_urdf() -> str:
    bodies = panda_bodies()
    for b in bodies:
        b.mu = 0.5
    names = [b.name for b in bodies]
    out = [
        (
            '<?xml version="1.0"?>\n'
            "<!-- Franka Emika Panda, standard Franka kinematics (SPEC section 4), primitive\n"
            "     geometry (capsules, cylinders, boxes) and inertias computed from those shapes.\n"
            "     panda_link8 is the flange (0.107 m along link7 z). At q = 0 the flange lies at\n"
            "     (0.088, 0, 0.926) in panda_link0. The code welds panda_link0 to the world.\n"
            "     Generated by models/generate_models.py. -->\n"
            '<robot name="panda" xmlns:drake="http://drake.mit.edu">\n'
        ),
        urdf_materials(["panda_white", "panda_grey", "panda_dark"]),
    ]
    out += [urdf_link(b) for b in bodies]
    for i, (name, xyz, rpy, lo, hi, effort, vel) in enumerate(PANDA_JOINTS):
        out.append(
            f'  <joint name="{name}" type="revolute">\n'
            f'    <parent link="{names[i]}"/>\n'
            f'    <child link="{names[i + 1]}"/>\n'
            f'    <origin xyz="{fv(xyz)}" rpy="{fv(rpy)}"/>\n'
            '    <axis xyz="0 0 1"/>\n'
            f'    <limit lower="{f(lo)}" upper="{f(hi)}" effort="{f(effort)}" '
            f'velocity="{f(vel)}"/>\n'
            '    <dynamics damping="0.1"/>\n'
            "  </joint>\n"
        )
    out.append(
        '  <joint name="panda_joint8" type="fixed">\n'
        '    <parent link="panda_link7"/>\n'
        '    <child link="panda_link8"/>\n'
        '    <origin xyz="0 0 0.107" rpy="0 0 0"/>\n'
        "  </joint>\n"
    )
    for name, *_ in PANDA_JOINTS:
        out.append(urdf_transmission(name, f"{name}_motor"))
    out.append('  <drake:collision_filter_group name="panda_self">\n')
    out += [f'    <drake:member link="{n}"/>\n' for n in names]
    out.append('    <drake:ignored_collision_filter_group name="panda_self"/>\n')
    out.append("  </drake:collision_filter_group>\n")
    out.append("</robot>\n")
    return "".join(out)


# ================================================================================ mobile robots
# Shared URDF writer of Spot, the Google Robot and GR-1: links (Body), joints (UrdfJoint), one
# transmission "<joint>_motor" per actuated joint, and one self-collision filter group.

VIRTUAL_MASS = 0.01
VIRTUAL_INERTIA = (np.zeros(3), np.eye(3) * 1e-5)


@dataclass
class UrdfJoint:
    """A URDF joint: kind is "revolute", "prismatic" or "fixed"; xyz/rpy = origin in parent."""

    name: str
    kind: str
    parent: str
    child: str
    xyz: tuple = (0.0, 0.0, 0.0)
    rpy: tuple = (0.0, 0.0, 0.0)
    axis: tuple | None = None
    lower: float = 0.0
    upper: float = 0.0
    effort: float = 0.0
    velocity: float = 0.0
    damping: float | None = None


def urdf_joint(j: UrdfJoint) -> str:
    """The <joint> element of ``j``."""
    out = (
        f'  <joint name="{j.name}" type="{j.kind}">\n'
        f'    <parent link="{j.parent}"/>\n'
        f'    <child link="{j.child}"/>\n'
        f'    <origin xyz="{fv(j.xyz)}" rpy="{fv(j.rpy)}"/>\n'
    )
    if j.kind != "fixed":
        out += (
            f'    <axis xyz="{fv(j.axis)}"/>\n'
            f'    <limit lower="{f(j.lower)}" upper="{f(j.upper)}" effort="{f(j.effort)}" '
            f'velocity="{f(j.velocity)}"/>\n'
        )
        if j.damping is not None:
            out += f'    <dynamics damping="{f(j.damping)}"/>\n'
    return out + "  </joint>\n"


def virtual_link(name: str) -> Body:
    """A light link of a virtual (base-pose) joint chain: 0.01 kg, inertia 1e-5, no geometry."""
    return Body(name, VIRTUAL_MASS)


def urdf_robot(
    model: str,
    comment: str,
    colours: list[str],
    bodies: list[Body],
    joints: list[UrdfJoint],
    virtual: tuple[str, ...] = (),
) -> str:
    """A robot URDF: materials, links (``virtual`` ones with the light fixed inertia), joints,
    a transmission per actuated joint and a collision filter group of all links."""
    names = [b.name for b in bodies]
    assert len(set(names)) == len(names), model
    for j in joints:
        assert j.parent in names and j.child in names, j.name
    out = [
        '<?xml version="1.0"?>\n',
        f"<!-- {comment}\n"
        "     Generated by models/generate_models.py; primitive geometry only. -->\n",
        f'<robot name="{model}" xmlns:drake="http://drake.mit.edu">\n',
        urdf_materials(colours),
    ]
    for b in bodies:
        out.append(urdf_link(b, VIRTUAL_INERTIA if b.name in virtual else None))
    out += [urdf_joint(j) for j in joints]
    out += [urdf_transmission(j.name, f"{j.name}_motor") for j in joints if j.kind != "fixed"]
    out.append(f'  <drake:collision_filter_group name="{model}_self">\n')
    out += [f'    <drake:member link="{n}"/>\n' for n in names]
    out.append(f'    <drake:ignored_collision_filter_group name="{model}_self"/>\n')
    out.append("  </drake:collision_filter_group>\n")
    out.append("</robot>\n")
    return "".join(out)


def tip_link(name: str, mass: float = 0.01) -> Body:
    """A small massive link marking a frame (tool, foot, camera): a 1 cm mass-only sphere."""
    return Body(name, mass, [Shape("sph", (0.01,), role="none")])


def cyl_along(axis: str, r: float, length: float, xyz=(0.0, 0.0, 0.0), **kw) -> Shape:
    """A cylinder (or capsule, kind="cap") whose axis is the body's x, y or z axis."""
    rpy = {"x": (0.0, H, 0.0), "y": (H, 0.0, 0.0), "z": (0.0, 0.0, 0.0)}[axis]
    kind = kw.pop("kind", "cyl")
    return Shape(kind, (r, length), tuple(float(c) for c in xyz), rpy, **kw)


# -------------------------------------------------------------------------------- spot

# Leg geometry and limits: legato_drake/dimensions.py (the leg IK uses them too).
SPOT_FOOT_RADIUS = 0.02
SPOT_BODY_JOINTS = [
    # name, kind, axis, lower, upper, effort: absolute world pose of the body frame, within
    # SPOT_BODY_HALF_RANGE of SPOT_NOMINAL_BODY_POSE
    (name, kind, axis, centre - half, centre + half, effort)
    for (name, kind, axis, effort), centre, half in zip(
        [("body_x", "prismatic", (1, 0, 0), 2000.0),
         ("body_y", "prismatic", (0, 1, 0), 2000.0),
         ("body_z", "prismatic", (0, 0, 1), 2000.0),
         ("body_roll", "revolute", (1, 0, 0), 500.0),
         ("body_pitch", "revolute", (0, 1, 0), 500.0),
         ("body_yaw", "revolute", (0, 0, 1), 500.0)],
        SPOT_NOMINAL_BODY_POSE, SPOT_BODY_HALF_RANGE, strict=True)
]
SPOT_ARM_JOINTS = [
    # name, parent, child, xyz, axis, lower, upper, effort
    ("arm_sh0", "body", "arm_link_sh0", (0.292, 0, 0.188), (0, 0, 1), -2.618, PI, 90.0),
    ("arm_sh1", "arm_link_sh0", "arm_link_sh1", (0, 0, 0), (0, 1, 0), -PI, 0.5236, 180.0),
    ("arm_el0", "arm_link_sh1", "arm_link_el0", (0.3385, 0, 0), (0, 1, 0), 0.0, PI, 90.0),
    ("arm_el1", "arm_link_el0", "arm_link_el1", (0.4033, 0, 0.075), (1, 0, 0), -2.7925, 2.7925,
     30.0),
    ("arm_wr0", "arm_link_el1", "arm_link_wr0", (0, 0, 0), (0, 1, 0), -1.8326, 1.8326, 30.0),
    ("arm_wr1", "arm_link_wr0", "arm_link_wr1", (0, 0, 0), (1, 0, 0), -2.88, 2.88, 30.0),
]
SPOT_TOOL = (0.2, 0.0, -0.03)


def spot_bodies() -> list[Body]:
    """Spot's links in their own frames (all zero-rotation joint origins)."""
    Y, D = "spot_yellow", "spot_dark"
    bodies = [virtual_link("spot_world_anchor")]
    bodies += [virtual_link(f"{name}_link") for name, *_ in SPOT_BODY_JOINTS[:-1]]
    bodies.append(
        Body(
            "body",
            16.7,
            [
                Shape("box", (0.85, 0.24, 0.18), colour=Y),
                # Front camera face and rear bumper: visual, massless.
                Shape("box", (0.02, 0.2, 0.1), (0.43, 0, 0), role="visual", colour=D,
                      inertial=False),
                Shape("box", (0.02, 0.2, 0.1), (-0.43, 0, 0), role="visual", colour=D,
                      inertial=False),
            ],
        )
    )
    kx, kz = SPOT_KNEE
    for leg, (_, side) in SPOT_LEG_SIGNS.items():
        bodies += [
            Body(
                f"{leg}_hip",
                1.0,
                [capsule_between((0, 0, 0), (0, side * SPOT_HIP_Y, 0), 0.045, kind="cyl",
                                 colour=D)],
            ),
            Body(
                f"{leg}_upper_leg",
                1.0,
                [capsule_between((0, 0, -0.03), (kx, 0, kz + 0.03), 0.04, colour=Y)],
            ),
            Body(
                f"{leg}_lower_leg",
                0.5,
                [capsule_between((0, 0, -0.02), (0, 0, -SPOT_LOWER_LEG + 0.04), 0.02, colour=D)],
            ),
            Body(f"{leg}_foot", 0.05, [Shape("sph", (SPOT_FOOT_RADIUS,), colour=D)]),
        ]
    bodies += [
        Body("arm_link_sh0", 2.0, [cyl_along("z", 0.05, 0.098, (0, 0, -0.049), colour=D)]),
        Body(
            "arm_link_sh1",
            1.6,
            [
                cyl_along("y", 0.055, 0.11, colour=D),
                capsule_between((0.07, 0, 0), (0.29, 0, 0), 0.04, colour=Y),
            ],
        ),
        Body(
            "arm_link_el0",
            1.2,
            [
                cyl_along("y", 0.045, 0.09, colour=D),
                capsule_between((0.03, 0, 0.03), (0.08, 0, 0.075), 0.035, colour=D),
                capsule_between((0.1, 0, 0.075), (0.3, 0, 0.075), 0.035, colour=Y),
            ],
        ),
        Body("arm_link_el1", 0.7, [capsule_between((-0.08, 0, 0), (-0.03, 0, 0), 0.035,
                                                   colour=Y)]),
        Body("arm_link_wr0", 0.6, [cyl_along("y", 0.035, 0.07, colour=D)]),
        Body("arm_link_wr1", 0.5, [cyl_along("x", 0.035, 0.1, (0.08, 0, 0), colour=D)]),
        tip_link("arm_tool"),
    ]
    for b in bodies:
        b.mu = 0.8 if b.name.endswith("_foot") else 0.5
    return bodies


def spot_joints() -> list[UrdfJoint]:
    """Body-pose chain, the four legs, the arm and the fixed tool/foot frames."""
    chain = ["spot_world_anchor"] + [f"{n}_link" for n, *_ in SPOT_BODY_JOINTS[:-1]] + ["body"]
    joints = [
        UrdfJoint(name, kind, parent, child, axis=axis, lower=lo, upper=hi, effort=effort,
                  velocity=1.0)
        for (name, kind, axis, lo, hi, effort), parent, child in zip(
            SPOT_BODY_JOINTS, chain[:-1], chain[1:], strict=True
        )
    ]
    kx, kz = SPOT_KNEE
    for leg, (front, side) in SPOT_LEG_SIGNS.items():
        kw = dict(velocity=10.0, damping=0.1)
        joints += [
            UrdfJoint(f"{leg}_hip_x", "revolute", "body", f"{leg}_hip",
                      (front * SPOT_HIP_X[0], side * SPOT_HIP_X[1], 0), axis=(1, 0, 0),
                      lower=SPOT_HIP_X_LIMITS[0], upper=SPOT_HIP_X_LIMITS[1], effort=45.0, **kw),
            UrdfJoint(f"{leg}_hip_y", "revolute", f"{leg}_hip", f"{leg}_upper_leg",
                      (0, side * SPOT_HIP_Y, 0), axis=(0, 1, 0), lower=SPOT_HIP_Y_LIMITS[0],
                      upper=SPOT_HIP_Y_LIMITS[1], effort=45.0, **kw),
            UrdfJoint(f"{leg}_knee", "revolute", f"{leg}_upper_leg", f"{leg}_lower_leg",
                      (kx, 0, kz), axis=(0, 1, 0), lower=SPOT_KNEE_LIMITS[0],
                      upper=SPOT_KNEE_LIMITS[1], effort=115.0, **kw),
            UrdfJoint(f"{leg}_foot_joint", "fixed", f"{leg}_lower_leg", f"{leg}_foot",
                      (0, 0, -SPOT_LOWER_LEG)),
        ]
    for name, parent, child, xyz, axis, lo, hi, effort in SPOT_ARM_JOINTS:
        joints.append(UrdfJoint(name, "revolute", parent, child, xyz, axis=axis, lower=lo,
                                upper=hi, effort=effort, velocity=3.0, damping=0.1))
    joints.append(UrdfJoint("arm_tool_joint", "fixed", "arm_link_wr1", "arm_tool", SPOT_TOOL))
    return joints


def spot_urdf() -> str:
    """The Spot-with-arm URDF (robot ``spot``)."""
    comment = (
        "Boston Dynamics Spot with arm (SPEC section 4), primitive geometry.\n"
        "     The body pose is six controlled virtual joints from spot_world_anchor (welded at\n"
        "     the world origin): body_x, body_y, body_z (prismatic), body_roll, body_pitch,\n"
        "     body_yaw (revolute about x, y, z, in that chain order), so their positions are the\n"
        "     body frame's world coordinates and R_WB = Rx(roll) Ry(pitch) Rz(yaw). Legs fl, fr,\n"
        "     hl, hr (left = +y): hip_x about x, hip_y and knee about y; {leg}_foot is 0.33 m\n"
        "     below the knee along the lower leg (foot sphere radius 0.02 centred there).\n"
        "     arm_tool = Spot's tool frame (0.2, 0, -0.03) in arm_link_wr1, where the gripper\n"
        "     mounts. Idealised: the body is held by its stiff virtual joints, not by the legs;\n"
        "     the legs follow it through analytic leg IK (legato_drake/systems/spot_legs.py)."
    )
    return urdf_robot(
        "spot",
        comment,
        ["spot_yellow", "spot_dark"],
        spot_bodies(),
        spot_joints(),
        virtual=("spot_world_anchor", *(f"{n}_link" for n, *_ in SPOT_BODY_JOINTS[:-1])),
    )


# -------------------------------------------------------------------------------- google robot

GOOGLE_BASE_JOINTS = [
    # name, kind, axis, lower, upper, effort, velocity: absolute planar pose of the base
    ("base_x", "prismatic", (1, 0, 0), -0.6, 0.0, 2000.0, 0.1),
    ("base_y", "prismatic", (0, 1, 0), -0.2, 0.4, 2000.0, 0.1),
    ("base_yaw", "revolute", (0, 0, 1), -PI, PI, 500.0, 0.1),
]
GOOGLE_GRIPPER_UPPER = 1.79
"""joint_gripper's upper limit. SPEC gives [-4.49, 1.35], which excludes the SPEC home
0.5 pi = 1.5708 (and -1.5 pi too); widened to 1.79 (the wrist's bound) so home is inside."""
GOOGLE_ARM_JOINTS = [
    # name, parent, child, xyz, axis, lower, upper, effort
    ("joint_torso", "base", "link_torso", (0, 0, 0.6565), (0, 0, 1), -4.49, 1.35, 150.0),
    ("joint_shoulder", "link_torso", "link_shoulder", (0, -0.167289, 0.113), (0, 1, 0), -2.66,
     3.18, 150.0),
    ("joint_bicep", "link_shoulder", "link_bicep", (0, 0.002289, 0.215029), (0, 0, 1), -2.13,
     3.71, 100.0),
    ("joint_elbow", "link_bicep", "link_elbow", (0, -0.064, 0.185036), (0, 1, 0), -2.05, 3.79,
     100.0),
    ("joint_forearm", "link_elbow", "link_forearm", (0, -0.101, 0.0914359), (0, 0, 1), -2.92,
     2.92, 60.0),
    ("joint_wrist", "link_forearm", "link_wrist", (0, -0.00604, 0.2735), (0, 1, 0), -1.79, 1.79,
     60.0),
    ("joint_gripper", "link_wrist", "link_gripper", (0, 0.0060384, 0.10911), (0, 0, 1), -4.49,
     GOOGLE_GRIPPER_UPPER, 60.0),
]


def google_robot_bodies() -> list[Body]:
    """The Google Robot's links: planar virtual chain, base, 7-DoF arm, tool."""
    W, G, D = "google_white", "google_grey", "google_dark"
    wheel = dict(role="visual", colour=D, inertial=False)
    bodies = [virtual_link("gr_world_anchor"), virtual_link("base_x_link"),
              virtual_link("base_y_link")]
    bodies += [
        Body(
            "base",
            30.0,
            [
                cyl_along("z", 0.24, 0.28, (0, 0, 0.16), colour=G, mass=22.0),
                Shape("box", (0.22, 0.22, 0.34), (0, 0, 0.47), colour=W, mass=8.0),
                cyl_along("y", 0.06, 0.02, (0, 0.18283, 0.06), **wheel),
                cyl_along("y", 0.06, 0.02, (0, -0.18283, 0.06), **wheel),
                # Head on a mast above the torso column (visual, massless).
                cyl_along("z", 0.025, 0.2, (0, 0, 1.05), role="visual", colour=G,
                          inertial=False),
                Shape("box", (0.14, 0.22, 0.1), (0.03, 0, 1.18), role="visual", colour=W,
                      inertial=False),
            ],
        ),
        Body(
            "link_torso",
            2.5,
            [
                cyl_along("z", 0.09, 0.28, (0, 0, 0.14), colour=W),
                Shape("box", (0.1, 0.06, 0.12), (0, -0.11, 0.113), colour=G),
            ],
        ),
        Body(
            "link_shoulder",
            2.1,
            [
                cyl_along("y", 0.06, 0.08, colour=G),
                capsule_between((0, 0, 0.02), (0, 0.002289, 0.2), 0.05, colour=W),
            ],
        ),
        Body(
            "link_bicep",
            1.4,
            [
                capsule_between((0, 0, 0.02), (0, 0, 0.185036), 0.05, colour=W),
                cyl_along("y", 0.05, 0.06, (0, -0.03, 0.185036), colour=G),
            ],
        ),
        Body(
            "link_elbow",
            0.8,
            [capsule_between((0, 0, 0), (0, -0.101, 0.0914359), 0.045, colour=G)],
        ),
        Body(
            "link_forearm",
            0.8,
            [capsule_between((0, 0, 0.03), (0, -0.00604, 0.25), 0.045, colour=W)],
        ),
        Body(
            "link_wrist",
            0.55,
            [capsule_between((0, 0, 0), (0, 0.0060384, 0.09), 0.04, colour=G)],
        ),
        Body("link_gripper", 0.4, [cyl_along("z", 0.04, 0.06, (0, 0, 0.03), colour=D)]),
        tip_link("link_tool"),
    ]
    for b in bodies:
        b.mu = 0.5
    return bodies


def google_robot_joints() -> list[UrdfJoint]:
    """Planar base chain, the arm and the fixed tool frame."""
    chain = ["gr_world_anchor", "base_x_link", "base_y_link", "base"]
    joints = [
        UrdfJoint(name, kind, parent, child, axis=axis, lower=lo, upper=hi, effort=effort,
                  velocity=vel)
        for (name, kind, axis, lo, hi, effort, vel), parent, child in zip(
            GOOGLE_BASE_JOINTS, chain[:-1], chain[1:], strict=True
        )
    ]
    for name, parent, child, xyz, axis, lo, hi, effort in GOOGLE_ARM_JOINTS:
        joints.append(UrdfJoint(name, "revolute", parent, child, xyz, axis=axis, lower=lo,
                                upper=hi, effort=effort, velocity=3.0, damping=0.1))
    joints.append(UrdfJoint("joint_tool", "fixed", "link_gripper", "link_tool", (0, 0, 0.1)))
    return joints


def google_robot_urdf() -> str:
    """The Google Robot URDF (robot ``google_robot``)."""
    comment = (
        "Google Robot (Everyday Robots mobile manipulator, SPEC section 4), primitive\n"
        "     geometry. Planar base on three controlled virtual joints from gr_world_anchor\n"
        "     (welded at the world origin): base_x, base_y (prismatic), base_yaw (about z);\n"
        "     their positions are the base frame's world pose. 7-DoF arm from base; link_tool\n"
        "     is 0.1 m along link_gripper's z, where the gripper mounts. joint_gripper's upper\n"
        "     limit is 1.79 (SPEC: 1.35) so that the SPEC home 0.5 pi lies inside it."
    )
    return urdf_robot(
        "google_robot",
        comment,
        ["google_white", "google_grey", "google_dark"],
        google_robot_bodies(),
        google_robot_joints(),
        virtual=("gr_world_anchor", "base_x_link", "base_y_link"),
    )


# -------------------------------------------------------------------------------- GR-1

GR1_TILT = math.radians(25.0)
GR1_JOINTS = [
    # name, parent, child, xyz, rpy, axis, lower, upper, effort
    ("waist_yaw", "pelvis", "waist_yaw_link", (0, 0, 0.0065), (0, 0, 0), (0, 0, 1), -1.05, 1.05,
     100.0),
    ("waist_pitch", "waist_yaw_link", "waist_pitch_link", (0, 0, 0.055), (0, 0, 0), (0, 1, 0),
     -0.52, 1.22, 100.0),
    ("waist_roll", "waist_pitch_link", "torso", (0, 0, 0.085), (0, 0, 0), (1, 0, 0), -0.7, 0.7,
     100.0),
    ("r_shoulder_pitch", "torso", "r_upper_arm_pitch", (0, -0.12664, 0.21725), (-GR1_TILT, 0, 0),
     (0, 1, 0), -2.79, 1.92, 80.0),
    ("r_shoulder_roll", "r_upper_arm_pitch", "r_upper_arm_roll", (0, -0.067, 0), (GR1_TILT, 0, 0),
     (1, 0, 0), -3.27, 0.57, 80.0),
    ("r_shoulder_yaw", "r_upper_arm_roll", "r_upper_arm_yaw", (0, -0.04, -0.0575), (0, 0, 0),
     (0, 0, 1), -2.97, 2.97, 60.0),
    ("r_elbow_pitch", "r_upper_arm_yaw", "r_lower_arm_pitch", (0, 0, -0.18853), (0, 0, 0),
     (0, 1, 0), -2.27, 2.27, 60.0),
    ("r_wrist_yaw", "r_lower_arm_pitch", "r_hand_yaw", (0, 0, -0.0405), (0, 0, 0), (0, 0, 1),
     -2.97, 2.97, 50.0),
    ("r_wrist_roll", "r_hand_yaw", "r_hand_roll", (0, 0, -0.20153), (0, 0, 0), (1, 0, 0), -0.61,
     0.61, 50.0),
    ("r_wrist_pitch", "r_hand_roll", "r_hand_pitch", (0, 0, 0), (0, 0, 0), (0, 1, 0), -0.61,
     0.61, 50.0),
    ("head_yaw", "torso", "head_yaw_link", (0, 0, 0.34453), (0, 0, 0), (0, 0, 1), -2.71, 2.71,
     50.0),
    ("head_pitch", "head_yaw_link", "head_pitch_link", (0, 0, 0), (0, 0, 0), (0, 1, 0), -0.5, 0.5,
     50.0),
    ("head_roll", "head_pitch_link", "head", (0, 0, 0), (0, 0, 0), (1, 0, 0), -0.5, 0.5, 50.0),
]
GR1_TOOL = (0.0, 0.0, -0.1)
GR1_CAMERA = (0.09, 0.0, 0.13)


def gr1_leg_shapes(side: float) -> list[Shape]:
    """A straight standing leg (visual, massless) from the hip to the sole at z = -0.88."""
    y, S, D = side * 0.1, "gr1_silver", "gr1_dark"
    kw = dict(role="visual", inertial=False)
    return [
        capsule_between((0, y, -0.06), (0, y, -0.42), 0.06, colour=S, **kw),
        capsule_between((0, y, -0.46), (0, y, -0.78), 0.05, colour=S, **kw),
        Shape("box", (0.22, 0.1, 0.05), (0.03, y, -GR1_PELVIS_HEIGHT + 0.025), colour=D, **kw),
    ]


def gr1_bodies() -> list[Body]:
    """GR-1's links: pelvis with the held legs, waist, torso with the held left arm, right
    arm, head with its camera frame."""
    S, D = "gr1_silver", "gr1_dark"
    left_arm = dict(role="visual", colour=S)
    bodies = [
        Body(
            "pelvis",
            6.0,
            [Shape("box", (0.14, 0.26, 0.12), (-0.02, 0, -0.04), colour=D),
             *gr1_leg_shapes(1.0), *gr1_leg_shapes(-1.0)],
        ),
        Body("waist_yaw_link", 0.5, [cyl_along("z", 0.05, 0.05, (0, 0, 0.025), colour=D)]),
        Body("waist_pitch_link", 3.0, [Shape("box", (0.1, 0.16, 0.08), (0, 0, 0.04), colour=D)]),
        Body(
            "torso",
            11.0,
            [
                Shape("box", (0.2, 0.24, 0.3), (-0.01, 0, 0.19), colour=S, mass=8.0),
                # The held left arm, hanging down from the left shoulder (not actuated).
                capsule_between((0, 0.2, 0.2), (0, 0.2, -0.03), 0.04, mass=1.5, **left_arm),
                capsule_between((0, 0.2, -0.05), (0, 0.2, -0.27), 0.035, mass=1.0, **left_arm),
                Shape("box", (0.04, 0.08, 0.12), (0, 0.2, -0.35), mass=0.5, role="visual",
                      colour=D),
            ],
        ),
        Body("r_upper_arm_pitch", 0.8, [cyl_along("y", 0.04, 0.06, (0, -0.03, 0), colour=D)]),
        Body("r_upper_arm_roll", 0.3,
             [capsule_between((0, 0, 0), (0, -0.04, -0.0575), 0.035, colour=D)]),
        Body("r_upper_arm_yaw", 0.8,
             [capsule_between((0, 0, -0.01), (0, 0, -0.16), 0.04, colour=S)]),
        Body("r_lower_arm_pitch", 0.3, [cyl_along("y", 0.035, 0.07, colour=D)]),
        Body("r_hand_yaw", 0.6, [capsule_between((0, 0, -0.02), (0, 0, -0.18), 0.035, colour=S)]),
        Body("r_hand_roll", 0.1, [Shape("sph", (0.025,), colour=D)]),
        Body("r_hand_pitch", 0.5, [Shape("box", (0.04, 0.08, 0.12), (0, 0, -0.07), colour=D)]),
        tip_link("r_hand_tool"),
        Body("head_yaw_link", 0.3, [cyl_along("z", 0.035, 0.06, (0, 0, 0.03), colour=D)]),
        Body("head_pitch_link", 0.1, [Shape("sph", (0.02,), role="none")]),
        Body(
            "head",
            1.0,
            [
                Shape("box", (0.16, 0.16, 0.2), (0, 0, 0.12), colour=S),
                Shape("box", (0.01, 0.12, 0.06), (0.08, 0, 0.13), role="visual", colour=D,
                      inertial=False),
            ],
        ),
        tip_link("head_camera"),
    ]
    for b in bodies:
        b.mu = 0.5
    return bodies


def gr1_joints() -> list[UrdfJoint]:
    """Waist, right arm, head, and the fixed tool and camera frames."""
    joints = [
        UrdfJoint(name, "revolute", parent, child, xyz, rpy, axis, lo, hi, effort, 25.0, 0.1)
        for name, parent, child, xyz, rpy, axis, lo, hi, effort in GR1_JOINTS
    ]
    joints.append(UrdfJoint("r_hand_tool_joint", "fixed", "r_hand_pitch", "r_hand_tool",
                            GR1_TOOL))
    joints.append(UrdfJoint("head_camera_joint", "fixed", "head", "head_camera", GR1_CAMERA))
    return joints


def gr1_urdf() -> str:
    """The GR-1 upper-body URDF (robot ``gr1``)."""
    comment = (
        "Fourier GR-1 humanoid, standing (SPEC section 4), primitive geometry. The code welds\n"
        "     pelvis at (-0.1, 0, 0.88); the legs and the left arm are held: visual geometry\n"
        "     fixed to pelvis (legs down to the sole at z = -0.88) and to torso. Actuated: waist\n"
        "     (yaw, pitch, roll), right arm (7) and head (yaw, pitch, roll). r_shoulder_pitch's\n"
        "     child frame is tilted -25 deg about x, r_shoulder_roll's tilted back +25 deg.\n"
        "     r_hand_tool (0, 0, -0.1) in r_hand_pitch is where the gripper mounts;\n"
        "     head_camera looks along its +x."
    )
    return urdf_robot("gr1", comment, ["gr1_silver", "gr1_dark"], gr1_bodies(), gr1_joints())


# ================================================================================ lid scene


def table_sdf() -> str:
    shapes = [Shape("box", (1.3, 2.0, 0.04), (0, 0, -0.02), colour="wood")]
    for x in (-0.6, 0.6):
        for y in (-0.95, 0.95):
            shapes.append(
                Shape(
                    "box",
                    (0.05, 0.05, 0.6),
                    (x, y, -0.34),
                    role="visual",
                    colour="wood_dark",
                    inertial=False,
                )
            )
    body = Body("table_top", 20.0, shapes, mu=0.7)
    return sdf_file(
        "table",
        "Table (SPEC section 6): table_top's origin is the centre of the top surface; the\n"
        "     1.3 x 2.0 x 0.04 top hangs below it; the legs are visual only. The code welds it.",
        sdf_body(body),
    )


def support_spheres(xys, radius: float, bottom: float) -> list[Shape]:
    """Massless collision spheres whose lowest points are flush with z = bottom.

    Drake's point contact gives a box-on-box or disc-on-box pair a single contact point, so
    a flat body rocks from corner to corner and slowly sinks into its support; a few
    spheres at the corners of its bottom face give it a stable multi-point support.
    """
    return [
        Shape("sph", (radius,), (x, y, bottom + radius), role="collision", inertial=False)
        for x, y in xys
    ]


def stove_sdf() -> str:
    body = Body(
        "stove",
        1.0,
        [
            Shape("box", STOVE_SIZE, colour="stove"),
            Shape(
                "cyl",
                (0.07, 0.002),
                (0, 0, 0.0105),
                role="visual",
                colour="burner",
                inertial=False,
            ),
            *support_spheres(
                [(sx * 0.145, sy * 0.115) for sx in (1, -1) for sy in (1, -1)], 0.005, -0.01
            ),
        ],
        mu=0.7,
    )
    return sdf_file(
        "stove",
        "Stove (SPEC section 6): 0.30 x 0.24 x 0.02 box, origin at the box centre, with a\n"
        "     visual-only burner disc on top. Four collision spheres flush with the bottom\n"
        "     corners give the box a stable multi-point support under point contact.",
        sdf_body(body),
    )


POT_N = 16
POT_R_OUT = 0.095
POT_WALL = 0.008
POT_BASE = 0.01


def pot_sdf() -> str:
    shapes = [Shape("box", (0.2, 0.2, 0.01), (0, 0, 0.005), colour="pot")]
    seg = 2 * POT_R_OUT * math.tan(PI / POT_N)  # closes the ring at the outer face
    rc = POT_R_OUT - POT_WALL / 2
    for k in range(POT_N):
        a = 2 * PI * k / POT_N
        shapes.append(
            Shape(
                "box",
                (POT_WALL, seg, POT_HEIGHT - POT_BASE),
                (rc * math.cos(a), rc * math.sin(a), (POT_HEIGHT + POT_BASE) / 2),
                (0, 0, a),
                colour="pot",
            )
        )
    for s in (1.0, -1.0):
        shapes.append(
            Shape(
                "box",
                (0.04, 0.03, 0.01),
                (0, s * (POT_R_OUT - 0.002 + 0.015), 0.085),
                colour="pot_handle",
            )
        )
    shapes += support_spheres(
        [(sx * 0.09, sy * 0.09) for sx in (1, -1) for sy in (1, -1)], 0.005, 0.0)
    body = Body("pot", 0.4, shapes, mu=0.5)
    frame = (
        '    <frame name="pot_rim" attached_to="pot">\n'
        f'      <pose relative_to="pot">0 0 {f(POT_HEIGHT)} 0 0 0</pose>\n'
        "    </frame>\n"
    )
    return sdf_file(
        "pot",
        "Pot (SPEC section 6): origin at the centre of the bottom face; 0.2 x 0.2 x 0.01\n"
        "     base plate; wall of outer radius 0.095, thickness 0.008, up to 0.1, made of 16\n"
        "     tangential boxes standing on the plate; two side handles at +-y; 0.4 kg. Four\n"
        "     collision spheres flush with the bottom corners give it a stable support.\n"
        "     pot_rim = centre of the rim plane.",
        sdf_body(body) + frame,
    )


def lid_sdf() -> str:
    body = Body(
        "lid",
        0.16,
        [
            Shape("cyl", (LID_RADIUS, LID_THICKNESS), colour="lid", mass=0.12),
            Shape("box", LID_HANDLE_BAR, (0, 0, LID_HANDLE_Z), colour="lid_handle"),
            Shape("box", (0.012, 0.012, 0.03), (0, 0.034, 0.02), colour="lid_handle"),
            Shape("box", (0.012, 0.012, 0.03), (0, -0.034, 0.02), colour="lid_handle"),
            *support_spheres(
                [(0.1 * math.cos(k * PI / 4), 0.1 * math.sin(k * PI / 4)) for k in range(8)],
                0.004,
                -0.005,
            ),
        ],
        mu=0.8,
    )
    frame = (
        '    <frame name="lid_handle" attached_to="lid">\n'
        f'      <pose relative_to="lid">0 0 {f(LID_HANDLE_Z)} 0 0 0</pose>\n'
        "    </frame>\n"
    )
    return sdf_file(
        "lid",
        "Lid (SPEC section 6): origin at the centre of the disc (radius 0.11, 0.01 thick);\n"
        "     bar handle 0.08 long along the lid's y, 0.02 x 0.02, centre 0.04 above the disc\n"
        "     top (z 0.045), on two posts at y = +-0.034. lid_handle = bar centre. Eight\n"
        "     collision spheres flush with the disc's bottom face (radius 0.1) give it a\n"
        "     stable multi-point support on flat surfaces under point contact.",
        sdf_body(body) + frame,
    )


# ================================================================================ cup scene

# SHELF_SIZE, SHELF_SIDE, SHELF_BACK, SHELF_BOARD: legato_drake/dimensions.py.


def box_corners(size, radius: float, bottom: float, inset: float = 0.0) -> list[Shape]:
    """Support spheres under the four bottom corners of a ``size`` footprint centred at 0."""
    hx, hy = size[0] / 2 - radius - inset, size[1] / 2 - radius - inset
    return support_spheres([(sx * hx, sy * hy) for sx in (1, -1) for sy in (1, -1)], radius,
                           bottom)


def shelf_sdf() -> str:
    """The doorless open shelf of the cup task (the reference's cabinet without doors)."""
    w, d, h = SHELF_SIZE
    shapes = [
        Shape("box", (w, d, SHELF_BOARD), (0, 0, SHELF_BOARD / 2), colour="shelf"),
        Shape("box", (w, d, SHELF_BOARD), (0, 0, h - SHELF_BOARD / 2), colour="shelf"),
        Shape("box", (w, SHELF_BACK, h - 2 * SHELF_BOARD), (0, -d / 2 + SHELF_BACK / 2, h / 2),
              colour="shelf"),
    ]
    for s in (1.0, -1.0):
        shapes.append(Shape("box", (SHELF_SIDE, d - SHELF_BACK, h - 2 * SHELF_BOARD),
                            (s * (w - SHELF_SIDE) / 2, SHELF_BACK / 2, h / 2), colour="shelf"))
    shapes += box_corners((w, d), 0.008, 0.0, inset=0.005)
    body = Body("shelf", 5.0, shapes, mu=0.6)
    interior_y = SHELF_BACK / 2
    frame = (
        '    <frame name="shelf_interior" attached_to="shelf">\n'
        f'      <pose relative_to="shelf">0 {f(interior_y)} {f(h / 2)} 0 0 0</pose>\n'
        "    </frame>\n"
    )
    return sdf_file(
        "shelf",
        "Open shelf (SPEC section 6, cup task; a doorless cabinet): outer 0.5 (x) x 0.3 (y)\n"
        "     x 0.43 (z), origin at the centre of the bottom face, open front facing +y.\n"
        "     Interior 0.46 x 0.28 x 0.36 between 0.02 side and back walls and 0.035 top and\n"
        "     bottom boards; shelf_interior = interior centre. 5 kg. Four collision spheres\n"
        "     flush with the bottom give it a stable support under point contact.",
        sdf_body(body) + frame,
    )


CUP_N = 16
"""Wall boxes of the cup; its dimensions (CUP_*): legato_drake/dimensions.py."""


def cup_sdf() -> str:
    """The cup of the cup task: a thin-walled cylinder with a vertical loop handle on +y."""
    # The base is visual (with mass); its collision is a ring of spheres, because a flat
    # disc would rock under point contact.
    shapes = [Shape("cyl", (CUP_R_OUT, CUP_BASE), (0, 0, CUP_BASE / 2), colour="cup",
                    role="visual")]
    wall = CUP_R_OUT - CUP_R_IN
    seg = 2 * CUP_R_OUT * math.tan(PI / CUP_N)
    rc = CUP_R_OUT - wall / 2
    for k in range(CUP_N):
        a = 2 * PI * k / CUP_N
        shapes.append(Shape("box", (wall, seg, CUP_H - CUP_BASE),
                            (rc * math.cos(a), rc * math.sin(a), (CUP_H + CUP_BASE) / 2),
                            (0, 0, a), colour="cup"))
    # The handle stands on the cup's +y side: at the SPEC's cup yaw (0.75 pi) it points to
    # -x -y, towards the robots, and a gripper reaches it pointing forward and left.
    depth, width, height = CUP_HANDLE
    shapes.append(Shape("box", (width, depth, height), (0, CUP_HANDLE_R, CUP_HANDLE_Z),
                        colour="cup", name="cup_handle_bar"))
    arm_y0 = CUP_R_OUT - 0.002
    arm_y1 = CUP_HANDLE_R - depth / 2
    for z in (CUP_HANDLE_Z - height / 2 + 0.006, CUP_HANDLE_Z + height / 2 - 0.006):
        shapes.append(Shape("box", (width, arm_y1 - arm_y0, 0.012),
                            (0, (arm_y0 + arm_y1) / 2, z), colour="cup"))
    shapes += support_spheres(
        [(0.072 * math.cos(k * PI / 4), 0.072 * math.sin(k * PI / 4)) for k in range(8)],
        0.004, 0.0)
    body = Body("cup", 0.1, shapes, mu=0.8)
    frame = (
        '    <frame name="cup_handle" attached_to="cup">\n'
        f'      <pose relative_to="cup">0 {f(CUP_HANDLE_R)} {f(CUP_HANDLE_Z)} 0 0 0</pose>\n'
        "    </frame>\n"
    )
    return sdf_file(
        "cup",
        "Cup (SPEC section 6): origin at the centre of the bottom face; outer radius 0.08,\n"
        "     inner 0.07, 0.16 tall (a 0.01 base and 16 tangential wall boxes); a vertical\n"
        "     handle bar 0.024 (radial) x 0.014 (tangential) x 0.10 at radius 0.115 on +y,\n"
        "     joined to the wall by two arms; 0.1 kg. cup_handle = bar centre. Eight\n"
        "     collision spheres flush with the bottom give it a stable support.",
        sdf_body(body) + frame,
    )


# ================================================================================ ladle scene

# LADLE_HANDLE, LADLE_STICK, LADLE_SCOOP: legato_drake/dimensions.py.


def corner_spheres(size, centre, radius: float) -> list[Shape]:
    """Massless collision spheres in the eight corners of a box, flush with its faces."""
    half = np.asarray(size) / 2 - radius
    return [Shape("sph", (radius,), (centre[0] + sx * half[0], centre[1] + sy * half[1],
                                     centre[2] + sz * half[2]), role="collision",
                  inertial=False)
            for sx in (1, -1) for sy in (1, -1) for sz in (1, -1)]


def ladle_sdf() -> str:
    """The ladle: handle, stick and scoop boxes in a row along +x; high friction (2)."""
    hx, sx, cx = LADLE_HANDLE[0], LADLE_STICK[0], LADLE_SCOOP[0]
    handle_c = (hx / 2, 0.0, 0.0)
    scoop_c = (hx + sx + cx / 2, 0.0, 0.0)
    shapes = [
        Shape("box", LADLE_HANDLE, handle_c, colour="ladle_handle"),
        Shape("box", LADLE_STICK, (hx + sx / 2, 0, 0), colour="ladle"),
        Shape("box", LADLE_SCOOP, scoop_c, colour="ladle"),
        *corner_spheres(LADLE_HANDLE, handle_c, 0.004),
        *corner_spheres(LADLE_SCOOP, scoop_c, 0.004),
    ]
    body = Body("ladle", 0.2, shapes, mu=2.0)
    frame = (
        '    <frame name="ladle_handle" attached_to="ladle">\n'
        f'      <pose relative_to="ladle">{f(hx / 2)} 0 0 0 0 0</pose>\n'
        "    </frame>\n"
    )
    return sdf_file(
        "ladle",
        "Ladle (SPEC section 6): along +x from the origin at the handle's end: handle\n"
        "     0.08 x 0.04 x 0.04, stick 0.12 x 0.02 x 0.02, scoop 0.06 x 0.06 x 0.03, all\n"
        "     centred on the x axis; 0.2 kg; friction 2 (SPEC: the ladle needs more grip).\n"
        "     ladle_handle = handle centre. Collision spheres in the handle's and scoop's\n"
        "     corners give it a stable multi-point support under point contact.",
        sdf_body(body) + frame,
    )


# CASE_INTERIOR, CASE_WALL, CASE_BASE, CASE_WALL_H: legato_drake/dimensions.py.


def case_sdf() -> str:
    """The utensil case: an open tray (interior 0.16 x 0.26, walls 0.04 above its floor)."""
    ix, iy = CASE_INTERIOR
    ox, oy = ix + 2 * CASE_WALL, iy + 2 * CASE_WALL
    z_wall = CASE_BASE + CASE_WALL_H / 2
    shapes = [
        Shape("box", (ox, oy, CASE_BASE), (0, 0, CASE_BASE / 2), colour="case"),
        Shape("box", (CASE_WALL, oy, CASE_WALL_H), ((ix + CASE_WALL) / 2, 0, z_wall),
              colour="case"),
        Shape("box", (CASE_WALL, oy, CASE_WALL_H), (-(ix + CASE_WALL) / 2, 0, z_wall),
              colour="case"),
        Shape("box", (ix, CASE_WALL, CASE_WALL_H), (0, (iy + CASE_WALL) / 2, z_wall),
              colour="case"),
        Shape("box", (ix, CASE_WALL, CASE_WALL_H), (0, -(iy + CASE_WALL) / 2, z_wall),
              colour="case"),
        *box_corners((ox, oy), 0.005, 0.0),
    ]
    body = Body("case", 0.5, shapes, mu=0.7)
    frame = (
        '    <frame name="case_floor" attached_to="case">\n'
        f'      <pose relative_to="case">0 0 {f(CASE_BASE)} 0 0 0</pose>\n'
        "    </frame>\n"
    )
    return sdf_file(
        "case",
        "Utensil case (SPEC section 6, ladle task): origin at the centre of the bottom face;\n"
        "     0.01 floor plate, interior 0.16 (x) x 0.26 (y), 0.01 walls 0.04 high above the\n"
        "     floor; 0.5 kg. case_floor = centre of the floor's top face. Four collision\n"
        "     spheres flush with the bottom give it a stable support.",
        sdf_body(body) + frame,
    )


PACKAGE_XML = """<?xml version="1.0"?>
<package format="2">
  <name>legato_drake</name>
  <version>0.1.0</version>
  <description>Primitive-geometry simulation models of legato-drake (LEGATO gripper,
    Abstract and Panda embodiments, lid task scene).</description>
  <maintainer email="legato-drake@example.com">legato-drake</maintainer>
  <license>MIT</license>
</package>
"""


def model_files() -> dict[str, str]:
    """Every file this script writes: name -> text."""
    return {
        "package.xml": PACKAGE_XML,
        "legato_gripper.sdf": gripper_sdf(),
        "abstract.urdf": abstract_urdf(),
        "panda.urdf": panda_urdf(),
        "spot.urdf": spot_urdf(),
        "google_robot.urdf": google_robot_urdf(),
        "gr1.urdf": gr1_urdf(),
        "table.sdf": table_sdf(),
        "stove.sdf": stove_sdf(),
        "pot.sdf": pot_sdf(),
        "lid.sdf": lid_sdf(),
        "shelf.sdf": shelf_sdf(),
        "cup.sdf": cup_sdf(),
        "ladle.sdf": ladle_sdf(),
        "case.sdf": case_sdf(),
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="Writes the primitive-geometry model files.")
    parser.add_argument("--out", type=Path, default=HERE,
                        help="folder to write them to (default: this one, models/)")
    out = parser.parse_args(argv).out
    out.mkdir(parents=True, exist_ok=True)
    for name, text in model_files().items():
        (out / name).write_text(text)
        print("wrote", out / name)


if __name__ == "__main__":
    main()
