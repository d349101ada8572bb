"""Collecting datasets: real short episodes, seed selection, resuming after a kill, the CLI."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from legato_drake.data.layout import DatasetError, check_file, open_dataset, sorted_demos
from legato_drake.data.synthetic import synthetic_episode
from legato_drake.pipelines import collect as collect_module
from legato_drake.pipelines.collect import collect, parts_dir, record_episode
from legato_drake.scenario import ExpertNoiseConfig, Scenario
from legato_drake.tasks import TASKS


def _cli(*args: str, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "legato_drake.cli", *args],
                          capture_output=True, text=True, timeout=300, **kwargs)


def _seeds(path: Path) -> list[int]:
    with open_dataset(path) as f:
        return [int(f["data"][n].attrs["seed"]) for n in sorted_demos(f["data"])]


def test_state_only_collect_writes_what_the_recorder_recorded(tmp_path):
    out = tmp_path / "d.hdf5"
    report = collect("lid", "abstract", 2, out, keep_failures=True, duration=0.5,
                     camera=False)
    assert [o["seed"] for o in report.kept] == [0, 1]
    check_file(out)
    assert not parts_dir(out).exists()
    manifest = json.loads(out.with_name("d.hdf5.manifest.json").read_text())
    assert manifest["kept"] == ["seed_000000", "seed_000001"] and len(manifest["failed"]) == 2
    scenario = Scenario(embodiment="abstract", task="lid", seed=1, duration=0.5)
    scenario.camera.enabled = False
    _, episode = record_episode(scenario.validate())
    with open_dataset(out) as f:
        demo = f["data/demo_1"]
        assert demo.attrs["num_samples"] == len(episode) == 5
        assert not demo.attrs["success"] and demo.attrs["reason"]
        assert "left_gray" not in demo["obs"]
        np.testing.assert_array_equal(demo["actions"][()], episode.actions)
        np.testing.assert_array_equal(demo["states"][()], episode.states)
        for key, value in episode.obs.items():
            np.testing.assert_array_equal(demo["obs"][key][()], value)
        assert json.loads(demo.attrs["scenario"])["seed"] == 1


class FakeRunner:
    """Stands in for ``run_job``: a synthetic part's bytes; seeds = 1 mod 3 fail."""

    def __init__(self):
        self.seeds: list[int] = []

    def __call__(self, job):
        seed = job.scenario.seed
        self.seeds.append(seed)
        ok = seed % 3 != 1
        episode = synthetic_episode(3, seed=seed, images=False, success=ok)
        episode.attrs.update(key=job.key)
        outcome = dict(key=job.key, seed=seed, success=ok, reason="" if ok else "dropped it",
                       num_samples=3, wall_time=0.0, source="")
        return outcome, collect_module._part_bytes([episode], outcome)


def test_keeps_the_first_successful_seeds_and_extends(tmp_path, monkeypatch):
    runner = FakeRunner()
    monkeypatch.setattr(collect_module, "run_job", runner)
    out = tmp_path / "d.hdf5"
    report = collect("lid", "abstract", 4, out, camera=False)
    assert _seeds(out) == [0, 2, 3, 5] and runner.seeds == [0, 1, 2, 3, 4, 5]
    assert [o["seed"] for o in report.failed] == [1, 4]
    assert report.failed[0]["reason"] == "dropped it"
    runner.seeds.clear()
    collect("lid", "abstract", 4, out, camera=False)  # already there: nothing to do
    assert runner.seeds == []
    collect("lid", "abstract", 6, out, camera=False)  # extends, failures not retried
    assert runner.seeds == [6, 7, 8] and _seeds(out) == [0, 2, 3, 5, 6, 8]
    with pytest.raises(DatasetError, match="other settings.*camera=False, now True"):
        collect("lid", "abstract", 6, out, camera=True)
    # The lid's expert changed since (a new demo version): the old demos are not resumed.
    version = TASKS["lid"].demo_version
    monkeypatch.setattr(TASKS["lid"], "demo_version", version + 1)
    with pytest.raises(DatasetError,
                       match=f"other settings.*demo_version={version}, now {version + 1}"):
        collect("lid", "abstract", 8, out, camera=False)


def test_datasets_recorded_before_the_noise_full_speed_still_resume(tmp_path, monkeypatch):
    """A manifest written before ``expert_noise.full_speed`` existed was collected at its
    default: it is up to date for the default and refused for another speed."""
    runner = FakeRunner()
    monkeypatch.setattr(collect_module, "run_job", runner)
    out = tmp_path / "d.hdf5"
    noise = ExpertNoiseConfig(0.005, 2.0)
    collect("lid", "abstract", 2, out, camera=False, expert_noise=noise)
    manifest_file = out.with_name("d.hdf5.manifest.json")
    manifest = json.loads(manifest_file.read_text())
    assert manifest["config"]["expert_noise"].pop("full_speed") == 0.15
    manifest_file.write_text(json.dumps(manifest))
    runner.seeds.clear()
    collect("lid", "abstract", 2, out, camera=False, expert_noise=noise)
    assert runner.seeds == []  # up to date: nothing collected again
    with pytest.raises(DatasetError, match="other settings.*expert_noise"):
        collect("lid", "abstract", 3, out, camera=False,
                expert_noise=ExpertNoiseConfig(0.005, 2.0, full_speed=0.03))


def test_too_few_successes(tmp_path, monkeypatch):
    monkeypatch.setattr(collect_module, "run_job", FakeRunner())
    report = collect("lid", "abstract", 3, tmp_path / "d.hdf5", seed0=1, max_attempts=3,
                     camera=False)
    assert [o["seed"] for o in report.kept] == [2, 3] and report.requested == 3
    with pytest.raises(DatasetError, match="no episode kept"):
        collect("lid", "abstract", 1, tmp_path / "e.hdf5", seed0=1, max_attempts=1,
                camera=False)


def test_kill_and_resume(tmp_path):
    out = tmp_path / "d.hdf5"
    args = ["collect", "--episodes", "4", "--keep-failures", "--duration", "0.3",
            "--no-camera", "--out", str(out)]
    process = subprocess.Popen([sys.executable, "-m", "legato_drake.cli", *args],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                               start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        while not list(parts_dir(out).glob("seed_*.hdf5")) and time.monotonic() < deadline:
            assert process.poll() is None, "collect ended before it could be killed"
            time.sleep(0.05)
    finally:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
    done_before = sorted(p.stem for p in parts_dir(out).glob("seed_*.hdf5"))
    assert done_before and len(done_before) < 4 and not out.exists()
    result = _cli(*args)
    assert result.returncode == 0, result.stderr
    assert f"resuming: {len(done_before)} episode(s) already recorded" in result.stderr
    check_file(out)
    assert _seeds(out) == [0, 1, 2, 3]
    manifest = json.loads(out.with_name("d.hdf5.manifest.json").read_text())
    assert [o["seed"] for o in manifest["tried"]] == [0, 1, 2, 3]


def _children(pid: int) -> list[int]:
    path = Path(f"/proc/{pid}/task/{pid}/children")
    return [int(c) for c in path.read_text().split()] if path.exists() else []


@pytest.mark.skipif(not Path("/proc/self/task").exists(), reason="reads /proc (Linux)")
def test_sigterm_ends_the_worker_processes_too(tmp_path):
    """``kill`` of a command that runs workers stops them with it, as Ctrl-C does (they would
    otherwise go on using the cores), and the parts recorded so far are kept to resume."""
    out = tmp_path / "d.hdf5"
    process = subprocess.Popen(
        [sys.executable, "-m", "legato_drake.cli", "collect", "--episodes", "6", "--workers",
         "2", "--no-camera", "--duration", "30", "--out", str(out)],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        while len(workers := _children(process.pid)) < 2 and time.monotonic() < deadline:
            assert process.poll() is None, "collect ended before it could be stopped"
            time.sleep(0.05)
        assert len(workers) >= 2, "no worker processes started"
        process.send_signal(signal.SIGTERM)  # the parent alone, not its process group
        _, stderr = process.communicate(timeout=60)
        assert process.returncode == 130 and "interrupted" in stderr
        deadline = time.monotonic() + 30
        while any(Path(f"/proc/{w}").exists() for w in workers) and \
                time.monotonic() < deadline:
            time.sleep(0.1)
        assert not any(Path(f"/proc/{w}").exists() for w in workers), "workers left running"
    finally:  # whatever is left of the group, the parent or orphaned workers
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGKILL)
        process.wait()


def test_cli_collect_with_cameras_and_inspect(tmp_path):
    out = tmp_path / "d.hdf5"
    result = _cli("collect", "--episodes", "2", "--keep-failures", "--duration", "0.4",
                  "--out", str(out), "--workers", "2")
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines()[0].split()[:3] == ["dataset", "episodes", "kept"]
    with open_dataset(out) as f:
        images = f["data/demo_1/obs/left_gray"]
        assert images.shape == (4, 128, 128, 1) and images.dtype == np.uint8
        assert images[()].std() > 5.0  # a scene, not a blank frame

    result = _cli("inspect", str(out), "--episode", "1", "--out", str(tmp_path / "plots"))
    assert result.returncode == 0, result.stderr
    assert "episodes             2" in result.stdout and "valid:" in result.stdout
    assert "dpitch" in result.stdout
    for name in ("demo_1_frames.png", "demo_1_trajectory.png"):
        assert (tmp_path / "plots" / name).read_bytes()[:4] == b"\x89PNG"

    result = _cli("inspect", str(out), "--episode", "5", "--out", str(tmp_path / "plots"))
    assert result.returncode == 2 and "has no episode 5" in result.stderr

    cut = tmp_path / "cut.hdf5"
    cut.write_bytes(out.read_bytes()[:out.stat().st_size // 2])
    result = _cli("inspect", str(cut))
    assert result.returncode == 2 and "truncated" in result.stderr
    assert "Traceback" not in result.stderr

    import h5py

    with h5py.File(out, "a") as f:
        del f["data/demo_0/obs/tcp_commanded"]
    result = _cli("inspect", str(out))
    assert result.returncode == 1
    assert "INVALID" in result.stdout and "demo_0: missing 'obs/tcp_commanded'" in result.stdout
    assert "Traceback" not in result.stderr
