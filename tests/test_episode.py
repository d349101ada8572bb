"""The closed loop: a smoke test per embodiment, lid successes, determinism."""

from __future__ import annotations

import pytest

from legato_drake.embodiments import EMBODIMENTS
from legato_drake.episode import run_episode
from legato_drake.scenario import Scenario


@pytest.mark.parametrize("embodiment", sorted(EMBODIMENTS))
def test_smoke_every_embodiment_with_cameras(embodiment):
    """Build, render and run 1.5 s of controller time: no crash, tight tracking."""
    result = run_episode(Scenario(embodiment=embodiment, duration=1.5))
    assert result.episode_time == pytest.approx(1.5, abs=0.01)
    assert result.tracking.samples > 100
    assert result.tracking.rms_mm < 5.0 and result.tracking.rms_deg < 2.0
    assert not result.success and result.reason


@pytest.mark.parametrize("task", ["cup", "ladle"])
def test_smoke_every_new_task_with_cameras(task):
    """Build, render and run 1 s of the cup and ladle scenes on Abstract: no crash."""
    result = run_episode(Scenario(embodiment="abstract", task=task, duration=1.0))
    assert result.task == task
    assert result.episode_time == pytest.approx(1.0, abs=0.01)
    assert result.tracking.rms_mm < 5.0 and result.tracking.rms_deg < 2.0
    assert not result.success and result.reason


@pytest.mark.slow
@pytest.mark.parametrize("task, embodiment, seed", [
    ("lid", "abstract", 1), ("lid", "abstract", 2), ("lid", "panda", 1), ("lid", "panda", 2),
    ("cup", "abstract", 1), ("cup", "panda", 2), ("ladle", "abstract", 1),
    ("ladle", "panda", 2)])
def test_scripted_expert_succeeds(task, embodiment, seed):
    scenario = Scenario(embodiment=embodiment, task=task, seed=seed)
    scenario.camera.enabled = False
    result = run_episode(scenario)
    assert result.success, result.reason
    assert result.tracking.rms_mm <= 5.0 and result.tracking.rms_deg <= 2.0
    limit = {"lid": 25.0, "cup": 25.0, "ladle": 30.0}[task]  # medians: 11.5, 12.5, 16.1 s
    assert result.success_time is not None and result.success_time < limit


@pytest.mark.parametrize("task", ["lid", "cup", "ladle"])
def test_same_seed_same_episode(task):
    scenario = Scenario(embodiment="abstract", task=task, seed=3, duration=6.0)
    scenario.camera.enabled = False
    a, b = run_episode(scenario), run_episode(scenario)
    assert a.metrics == b.metrics and a.tracking == b.tracking
    other = run_episode(scenario.replace(seed=4))
    assert other.metrics != a.metrics


@pytest.mark.slow
def test_spot_feet_stay_put_and_legs_follow_the_body():
    scenario = Scenario(embodiment="spot", seed=0, duration=6.0)
    scenario.camera.enabled = False
    result = run_episode(scenario)
    assert result.tracking.max_foot_drift_mm < 5.0
    assert result.tracking.rms_mm < 5.0


def test_the_fisheye_camera_in_the_closed_loop():
    """``camera.model: fisheye`` renders the gripper's view through the T265-like lens: same
    image format as the pinhole, a different (wider-cornered) picture of the same scene."""
    from pydrake.systems.analysis import Simulator

    from legato_drake.diagram import build_diagram
    from legato_drake.episode import initialize

    images = {}
    for model in ("pinhole", "fisheye"):
        scenario = Scenario(embodiment="panda", duration=0.5)
        scenario.camera.model = model
        built = build_diagram(scenario)
        simulator = Simulator(built.diagram)
        initialize(built, simulator)
        simulator.AdvanceTo(0.5)
        left, right = built.camera.render(
            built.camera.GetMyContextFromRoot(simulator.get_context()))
        assert left.shape == right.shape == (128, 128, 1) and left.dtype.name == "uint8"
        assert 20 < left.mean() < 235 and left.std() > 10  # a scene, not a blank
        images[model] = left.astype(float)
    assert abs(images["pinhole"] - images["fisheye"]).mean() > 5
