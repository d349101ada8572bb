"""Checkpoint selection by rollouts on validation seeds: candidates, the choice, and the
seed wall between selection and evaluation."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from legato_drake.errors import ConfigError
from legato_drake.learning.checkpoint import load_checkpoint
from legato_drake.learning.train import train
from legato_drake.pipelines import evaluate as evaluation
from legato_drake.pipelines.evaluate import TrialJob, evaluate
from legato_drake.pipelines.selection import SELECT_SEED0, candidates, select_checkpoint
from tests.learning_helpers import synthetic_dataset, tiny_config


@pytest.fixture(scope="module")
def run(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("select")
    data = synthetic_dataset(tmp / "d.hdf5", demos=3, length=10, images=False)
    train(tiny_config(steps=6, snapshot_every=2, checkpoint_every=3), data, tmp / "run",
          progress=False)
    return tmp / "run"


def test_snapshots_are_the_candidates(run):
    names = [p.name for p in candidates(run)]
    assert names == ["step_000002.pt", "step_000004.pt", "step_000006.pt"]  # last.pt = step 6
    assert load_checkpoint(run / "step_000004.pt").step == 4


def test_the_most_successful_candidate_is_selected_and_its_seeds_are_walled_off(
        run, monkeypatch):
    seen = []

    def fake_trial(job: TrialJob) -> dict:
        s = job.scenario
        seen.append(s.seed)
        step = load_checkpoint(s.checkpoint).step
        ok = s.seed - SELECT_SEED0 < {2: 1, 4: 3, 6: 2}[step]
        return {"method": job.method, "embodiment": s.embodiment, "task": s.task,
                "trial": job.trial, "seed": s.seed, "success": ok,
                "reason": "" if ok else "fake", "success_time": 1.0, "episode_time": 2.0,
                "wall_time": 0.1, "html": None}

    monkeypatch.setattr(evaluation, "run_trial", fake_trial)
    summary = select_checkpoint(run, "lid", trials=4, progress=False)
    assert set(seen) == set(range(SELECT_SEED0, SELECT_SEED0 + 4))  # never evaluation seeds
    assert summary["selected"] == "step_000004.pt" and summary["step"] == 4
    assert [c["successes"] for c in summary["candidates"]] == [1, 3, 2]
    selected = load_checkpoint(run / "selected.pt")
    assert selected.step == 4 and selected.selection["seeds"] == list(range(5000, 5004))
    assert json.loads((run / "selection.json").read_text())["selected"] == "step_000004.pt"
    with pytest.raises(ConfigError, match="checkpoint selection"):
        evaluate(run / "selected.pt", ["abstract"], ["lid"], 3, run / "eval",
                 seed0=SELECT_SEED0 + 2, progress=False)
    doc = evaluate(run / "selected.pt", ["abstract"], ["lid"], 2, run / "eval",
                   progress=False)
    assert [t["seed"] for t in doc["trials"]] == [10000, 10001]


def test_a_folder_without_candidates_is_a_clear_error(tmp_path):
    with pytest.raises(ConfigError, match="snapshot_every"):
        select_checkpoint(tmp_path, "lid")
