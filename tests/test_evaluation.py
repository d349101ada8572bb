"""Evaluation: resumable results, tables, plots; and the end-to-end pipeline (collect, train,
evaluate through the real diagram)."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from legato_drake.cli import main
from legato_drake.errors import ConfigError
from legato_drake.learning.train import train
from legato_drake.pipelines import evaluate as evaluation
from legato_drake.pipelines.evaluate import (
    TrialJob,
    combine,
    evaluate,
    load_results,
    plot_success,
    results_path,
)
from legato_drake.summary import failure_rows, reason_kind, trial_rows
from tests.learning_helpers import synthetic_dataset, tiny_config

CONFIGS = Path(__file__).resolve().parents[1] / "configs"


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("eval")
    data = synthetic_dataset(tmp / "d.hdf5", demos=3, length=10, images=False)
    train(tiny_config(steps=2), data, tmp / "run", progress=False)
    return tmp / "run" / "best.pt"


def _fake_trial(job: TrialJob) -> dict:
    s = job.scenario
    return {"method": job.method, "embodiment": s.embodiment, "task": s.task,
            "trial": job.trial, "seed": s.seed, "success": s.seed % 2 == 0,
            "reason": "" if s.seed % 2 == 0 else "fake", "success_time": 1.0,
            "episode_time": 2.0, "wall_time": 0.1, "html": None}


def test_results_are_written_per_trial_and_an_interrupted_run_resumes(tmp_path, checkpoint,
                                                                       monkeypatch):
    calls = []

    def flaky(job):
        calls.append(job.scenario.seed)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return _fake_trial(job)

    monkeypatch.setattr(evaluation, "run_trial", flaky)
    with pytest.raises(KeyboardInterrupt):
        evaluate(checkpoint, ["abstract", "panda"], ["lid"], 2, tmp_path, progress=False)
    path = results_path(tmp_path, "tiny")
    assert len(load_results(path)["trials"]) == 2
    monkeypatch.setattr(evaluation, "run_trial", _fake_trial)
    doc = evaluate(checkpoint, ["abstract", "panda"], ["lid"], 2, tmp_path, progress=False)
    assert [(t["embodiment"], t["seed"]) for t in doc["trials"]] == [
        ("abstract", 10000), ("abstract", 10001), ("panda", 10000), ("panda", 10001)]
    with open(path.with_suffix(".csv"), newline="") as f:
        assert len(list(csv.DictReader(f))) == 4
    rows = trial_rows(doc["trials"])
    assert rows[0][:4] == ["tiny", "abstract", "lid", "1/2"] and rows[0][4] == 50.0
    assert failure_rows(doc["trials"])[0][3] == "fake x1"
    assert reason_kind("lid still held: the fingers are open 1 mm") == "lid still held"
    assert reason_kind("lid centre 23.9 cm from the pot axis (max 3 cm)") == \
        "lid centre … from the pot axis"
    assert reason_kind("lid -1.4 cm from resting on the rim (allowed -1.0 to +1.5 cm)") == \
        "lid … from resting on the rim"
    assert reason_kind("lid tilted 62 deg (max 15 deg)") == "lid tilted …"
    png = plot_success(combine([path]), tmp_path / "p.png")
    assert png.stat().st_size > 1000


def test_training_seeds_and_foreign_results_are_refused(tmp_path, checkpoint):
    with pytest.raises(ConfigError, match="used for training"):
        evaluate(checkpoint, ["abstract"], ["lid"], 2, tmp_path, seed0=0, progress=False)
    results_path(tmp_path, "tiny").write_text(json.dumps(
        {"format": evaluation.FORMAT, "checkpoint": "/else.pt", "trials": []}))
    with pytest.raises(ConfigError, match="/else.pt"):
        evaluate(checkpoint, ["abstract"], ["lid"], 1, tmp_path, progress=False)
    (tmp_path / "x.json").write_text("[]")
    with pytest.raises(ConfigError, match="not a legato_drake evaluation"):
        load_results(tmp_path / "x.json")


def test_training_scenes_run_only_as_a_labelled_diagnostic(tmp_path, checkpoint, monkeypatch):
    """``seen_scenes`` (``--seen-scenes``) runs the seeds the checkpoint trained on and says
    which they were; a run on unseen seeds lists none."""
    monkeypatch.setattr(evaluation, "run_trial", _fake_trial)
    doc = evaluate(checkpoint, ["abstract"], ["lid"], 2, tmp_path, seed0=1, progress=False,
                   seen_scenes=True)
    assert [t["seed"] for t in doc["trials"]] == [1, 2]
    assert doc["seen_scenes"] == [1, 2]
    assert load_results(results_path(tmp_path, "tiny"))["seen_scenes"] == [1, 2]
    fresh = evaluate(checkpoint, ["abstract"], ["lid"], 1, tmp_path / "b", progress=False,
                     seen_scenes=True)
    assert fresh["seen_scenes"] == []


def test_a_changed_checkpoint_duration_or_target_lead_is_not_mixed_in(tmp_path, checkpoint,
                                                                     monkeypatch):
    monkeypatch.setattr(evaluation, "run_trial", _fake_trial)
    ckpt = tmp_path / "model.pt"
    ckpt.write_bytes(checkpoint.read_bytes())
    out = tmp_path / "results"
    doc = evaluate(ckpt, ["abstract"], ["lid"], 1, out, duration=5.0, progress=False)
    assert doc["checkpoint_sha256"] == evaluation.file_sha256(ckpt)
    assert evaluation.file_sha256(out / "tiny.pt") == doc["checkpoint_sha256"]  # the frozen copy
    with pytest.raises(ConfigError, match="--duration"):
        evaluate(ckpt, ["abstract"], ["lid"], 2, out, duration=9.0, progress=False)
    with pytest.raises(ConfigError, match="--max-target-lead"):
        evaluate(ckpt, ["abstract"], ["lid"], 2, out, duration=5.0, progress=False,
                 max_target_lead=0.0)
    train(tiny_config(steps=3), synthetic_dataset(tmp_path / "d.hdf5", demos=3, length=10,
                                                  images=False), tmp_path / "run",
          progress=False)
    ckpt.write_bytes((tmp_path / "run" / "best.pt").read_bytes())  # retrained in place
    with pytest.raises(ConfigError, match="checkpoint_sha256"):
        evaluate(ckpt, ["abstract"], ["lid"], 2, out, duration=5.0, progress=False)


def test_rollout_settings_change_a_copy_and_are_not_mixed_in(tmp_path, checkpoint,
                                                              monkeypatch):
    """``--set inference_steps=3``: the trials run a copy of the checkpoint with that setting
    (the weights unchanged), the results file records it, a rerun with other settings is
    refused, and a training field cannot be set at evaluation."""
    from legato_drake.learning.checkpoint import load_checkpoint

    seen = []

    def trial(job: TrialJob) -> dict:
        seen.append(load_checkpoint(job.scenario.checkpoint).config.inference_steps)
        return _fake_trial(job)

    monkeypatch.setattr(evaluation, "run_trial", trial)
    doc = evaluate(checkpoint, ["abstract"], ["lid"], 1, tmp_path, progress=False,
                   overrides=["inference_steps=3", "action_horizon=2"])
    assert seen == [3] and doc["rollout"] == {"action_horizon": 2, "inference_steps": 3,
                                              "sample_seed": None, "rollout_noise": "policy",
                                              "noise_scale": 1.0,
                                              "rnn_memory": "reset",
                                              "gmm_action": "most_likely"}
    # A results file written before rnn_memory, gmm_action and the rollout noise's fields
    # existed resumes: a missing field is its default.
    older = json.loads((tmp_path / "tiny.json").read_text())
    for name in ("rnn_memory", "gmm_action", "sample_seed", "rollout_noise", "noise_scale"):
        del older["rollout"][name]
    (tmp_path / "tiny.json").write_text(json.dumps(older))
    evaluate(checkpoint, ["abstract"], ["lid"], 1, tmp_path, progress=False,
             overrides=["inference_steps=3", "action_horizon=2"])
    frozen, trained = load_checkpoint(tmp_path / "tiny.pt"), load_checkpoint(checkpoint)
    assert frozen.config.action_horizon == 2 and trained.config.inference_steps != 3
    for name, tensor in trained.policy.state_dict().items():
        assert np.array_equal(frozen.policy.state_dict()[name].numpy(), tensor.numpy())
    with pytest.raises(ConfigError, match="--set"):
        evaluate(checkpoint, ["abstract"], ["lid"], 1, tmp_path, progress=False,
                 overrides=["inference_steps=5", "action_horizon=2"])
    with pytest.raises(ConfigError, match="'lr=0.1'.*action_horizon, inference_steps, "
                                          "sample_seed, rollout_noise, noise_scale, "
                                          "rnn_memory, "
                                          "gmm_action"):
        evaluate(checkpoint, ["abstract"], ["lid"], 1, tmp_path / "other", progress=False,
                 overrides=["lr=0.1"])
    assert not (tmp_path / "other").exists()


def test_a_trial_that_raises_is_a_recorded_failure(tmp_path, checkpoint, monkeypatch):
    def boom(scenario, html=None):
        raise RuntimeError("the solver diverged")

    monkeypatch.setattr(evaluation, "run_episode", boom)
    doc = evaluate(checkpoint, ["abstract"], ["lid"], 1, tmp_path, progress=False)
    (trial,) = doc["trials"]
    assert not trial["success"] and "the solver diverged" in trial["reason"]


def test_scenario_checks_the_checkpoint_field(tmp_path):
    from legato_drake.scenario import Scenario

    with pytest.raises(ConfigError, match="checkpoint must name"):
        Scenario(controller="policy").validate()
    with pytest.raises(ConfigError, match=r"checkpoint: file not found: .*none\.pt"):
        Scenario(controller="policy", checkpoint=str(tmp_path / "none.pt")).validate()


def test_image_policy_needs_the_camera(tmp_path):
    from legato_drake.diagram import build_diagram
    from legato_drake.scenario import Scenario

    data = synthetic_dataset(tmp_path / "d.hdf5", demos=2, length=6)
    train(tiny_config(obs_mode="image", steps=1), data, tmp_path / "run", progress=False)
    scenario = Scenario(embodiment="abstract", controller="policy",
                        checkpoint=str(tmp_path / "run" / "last.pt"))
    scenario.camera.enabled = False
    with pytest.raises(ConfigError, match="camera.enabled"):
        build_diagram(scenario.validate())


@pytest.mark.slow
def test_image_policy_drives_the_diagram_from_the_cameras(tmp_path):
    from legato_drake.diagram import build_diagram
    from legato_drake.episode import simulate
    from legato_drake.scenario import Scenario

    data = synthetic_dataset(tmp_path / "d.hdf5", demos=2, length=6)
    train(tiny_config(obs_mode="image", steps=1), data, tmp_path / "run", progress=False)
    scenario = Scenario(embodiment="abstract", controller="policy", duration=0.25,
                        checkpoint=str(tmp_path / "run" / "last.pt"))
    scenario.camera.width = scenario.camera.height = 32
    built = build_diagram(scenario.validate())
    simulator, result = simulate(built)
    context = built.controller.GetMyContextFromRoot(simulator.get_context())
    assert built.controller.policy_state(context).step == 3
    assert result.episode_time == pytest.approx(0.25, abs=0.01)


@pytest.mark.slow
def test_collect_train_evaluate_end_to_end(tmp_path, capsys):
    """Real short episodes (camera off), the small state config trained for 150 steps, then
    one closed-loop trial through the real diagram, evaluated twice (the second resumes)."""
    from legato_drake.pipelines.collect import collect

    data = tmp_path / "lid.hdf5"
    collect("lid", "abstract", 3, data, keep_failures=True, duration=4.0, camera=False,
            progress=False)
    run = tmp_path / "run"
    assert main(["train", "--config", str(CONFIGS / "legato_small_state.yaml"), "--data",
                 str(data), "--out", str(run), "--steps", "150", "--set", "valid_every=50",
                 "--set", "checkpoint_every=50", "--set", "valid_batches=2"]) == 0
    with open(run / "log.csv", newline="") as f:
        losses = [float(row["total"]) for row in csv.DictReader(f)]
    assert len(losses) == 150
    assert np.mean(losses[-20:]) < 0.8 * np.mean(losses[:20])

    args = ["evaluate", "--checkpoint", str(run / "best.pt"), "--embodiments", "abstract",
            "--tasks", "lid", "--trials", "1", "--out", str(tmp_path / "results"),
            "--duration", "1.0", "--replays", "1"]
    assert main(args) == 0
    path = tmp_path / "results" / "legato_small_state.json"
    first = load_results(path)
    (trial,) = first["trials"]
    assert trial["seed"] == 10000 and trial["episode_time"] == pytest.approx(1.0, abs=0.01)
    assert trial["reason"] or trial["success"]
    assert "center_offset" in trial["metrics"]
    assert Path(trial["html"]).stat().st_size > 100_000
    assert (tmp_path / "results" / "legato_small_state.png").is_file()
    assert main(args) == 0  # resumes: nothing left to run
    assert load_results(path) == first
    assert main(["evaluate", "--plot", str(path), "--out", str(tmp_path / "results")]) == 0
    assert (tmp_path / "results" / "success_rates.png").is_file()
    assert "legato_small_state" in capsys.readouterr().out


def test_another_seed_range_is_refused_unless_overwrite(tmp_path, checkpoint, monkeypatch):
    monkeypatch.setattr(evaluation, "run_trial", _fake_trial)
    evaluate(checkpoint, ["abstract"], ["lid"], 2, tmp_path, progress=False)
    path = results_path(tmp_path, "tiny")
    before = path.read_text()
    with pytest.raises(ConfigError, match="--seed0") as error:
        evaluate(checkpoint, ["abstract"], ["lid"], 2, tmp_path, seed0=20000, progress=False)
    assert "--overwrite" in str(error.value)
    with pytest.raises(ConfigError, match="outside"):  # fewer trials: another trial set
        evaluate(checkpoint, ["abstract"], ["lid"], 1, tmp_path, progress=False)
    assert path.read_text() == before  # nothing merged, nothing lost
    doc = evaluate(checkpoint, ["abstract"], ["lid"], 3, tmp_path, progress=False)
    assert [t["seed"] for t in doc["trials"]] == [10000, 10001, 10002]  # extends
    doc = evaluate(checkpoint, ["abstract"], ["lid"], 2, tmp_path, seed0=20000,
                   overwrite=True, progress=False)
    assert [t["seed"] for t in doc["trials"]] == [20000, 20001]
    assert load_results(path)["seed0"] == 20000


@pytest.mark.parametrize("changes, words", [
    (dict(trials=0), ["--trials"]),
    (dict(seed0=-100), ["--seed0"]),
    (dict(duration=float("nan")), ["--duration"]),
    (dict(duration=-1.0), ["--duration"]),
    (dict(workers=0), ["--workers"]),
    (dict(replays=-1), ["--replays"]),
    (dict(method="../x"), ["--method"]),
    (dict(embodiments=["r2d2"]), ["--embodiments", "r2d2"]),
    (dict(tasks=[]), ["--tasks"]),
])
def test_inputs_are_checked_before_any_work(tmp_path, changes, words):
    args = dict(embodiments=["abstract"], tasks=["lid"], trials=1, workers=1, replays=0,
                method=None, seed0=10000, duration=None)
    args.update(changes)
    with pytest.raises(ConfigError) as error:
        evaluation.check_inputs(**args)
    for word in words:
        assert word in str(error.value)
    kwargs = {k: v for k, v in args.items() if k not in ("embodiments", "tasks", "trials")}
    with pytest.raises(ConfigError):  # evaluate checks them before reading the checkpoint
        evaluate(tmp_path / "none.pt", args["embodiments"], args["tasks"], args["trials"],
                 tmp_path, **kwargs)
