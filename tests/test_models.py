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
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.parsing import PackageMap, Parser
from pydrake.multibody.plant import (
    AddMultibodyPlant,
    AddMultibodyPlantSceneGraph,
    MultibodyPlantConfig,
)
from pydrake.multibody.tree import PrismaticJoint, RevoluteJoint, WeldJoint
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

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
    expected = {
        "legato_gripper.sdf": module.gripper_sdf(),
        "abstract.urdf": module.abstract_urdf(),
        "panda.urdf": module.panda_urdf(),
        "spot.urdf": module.spot_urdf(),
        "google_robot.urdf": module.google_robot_urdf(),
        "gr1.urdf": module.gr1_urdf(),
        "table.sdf": module.table_sdf(),
        "stove.sdf": module.stove_sdf(),
        "pot.sdf": module.pot_sdf(),
        "lid.sdf": module.lid_sdf(),
        "package.xml": module.PACKAGE_XML,
    }
    for name, text in expected.items():
        assert (models_dir / name).read_text() == text, f"{name}: rerun generate_models.py"


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
    assert joint.position_upper_limits()[0] == pytest.approx(0.052)
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
    assert inner_pad_gap(gripper, 0.052) == pytest.approx(0.104)
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
        pot.frame("pot_rim").GetFixedPoseInBodyFrame().translation(), [0, 0, 0.1]
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
    plant.SetPositions(context, gripper, [0.052, 0.052])
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
