"""Bring your own robot: an embodiment defined only by a YAML file."""

from __future__ import annotations

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


@pytest.mark.slow
def test_yaml_robot_closes_the_lid(tmp_path):
    scenario = Scenario(embodiment_file=str(write_ur_arm(tmp_path)), seed=1)
    scenario.camera.enabled = False
    result = run_episode(scenario.validate())
    assert result.embodiment == "ur_arm"
    assert result.success, result.reason
    assert result.tracking.rms_mm < 5.0
