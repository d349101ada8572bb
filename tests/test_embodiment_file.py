"""Bring your own robot: an embodiment defined only by a YAML file."""

from __future__ import annotations

from pathlib import Path

import pytest

from legato_drake.embodiments import add_embodiment
from legato_drake.embodiments.from_file import load_embodiment_file
from legato_drake.episode import run_episode
from legato_drake.errors import ConfigError
from legato_drake.scenario import Scenario
from tests.fixtures.ur_arm import write_ur_arm


def test_loads_and_fills_default_gains(tmp_path):
    emb = load_embodiment_file(write_ur_arm(tmp_path))
    assert emb.name == "ur_arm" and emb.mount_frame == "ee_link"
    assert emb.pd_gains["shoulder_pan"] == (3000.0, 150.0)  # from `default`
    assert emb.pd_gains["wrist_3"] == (500.0, 25.0)


@pytest.mark.parametrize("overrides, words", [
    (dict(mount_frame="flange"), ["mount_frame 'flange'", "ee_link"]),       # missing tool frame
    (dict(home="{elbw: 1.0}"), ["unknown joint", "elbw"]),                   # unknown joint
    (dict(pd_gains="{shoulder_pan: [1, 2], wrist_9: [1, 1]}"), ["wrist_9"]),  # unknown joint
    (dict(model="nowhere.urdf"), ["file not found", "nowhere.urdf"]),         # missing model
    (dict(base_type="hovering"), ["base_type 'hovering'", "fixed", "planar"]),  # base type
    (dict(base_frame=None), ["missing required", "base_frame"]),
    (dict(tool="x"), ["unknown field", "tool"]),
    (dict(mount="{xyz: [0, 0]}"), ["mount.xyz"]),
    (dict(ik="{joint_velocity_weights: {wrist_9: 2}}"), ["ik.joint_velocity_weights",
                                                        "wrist_9"]),
    (dict(ik="{joint_velocity_weights: {wrist_1: 0}}"), ["joint_velocity_weights",
                                                        "positive"]),
])
def test_bad_files_name_the_problem(tmp_path, overrides, words):
    path = write_ur_arm(tmp_path, **overrides)
    with pytest.raises(ConfigError) as error:
        load_embodiment_file(path)
    assert str(path) in str(error.value)
    for word in words:
        assert word in str(error.value)


def test_planar_base_adds_actuated_virtual_joints(tmp_path):
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant

    from legato_drake.models import add_package

    emb = load_embodiment_file(write_ur_arm(
        tmp_path, base_type="planar", base_range="{x: 0.2, y: 0.1, yaw: 30}"))
    plant = MultibodyPlant(0.002)
    robot = add_embodiment(plant, add_package(Parser(plant)), emb)
    plant.Finalize()
    names = [j.name() for j in robot.controlled_joints]
    assert names[-3:] == ["base_x", "base_y", "base_yaw"]
    x = plant.GetJointByName("base_x")
    assert x.position_lower_limits()[0] == pytest.approx(-0.45 - 0.2)
    assert robot.home_positions[-3] == pytest.approx(-0.45)


def test_an_embodiment_file_is_read_once_per_version(tmp_path, monkeypatch):
    from legato_drake.embodiments import from_file
    from legato_drake.embodiments.from_file import read_text_file

    reads = []
    monkeypatch.setattr(from_file, "read_text_file",
                        lambda *a: reads.append(a[0]) or read_text_file(*a))
    path = write_ur_arm(tmp_path)
    from_file._load_embodiment_file.cache_clear()
    scenario = Scenario(embodiment_file=str(path)).validate()  # reads it for the name
    assert scenario.embodiment == "ur_arm"
    assert load_embodiment_file(path) is load_embodiment_file(path)
    assert len(reads) == 1
    path.write_text(path.read_text().replace("name: ur_arm", "name: ur_arm_2"))
    assert load_embodiment_file(path).name == "ur_arm_2" and len(reads) == 2


@pytest.mark.slow
def test_yaml_robot_closes_the_lid(tmp_path):
    scenario = Scenario(embodiment_file=str(write_ur_arm(tmp_path)), seed=1)
    scenario.camera.enabled = False
    result = run_episode(scenario.validate())
    assert result.embodiment == "ur_arm"
    assert result.success, result.reason
    assert result.tracking.rms_mm < 5.0


@pytest.mark.parametrize("overrides, words", [
    (dict(ik="{tracking_gain: [1,"), ["not valid YAML", "line"]),              # malformed
    (dict(home="{elbow: fast}"), ["home.elbow", "number", "fast"]),
    (dict(ik="{tracking_gain: fast}"), ["ik.tracking_gain", "number", "fast"]),
    (dict(ik="{tracking_gain: 0}"), ["ik.tracking_gain", "positive"]),
    (dict(ik="{max_joint_speed: .nan}"), ["ik.max_joint_speed"]),
    (dict(ik="{posture_joints: elbow}"), ["ik.posture_joints", "list"]),
    (dict(ik="{joint_speed_limits: {elbow: fast}}"), ["ik.joint_speed_limits.elbow"]),
    (dict(ik="{joint_position_limits: {elbow: [1, -1]}}"), ["ik.joint_position_limits.elbow"]),
    (dict(ik="{orientation_tasks: [{frame: nowhere}]}"),
     ["ik.orientation_tasks[0].frame", "nowhere", "ee_link"]),                # unknown frame
    (dict(ik="{orientation_tasks: [{frame: ee_link, gain: fast}]}"),
     ["ik.orientation_tasks[0].gain"]),
    (dict(ik="{orientation_tasks: {frame: ee_link}}"), ["ik.orientation_tasks", "list"]),
    (dict(name="panda"), ["name 'panda'", "built-in"]),                       # reused name
    (dict(name="[a, b]"), ["name", "string"]),
    (dict(model="5"), ["model", "string"]),
    (dict(base_gains="{translation: [1, 2]}"), ["base_gains", "fixed"]),      # ignored before
    (dict(base_type="planar", base_gains="{translation: [1, -2]}"),
     ["base_gains.translation"]),
    (dict(base_type="planar", base_gains="[[1, 2], [3, 4]]"), ["base_gains", "rotation"]),
    (dict(base_type="planar", base_range="{x: far}"), ["base_range.x", "far"]),
    (dict(mount="{xyz: [a, 0, 0]}"), ["mount.xyz[0]"]),
    (dict(pd_gains="{default: [.nan, 1]}"), ["pd_gains.default"]),
])
def test_wrong_types_and_values_name_the_field(tmp_path, overrides, words):
    path = write_ur_arm(tmp_path, **overrides)
    with pytest.raises(ConfigError) as error:
        load_embodiment_file(path)
    message = str(error.value)
    assert str(path) in message and "\n" not in message
    for word in words:
        assert word in message, (word, message)


def test_planar_base_gains_are_used(tmp_path):
    emb = load_embodiment_file(write_ur_arm(
        tmp_path, base_type="planar", base_gains="{translation: [100, 10]}"))
    assert emb.base_gains[0] == (100.0, 10.0)
    assert emb.base_gains[1] == type(emb).__dataclass_fields__["base_gains"].default[1]


@pytest.mark.parametrize("content", [b"name: [x\n", b"\xff\xfe\x00binary", b"- a\n- b\n"])
def test_malformed_or_binary_files_are_clear_errors(tmp_path, content):
    path = tmp_path / "robot.yaml"
    path.write_bytes(content)
    with pytest.raises(ConfigError) as error:
        load_embodiment_file(path)
    assert str(path) in str(error.value) and "\n" not in str(error.value)


def test_a_urdf_without_transmissions_actuates_every_joint(tmp_path, monkeypatch, caplog):
    import logging
    import re

    from legato_drake.embodiments.from_file import check_embodiment

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    path = write_ur_arm(tmp_path)
    urdf = tmp_path / "ur_arm.urdf"
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "tip.obj").write_text(
        "v 0 0 0\nv 0.01 0 0\nv 0 0.01 0\nv 0 0 0.01\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n")
    text = re.sub(r"<transmission.*?</transmission>", "", urdf.read_text())
    text = text.replace('<link name="ee_link">', '<link name="ee_link"><visual><geometry>'
                        '<mesh filename="meshes/tip.obj"/></geometry></visual>')
    urdf.write_text(text)
    with caplog.at_level(logging.INFO, logger="legato_drake"):
        emb = load_embodiment_file(path)
    assert "no <transmission> elements" in caplog.text
    assert sorted(emb.pd_gains) == ["elbow", "shoulder_lift", "shoulder_pan", "wrist_1",
                                    "wrist_2", "wrist_3"]
    assert emb.model.startswith(str(tmp_path / "cache")) and emb.model.endswith(".urdf")
    assert str(tmp_path / "meshes" / "tip.obj") in Path(emb.model).read_text()
    assert urdf.read_text() == text  # the user's file is left alone
    check_embodiment(emb)
    assert load_embodiment_file(path).model == emb.model  # one copy, by content


def test_a_model_without_movable_joints_is_refused(tmp_path):
    (tmp_path / "rigid.urdf").write_text(
        '<?xml version="1.0"?>\n<robot name="rigid"><link name="base_link"><inertial>'
        '<mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/>'
        "</inertial></link></robot>\n")
    path = write_ur_arm(tmp_path, model="rigid.urdf")
    (tmp_path / "ur_arm.urdf").unlink()
    with pytest.raises(ConfigError, match="no revolute, continuous or prismatic joint"):
        load_embodiment_file(path)
