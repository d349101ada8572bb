"""The model files in models/ load offline in Drake and honour their naming and geometry contract.

Each model is parsed with strict parsing (every URDF/SDFormat warning is an error) into a fresh
MultibodyPlant(time_step=0.002) wired to a SceneGraph, with the package map resolving
``package://legato_drake/...`` to models/.
"""

from __future__ import annotations

import importlib.util
import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest
from pydrake.geometry import Box, Cylinder, Role, Sphere
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.multibody.parsing import PackageMap, Parser
from pydrake.multibody.plant import (
    AddMultibodyPlant,
    AddMultibodyPlantSceneGraph,
    MultibodyPlantConfig,
)
from pydrake.multibody.tree import PrismaticJoint, RevoluteJoint, WeldJoint
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from legato_drake.dimensions import (
    CASE_INTERIOR,
    GR1_PELVIS_HEIGHT,
    GRIPPER_OPEN,
    POT_HEIGHT,
    SPOT_HIP_X,
    SPOT_HIP_X_LIMITS,
    SPOT_HIP_Y,
    SPOT_HIP_Y_LIMITS,
    SPOT_KNEE,
    SPOT_KNEE_LIMITS,
    SPOT_LEG_SIGNS,
    SPOT_NOMINAL_BODY_POSE,
)

MODEL_FILES = (
    "legato_gripper.sdf",
    "abstract.urdf",
    "panda.urdf",
    "spot.urdf",
    "google_robot.urdf",
    "gr1.urdf",
    "table.sdf",
    "stove.sdf",
    "pot.sdf",
    "lid.sdf",
    "shelf.sdf",
    "cup.sdf",
    "ladle.sdf",
    "case.sdf",
)
PANDA_LIMITS = {  # name: (lower, upper, effort, velocity)
    "panda_joint1": (-2.8973, 2.8973, 87.0, 2.175),
    "panda_joint2": (-1.7628, 1.7628, 87.0, 2.175),
    "panda_joint3": (-2.8973, 2.8973, 87.0, 2.175),
    "panda_joint4": (-3.0718, -0.0698, 87.0, 2.175),
    "panda_joint5": (-2.8973, 2.8973, 12.0, 2.61),
    "panda_joint6": (-0.0175, 3.7525, 12.0, 2.61),
    "panda_joint7": (-2.8973, 2.8973, 12.0, 2.61),
}
PANDA_MASSES = (4.0, 4.0, 3.0, 3.0, 2.0, 2.0, 2.0, 1.5, 0.1)


@pytest.fixture(scope="module")
def models_dir() -> Path:
    return Path(__file__).parents[1] / "models"


class Loaded:
    """A finalized plant holding one model (`weld` welded to the world at `X_weld`, if given)."""

    def __init__(self, models_dir: Path, filename: str, weld: str | None = None,
                 X_weld: RigidTransform | None = None):
        builder = DiagramBuilder()
        self.plant, self.scene_graph = AddMultibodyPlantSceneGraph(builder, time_step=0.002)
        parser = Parser(self.plant)
        parser.SetStrictParsing()
        parser.package_map().Add("legato_drake", str(models_dir))
        (self.model,) = parser.AddModels(url=f"package://legato_drake/{filename}")
        if weld is not None:
            self.plant.WeldFrames(
                self.plant.world_frame(),
                self.plant.GetFrameByName(weld, self.model),
                RigidTransform() if X_weld is None else X_weld,
            )
        self.plant.Finalize()
        self.context = self.plant.CreateDefaultContext()
        self.inspector = self.scene_graph.model_inspector()

    def bodies(self):
        return [self.plant.get_body(i) for i in self.plant.GetBodyIndices(self.model)]

    def joint(self, name: str):
        return self.plant.GetJointByName(name, self.model)

    def frame(self, name: str):
        return self.plant.GetFrameByName(name, self.model)

    def pose(self, frame: str, relative_to: str) -> RigidTransform:
        return self.frame(frame).CalcPose(self.context, self.frame(relative_to))

    def collisions(self, body: str):
        return self.plant.GetCollisionGeometriesForBody(self.plant.GetBodyByName(body, self.model))

    def friction(self, geometry_id):
        props = self.inspector.GetProximityProperties(geometry_id)
        return props.GetProperty("material", "coulomb_friction")

    def actuator_names(self):
        return [
            self.plant.get_joint_actuator(i).name()
            for i in self.plant.GetJointActuatorIndices(self.model)
        ]

    def geometry_pose_in_body(self, geometry_id) -> RigidTransform:
        return self.inspector.GetPoseInFrame(geometry_id)


def axis_in_parent_body(joint) -> np.ndarray:
    """The joint axis expressed in the parent body's frame."""
    axis = joint.translation_axis() if isinstance(joint, PrismaticJoint) else joint.revolute_axis()
    return joint.frame_on_parent().GetFixedPoseInBodyFrame().rotation() @ axis


@pytest.fixture(scope="module")
def gripper(models_dir) -> Loaded:
    return Loaded(models_dir, "legato_gripper.sdf", weld="gripper_base")


@pytest.fixture(scope="module")
def panda(models_dir) -> Loaded:
    return Loaded(models_dir, "panda.urdf", weld="panda_link0")


@pytest.fixture(scope="module")
def abstract(models_dir) -> Loaded:
    return Loaded(models_dir, "abstract.urdf", weld="abstract_root")


# ---------------------------------------------------------------------------- all files


def test_package_xml_names_the_package(models_dir):
    package_map = PackageMap.MakeEmpty()
    package_map.AddPackageXml(str(models_dir / "package.xml"))
    assert Path(package_map.GetPath("legato_drake")) == models_dir.resolve()


@pytest.mark.parametrize("filename", MODEL_FILES)
def test_file_is_offline_primitive_only(models_dir, filename):
    text = (models_dir / filename).read_text()
    assert "drake_models" not in text
    assert "<mesh" not in text and "http://" not in text.replace("http://drake.mit.edu", "")
    assert "<world" not in text and 'name="world"' not in text  # no world joint
    assert "<static>" not in text


@pytest.mark.parametrize("filename", MODEL_FILES)
def test_every_body_has_valid_mass_and_inertia(models_dir, filename):
    loaded = Loaded(models_dir, filename)
    for body in loaded.bodies():
        assert body.default_mass() > 0, body.name()
        spatial_inertia = body.default_spatial_inertia()
        assert spatial_inertia.IsPhysicallyValid(), body.name()
        about_com = spatial_inertia.Shift(spatial_inertia.get_com())
        moments = np.linalg.eigvalsh(about_com.CalcRotationalInertia().CopyToFullMatrix3())
        assert np.all(moments > 0), body.name()


@pytest.mark.parametrize("filename", [f for f in MODEL_FILES if f != "abstract.urdf"])
def test_every_collision_geometry_has_friction(models_dir, filename):
    loaded = Loaded(models_dir, filename)
    count = 0
    for body in loaded.bodies():
        for geometry_id in loaded.plant.GetCollisionGeometriesForBody(body):
            props = loaded.inspector.GetProximityProperties(geometry_id)
            assert props.HasProperty("material", "coulomb_friction"), body.name()
            count += 1
    assert count > 0


def test_generator_reproduces_the_files(models_dir):
    """The committed files equal what models/generate_models.py writes (edit that, rerun it)."""
    spec = importlib.util.spec_from_file_location(
        "legato_generate_models", models_dir / "generate_models.py"
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while it executes
    try:
        spec.loader.exec_module(module)
    finally:
        del sys.modules[spec.name]
    expected = module.model_files()
    written = {p.name for p in models_dir.iterdir() if p.suffix in (".sdf", ".urdf", ".xml")}
    assert set(expected) == written, "every model file is generated"
    for name, text in expected.items():
        problem = text_difference((models_dir / name).read_text(), text)
        assert problem is None, f"{name}: {problem}; rerun generate_models.py"


NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
"""A decimal number in a model file (integers, decimals and exponents)."""


def text_difference(committed: str, generated: str, rel_tol: float = 1e-9,
                    abs_tol: float = 1e-12) -> str | None:
    """Where two model texts differ (None if they agree): the non-numeric text must be
    identical and the numbers equal within ``rel_tol`` (relative) or ``abs_tol``, so the
    last digits that numpy/BLAS builds compute differently do not matter, but a changed
    dimension, mass or name does."""
    pieces = [NUMBER.split(committed), NUMBER.split(generated)]
    numbers = [NUMBER.findall(committed), NUMBER.findall(generated)]
    if len(numbers[0]) != len(numbers[1]) or pieces[0] != pieces[1]:
        for i, (a, b) in enumerate(zip(pieces[0], pieces[1], strict=False)):
            if a != b:
                line = 1 + "".join(pieces[0][:i]).count("\n")
                return f"text differs near line {line}: {a[:60]!r} vs {b[:60]!r}"
        return f"{len(numbers[0])} numbers in the file, {len(numbers[1])} generated"
    for i, (a, b) in enumerate(zip(numbers[0], numbers[1], strict=True)):
        if not math.isclose(float(a), float(b), rel_tol=rel_tol, abs_tol=abs_tol):
            line = 1 + "".join(pieces[0][:i + 1]).count("\n")
            return f"number {i} (line {line}) is {a} in the file, {b} generated"
    return None


def test_text_difference_ignores_last_digits_only():
    text = '<origin xyz="0 0.01 -0.155" rpy="0 0.08673833867598359 -1.5707963267948966"/>'
    assert text_difference(text, text.replace("598359", "598486")) is None
    assert "number 2" in text_difference(text, text.replace("-0.155", "-0.156"))
    assert "text differs" in text_difference(text, text.replace("rpy", "rqy"))
    assert text_difference(text, text.replace('"0 0.01', '"0 0 0.01')) is not None
    assert text_difference("a 1e-14", "a 0") is None


# ---------------------------------------------------------------------------- gripper


def test_gripper_names_and_mass(gripper):
    plant = gripper.plant
    assert plant.GetModelInstanceName(gripper.model) == "legato_gripper"
    names = {b.name() for b in gripper.bodies()}
    assert names == {"gripper_base", "left_finger", "right_finger"}
    assert plant.GetBodyByName("gripper_base").default_mass() == pytest.approx(0.16)
    assert plant.GetBodyByName("left_finger").default_mass() == pytest.approx(0.095)
    assert plant.GetBodyByName("right_finger").default_mass() == pytest.approx(0.095)
    total = plant.CalcTotalMass(gripper.context, [gripper.model])
    assert total == pytest.approx(0.35)
    for frame in ("gripper_tcp", "left_camera_optical", "right_camera_optical"):
        assert gripper.frame(frame).body().name() == "gripper_base"
    assert sorted(gripper.actuator_names()) == ["left_finger_joint", "right_finger_joint"]


@pytest.mark.parametrize(
    ("joint_name", "child", "axis"),
    [
        ("left_finger_joint", "left_finger", (0, 1, 0)),
        ("right_finger_joint", "right_finger", (0, -1, 0)),
    ],
)
def test_gripper_finger_joints(gripper, joint_name, child, axis):
    joint = gripper.joint(joint_name)
    assert isinstance(joint, PrismaticJoint)
    assert joint.parent_body().name() == "gripper_base"
    assert joint.child_body().name() == child
    np.testing.assert_allclose(axis_in_parent_body(joint), axis, atol=1e-12)
    np.testing.assert_allclose(
        joint.frame_on_parent().GetFixedPoseInBodyFrame().translation(), [0.07, 0, 0], atol=1e-12
    )
    assert joint.position_lower_limits()[0] == pytest.approx(0.0)
    assert joint.position_upper_limits()[0] == pytest.approx(GRIPPER_OPEN)
    assert joint.velocity_upper_limits()[0] == pytest.approx(0.2)
    assert joint.default_damping_vector()[0] == pytest.approx(0.1)
    actuator = gripper.plant.GetJointActuatorByName(joint_name, gripper.model)
    assert actuator.effort_limit() == pytest.approx(40.0)


def inner_pad_gap(gripper: Loaded, q: float) -> float:
    """Distance between the pads' inner faces (each finger frame's y = 0 plane)."""
    gripper.plant.SetPositions(gripper.context, gripper.model, [q, q])
    left = gripper.pose("left_finger", "gripper_base").translation()
    right = gripper.pose("right_finger", "gripper_base").translation()
    return left[1] - right[1]


def test_gripper_finger_gap(gripper):
    assert inner_pad_gap(gripper, GRIPPER_OPEN) == pytest.approx(2 * GRIPPER_OPEN)
    assert inner_pad_gap(gripper, 0.0) == pytest.approx(0.0, abs=1e-12)
    # The left inner face is at y = q, the right at y = -q, both at x = 0.07.
    gripper.plant.SetPositions(gripper.context, gripper.model, [0.03, 0.03])
    np.testing.assert_allclose(
        gripper.pose("left_finger", "gripper_base").translation(), [0.07, 0.03, 0], atol=1e-12
    )
    np.testing.assert_allclose(
        gripper.pose("right_finger", "gripper_base").translation(), [0.07, -0.03, 0], atol=1e-12
    )


@pytest.mark.parametrize(("finger", "side"), [("left_finger", 1.0), ("right_finger", -1.0)])
def test_gripper_pads(gripper, finger, side):
    pads = []
    for geometry_id in gripper.collisions(finger):
        shape = gripper.inspector.GetShape(geometry_id)
        if isinstance(shape, Sphere):
            pads.append(geometry_id)
            assert shape.radius() == pytest.approx(0.004)
            friction = gripper.friction(geometry_id)
            assert friction.static_friction() == pytest.approx(0.7)
            assert friction.dynamic_friction() == pytest.approx(0.7)
        else:
            assert isinstance(shape, Box)
            np.testing.assert_allclose(shape.size(), [0.09, 0.012, 0.03])
            centre = gripper.geometry_pose_in_body(geometry_id).translation()
            np.testing.assert_allclose(centre, [0.045, side * 0.006, 0], atol=1e-12)
    assert len(pads) == 6
    centres = sorted(
        tuple(np.round(gripper.geometry_pose_in_body(g).translation(), 9)) for g in pads
    )
    expected = sorted((x, side * 0.003, z) for x in (0.045, 0.065, 0.085) for z in (-0.01, 0.01))
    np.testing.assert_allclose(centres, expected, atol=1e-9)
    # Each pad protrudes 1 mm past the inner face (y = 0) toward the other finger.
    for centre in centres:
        assert side * centre[1] - 0.004 == pytest.approx(-0.001)


def test_gripper_self_collision_is_filtered(gripper):
    bodies = ("gripper_base", "left_finger", "right_finger")
    ids = [g for b in bodies for g in gripper.collisions(b)]
    assert len(ids) == 1 + 7 + 7
    for i, a in enumerate(ids):
        for b in ids[i + 1 :]:
            assert gripper.inspector.CollisionFiltered(a, b)


def test_gripper_tcp_and_cameras(gripper):
    X_tcp = gripper.frame("gripper_tcp").GetFixedPoseInBodyFrame()
    np.testing.assert_allclose(X_tcp.translation(), [0.14, 0, 0], atol=1e-12)
    np.testing.assert_allclose(X_tcp.rotation().matrix(), np.eye(3), atol=1e-12)
    for name, y in (("left_camera_optical", 0.032), ("right_camera_optical", -0.032)):
        X_BC = gripper.frame(name).GetFixedPoseInBodyFrame()
        np.testing.assert_allclose(X_BC.translation(), [0.02, y, 0.0525], atol=1e-12)
        R = X_BC.rotation().matrix()
        np.testing.assert_allclose(R[:, 2], [1, 0, 0], atol=1e-12)  # looks along gripper +x
        np.testing.assert_allclose(R[:, 0], [0, -1, 0], atol=1e-12)  # image right = -y
        np.testing.assert_allclose(R[:, 1], [0, 0, -1], atol=1e-12)  # image down = -z
    # The left camera is the one on the gripper's left (+y).
    left = gripper.frame("left_camera_optical").GetFixedPoseInBodyFrame().translation()
    right = gripper.frame("right_camera_optical").GetFixedPoseInBodyFrame().translation()
    assert left[1] - right[1] == pytest.approx(0.064)


def test_gripper_housing_and_camera_bar(gripper):
    (housing,) = gripper.collisions("gripper_base")
    np.testing.assert_allclose(gripper.inspector.GetShape(housing).size(), [0.07, 0.13, 0.05])
    np.testing.assert_allclose(
        gripper.geometry_pose_in_body(housing).translation(), [0.035, 0, 0], atol=1e-12
    )
    base_frame = gripper.plant.GetBodyFrameIdOrThrow(
        gripper.plant.GetBodyByName("gripper_base").index()
    )
    visuals = gripper.inspector.GetGeometries(base_frame, Role.kPerception)
    assert len(visuals) == 2  # housing + camera bar (visual only)


# ---------------------------------------------------------------------------- abstract


ABSTRACT_JOINTS = [
    ("abstract_x", PrismaticJoint, (1, 0, 0), -2.0, 2.0),
    ("abstract_y", PrismaticJoint, (0, 1, 0), -2.0, 2.0),
    ("abstract_z", PrismaticJoint, (0, 0, 1), 0.0, 2.0),
    ("abstract_roll", RevoluteJoint, (1, 0, 0), -3.14159, 3.14159),
    ("abstract_pitch", RevoluteJoint, (0, 1, 0), -1.5, 1.5),
    ("abstract_yaw", RevoluteJoint, (0, 0, 1), -3.14159, 3.14159),
]
ABSTRACT_LINKS = [
    "abstract_root",
    "abstract_x_link",
    "abstract_y_link",
    "abstract_z_link",
    "abstract_roll_link",
    "abstract_pitch_link",
    "abstract_mount",
]


def test_abstract_chain(abstract):
    assert abstract.plant.GetModelInstanceName(abstract.model) == "abstract"
    assert [b.name() for b in abstract.bodies()] == ABSTRACT_LINKS
    for body in abstract.bodies():
        assert body.default_mass() == pytest.approx(0.01)
    for (name, kind, axis, lower, upper), parent, child in zip(
        ABSTRACT_JOINTS, ABSTRACT_LINKS[:-1], ABSTRACT_LINKS[1:], strict=True
    ):
        joint = abstract.joint(name)
        assert isinstance(joint, kind), name
        assert joint.parent_body().name() == parent
        assert joint.child_body().name() == child
        np.testing.assert_allclose(axis_in_parent_body(joint), axis, atol=1e-12)
        X_PF = joint.frame_on_parent().GetFixedPoseInBodyFrame()
        assert X_PF.IsExactlyIdentity()
        assert joint.position_lower_limits()[0] == pytest.approx(lower)
        assert joint.position_upper_limits()[0] == pytest.approx(upper)
        assert joint.velocity_upper_limits()[0] == pytest.approx(2.0)
        actuator = abstract.plant.GetJointActuatorByName(f"{name}_motor", abstract.model)
        assert actuator.joint().name() == name
        assert actuator.effort_limit() == pytest.approx(1000.0)
    assert abstract.actuator_names() == [f"{j[0]}_motor" for j in ABSTRACT_JOINTS]
    assert abstract.plant.num_positions() == 6


def test_abstract_moves_mount_as_six_dof(abstract):
    plant, context = abstract.plant, abstract.context
    q = [0.1, -0.3, 0.8, 0.2, -0.3, 0.4]
    plant.SetPositions(context, abstract.model, q)
    X = abstract.pose("abstract_mount", "abstract_root")
    np.testing.assert_allclose(X.translation(), q[:3], atol=1e-12)
    expected = (
        RotationMatrix.MakeXRotation(q[3])
        @ RotationMatrix.MakeYRotation(q[4])
        @ RotationMatrix.MakeZRotation(q[5])
    )
    np.testing.assert_allclose(X.rotation().matrix(), expected.matrix(), atol=1e-12)


# ---------------------------------------------------------------------------- panda


def franka_fk(q) -> np.ndarray:
    """Flange pose in panda_link0 from Franka's published modified-DH (Craig) parameters."""
    a = [0, 0, 0, 0.0825, -0.0825, 0, 0.088, 0]
    d = [0.333, 0, 0.316, 0, 0.384, 0, 0, 0.107]
    alpha = [0, -math.pi / 2, math.pi / 2, math.pi / 2, -math.pi / 2, math.pi / 2, math.pi / 2, 0]
    theta = [*q, 0.0]
    T = np.eye(4)
    for ai, di, al, th in zip(a, d, alpha, theta, strict=True):
        ca, sa, ct, st = math.cos(al), math.sin(al), math.cos(th), math.sin(th)
        T = T @ np.array(
            [
                [ct, -st, 0, ai],
                [st * ca, ct * ca, -sa, -sa * di],
                [st * sa, ct * sa, ca, ca * di],
                [0, 0, 0, 1],
            ]
        )
    return T


def test_panda_names_and_masses(panda):
    plant = panda.plant
    assert plant.GetModelInstanceName(panda.model) == "panda"
    names = [f"panda_link{i}" for i in range(9)]
    assert [b.name() for b in panda.bodies()] == names
    for name, mass in zip(names, PANDA_MASSES, strict=True):
        assert plant.GetBodyByName(name, panda.model).default_mass() == pytest.approx(mass)
    assert isinstance(panda.joint("panda_joint8"), WeldJoint)
    assert panda.joint("panda_joint8").parent_body().name() == "panda_link7"
    assert panda.joint("panda_joint8").child_body().name() == "panda_link8"
    assert panda.actuator_names() == [f"panda_joint{i}_motor" for i in range(1, 8)]
    assert plant.num_positions() == 7


def test_panda_joints_and_limits(panda):
    for i, (name, (lower, upper, effort, velocity)) in enumerate(PANDA_LIMITS.items()):
        joint = panda.joint(name)
        assert isinstance(joint, RevoluteJoint)
        np.testing.assert_allclose(joint.revolute_axis(), [0, 0, 1])
        assert joint.parent_body().name() == f"panda_link{i}"
        assert joint.child_body().name() == f"panda_link{i + 1}"
        assert joint.position_lower_limits()[0] == pytest.approx(lower)
        assert joint.position_upper_limits()[0] == pytest.approx(upper)
        assert joint.velocity_upper_limits()[0] == pytest.approx(velocity)
        actuator = panda.plant.GetJointActuatorByName(f"{name}_motor", panda.model)
        assert actuator.joint().name() == name
        assert actuator.effort_limit() == pytest.approx(effort)


def test_panda_forward_kinematics(panda):
    plant, context = panda.plant, panda.context
    # q = 0: 0.333 + 0.316 + 0.384 - 0.107 = 0.926 high, 0.0825 - 0.0825 + 0.088 forward,
    # flange z pointing down (link8 = link0 rotated pi about x).
    plant.SetPositions(context, panda.model, np.zeros(7))
    X = panda.pose("panda_link8", "panda_link0")
    np.testing.assert_allclose(X.translation(), [0.088, 0, 0.926], atol=1e-12)
    np.testing.assert_allclose(
        X.rotation().matrix(), RotationMatrix.MakeXRotation(math.pi).matrix(), atol=1e-12
    )
    rng = np.random.default_rng(0)
    lower = plant.GetPositionLowerLimits()
    upper = plant.GetPositionUpperLimits()
    home = np.array([-0.125, 0.2, -0.125, -0.7, 0.75, 0.5, -0.666]) * math.pi
    assert np.all(home > lower) and np.all(home < upper)
    for q in [home, *rng.uniform(lower, upper, size=(5, 7))]:
        plant.SetPositions(context, panda.model, q)
        np.testing.assert_allclose(
            panda.pose("panda_link8", "panda_link0").GetAsMatrix4(), franka_fk(q), atol=1e-12
        )


def test_panda_collision_geometry_and_filter(panda):
    ids = []
    for i in range(1, 9):
        link_ids = panda.collisions(f"panda_link{i}")
        assert link_ids, f"panda_link{i} has no collision geometry"
        ids += link_ids
    ids += panda.collisions("panda_link0")
    for i, a in enumerate(ids):
        for b in ids[i + 1 :]:
            assert panda.inspector.CollisionFiltered(a, b)


# ---------------------------------------------------------------------------- lid scene


def single_body(models_dir: Path, filename: str, model: str, body: str) -> Loaded:
    loaded = Loaded(models_dir, filename)
    assert loaded.plant.GetModelInstanceName(loaded.model) == model
    assert [b.name() for b in loaded.bodies()] == [body]
    return loaded


def test_table(models_dir):
    table = single_body(models_dir, "table.sdf", "table", "table_top")
    assert table.plant.GetBodyByName("table_top").default_mass() == pytest.approx(20.0)
    (top,) = table.collisions("table_top")
    np.testing.assert_allclose(table.inspector.GetShape(top).size(), [1.3, 2.0, 0.04])
    np.testing.assert_allclose(table.geometry_pose_in_body(top).translation(), [0, 0, -0.02])
    assert table.friction(top).static_friction() == pytest.approx(0.7)


def test_stove(models_dir):
    stove = single_body(models_dir, "stove.sdf", "stove", "stove")
    assert stove.plant.GetBodyByName("stove").default_mass() == pytest.approx(1.0)
    ids = stove.collisions("stove")
    (box,) = [g for g in ids if isinstance(stove.inspector.GetShape(g), Box)]
    np.testing.assert_allclose(stove.inspector.GetShape(box).size(), [0.30, 0.24, 0.02])
    np.testing.assert_allclose(stove.geometry_pose_in_body(box).translation(), [0, 0, 0])
    for geometry_id in ids:
        assert stove.friction(geometry_id).static_friction() == pytest.approx(0.7)
    # Support spheres at the bottom corners: inside the box, their lowest points flush with
    # its bottom face (point contact would otherwise give the box a single, rocking point).
    spheres = [g for g in ids if isinstance(stove.inspector.GetShape(g), Sphere)]
    assert len(spheres) == 4
    for geometry_id in spheres:
        r = stove.inspector.GetShape(geometry_id).radius()
        p = stove.geometry_pose_in_body(geometry_id).translation()
        assert p[2] - r == pytest.approx(-0.01)
        assert abs(p[0]) + r <= 0.15 + 1e-12 and abs(p[1]) + r <= 0.12 + 1e-12


def test_pot(models_dir):
    pot = single_body(models_dir, "pot.sdf", "pot", "pot")
    assert pot.plant.GetBodyByName("pot").default_mass() == pytest.approx(0.4)
    np.testing.assert_allclose(
        pot.frame("pot_rim").GetFixedPoseInBodyFrame().translation(), [0, 0, POT_HEIGHT]
    )
    walls, handles, base, feet = [], [], [], []
    for geometry_id in pot.collisions("pot"):
        if pot.inspector.GetShape(geometry_id).__class__.__name__ == "Sphere":
            feet.append(pot.geometry_pose_in_body(geometry_id).translation()
                        - [0, 0, pot.inspector.GetShape(geometry_id).radius()])
            continue
        size = pot.inspector.GetShape(geometry_id).size()
        X = pot.geometry_pose_in_body(geometry_id)
        assert pot.friction(geometry_id).static_friction() == pytest.approx(0.5)
        if size[2] == pytest.approx(0.09):
            walls.append((size, X))
        elif size[0] == pytest.approx(0.2):
            base.append((size, X))
        else:
            handles.append((size, X))
    assert len(base) == 1 and len(walls) == 16 and len(handles) == 2 and len(feet) == 4
    np.testing.assert_allclose(np.array(feet)[:, 2], 0.0, atol=1e-12)  # flush with the bottom
    np.testing.assert_allclose(base[0][1].translation(), [0, 0, 0.005])
    for size, X in walls:
        p = X.translation()
        assert size[0] == pytest.approx(0.008)
        assert p[2] == pytest.approx(0.055)  # standing on the 0.01 base plate, up to 0.1
        # Outer face tangent to the 0.095 circle; radial axis = the box's x axis.
        radial = X.rotation().matrix()[:, 0]
        assert np.dot(p[:2], radial[:2]) + size[0] / 2 == pytest.approx(0.095)
        # Neighbouring boxes close the ring at the outer radius.
        assert size[1] == pytest.approx(2 * 0.095 * math.tan(math.pi / 16))
    for size, X in handles:
        assert X.translation()[2] == pytest.approx(0.085)
        assert abs(X.translation()[1]) - size[1] / 2 < 0.095  # attached to the wall
    assert sorted(np.sign(X.translation()[1]) for _, X in handles) == [-1, 1]


def test_lid(models_dir):
    lid = single_body(models_dir, "lid.sdf", "lid", "lid")
    body = lid.plant.GetBodyByName("lid")
    assert body.default_mass() == pytest.approx(0.16)
    np.testing.assert_allclose(
        lid.frame("lid_handle").GetFixedPoseInBodyFrame().translation(), [0, 0, 0.045]
    )
    shapes = {}
    for geometry_id in lid.collisions("lid"):
        assert lid.friction(geometry_id).static_friction() == pytest.approx(0.8)
        shape = lid.inspector.GetShape(geometry_id)
        shapes.setdefault(type(shape), []).append((shape, lid.geometry_pose_in_body(geometry_id)))
    for sphere, X in shapes[Sphere]:  # support spheres flush with the disc's bottom face
        assert X.translation()[2] - sphere.radius() == pytest.approx(-0.005)
        assert np.linalg.norm(X.translation()[:2]) + sphere.radius() < 0.11
    ((disc, X_disc),) = shapes[Cylinder]
    assert disc.radius() == pytest.approx(0.11) and disc.length() == pytest.approx(0.01)
    np.testing.assert_allclose(X_disc.translation(), [0, 0, 0])
    boxes = sorted(shapes[Box], key=lambda sx: -sx[0].size()[1])
    bar, posts = boxes[0], boxes[1:]
    np.testing.assert_allclose(bar[0].size(), [0.02, 0.08, 0.02])
    np.testing.assert_allclose(bar[1].translation(), [0, 0, 0.045])
    assert sorted(X.translation()[1] for _, X in posts) == pytest.approx([-0.034, 0.034])
    for shape, X in posts:
        bottom = X.translation()[2] - shape.size()[2] / 2
        top = X.translation()[2] + shape.size()[2] / 2
        assert bottom == pytest.approx(0.005) and top == pytest.approx(0.035)
    # The handle (bar + posts) carries about 0.04 kg: the centre of mass sits above the disc.
    com = body.default_com()
    assert 0.005 < com[2] < 0.02


def test_colours_are_distinct_in_grayscale(models_dir):
    """Table, stove, pot, lid, gripper visuals differ in brightness (luma) by >= 0.1."""

    def luma(filename):
        text = (models_dir / filename).read_text()
        rgba = [float(v) for v in re.search(r"<diffuse>([^<]+)</diffuse>", text).group(1).split()]
        return 0.299 * rgba[0] + 0.587 * rgba[1] + 0.114 * rgba[2]

    values = sorted(
        luma(f) for f in ("table.sdf", "stove.sdf", "pot.sdf", "lid.sdf", "legato_gripper.sdf")
    )
    assert min(np.diff(values)) >= 0.1


# ---------------------------------------------------------------------------- dynamics


def scene_simulator(models_dir: Path, filenames, welds):
    builder = DiagramBuilder()
    config = MultibodyPlantConfig(time_step=0.002, discrete_contact_approximation="sap")
    plant, _ = AddMultibodyPlant(config, builder)
    parser = Parser(plant)
    parser.SetStrictParsing()
    parser.package_map().Add("legato_drake", str(models_dir))
    for filename in filenames:
        parser.AddModels(url=f"package://legato_drake/{filename}")
    for frame, X in welds.items():
        plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(frame), X)
    plant.Finalize()
    simulator = Simulator(builder.Build())
    return plant, simulator, plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())


def test_stove_pot_lid_settle_on_the_table(models_dir):
    """Dropped a few mm, the stack rests at its nominal heights (no rocking, no sinking)."""
    plant, simulator, context = scene_simulator(
        models_dir,
        ["table.sdf", "stove.sdf", "pot.sdf", "lid.sdf"],
        {"table_top": RigidTransform([0.5, 0, 0.7])},
    )
    plant.SetFreeBodyPose(context, plant.GetBodyByName("stove"), RigidTransform([0.68, 0, 0.713]))
    plant.SetFreeBodyPose(context, plant.GetBodyByName("pot"), RigidTransform([0.68, 0, 0.725]))
    plant.SetFreeBodyPose(
        context,
        plant.GetBodyByName("lid"),
        RigidTransform(RotationMatrix.MakeZRotation(math.pi / 2), [0.6, -0.25, 0.708]),
    )
    simulator.AdvanceTo(0.6)
    expected_z = {"stove": 0.71, "pot": 0.72, "lid": 0.705}
    for name, z in expected_z.items():
        X = plant.GetBodyByName(name).EvalPoseInWorld(context)
        assert X.translation()[2] == pytest.approx(z, abs=1e-3), name
        assert X.rotation().col(2)[2] > math.cos(math.radians(1.0)), name
    # The lid placed on the pot rests on the rim.
    rim = plant.GetFrameByName("pot_rim").CalcPoseInWorld(context).translation()
    plant.SetFreeBodyPose(context, plant.GetBodyByName("lid"), RigidTransform(rim + [0, 0, 0.008]))
    simulator.AdvanceTo(1.2)
    lid = plant.GetBodyByName("lid").EvalPoseInWorld(context).translation()
    assert lid[2] == pytest.approx(rim[2] + 0.005, abs=1e-3)


def test_gripper_pads_hold_the_lid_by_its_handle(models_dir):
    """Gripper pointing down (approach = world -z), tcp on the handle bar, fingers squeezed
    with 10 N each: the lid hangs from the pads (which protrude 1 mm past the fingers)."""
    # Gripper axes in the world: x = -z (down), y = +x (across the bar), z = -y.
    R_WG = RotationMatrix(np.array([[0.0, 1, 0], [0, 0, -1], [-1, 0, 0]]))
    bar = np.array([0.0, 0.0, 1.0])
    plant, simulator, context = scene_simulator(
        models_dir,
        ["legato_gripper.sdf", "lid.sdf"],
        {"gripper_base": RigidTransform(R_WG, bar + [0, 0, 0.14])},
    )
    gripper = plant.GetModelInstanceByName("legato_gripper")
    plant.SetPositions(context, gripper, [GRIPPER_OPEN, GRIPPER_OPEN])
    plant.SetFreeBodyPose(context, plant.GetBodyByName("lid"), RigidTransform(bar - [0, 0, 0.045]))
    plant.get_actuation_input_port(gripper).FixValue(context, [-10.0, -10.0])
    simulator.AdvanceTo(0.5)
    tcp = plant.GetFrameByName("gripper_tcp").CalcPoseInWorld(context).translation()
    np.testing.assert_allclose(tcp, bar, atol=1e-12)
    handle = plant.GetFrameByName("lid_handle").CalcPoseInWorld(context).translation()
    assert np.linalg.norm(handle - bar) < 0.005
    # Rigid pads would stop at q = 0.01 - 0.001; point contact lets them sink in a little.
    q = plant.GetPositions(context, gripper)
    assert q[0] == pytest.approx(q[1], abs=1e-6)
    assert 0.0085 < q[0] < 0.011


# ---------------------------------------------------------------------------- mobile robots
# Spot, the Google Robot and GR-1: each robot is one model whose actuated joints (virtual base
# joints included) all carry a "<joint>_motor" transmission, with no world or floating joint.

PI = math.pi
R = "revolute"
P = "prismatic"
SPOT_ARM_HOME = np.array([0.0, -0.66, 0.66, 0.0, 0.0, 0.0]) * PI
SPOT_ARM = ("arm_sh0", "arm_sh1", "arm_el0", "arm_el1", "arm_wr0", "arm_wr1")
SPOT_BODY_HOME = SPOT_NOMINAL_BODY_POSE
GOOGLE_ARM = ("joint_torso", "joint_shoulder", "joint_bicep", "joint_elbow", "joint_forearm",
              "joint_wrist", "joint_gripper")
GOOGLE_HOME = np.array([0.0, 0.125, 0.0, 0.625, 0.0, -0.25, 0.5]) * PI
GR1_ARM = ("r_shoulder_pitch", "r_shoulder_roll", "r_shoulder_yaw", "r_elbow_pitch",
           "r_wrist_yaw", "r_wrist_roll", "r_wrist_pitch")
GR1_HOME = np.array([0.0, -0.16, 0.33, -0.16, -0.16, 0.0, 0.0]) * PI
GR1_PELVIS = RigidTransform([-0.1, 0.0, GR1_PELVIS_HEIGHT])
TILT = math.radians(25.0)


def spot_leg_rows():
    rows = []
    for leg, (front, side) in SPOT_LEG_SIGNS.items():
        rows += [
            (f"{leg}_hip_x", R, "body", f"{leg}_hip",
             (front * SPOT_HIP_X[0], side * SPOT_HIP_X[1], 0), (0, 0, 0), (1, 0, 0),
             *SPOT_HIP_X_LIMITS),
            (f"{leg}_hip_y", R, f"{leg}_hip", f"{leg}_upper_leg", (0, side * SPOT_HIP_Y, 0),
             (0, 0, 0), (0, 1, 0), *SPOT_HIP_Y_LIMITS),
            (f"{leg}_knee", R, f"{leg}_upper_leg", f"{leg}_lower_leg",
             (SPOT_KNEE[0], 0, SPOT_KNEE[1]), (0, 0, 0), (0, 1, 0), *SPOT_KNEE_LIMITS),
        ]
    return rows


# name, kind, parent, child, xyz, rpy, axis (joint frame), lower, upper
SPOT_JOINTS = [
    ("body_x", P, "spot_world_anchor", "body_x_link", (0, 0, 0), (0, 0, 0), (1, 0, 0), -0.3,
     -0.1),
    ("body_y", P, "body_x_link", "body_y_link", (0, 0, 0), (0, 0, 0), (0, 1, 0), -0.1, 0.1),
    ("body_z", P, "body_y_link", "body_z_link", (0, 0, 0), (0, 0, 0), (0, 0, 1), 0.3, 0.5),
    ("body_roll", R, "body_z_link", "body_roll_link", (0, 0, 0), (0, 0, 0), (1, 0, 0), -PI / 16,
     PI / 16),
    ("body_pitch", R, "body_roll_link", "body_pitch_link", (0, 0, 0), (0, 0, 0), (0, 1, 0),
     -PI / 16, PI / 16),
    ("body_yaw", R, "body_pitch_link", "body", (0, 0, 0), (0, 0, 0), (0, 0, 1), -PI / 16,
     PI / 16),
    *spot_leg_rows(),
    ("arm_sh0", R, "body", "arm_link_sh0", (0.292, 0, 0.188), (0, 0, 0), (0, 0, 1), -2.618, PI),
    ("arm_sh1", R, "arm_link_sh0", "arm_link_sh1", (0, 0, 0), (0, 0, 0), (0, 1, 0), -PI,
     0.5236),
    ("arm_el0", R, "arm_link_sh1", "arm_link_el0", (0.3385, 0, 0), (0, 0, 0), (0, 1, 0), 0.0,
     PI),
    ("arm_el1", R, "arm_link_el0", "arm_link_el1", (0.4033, 0, 0.075), (0, 0, 0), (1, 0, 0),
     -2.7925, 2.7925),
    ("arm_wr0", R, "arm_link_el1", "arm_link_wr0", (0, 0, 0), (0, 0, 0), (0, 1, 0), -1.8326,
     1.8326),
    ("arm_wr1", R, "arm_link_wr0", "arm_link_wr1", (0, 0, 0), (0, 0, 0), (1, 0, 0), -2.88, 2.88),
]
GOOGLE_JOINTS = [
    ("base_x", P, "gr_world_anchor", "base_x_link", (0, 0, 0), (0, 0, 0), (1, 0, 0), -0.6, 0.0),
    ("base_y", P, "base_x_link", "base_y_link", (0, 0, 0), (0, 0, 0), (0, 1, 0), -0.2, 0.4),
    ("base_yaw", R, "base_y_link", "base", (0, 0, 0), (0, 0, 0), (0, 0, 1), -PI, PI),
    ("joint_torso", R, "base", "link_torso", (0, 0, 0.6565), (0, 0, 0), (0, 0, 1), -4.49, 1.35),
    ("joint_shoulder", R, "link_torso", "link_shoulder", (0, -0.167289, 0.113), (0, 0, 0),
     (0, 1, 0), -2.66, 3.18),
    ("joint_bicep", R, "link_shoulder", "link_bicep", (0, 0.002289, 0.215029), (0, 0, 0),
     (0, 0, 1), -2.13, 3.71),
    ("joint_elbow", R, "link_bicep", "link_elbow", (0, -0.064, 0.185036), (0, 0, 0), (0, 1, 0),
     -2.05, 3.79),
    ("joint_forearm", R, "link_elbow", "link_forearm", (0, -0.101, 0.0914359), (0, 0, 0),
     (0, 0, 1), -2.92, 2.92),
    ("joint_wrist", R, "link_forearm", "link_wrist", (0, -0.00604, 0.2735), (0, 0, 0),
     (0, 1, 0), -1.79, 1.79),
    # Upper limit 1.79, not the SPEC's 1.35: the SPEC home 0.5 pi must lie inside.
    ("joint_gripper", R, "link_wrist", "link_gripper", (0, 0.0060384, 0.10911), (0, 0, 0),
     (0, 0, 1), -4.49, 1.79),
]
GR1_JOINTS = [
    ("waist_yaw", R, "pelvis", "waist_yaw_link", (0, 0, 0.0065), (0, 0, 0), (0, 0, 1), -1.05,
     1.05),
    ("waist_pitch", R, "waist_yaw_link", "waist_pitch_link", (0, 0, 0.055), (0, 0, 0),
     (0, 1, 0), -0.52, 1.22),
    ("waist_roll", R, "waist_pitch_link", "torso", (0, 0, 0.085), (0, 0, 0), (1, 0, 0), -0.7,
     0.7),
    ("r_shoulder_pitch", R, "torso", "r_upper_arm_pitch", (0, -0.12664, 0.21725), (-TILT, 0, 0),
     (0, 1, 0), -2.79, 1.92),
    ("r_shoulder_roll", R, "r_upper_arm_pitch", "r_upper_arm_roll", (0, -0.067, 0), (TILT, 0, 0),
     (1, 0, 0), -3.27, 0.57),
    ("r_shoulder_yaw", R, "r_upper_arm_roll", "r_upper_arm_yaw", (0, -0.04, -0.0575), (0, 0, 0),
     (0, 0, 1), -2.97, 2.97),
    ("r_elbow_pitch", R, "r_upper_arm_yaw", "r_lower_arm_pitch", (0, 0, -0.18853), (0, 0, 0),
     (0, 1, 0), -2.27, 2.27),
    ("r_wrist_yaw", R, "r_lower_arm_pitch", "r_hand_yaw", (0, 0, -0.0405), (0, 0, 0), (0, 0, 1),
     -2.97, 2.97),
    ("r_wrist_roll", R, "r_hand_yaw", "r_hand_roll", (0, 0, -0.20153), (0, 0, 0), (1, 0, 0),
     -0.61, 0.61),
    ("r_wrist_pitch", R, "r_hand_roll", "r_hand_pitch", (0, 0, 0), (0, 0, 0), (0, 1, 0), -0.61,
     0.61),
    ("head_yaw", R, "torso", "head_yaw_link", (0, 0, 0.34453), (0, 0, 0), (0, 0, 1), -2.71,
     2.71),
    ("head_pitch", R, "head_yaw_link", "head_pitch_link", (0, 0, 0), (0, 0, 0), (0, 1, 0), -0.5,
     0.5),
    ("head_roll", R, "head_pitch_link", "head", (0, 0, 0), (0, 0, 0), (1, 0, 0), -0.5, 0.5),
]
ROBOTS = {  # file: (weld frame, weld pose, joint table, tool frame, tool parent, tool offset)
    "spot.urdf": ("spot_world_anchor", RigidTransform(), SPOT_JOINTS, "arm_tool", "arm_link_wr1",
                  (0.2, 0, -0.03)),
    "google_robot.urdf": ("gr_world_anchor", RigidTransform(), GOOGLE_JOINTS, "link_tool",
                          "link_gripper", (0, 0, 0.1)),
    "gr1.urdf": ("pelvis", GR1_PELVIS, GR1_JOINTS, "r_hand_tool", "r_hand_pitch", (0, 0, -0.1)),
}


@pytest.fixture(scope="module")
def robots(models_dir) -> dict[str, Loaded]:
    return {name: Loaded(models_dir, name, weld=weld, X_weld=X)
            for name, (weld, X, *_) in ROBOTS.items()}


def set_joint_positions(loaded: Loaded, positions: dict[str, float]) -> None:
    """Sets the named single-DoF joints (the others keep their values)."""
    q = loaded.plant.GetPositions(loaded.context)
    for name, value in positions.items():
        q[loaded.joint(name).position_start()] = value
    loaded.plant.SetPositions(loaded.context, q)


@pytest.mark.parametrize("filename", list(ROBOTS))
def test_robot_joint_table(robots, filename):
    """Every actuated joint: type, parent/child, origin, axis, limits, a `<joint>_motor`."""
    loaded = robots[filename]
    table = ROBOTS[filename][2]
    for name, kind, parent, child, xyz, rpy, axis, lower, upper in table:
        joint = loaded.joint(name)
        assert isinstance(joint, RevoluteJoint if kind == R else PrismaticJoint), name
        assert joint.parent_body().name() == parent, name
        assert joint.child_body().name() == child, name
        X_PF = joint.frame_on_parent().GetFixedPoseInBodyFrame()
        np.testing.assert_allclose(X_PF.translation(), xyz, atol=1e-12, err_msg=name)
        np.testing.assert_allclose(X_PF.rotation().matrix(),
                                   RotationMatrix(RollPitchYaw(rpy)).matrix(), atol=1e-12)
        assert joint.frame_on_child().GetFixedPoseInBodyFrame().IsExactlyIdentity(), name
        local = joint.revolute_axis() if kind == R else joint.translation_axis()
        np.testing.assert_allclose(local, axis, atol=1e-12, err_msg=name)
        assert joint.position_lower_limits()[0] == pytest.approx(lower, abs=1e-12), name
        assert joint.position_upper_limits()[0] == pytest.approx(upper, abs=1e-12), name
        actuator = loaded.plant.GetJointActuatorByName(f"{name}_motor", loaded.model)
        assert actuator.joint().name() == name
        assert actuator.effort_limit() >= 30.0, name
    # Nothing else moves: exactly one actuator per degree of freedom, no floating body.
    assert sorted(loaded.actuator_names()) == sorted(f"{row[0]}_motor" for row in table)
    assert loaded.plant.num_positions() == loaded.plant.num_velocities() == len(table)
    assert not loaded.plant.GetFloatingBaseBodies()


@pytest.mark.parametrize("filename", list(ROBOTS))
def test_robot_tool_frame_and_self_collision_filter(robots, filename):
    loaded = robots[filename]
    *_, tool, parent, offset = ROBOTS[filename]
    X = loaded.pose(tool, parent)
    np.testing.assert_allclose(X.translation(), offset, atol=1e-12)
    np.testing.assert_allclose(X.rotation().matrix(), np.eye(3), atol=1e-12)
    weld = "joint_tool" if tool == "link_tool" else f"{tool}_joint"
    assert isinstance(loaded.joint(weld), WeldJoint)
    assert loaded.joint(weld).child_body().name() == tool
    ids = [g for body in loaded.bodies() for g in loaded.plant.GetCollisionGeometriesForBody(body)]
    assert len(ids) >= 8
    for i, a in enumerate(ids):
        for b in ids[i + 1:]:
            assert loaded.inspector.CollisionFiltered(a, b)


# ------------------------------------------------------------------ spot


def test_spot_body_pose_is_absolute(robots):
    """The six body joints' positions are the body frame's world pose, R = Rx Ry Rz."""
    spot = robots["spot.urdf"]
    q = (-0.25, 0.07, 0.33, 0.1, -0.15, 0.18)
    set_joint_positions(spot, dict(zip([row[0] for row in SPOT_JOINTS[:6]], q, strict=True)))
    X = spot.plant.GetBodyByName("body").EvalPoseInWorld(spot.context)
    np.testing.assert_allclose(X.translation(), q[:3], atol=1e-12)
    expected = (RotationMatrix.MakeXRotation(q[3]) @ RotationMatrix.MakeYRotation(q[4])
                @ RotationMatrix.MakeZRotation(q[5]))
    np.testing.assert_allclose(X.rotation().matrix(), expected.matrix(), atol=1e-12)


def test_spot_masses_and_geometry(robots):
    spot = robots["spot.urdf"]
    plant = spot.plant
    assert plant.GetModelInstanceName(spot.model) == "spot"
    body = plant.GetBodyByName("body", spot.model)
    assert body.default_mass() == pytest.approx(16.7)
    (box,) = spot.collisions("body")
    np.testing.assert_allclose(spot.inspector.GetShape(box).size(), [0.85, 0.24, 0.18])
    for name in ("spot_world_anchor", "body_x_link", "body_y_link", "body_z_link",
                 "body_roll_link", "body_pitch_link"):
        assert plant.GetBodyByName(name, spot.model).default_mass() == pytest.approx(0.01)
    for leg in ("fl", "fr", "hl", "hr"):
        assert plant.GetBodyByName(f"{leg}_upper_leg").default_mass() == pytest.approx(1.0)
        assert plant.GetBodyByName(f"{leg}_lower_leg").default_mass() == pytest.approx(0.5)
        assert isinstance(spot.joint(f"{leg}_foot_joint"), WeldJoint)
        np.testing.assert_allclose(spot.pose(f"{leg}_foot", f"{leg}_lower_leg").translation(),
                                   [0, 0, -0.33], atol=1e-12)
        (foot,) = spot.collisions(f"{leg}_foot")
        assert spot.inspector.GetShape(foot).radius() == pytest.approx(0.02)
        np.testing.assert_allclose(spot.geometry_pose_in_body(foot).translation(), 0, atol=1e-12)
    arm = sum(plant.GetBodyByName(b).default_mass() for b in (
        "arm_link_sh0", "arm_link_sh1", "arm_link_el0", "arm_link_el1", "arm_link_wr0",
        "arm_link_wr1", "arm_tool"))
    assert 4.0 < arm < 8.0
    assert plant.CalcTotalMass(spot.context, [spot.model]) == pytest.approx(33.57)


def test_spot_home_posture(robots):
    """Home: body (-0.2, 0, 0.4), arm home, legs standing: feet on z = 0 below the hips,
    tool frame where the arm's offsets put it (forearm level, pitch 0)."""
    from legato_drake.embodiments.spot import LEG_JOINTS
    from legato_drake.leg_kinematics import standing_leg_angles

    spot = robots["spot.urdf"]
    legs = standing_leg_angles()
    home = {**dict(zip([row[0] for row in SPOT_JOINTS[:6]], SPOT_BODY_HOME, strict=True)),
            **dict(zip(LEG_JOINTS, legs, strict=True)),
            **dict(zip(SPOT_ARM, SPOT_ARM_HOME, strict=True))}
    set_joint_positions(spot, home)
    q = spot.plant.GetPositions(spot.context)
    assert np.all(q >= spot.plant.GetPositionLowerLimits())
    assert np.all(q <= spot.plant.GetPositionUpperLimits())
    for leg, x, y in (("fl", 1, 1), ("fr", 1, -1), ("hl", -1, 1), ("hr", -1, -1)):
        foot = spot.frame(f"{leg}_foot").CalcPoseInWorld(spot.context).translation()
        np.testing.assert_allclose(foot, [-0.2 + x * SPOT_HIP_X[0],
                                          y * (SPOT_HIP_X[1] + SPOT_HIP_Y), 0.0],
                                   atol=1e-12)
    a = -0.66 * PI
    elbow = np.array([0.092 + 0.3385 * math.cos(a), 0.0, 0.588 - 0.3385 * math.sin(a)])
    X = spot.frame("arm_tool").CalcPoseInWorld(spot.context)
    np.testing.assert_allclose(X.translation(), elbow + [0.4033 + 0.2, 0, 0.075 - 0.03],
                               atol=1e-12)
    np.testing.assert_allclose(X.rotation().matrix(), np.eye(3), atol=1e-12)


# ------------------------------------------------------------------ google robot


def test_google_robot_masses_and_base(robots):
    google = robots["google_robot.urdf"]
    plant = google.plant
    assert plant.GetModelInstanceName(google.model) == "google_robot"
    assert plant.GetBodyByName("base", google.model).default_mass() == pytest.approx(30.0)
    assert plant.CalcTotalMass(google.context, [google.model]) == pytest.approx(38.59)
    # Base: about 0.5 m footprint, about 0.6 m tall, clear of the floor.
    lows, highs = [], []
    for geometry_id in google.collisions("base"):
        shape = google.inspector.GetShape(geometry_id)
        z = google.geometry_pose_in_body(geometry_id).translation()[2]
        half = shape.length() / 2 if isinstance(shape, Cylinder) else shape.size()[2] / 2
        lows.append(z - half)
        highs.append(z + half)
        if isinstance(shape, Cylinder):
            assert 0.2 < shape.radius() < 0.3
    assert 0.0 < min(lows) < 0.05 and 0.55 < max(highs) < 0.6565


def test_google_robot_home_and_straight_arm(robots):
    google = robots["google_robot.urdf"]
    home = dict(zip(GOOGLE_ARM, GOOGLE_HOME, strict=True))
    set_joint_positions(google, {"base_x": -0.3, "base_y": 0.1, "base_yaw": 0.0, **home})
    q = google.plant.GetPositions(google.context)
    assert np.all(q >= google.plant.GetPositionLowerLimits())
    assert np.all(q <= google.plant.GetPositionUpperLimits())
    # Arm straight up (zero angles): the tool lies at the sum of the offsets, rotated by yaw.
    yaw = 0.7
    set_joint_positions(google, {"base_x": -0.5, "base_y": 0.3, "base_yaw": yaw,
                                 **dict.fromkeys(GOOGLE_ARM, 0.0)})
    offsets = np.array([row[4] for row in GOOGLE_JOINTS[3:]]).sum(axis=0) + [0, 0, 0.1]
    X = google.frame("link_tool").CalcPoseInWorld(google.context)
    Rz = RotationMatrix.MakeZRotation(yaw)
    np.testing.assert_allclose(X.translation(), [-0.5, 0.3, 0] + Rz @ offsets, atol=1e-12)
    np.testing.assert_allclose(X.rotation().matrix(), Rz.matrix(), atol=1e-12)


# ------------------------------------------------------------------ GR-1


def test_gr1_masses_and_held_limbs(robots):
    gr1 = robots["gr1.urdf"]
    plant = gr1.plant
    assert plant.GetModelInstanceName(gr1.model) == "gr1"
    assert 20.0 < plant.CalcTotalMass(gr1.context, [gr1.model]) < 30.0
    assert plant.CalcTotalMass(gr1.context, [gr1.model]) == pytest.approx(25.32)
    # pelvis is the root (only the test's weld to the world holds it); no left-arm or leg
    # joint exists.
    joints = [plant.get_joint(i) for i in plant.GetJointIndices(gr1.model)]
    names = [j.name() for j in joints]
    assert [j.parent_body().name() for j in joints if j.child_body().name() == "pelvis"] == [
        "world"]
    assert not [n for n in names if n.startswith("l_") or "hip" in n or "knee" in n]
    # The held legs are visual only and reach the ground (z = 0 in the world at the weld).
    pelvis = plant.GetBodyFrameIdOrThrow(plant.GetBodyByName("pelvis").index())
    lowest = min(
        gr1.inspector.GetPoseInFrame(g).translation()[2]
        - gr1.inspector.GetShape(g).size()[2] / 2
        for g in gr1.inspector.GetGeometries(pelvis, Role.kIllustration)
        if isinstance(gr1.inspector.GetShape(g), Box)
    )
    assert GR1_PELVIS.translation()[2] + lowest == pytest.approx(0.0, abs=1e-12)
    for geometry_id in gr1.collisions("pelvis"):
        assert gr1.geometry_pose_in_body(geometry_id).translation()[2] > -0.2


def test_gr1_home_arm_tilt_and_head_camera(robots):
    gr1 = robots["gr1.urdf"]
    home = dict(zip(GR1_ARM, GR1_HOME, strict=True))
    set_joint_positions(gr1, home)
    q = gr1.plant.GetPositions(gr1.context)
    assert np.all(q >= gr1.plant.GetPositionLowerLimits())
    assert np.all(q <= gr1.plant.GetPositionUpperLimits())
    # Zero posture: the -25 deg / +25 deg tilts cancel below the shoulder roll joint.
    set_joint_positions(gr1, dict.fromkeys(GR1_ARM, 0.0))
    X = gr1.frame("r_hand_tool").CalcPoseInWorld(gr1.context)
    torso = GR1_PELVIS.translation() + [0, 0, 0.0065 + 0.055 + 0.085]
    roll_joint = torso + [0, -0.12664, 0.21725] + RotationMatrix.MakeXRotation(-TILT) @ [
        0, -0.067, 0]
    below = [0, -0.04, -0.0575 - 0.18853 - 0.0405 - 0.20153 - 0.1]
    np.testing.assert_allclose(X.translation(), roll_joint + below, atol=1e-12)
    np.testing.assert_allclose(X.rotation().matrix(), np.eye(3), atol=1e-12)
    np.testing.assert_allclose(
        gr1.pose("r_upper_arm_pitch", "torso").rotation().matrix(),
        RotationMatrix.MakeXRotation(-TILT).matrix(), atol=1e-12)
    # The head camera looks along +x (forward) at zero head angles, above the chest.
    X_cam = gr1.frame("head_camera").CalcPoseInWorld(gr1.context)
    np.testing.assert_allclose(X_cam.rotation().matrix(), np.eye(3), atol=1e-12)
    assert 1.4 < X_cam.translation()[2] < 1.6
    assert gr1.frame("head_camera").body().name() == "head_camera"
    assert gr1.joint("head_camera_joint").parent_body().name() == "head"


# ---------------------------------------------------------------------------- cup and ladle scenes


def collision_boxes(loaded: Loaded, body: str) -> list[tuple[np.ndarray, RigidTransform]]:
    """(size, pose in the body) of the body's box collision geometries."""
    return [(np.array(loaded.inspector.GetShape(g).size()), loaded.geometry_pose_in_body(g))
            for g in loaded.collisions(body) if isinstance(loaded.inspector.GetShape(g), Box)]


def collision_feet(loaded: Loaded, body: str) -> np.ndarray:
    """Lowest points of the body's sphere collision geometries."""
    return np.array([loaded.geometry_pose_in_body(g).translation()
                     - [0, 0, loaded.inspector.GetShape(g).radius()]
                     for g in loaded.collisions(body)
                     if isinstance(loaded.inspector.GetShape(g), Sphere)])


def box_extent(boxes) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned bounds (min, max) of unrotated boxes."""
    lows = [X.translation() - size / 2 for size, X in boxes]
    highs = [X.translation() + size / 2 for size, X in boxes]
    return np.min(lows, axis=0), np.max(highs, axis=0)


def test_shelf(models_dir):
    shelf = single_body(models_dir, "shelf.sdf", "shelf", "shelf")
    assert shelf.plant.GetBodyByName("shelf").default_mass() == pytest.approx(5.0)
    boxes = collision_boxes(shelf, "shelf")
    assert len(boxes) == 5  # floor, top, back, two sides: no front, no doors
    low, high = box_extent(boxes)
    np.testing.assert_allclose(low, [-0.25, -0.15, 0.0], atol=1e-12)
    np.testing.assert_allclose(high, [0.25, 0.15, 0.43], atol=1e-12)
    # Interior 0.46 x 0.28 x 0.36, open at y = +0.15; shelf_interior = its centre.
    X_interior = shelf.frame("shelf_interior").GetFixedPoseInBodyFrame()
    np.testing.assert_allclose(X_interior.translation(), [0, 0.01, 0.215])
    p = X_interior.translation()
    for size, X in boxes:  # no wall reaches into the interior box
        overlap = np.minimum(X.translation() + size / 2, p + [0.23, 0.14, 0.18]) \
            - np.maximum(X.translation() - size / 2, p - [0.23, 0.14, 0.18])
        assert np.any(overlap <= 1e-12)
    feet = collision_feet(shelf, "shelf")
    assert len(feet) == 4
    np.testing.assert_allclose(feet[:, 2], 0.0, atol=1e-12)


def test_cup(models_dir):
    cup = single_body(models_dir, "cup.sdf", "cup", "cup")
    body = cup.plant.GetBodyByName("cup")
    assert body.default_mass() == pytest.approx(0.1)
    X_handle = cup.frame("cup_handle").GetFixedPoseInBodyFrame()
    np.testing.assert_allclose(X_handle.translation(), [0, 0.115, 0.085])
    boxes = collision_boxes(cup, "cup")
    walls = [(size, X) for size, X in boxes if size[2] == pytest.approx(0.15)]
    assert len(walls) == 16
    for size, X in walls:  # outer radius 0.08, inner 0.07, from the 0.01 base up to 0.16
        radial = X.rotation().matrix()[:, 0]
        r = np.dot(X.translation()[:2], radial[:2])
        assert r + size[0] / 2 == pytest.approx(0.08) and r - size[0] / 2 == pytest.approx(0.07)
        assert X.translation()[2] + size[2] / 2 == pytest.approx(0.16)
    (bar,) = [(size, X) for size, X in boxes if size[2] == pytest.approx(0.10)]
    np.testing.assert_allclose(bar[0], [0.014, 0.024, 0.10])  # 14 mm across the pads
    np.testing.assert_allclose(bar[1].translation(), [0, 0.115, 0.085])
    arms = [(size, X) for size, X in boxes if size[2] == pytest.approx(0.012)]
    assert len(arms) == 2
    for size, X in arms:  # joining the wall to the bar
        assert X.translation()[1] - size[1] / 2 < 0.08
        assert X.translation()[1] + size[1] / 2 == pytest.approx(0.115 - 0.012)
    feet = collision_feet(cup, "cup")
    assert len(feet) == 8
    np.testing.assert_allclose(feet[:, 2], 0.0, atol=1e-12)
    for geometry_id in cup.collisions("cup"):
        assert cup.friction(geometry_id).static_friction() == pytest.approx(0.8)


def test_ladle(models_dir):
    ladle = single_body(models_dir, "ladle.sdf", "ladle", "ladle")
    assert ladle.plant.GetBodyByName("ladle").default_mass() == pytest.approx(0.2)
    boxes = sorted(collision_boxes(ladle, "ladle"), key=lambda sx: sx[1].translation()[0])
    sizes = [size for size, _ in boxes]
    np.testing.assert_allclose(sizes, [[0.08, 0.04, 0.04], [0.12, 0.02, 0.02],
                                       [0.06, 0.06, 0.03]])
    np.testing.assert_allclose([X.translation() for _, X in boxes],
                               [[0.04, 0, 0], [0.14, 0, 0], [0.23, 0, 0]], atol=1e-12)
    np.testing.assert_allclose(
        ladle.frame("ladle_handle").GetFixedPoseInBodyFrame().translation(), [0.04, 0, 0])
    for geometry_id in ladle.collisions("ladle"):
        assert ladle.friction(geometry_id).static_friction() == pytest.approx(2.0)
        shape = ladle.inspector.GetShape(geometry_id)
        if isinstance(shape, Sphere):  # corner spheres stay inside the handle or the scoop
            p = ladle.geometry_pose_in_body(geometry_id).translation()
            inside = [np.all(np.abs(p - X.translation()) + shape.radius() <= size / 2 + 1e-12)
                      for size, X in boxes]
            assert any(inside)


def test_case(models_dir):
    case = single_body(models_dir, "case.sdf", "case", "case")
    assert case.plant.GetBodyByName("case").default_mass() == pytest.approx(0.5)
    boxes = collision_boxes(case, "case")
    assert len(boxes) == 5
    low, high = box_extent(boxes)
    np.testing.assert_allclose(low, [-0.09, -0.14, 0.0], atol=1e-12)
    np.testing.assert_allclose(high, [0.09, 0.14, 0.05], atol=1e-12)
    np.testing.assert_allclose(
        case.frame("case_floor").GetFixedPoseInBodyFrame().translation(), [0, 0, 0.01])
    walls = [(size, X) for size, X in boxes if size[2] == pytest.approx(0.04)]
    assert len(walls) == 4
    inner_x = min(abs(X.translation()[0]) - size[0] / 2 for size, X in walls
                  if size[1] > 0.2)
    inner_y = min(abs(X.translation()[1]) - size[1] / 2 for size, X in walls
                  if size[0] < 0.2 and size[1] < 0.05)
    assert (2 * inner_x, 2 * inner_y) == pytest.approx(CASE_INTERIOR)
    feet = collision_feet(case, "case")
    assert len(feet) == 4
    np.testing.assert_allclose(feet[:, 2], 0.0, atol=1e-12)
