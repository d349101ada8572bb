"""A leg follower is data on the embodiment: Spot declares one, and a YAML robot can too.

A YAML copy of Spot (same model, home, gains, IK settings and ``leg_follower``) builds the
same diagram as the built-in Spot: the same joints driven by the IK and by the follower, and
the same simulated state, to the bit.
"""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.analysis import Simulator

from legato_drake.diagram import build_diagram
from legato_drake.embodiments import add_embodiment
from legato_drake.embodiments.from_file import load_embodiment_file
from legato_drake.embodiments.spot import BODY_JOINTS, LEG_JOINTS, SPOT
from legato_drake.errors import ConfigError
from legato_drake.leg_kinematics import SPOT_LEG_GEOMETRY
from legato_drake.models import add_package
from legato_drake.robot_types import Embodiment, LegFollower
from legato_drake.scenario import Scenario


def _flow(values) -> str:
    return "[" + ", ".join(repr(float(v)) if not isinstance(v, str) else v
                           for v in values) + "]"


def write_yaml_spot(folder, **overrides) -> str:
    """Spot as a YAML embodiment file (every number written to round-trip exactly)."""
    ik = SPOT.ik
    fields = {
        "name": "yaml_spot",
        "model": "package://legato_drake/spot.urdf",
        "base_frame": "spot_world_anchor",
        "mount_frame": "arm_tool",
        "home": "{" + ", ".join(f"{j}: {float(v)!r}" for j, v in SPOT.home.items()) + "}",
        "pd_gains": "{" + ", ".join(f"{j}: {_flow(g)}" for j, g in SPOT.pd_gains.items()) + "}",
        "ik": "{" + ", ".join([
            f"tracking_gain: {ik.tracking_gain!r}", f"posture_gain: {ik.posture_gain!r}",
            f"posture_task_weight: {ik.posture_task_weight!r}",
            f"posture_joints: {_flow(ik.posture_joints)}",
            f"max_joint_speed: {ik.max_joint_speed!r}",
            f"max_joint_acceleration: {ik.max_joint_acceleration!r}",
            "joint_speed_limits: {" + ", ".join(
                f"{j}: {v!r}" for j, v in ik.joint_speed_limits.items()) + "}",
            "joint_acceleration_limits: {" + ", ".join(
                f"{j}: {v!r}" for j, v in ik.joint_acceleration_limits.items()) + "}",
            "joint_position_limits: {" + ", ".join(
                f"{j}: {_flow(v)}" for j, v in ik.joint_position_limits.items()) + "}"]) + "}",
        "leg_follower": f"{{body_joints: {_flow(BODY_JOINTS)}, leg_joints: {_flow(LEG_JOINTS)}}}",
        "foot_frames": "[fl_foot, fr_foot, hl_foot, hr_foot]",
    }
    fields.update(overrides)
    text = "".join(f"{key}: {value}\n" for key, value in fields.items() if value is not None)
    path = folder / "yaml_spot.yaml"
    path.write_text(text)
    return str(path)


def test_spot_declares_its_legs_as_data():
    follower = SPOT.leg_follower
    assert isinstance(follower, LegFollower)
    assert follower.body_joints == BODY_JOINTS and len(follower.leg_joints) == 12
    assert follower.geometry == SPOT_LEG_GEOMETRY and follower.ground_z == 0.0
    assert SPOT.follower_joints() == LEG_JOINTS
    assert not any(callable(getattr(SPOT, f)) for f in Embodiment.__dataclass_fields__)


def test_yaml_spot_loads_the_same_follower(tmp_path):
    emb = load_embodiment_file(write_yaml_spot(tmp_path))
    assert emb.leg_follower == SPOT.leg_follower
    assert emb.foot_frames == SPOT.foot_frames
    assert emb.ik == SPOT.ik and emb.home == SPOT.home
    handles = []
    for e in (SPOT, emb):
        plant = MultibodyPlant(0.002)
        handles.append(add_embodiment(plant, add_package(Parser(plant)), e))
    # The YAML robot names no ik_joints: the IK drives every joint that the follower does not.
    assert [j.name() for j in handles[1].controlled_joints] == \
        [j.name() for j in handles[0].controlled_joints]
    assert {j.name() for j in handles[1].controlled_joints} == set(SPOT.ik_joints)


def test_yaml_spot_simulates_as_spot_does(tmp_path):
    """Same diagram, same state after 0.2 s of homing, bit for bit."""
    states = []
    for kind in ("built-in", "yaml"):
        scenario = Scenario(embodiment="spot", task="lid", controller="scripted")
        if kind == "yaml":
            scenario.embodiment_file = write_yaml_spot(tmp_path)
        scenario.camera.enabled = False
        built = build_diagram(scenario)
        for name in ("leg_follower_body_state", "leg_follower_ik", "joint_target_mux"):
            built.diagram.GetSubsystemByName(name)  # raises if absent
        simulator = Simulator(built.diagram)
        context = simulator.get_mutable_context()
        simulator.AdvanceTo(0.2)
        states.append(built.plant.GetPositionsAndVelocities(
            built.plant.GetMyContextFromRoot(context)).copy())
    np.testing.assert_array_equal(states[0], states[1])


@pytest.mark.parametrize("overrides, words", [
    (dict(leg_follower="[body_x]"), ["leg_follower", "mapping"]),
    (dict(leg_follower="{body_joints: [a, b]}"), ["leg_follower", "missing", "leg_joints"]),
    (dict(leg_follower="{body_joints: [a], leg_joints: [b], feet: 4}"),
     ["leg_follower", "unknown field", "feet"]),
    (dict(leg_follower=f"{{body_joints: [body_x], leg_joints: {_flow(LEG_JOINTS)}}}"),
     ["leg_follower.body_joints", "6", "roll"]),
    (dict(leg_follower=f"{{body_joints: {_flow(BODY_JOINTS)}, leg_joints: [fl_knee]}}"),
     ["leg_follower.leg_joints", "12", "hip_x"]),
    (dict(leg_follower=f"{{body_joints: {_flow(BODY_JOINTS)}, "
                       f"leg_joints: {_flow(LEG_JOINTS[:-1] + ('hr_kne',))}}}"),
     ["leg_follower.leg_joints", "unknown joint", "hr_kne"]),
    (dict(leg_follower=f"{{body_joints: {_flow(BODY_JOINTS)}, "
                       f"leg_joints: {_flow(LEG_JOINTS[:-1] + ('body_x',))}}}"),
     ["leg_follower.body_joints", "body_x"]),
    (dict(leg_follower=f"{{body_joints: {_flow(BODY_JOINTS)}, leg_joints: "
                       f"{_flow(LEG_JOINTS)}, geometry: {{hip_z_offset: 1}}}}"),
     ["leg_follower.geometry", "unknown field", "hip_z_offset", "lower_leg_length"]),
    (dict(leg_follower=f"{{body_joints: {_flow(BODY_JOINTS)}, leg_joints: "
                       f"{_flow(LEG_JOINTS)}, geometry: {{lower_leg_length: -0.3}}}}"),
     ["leg_follower.geometry.lower_leg_length", "positive"]),
    (dict(leg_follower=f"{{body_joints: {_flow(BODY_JOINTS)}, leg_joints: "
                       f"{_flow(LEG_JOINTS)}, geometry: {{hip_x_offset: [0.3, 0.05]}}}}"),
     ["leg_follower.geometry.hip_x_offset", "3 numbers"]),
    (dict(leg_follower=f"{{body_joints: {_flow(BODY_JOINTS)}, leg_joints: "
                       f"{_flow(LEG_JOINTS)}, geometry: {{knee_limits: [0, -1]}}}}"),
     ["leg_follower.geometry.knee_limits", "above upper"]),
    (dict(leg_follower=f"{{body_joints: {_flow(BODY_JOINTS)}, leg_joints: "
                       f"{_flow(LEG_JOINTS)}, ground_z: low}}"),
     ["leg_follower.ground_z", "number"]),
    (dict(foot_frames="[fl_foot, paw]"), ["foot_frames", "paw"]),
    (dict(foot_frames="fl_foot"), ["foot_frames", "list"]),
])
def test_bad_followers_name_the_file_and_field(tmp_path, overrides, words):
    path = write_yaml_spot(tmp_path, **overrides)
    with pytest.raises(ConfigError) as error:
        load_embodiment_file(path)
    message = str(error.value)
    assert message.startswith(path) and "\n" not in message
    for word in words:
        assert word in message, (word, message)
