"""The typed scenario: YAML loading, validation, clear errors."""

from __future__ import annotations

import pytest

from legato_drake.errors import ConfigError
from legato_drake.scenario import Scenario, load_scenario, scenario_from_yaml_text


def test_defaults_are_valid():
    scenario = Scenario().validate()
    assert (scenario.embodiment, scenario.task, scenario.controller) == \
        ("panda", "lid", "scripted")


def test_yaml_round_trip(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text("embodiment: abstract\nseed: 7\ncamera: {enabled: false, fov_y_deg: 90}\n")
    scenario = load_scenario(path)
    assert scenario.embodiment == "abstract" and scenario.seed == 7
    assert scenario.camera.enabled is False and scenario.camera.fov_y_deg == 90
    assert scenario.camera.width == 128  # untouched fields keep their defaults


@pytest.mark.parametrize("text, words", [
    ("embodiment: r2d2\n", ["embodiment 'r2d2'", "abstract", "panda"]),
    ("task: juggling\n", ["task 'juggling'", "lid"]),
    ("controller: magic\n", ["controller 'magic'", "scripted"]),
    ("duration: -1\n", ["duration", "positive"]),
    ("max_target_lead: -0.01\n", ["max_target_lead", "non-negative", "0: unbounded"]),
    ("camera: {fov_y_deg: 200}\n", ["camera.fov_y_deg"]),
    ("camera: {model: fish}\n", ["camera.model", "pinhole", "fisheye", "'fish'"]),
    ("camera: {model: fisheye, fisheye_fov_deg: 20}\n", ["camera.fisheye_fov_deg"]),
])
def test_bad_values_name_the_field_and_the_valid_values(tmp_path, text, words):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as error:
        load_scenario(path)
    message = str(error.value)
    assert str(path) in message
    for word in words:
        assert word in message


@pytest.mark.parametrize("text, words", [
    ("embodyment: panda\n", ["embodyment"]),          # misspelt key
    ("seed: twelve\n", ["seed"]),                     # wrong type
    ("camera: [1, 2]\n", ["camera"]),                 # wrong shape
])
def test_malformed_yaml_is_a_clear_error(text, words):
    with pytest.raises(ConfigError) as error:
        scenario_from_yaml_text(text, where="test.yaml")
    assert "test.yaml" in str(error.value)
    for word in words:
        assert word in str(error.value)


def test_missing_file(tmp_path):
    with pytest.raises(ConfigError, match="not found"):
        load_scenario(tmp_path / "nope.yaml")
