"""The retargeting benchmark: an Abstract trajectory replayed open-loop on another robot."""

from __future__ import annotations

import json

import pytest

from legato_drake.pipelines import retarget
from legato_drake.pipelines.retarget import run_benchmark, write_results
from legato_drake.summary import RETARGET_HEADERS, retarget_rows


def test_every_embodiment_replays_the_script_of_its_scene(monkeypatch):
    """Job wiring alone (no simulation): one recording per task and seed, on Abstract, then
    one replay per embodiment, task and seed of the recording of that task and seed."""
    def record(job):
        assert job.scenario.embodiment == "abstract" and not job.scenario.camera.enabled
        return (job.scenario.task, job.scenario.seed)

    def replay(job):
        s = job.scenario
        assert job.script == (s.task, s.seed) and not s.camera.enabled
        return dict(embodiment=s.embodiment, task=s.task, seed=s.seed)

    monkeypatch.setattr(retarget, "run_record_job", record)
    monkeypatch.setattr(retarget, "run_replay_job", replay)
    rows = run_benchmark(["panda", "spot"], ["lid", "cup"], [3, 4])
    assert [(r["embodiment"], r["task"], r["seed"]) for r in rows] == [
        (e, t, s) for e in ("panda", "spot") for t in ("lid", "cup") for s in (3, 4)]


@pytest.mark.slow
def test_abstract_trajectory_retargets_onto_the_google_robot(tmp_path):
    rows = run_benchmark(["abstract", "google"], ["lid"], [0])
    assert [r["embodiment"] for r in rows] == ["abstract", "google"]
    for row in rows:
        assert row["success"], row["reason"]
        assert row["rms_mm"] < 5.0 and row["rms_deg"] < 2.0
        assert row["min_limit_margin"] > -1e-3
        assert 0.0 < row["ik_median_ms"] < 50.0
    table = retarget_rows(rows)
    assert len(table) == 2 and len(table[0]) == len(RETARGET_HEADERS)
    csv_path, json_path = write_results(rows, tmp_path)
    assert csv_path.read_text().splitlines()[0].startswith("embodiment,task,seed,success")
    assert json.loads(json_path.read_text()) == rows
