"""An image policy keeps the camera it was trained with: the dataset records the camera, the
checkpoint takes it from the dataset, and the diagram renders the policy's images with it."""

from __future__ import annotations

import dataclasses

from legato_drake.data.layout import recorded_camera
from legato_drake.diagram import _policy_camera
from legato_drake.learning.train import train
from legato_drake.pipelines.collect import _setting
from legato_drake.scenario import CameraConfig, Scenario
from tests.learning_helpers import synthetic_dataset, tiny_config

FISHEYE = {**dataclasses.asdict(CameraConfig()), "model": "fisheye", "fisheye_fov_deg": 150.0}


def _dataset(path, camera: dict | None):
    from legato_drake.data.synthetic import synthetic_episode
    from legato_drake.data.writer import write_dataset

    env_args = {"env_kwargs": {"camera": camera}} if camera is not None else None
    return write_dataset(path, [synthetic_episode(24, seed=i, images=True, size=16, objects=3)
                                for i in range(4)], env_args=env_args)


def test_a_dataset_says_which_camera_rendered_it(tmp_path):
    camera = recorded_camera(_dataset(tmp_path / "fisheye.hdf5", FISHEYE))
    assert camera["model"] == "fisheye" and camera["fisheye_fov_deg"] == 150.0
    assert "enabled" not in camera  # only what decides how an image looks
    assert recorded_camera(synthetic_dataset(tmp_path / "unknown.hdf5")) == {}


def test_an_image_checkpoint_holds_its_datasets_camera_and_a_state_one_none(tmp_path):
    data = _dataset(tmp_path / "fisheye.hdf5", FISHEYE)
    image = train(tiny_config(obs_mode="image", steps=2), data, tmp_path / "image",
                  progress=False)
    state = train(tiny_config(steps=2), data, tmp_path / "state", progress=False)
    assert image.camera["model"] == "fisheye" and state.camera == {}
    from legato_drake.learning.checkpoint import load_checkpoint

    assert load_checkpoint(tmp_path / "image" / "last.pt").camera == image.camera


def test_the_diagram_renders_an_image_policy_with_its_camera(tmp_path):
    data = _dataset(tmp_path / "fisheye.hdf5", FISHEYE)
    ckpt = train(tiny_config(obs_mode="image", steps=2), data, tmp_path / "run",
                 progress=False)
    scenario = Scenario(controller="policy", checkpoint=str(tmp_path / "run" / "last.pt"))
    used = _policy_camera(scenario, ckpt)
    assert used.camera.model == "fisheye" and used.camera.fisheye_fov_deg == 150.0
    assert scenario.camera.model == "pinhole"  # the caller's scenario is left as it was
    ckpt.camera = {}
    assert _policy_camera(scenario, ckpt) is scenario


def test_datasets_from_before_the_camera_model_was_recorded_are_pinhole():
    assert _setting({}, "camera_model") == "pinhole"
    assert _setting({"camera_model": "fisheye"}, "camera_model") == "fisheye"
