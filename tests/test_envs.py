"""The Gymnasium environments: registration, Gymnasium's own checker, seeded resets that are
``evaluate``'s scenes, the episode code shared with ``evaluate`` (a scripted demonstration
replayed through ``step`` succeeds at the same instant), the vector env and bad input."""

from __future__ import annotations

import functools
import os

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from legato_drake.diagram import build_diagram, object_bodies
from legato_drake.envs import LegatoEnv, env_ids
from legato_drake.episode import EpisodeRun
from legato_drake.errors import ConfigError
from legato_drake.models import shipped_checkpoint
from legato_drake.pipelines.collect import record_episode
from legato_drake.pipelines.evaluate import trial_scenario
from legato_drake.scenario import Scenario
from tests.fixtures.ur_arm import write_ur_arm

CHECKED = ("LegatoDrake/Lid-Abstract-v0", "LegatoDrake/Cup-Panda-v0",
           "LegatoDrake/Ladle-GR1-v0")
"""The environments Gymnasium's checker runs on in every test run; LEGATO_ALL_ENVS=1 runs it
on every registered one (about 15 s each)."""
ZERO = np.zeros(7, np.float32)


def test_every_task_and_robot_is_registered():
    ids = env_ids()
    assert len(ids) == 3 * 6 and all(i in gym.registry for i in ids)
    assert "LegatoDrake/Ladle-Spot-v0" in ids and "LegatoDrake/Cup-v0" in ids
    env = gym.make("LegatoDrake/Cup-Google-v0")
    assert env.unwrapped.scenario.embodiment == "google" and env.unwrapped.scenario.task == "cup"
    env.close()


@pytest.mark.parametrize("env_id", env_ids())
def test_gymnasium_checker(env_id):
    if env_id not in CHECKED and not os.environ.get("LEGATO_ALL_ENVS"):
        pytest.skip("LEGATO_ALL_ENVS=1 checks every environment")
    env = gym.make(env_id, render_mode="rgb_array")
    check_env(env.unwrapped)
    frame = env.unwrapped.render()
    assert frame.shape == (240, 320, 3) and frame.dtype == np.uint8 and frame.std() > 10
    env.close()


def test_a_yaml_robot(tmp_path):
    env = gym.make("LegatoDrake/Lid-v0", embodiment_file=str(write_ur_arm(tmp_path)))
    obs, info = env.reset(seed=3)
    assert env.unwrapped.scenario.embodiment == "ur_arm"
    obs, reward, terminated, truncated, info = env.step(ZERO)
    assert obs["left_gray"].shape == (128, 128, 1) and not terminated and reward == 0.0
    env.close()


def test_reset_is_evaluates_scene_and_deterministic():
    """reset(seed=s) puts the plant where evaluate's trial of seed s starts; the same seed
    and actions give the same observations, another seed another scene."""
    env = LegatoEnv("lid", "panda", privileged=True)
    first, _ = env.reset(seed=10004)
    built = build_diagram(trial_scenario("panda", "lid", 10004, shipped_checkpoint("lid"),
                                         camera=False, duration=None))
    run = EpisodeRun(built)
    run.advance_to(env.run.time)
    plant_context = built.plant.GetMyContextFromRoot(run.context)
    objects = np.concatenate([[*b.EvalPoseInWorld(plant_context).translation()]
                              for b in object_bodies(built.plant, built.robot)])
    env_objects = first["object"].reshape(-1, 7)[:, :3].ravel()
    np.testing.assert_allclose(env_objects, objects, atol=1e-6)
    actions = [np.array([0.01, 0, -0.005, 0, 0, 0.02, 0], np.float32)] * 5
    runs = []
    for _ in range(2):
        obs, _ = env.reset(seed=10004)
        steps = [env.step(a)[0] for a in actions]
        runs.append([obs, *steps])
    for a, b in zip(*runs, strict=True):
        for key in a:
            np.testing.assert_array_equal(a[key], b[key])
    np.testing.assert_allclose(runs[0][-1]["delta_positions"], [0.01, 0, -0.005] * 2)
    other, _ = env.reset(seed=10005)
    assert np.abs(other["object"] - first["object"]).max() > 1e-3


def test_a_scripted_demonstration_replayed_through_step_succeeds_when_it_did():
    """The env runs the episode code of evaluate and collect: the scripted expert's recorded
    actions, sent one step at a time, reach success at the same simulated instant."""
    scenario = Scenario(embodiment="abstract", task="lid", seed=10003)
    scenario.camera.enabled = False
    result, episode = record_episode(scenario.validate())
    assert result["success"]
    env = LegatoEnv("lid", "abstract")
    env.reset(seed=10003)
    steps = 0
    for action in episode.actions:
        _, reward, terminated, truncated, info = env.step(action)
        steps += 1
        if terminated or truncated:
            break
    assert terminated and not truncated and reward == 1.0 and info["success"]
    assert steps == len(episode.actions)
    assert env.episode_result().success_time == pytest.approx(result["success_time"])


def test_time_limit_truncates_with_the_reason():
    env = LegatoEnv("cup", "abstract", duration=0.5)
    env.reset(seed=1)
    for _ in range(5):
        _, reward, terminated, truncated, info = env.step(ZERO)
    assert truncated and not terminated and reward == 0.0
    assert info["reason"] and info["time"] == pytest.approx(0.5, abs=1e-3)


def test_async_vector_env_matches_single_envs():
    make = functools.partial(gym.make, "legato_drake.envs:LegatoDrake/Lid-Abstract-v0")
    vector = gym.vector.AsyncVectorEnv([make, make], context="spawn")
    try:
        obs, _ = vector.reset(seed=[10000, 10001])
        assert obs["left_gray"].shape == (2, 128, 128, 1)
        action = np.tile(np.array([0, 0, -0.01, 0, 0, 0, 0], np.float32), (2, 1))
        for _ in range(3):
            obs, rewards, terminated, truncated, _ = vector.step(action)
    finally:
        vector.close()
    single = LegatoEnv("lid", "abstract")
    single.reset(seed=10001)
    for _ in range(3):
        expected, *_ = single.step(action[1])
    np.testing.assert_array_equal(obs["left_gray"][1], expected["left_gray"])
    assert rewards.shape == (2,) and not terminated.any()


def test_bad_arguments_are_named():
    with pytest.raises(ConfigError, match="embodiment"):
        LegatoEnv("lid", "r2d2")
    with pytest.raises(ConfigError, match="task"):
        LegatoEnv("soup", "panda")
    with pytest.raises(ValueError, match="render_mode: unknown 'human'"):
        LegatoEnv("lid", "abstract", render_mode="human")
    with pytest.raises(RuntimeError, match="reset"):
        LegatoEnv("lid", "abstract").step(ZERO)
