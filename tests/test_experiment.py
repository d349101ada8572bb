"""``legato-drake experiment``: the grid file, unit keys, the report, and the smoke grid end to
end on the local backend and on a local Ray cluster, with a killed driver and a killed Ray
worker."""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import logging
import os
import re
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
import torch

from legato_drake.errors import ConfigError
from legato_drake.executor import Blob, make_backend
from legato_drake.experiment import runner
from legato_drake.experiment.grid import load_grid, subset
from legato_drake.experiment.report import overall_table, task_table
from legato_drake.experiment.runner import (
    dataset_path,
    plan_runs,
    trained_runs,
    training_key,
    trial_key,
)
from legato_drake.experiment.units import TrainUnit, run_unit, unit_key
from legato_drake.learning.checkpoint import load_checkpoint
from legato_drake.learning.config import key_fields
from legato_drake.learning.train import train
from legato_drake.scenario import DEFAULT_MAX_TARGET_LEAD
from legato_drake.tasks import TASKS
from tests.learning_helpers import synthetic_dataset, tiny_config

ROOT = Path(__file__).resolve().parents[1]
SMOKE = ROOT / "configs" / "experiments" / "smoke.yaml"
PAPER = ROOT / "configs" / "experiments" / "paper.yaml"


def _cli(*args: str, timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "legato_drake.cli", *args],
                          capture_output=True, text=True, timeout=timeout)


def _rows(path: Path) -> dict[tuple, dict]:
    """trials.jsonl by (phase, checkpoint, robot, seed), without what differs between two
    experiment folders: the wall time, and the checkpoint's hash and so the key (a
    checkpoint records the path of its dataset, whose file differs in its timings)."""
    rows, keys = {}, set()
    for line in path.read_text().splitlines():
        row = json.loads(line)
        assert row["key"] not in keys, "a trial ran twice"
        keys.add(row.pop("key"))
        for name in ("wall_time", "checkpoint_sha256"):
            row.pop(name)
        rows[row["phase"], row["candidate"], row["embodiment"], row["seed"]] = row
    return rows


def _grid(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "grid.yaml"
    path.write_text(text)
    return path


# --- the grid file --------------------------------------------------------------------------

def test_shipped_grids_load():
    smoke, paper = load_grid(SMOKE), load_grid(PAPER)
    assert smoke.evaluation.tasks == ["lid"] and len(smoke.methods) == 1
    assert paper.evaluation.tasks == ["lid", "cup", "ladle"]
    assert len(paper.evaluation.embodiments) == 5 and paper.evaluation.trials == 50
    assert len(paper.training.seeds) >= 3
    assert {"legato", "legato_se3", "bc_rnn", "dp_velocity", "dp_reltraj"} <= \
        {m.name for m in paper.methods}


@pytest.mark.parametrize("path", sorted((ROOT / "configs" / "experiments").glob("*.yaml")),
                         ids=lambda p: p.stem)
def test_every_shipped_grid_builds_each_methods_learning_config(path):
    """Every shipped grid loads (``load_grid`` validates each method's config and overrides),
    so a method declared before it trains fails here on a typo, not hours into an
    experiment."""
    grid = load_grid(path)
    seed = grid.training.seeds[0]
    for method in grid.methods:
        assert grid.learning_config(method, seed).seed == seed, method.name


GOOD = """
datasets: [{task: lid, episodes: 4}]
methods: [{name: a, config: legato_small_state.yaml}]
"""


@pytest.mark.parametrize("text, message", [
    ("datasets: [{task: lid, episodes: 4, colour: red}]\nmethods: []",
     "unknown field 'datasets[0].colour'"),
    ("datasets: [{task: soup}]\nmethods: [{name: a, config: legato_small_state.yaml}]",
     "datasets[0].task: unknown 'soup'; valid values: lid, cup, ladle"),
    ("datasets: [{task: lid, noise_full_speed: 0}]\nmethods: [{name: a, config: "
     "legato_small_state.yaml}]", "datasets[0].noise_full_speed must be a positive speed"),
    ("datasets: [{task: lid, cameras: true, camera_model: orthographic}]\nmethods: [{name: a, "
     "config: legato_small_state.yaml}]",
     "datasets[0].camera_model: unknown 'orthographic'; valid values: pinhole, fisheye"),
    ("datasets: [{task: lid, camera_model: fisheye}]\nmethods: [{name: a, config: "
     "legato_small_state.yaml}]", "datasets[0].camera_model 'fisheye' needs cameras: true"),
    (GOOD + "training: {seeds: 0}", "training.seeds must be a list"),
    (GOOD + "training: {threads: two}", "training.threads must be an integer"),
    (GOOD + "training: {device: tpu}", "training.device: unknown 'tpu'; valid values: cpu"),
    (GOOD + "evaluation: {tasks: [cup]}", "evaluation.tasks[0]: no dataset of task 'cup'"),
    (GOOD + "evaluation: {embodiments: [r2d2]}", "evaluation.embodiments[0]: unknown 'r2d2'"),
    (GOOD + "evaluation: {seed0: 2}", "evaluation seeds overlap the training seeds"),
    (GOOD + "selection: {seed0: 10005}", "evaluation seeds overlap the selection seeds"),
    (GOOD + "evaluation: {max_target_lead: -0.01}",
     "evaluation.max_target_lead must be at least 0"),
    ("datasets: [{task: lid}]\nmethods: [{name: a, config: nope.yaml}]",
     "methods[0].config: no learning config 'nope.yaml'"),
    ("datasets: [{task: lid}]\nmethods: [{name: a, config: legato_small_state.yaml, "
     "overrides: [stepz=3]}]", "methods[0] (a):"),
    ("datasets: [{task: lid}]\nmethods: [{name: a b, config: legato_small_state.yaml}]",
     "methods[0].name 'a b'"),
    ("datasets: [{task: lid}]\nmethods: [{name: a, config: legato_small_state.yaml}, "
     "{name: a, config: bc_rnn_small_state.yaml}]", "expected a unique plain name"),
    ("methods: [", "malformed grid file"),
    ("datasets: [{task: lid}]\nmethods: [{name: a, config: legato_small_state.yaml}, "
     "{name: b, config: legato_small_state.yaml}]", "methods[1] (b) trains exactly what "
     "methods[0] trains"),
])
def test_bad_grids_are_one_line_errors(tmp_path, text, message):
    with pytest.raises(ConfigError, match=re.escape(message)):
        load_grid(_grid(tmp_path, text))


def test_cli_bad_input_is_one_line(tmp_path):
    result = _cli("experiment", str(SMOKE), "--out", str(tmp_path / "x"),
                  "--methods", "legato,nope", timeout=120)
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr.strip().splitlines() == [
        f"legato-drake: error: --methods: ['nope'] not in the grid {SMOKE}; it has: legato"]
    assert not (tmp_path / "x").exists()
    result = _cli("experiment", str(SMOKE), "--out", str(tmp_path / "y"),
                  "--ray-address", "127.0.0.1:1", timeout=120)
    assert result.returncode == 2
    assert "--ray-address: only with --backend ray" in result.stderr


def test_unit_keys_follow_their_inputs(tmp_path):
    """Changing one method changes only that method's runs; the part of a grid has the
    grid's own units."""
    assert unit_key("a", {"x": 1, "y": 2}) == unit_key("a", {"y": 2, "x": 1})
    assert unit_key("a", 1) != unit_key("a", 2)
    two = GOOD.replace("methods: [{name: a, config: legato_small_state.yaml}]",
                       "methods: [{name: a, config: legato_small_state.yaml}, "
                       "{name: b, config: bc_rnn_small_state.yaml}]")
    before = {(r.method.name, r.seed): r.key for r in plan_runs(
        load_grid(_grid(tmp_path, two + "training: {seeds: [0, 1]}")), tmp_path)}
    changed = two.replace("bc_rnn_small_state.yaml}", "bc_rnn_small_state.yaml, "
                          "overrides: [lr=0.0005]}")
    after = {(r.method.name, r.seed): r.key for r in plan_runs(
        load_grid(_grid(tmp_path, changed + "training: {seeds: [0, 1]}")), tmp_path)}
    assert len(set(before.values())) == 4
    assert [k for k in before if before[k] != after[k]] == [("b", 0), ("b", 1)]
    grid = load_grid(_grid(tmp_path, two + "training: {seeds: [0, 1]}"))
    part = subset(grid, methods=["b"], seeds=[1])
    assert [(r.method.name, r.seed, r.key) for r in plan_runs(part, tmp_path)] == \
        [("b", 1, before["b", 1])]


def test_development_seeds_move_the_evaluation_alone(tmp_path):
    """``--embodiments`` and ``--seed0`` evaluate the grid's own trainings elsewhere (e.g.
    development seeds on Abstract); seeds a training demo or a selection trial used are
    refused, naming the flag."""
    grid = load_grid(_grid(tmp_path, GOOD + "evaluation: {embodiments: [abstract, panda]}"))
    part = subset(grid, embodiments=["abstract"], seed0=20000)
    assert part.evaluation.embodiments == ["abstract"] and part.evaluation.seed0 == 20000
    assert [r.key for r in plan_runs(part, tmp_path)] == \
        [r.key for r in plan_runs(grid, tmp_path)]
    assert grid.evaluation.seed0 != 20000  # the grid itself is unchanged
    with pytest.raises(ConfigError, match=r"--seed0 5000: evaluation seeds overlap the "
                                          r"selection seeds"):
        subset(grid, seed0=5000)
    with pytest.raises(ConfigError, match=r"--seed0 3: .*overlap the training seeds"):
        subset(grid, seed0=3)
    with pytest.raises(ConfigError, match=r"--embodiments: \['spot'\] not in the grid"):
        subset(grid, embodiments=["spot"])


def test_dataset_keys_follow_the_experts_demo_version(tmp_path, monkeypatch):
    """A task whose expert changed (a higher ``demo_version``) gets a new dataset, and so new
    runs; version 1 keeps the keys of the grids that predate versions."""
    grid = load_grid(_grid(tmp_path, GOOD))
    task = grid.evaluation.tasks[0]
    monkeypatch.setattr(TASKS[task], "demo_version", 1)
    first = dataset_path(grid, task, tmp_path)
    assert first.name.endswith(unit_key("dataset", grid.dataset_for(task).key_fields())[:10]
                               + ".hdf5")
    runs = {r.key for r in plan_runs(grid, tmp_path)}
    monkeypatch.setattr(TASKS[task], "demo_version", 2)
    assert dataset_path(grid, task, tmp_path) != first
    assert not runs & {r.key for r in plan_runs(grid, tmp_path)}


def test_dataset_keys_name_the_noise_full_speed_and_the_lens_unless_default(tmp_path,
                                                                             monkeypatch):
    """``noise_full_speed`` and ``camera_model`` at their defaults keep the dataset keys of
    grids written before them; another value is another dataset, and the lens is the one the
    grid's collection records with."""
    grid = load_grid(_grid(tmp_path, GOOD))
    task = grid.evaluation.tasks[0]
    spec = grid.dataset_for(task)
    before = {k: v for k, v in dataclasses.asdict(spec).items()
              if k not in ("noise_full_speed", "camera_model")}
    first = dataset_path(grid, task, tmp_path)
    version = TASKS[task].demo_version
    assert first.name.endswith(unit_key("dataset", before, *([version] if version != 1
                                                             else []))[:10] + ".hdf5")
    spec.noise_full_speed = 0.03
    slow = dataset_path(grid, task, tmp_path)
    assert slow != first
    assert spec.expert_noise().full_speed == 0.03
    spec.cameras, spec.camera_model = True, "fisheye"
    fisheye = dataset_path(grid, task, tmp_path)
    spec.camera_model = "pinhole"
    assert len({fisheye, dataset_path(grid, task, tmp_path), slow}) == 3

    class CollectCalledError(Exception):
        pass

    def collect(*args, **kwargs):
        raise CollectCalledError(kwargs)

    monkeypatch.setattr(runner, "collect", collect)
    spec.camera_model = "fisheye"
    with pytest.raises(CollectCalledError) as caught:
        runner.run_experiment(grid, tmp_path / "out", make_backend("local", 1))
    assert caught.value.args[0]["camera"] is True
    assert caught.value.args[0]["camera_model"] == "fisheye"


def test_trial_keys_name_the_target_lead_bound_unless_unbounded(tmp_path):
    """A trial's key names the bound on the commanded gripper's lead it ran under, so that
    bounded and unbounded trials never count for one another; unbounded trials keep the keys
    they had before the bound existed."""
    blob = Blob.of(synthetic_dataset(tmp_path / "d.hdf5", demos=2, length=5, images=False))
    keys = {}
    for lead in (0.0, 0.03, 0.05):
        grid = load_grid(_grid(tmp_path, GOOD + f"evaluation: {{max_target_lead: {lead}}}"))
        run = plan_runs(grid, tmp_path)[0]
        keys[lead] = trial_key(run, blob, "spot", 10000, grid.evaluation)
    assert keys[0.0] == unit_key("trial", run.key, blob.sha256, "spot", "lid", 10000, 0.0)
    assert len(set(keys.values())) == 3
    assert load_grid(SMOKE).evaluation.max_target_lead == DEFAULT_MAX_TARGET_LEAD > 0


def test_training_keys_leave_out_the_rollout_fields_alone(tmp_path):
    """Configs that differ in ``ROLLOUT_FIELDS`` alone share a training key, any other field
    does not; a finished run is found by the config its ``unit.json`` records, so a run of
    an older format (a field missing) matches no current config."""
    config = tiny_config()
    recorded = config.to_dict()
    older = {k: v for k, v in recorded.items() if k != "chunk_targets"}
    for name, fields in (("current", recorded), ("older", older)):
        (tmp_path / "runs" / name).mkdir(parents=True)
        (tmp_path / "runs" / name / "unit.json").write_text(
            json.dumps({"data": "d.hdf5", "config": fields}))
    found = trained_runs(tmp_path)
    assert len(found) == 2
    acting = dataclasses.replace(config, action_horizon=2, inference_steps=3)
    assert found[training_key("d.hdf5", acting)].name == "current"
    for changed in (dataclasses.replace(config, lr=config.lr * 2),
                    dataclasses.replace(config, chunk_targets="actions")):
        assert training_key("d.hdf5", changed) not in found
    assert training_key("e.hdf5", acting) not in found


def test_fields_added_at_a_neutral_value_keep_the_keys_of_older_runs(tmp_path):
    """A run recorded before L_invar's turn resolution, Min-SNR weighting, image resizing,
    the object loss, the learning-rate schedule, the LSTM's rollout memory, the recurrent
    families' weight average, the batch order's own seed, the small trunk's strides, the
    GMM's rollout action and the rollout noise's own seed and scale existed
    keeps its keys for a
    config that sets them to what the code did before; other values get new keys (a rollout
    field's only where the trials are keyed: the training is shared)."""
    config = tiny_config()
    older = {k: v for k, v in config.to_dict().items()
             if k not in ("invariant_turn_eps", "invariant_snr_clip", "image_resize",
                          "object_aux_weight", "lr_schedule", "rnn_memory", "ema",
                          "batch_seed", "encoder_strides", "gmm_action", "sample_seed",
                          "rollout_noise", "noise_scale")}
    neutral = dataclasses.replace(config, invariant_turn_eps=config.invariant_eps,
                                  invariant_snr_clip=0.0, image_resize=0,
                                  object_aux_weight=0.0, lr_schedule="constant",
                                  rnn_memory="reset", ema=False, batch_seed=None,
                                  encoder_strides=None, gmm_action="most_likely",
                                  sample_seed=None)
    assert key_fields(neutral) == older
    assert key_fields(dataclasses.replace(neutral, batch_seed=neutral.seed)) == older
    assert key_fields(dataclasses.replace(neutral, sample_seed=neutral.seed)) == older
    assert key_fields(dataclasses.replace(neutral, encoder_strides=[2, 2])) == older
    assert training_key("d.hdf5", neutral) == training_key("d.hdf5", older)
    for acting in (dataclasses.replace(neutral, rnn_memory="window"),
                   dataclasses.replace(neutral, gmm_action="mixture_mean"),
                   dataclasses.replace(neutral, sample_seed=neutral.seed + 1),
                   dataclasses.replace(neutral, noise_scale=0.5)):
        assert key_fields(acting) != older
        assert training_key("d.hdf5", acting) == training_key("d.hdf5", older)
    for changed in (dataclasses.replace(neutral, invariant_turn_eps=0.5),
                    dataclasses.replace(neutral, invariant_snr_clip=5.0),
                    dataclasses.replace(neutral, image_resize=92),
                    dataclasses.replace(neutral, object_aux_weight=1.0),
                    dataclasses.replace(neutral, lr_schedule="cosine"),
                    dataclasses.replace(neutral, ema=True),
                    dataclasses.replace(neutral, batch_seed=1),
                    dataclasses.replace(neutral, encoder_strides=[2, 1]),
                    dataclasses.replace(neutral, invariant_eps=0.005)):
        assert training_key("d.hdf5", changed) != training_key("d.hdf5", older)
    (tmp_path / "runs" / "older").mkdir(parents=True)
    (tmp_path / "runs" / "older" / "unit.json").write_text(
        json.dumps({"data": "d.hdf5", "config": older}))
    assert trained_runs(tmp_path)[training_key("d.hdf5", neutral)].name == "older"


def test_tables_mean_range_and_pooled_interval():
    rows = [dict(method="m", train_seed=s, embodiment=e, task="lid", success=ok)
            for s, e, successes in [(0, "abstract", 4), (1, "abstract", 2),
                                    (0, "panda", 3), (1, "panda", 1),
                                    (0, "spot", 1), (1, "spot", 3)]
            for ok in [True] * successes + [False] * (4 - successes)]
    lines = task_table(rows, "lid", paper=False)
    assert lines[0] == "| method (training seeds) | abstract | panda | spot | " \
                       "cross-embodiment mean |"
    # abstract: seeds 100 % and 50 %; pooled 6/8; cross: seed 0 (75+25)/2, seed 1 (25+75)/2
    assert lines[2] == ("| m (0, 1) | 75 % (50-100); 6/8 [41-93] | 50 % (25-75); 4/8 [22-78] "
                        "| 50 % (25-75); 4/8 [22-78] | 50 % (50-50) |")
    assert overall_table(rows)[2] == "| m | 2 | 75 % (50-100) | 50 % (50-50) |"
    assert len(task_table(rows, "lid")) == 3 + 4  # and the paper's four methods


# --- the smoke grid, end to end -------------------------------------------------------------

@pytest.fixture(scope="module")
def local_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("experiment") / "local"
    result = _cli("experiment", str(SMOKE), "--out", str(out), "--workers", "2")
    assert result.returncode == 0, result.stderr
    assert "| legato (0) |" in result.stdout  # the summary, on stdout
    return out


def test_local_backend_end_to_end(local_run):
    grid = load_grid(SMOKE)
    with open(local_run / "results.csv") as f:
        results = list(csv.DictReader(f))
    cells = len(grid.evaluation.embodiments) * grid.evaluation.trials
    assert len(results) == cells
    assert {r["embodiment"] for r in results} == set(grid.evaluation.embodiments)
    assert {int(r["seed"]) for r in results} == {10000, 10001}
    assert {float(r["max_target_lead"]) for r in results} == {grid.evaluation.max_target_lead}
    rows = _rows(local_run / "trials.jsonl")
    (run,) = (local_run / "runs").iterdir()  # the training's scratch folder is gone
    selection = json.loads((run / "selection.json").read_text())
    assert [c["name"] for c in selection["candidates"]] == ["step_000030.pt", "step_000060.pt"]
    assert sum(r["phase"] == "select" for r in rows.values()) == 2
    assert (run / "selected.pt").is_file() and (local_run / "summary.md").is_file()
    assert (local_run / "figures" / "lid.png").stat().st_size > 1000
    assert (local_run / "figures" / "cross_embodiment.png").is_file()

    # A finished grid reruns nothing and changes no file.
    before = {p: p.stat().st_mtime_ns for p in local_run.rglob("*")
              if p.is_file() and p.name not in ("grid.json", "results.csv", "summary.md")
              and p.suffix != ".png"}
    result = _cli("experiment", str(SMOKE), "--out", str(local_run))
    assert result.returncode == 0, result.stderr
    assert "ran {'datasets': 0, 'trainings': 0, 'trials': 0}" in result.stderr
    assert {p: p.stat().st_mtime_ns for p in before} == before


def test_a_killed_training_resumes_from_its_scratch_folder(tmp_path, caplog):
    """A training unit whose scratch folder holds a checkpoint (its worker was killed after
    step 10) resumes there and ends with the weights of a training never interrupted; one
    killed before its first checkpoint starts afresh."""
    data = Blob.of(synthetic_dataset(tmp_path / "d.hdf5"))
    config = tiny_config(steps=20)
    _, whole = run_unit(TrainUnit("k", config.to_dict(), data))
    killed = tmp_path / "killed"
    train(config, data.path(), killed, steps=10, progress=False)
    early = tmp_path / "early"
    early.mkdir()
    (early / "log.csv").write_text("step,total\n")
    for scratch in (killed, early):
        caplog.clear()
        with caplog.at_level(logging.INFO, "legato_drake.experiment.units"):
            _, files = run_unit(TrainUnit("k", config.to_dict(), data, scratch=str(scratch)))
        assert ("resuming the training" in caplog.text) == (scratch == killed)
        steps = [row["step"] for row in csv.DictReader(io.StringIO(files["log.csv"].decode()))]
        assert steps == [str(s) for s in range(1, 21)]
        (tmp_path / "a.pt").write_bytes(files["last.pt"])
        (tmp_path / "b.pt").write_bytes(whole["last.pt"])
        a, b = load_checkpoint(tmp_path / "a.pt"), load_checkpoint(tmp_path / "b.pt")
        assert a.step == b.step == 20
        for name, tensor in b.policy.state_dict().items():
            torch.testing.assert_close(a.policy.state_dict()[name], tensor)


def test_a_killed_training_resumes_under_a_run_that_shares_it(tmp_path, caplog):
    """The scratch folder of a training is named by its training key, so a run differing in
    ``ROLLOUT_FIELDS`` alone resumes what another run started (a folder named by the run's
    own key, as before, is renamed), and its files act as its own config says: its rollout
    settings in every checkpoint and in ``config.yaml``, the weights of a training never
    interrupted."""
    data = Blob.of(synthetic_dataset(tmp_path / "d.hdf5"))
    started = tiny_config(steps=20, snapshot_every=10)
    sharing = dataclasses.replace(started, action_horizon=3)
    assert training_key("d", started) == training_key("d", sharing)
    _, whole = run_unit(TrainUnit("k", started.to_dict(), data))

    scratch_root = tmp_path / ".training"
    run = dataclasses.make_dataclass("Run", ["key", "training_key"])(
        "dp-lid-seed0-abc", training_key("d", started))
    train(started, data.path(), scratch_root / run.key, steps=10, progress=False)
    scheduler = dataclasses.make_dataclass("Scheduler", ["scratch"])(scratch_root)
    scratch = runner._Scheduler._scratch_of(scheduler, run)
    assert scratch == scratch_root / run.training_key and (scratch / "last.pt").is_file()
    assert not (scratch_root / run.key).exists()

    with caplog.at_level(logging.INFO, "legato_drake.experiment.units"):
        _, files = run_unit(TrainUnit("k2", sharing.to_dict(), data, scratch=str(scratch)))
    assert "resuming the training" in caplog.text and "with the rollout settings" in caplog.text
    assert "action_horizon: 3" in files["config.yaml"].decode()
    for name in ("last.pt", "step_000010.pt"):
        (tmp_path / name).write_bytes(files[name])
        assert load_checkpoint(tmp_path / name).config.action_horizon == 3
    (tmp_path / "whole.pt").write_bytes(whole["last.pt"])
    a, b = load_checkpoint(tmp_path / "last.pt"), load_checkpoint(tmp_path / "whole.pt")
    assert a.step == b.step == 20
    for name, tensor in b.policy.state_dict().items():
        torch.testing.assert_close(a.policy.state_dict()[name], tensor)


def test_killed_driver_resumes_without_loss_or_repeats(local_run, tmp_path):
    """Kill the driver once some trials are recorded, run again: the recorded trials stay
    as they were, each trial is recorded once, the results equal an uninterrupted run."""
    out = tmp_path / "killed"
    shutil.copytree(local_run / "datasets", out / "datasets")  # skip collecting again
    ledger = out / "trials.jsonl"
    process = subprocess.Popen(
        [sys.executable, "-m", "legato_drake.cli", "experiment", str(SMOKE), "--out",
         str(out)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        start_new_session=True)
    try:
        deadline = time.monotonic() + 300
        while not (ledger.is_file() and len(ledger.read_text().splitlines()) >= 2):
            assert process.poll() is None, "the experiment ended before it could be killed"
            assert time.monotonic() < deadline
            time.sleep(0.05)
    finally:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
    kept = ledger.read_text().splitlines()
    assert 2 <= len(kept) < 6
    result = _cli("experiment", str(SMOKE), "--out", str(out))
    assert result.returncode == 0, result.stderr
    assert "'trainings': 0" in result.stderr.split("ran ")[-1]  # the run was done: kept
    lines = ledger.read_text().splitlines()
    assert lines[:len(kept)] == kept and len(lines) == 6
    assert _rows(ledger) == _rows(local_run / "trials.jsonl")


def test_a_run_differing_in_rollout_settings_alone_shares_the_training(local_run, tmp_path):
    """A method that differs from a finished run only in ``ROLLOUT_FIELDS`` is not trained
    again: its run folder holds the finished run's weights and log, with its own rollout
    settings in every checkpoint and its config, and its trials run (on those
    checkpoints); two such methods in one grid train once."""
    out = tmp_path / "shared"
    shutil.copytree(local_run, out)
    text = SMOKE.read_text()
    overrides = "overrides: [steps=60"
    assert overrides in text
    grid = _grid(tmp_path, text.replace(overrides, "overrides: [action_horizon=3, steps=60"))
    result = _cli("experiment", str(grid), "--out", str(out))
    assert result.returncode == 0, result.stderr
    assert "ran {'datasets': 0, 'trainings': 0, 'trials': 6}" in result.stderr
    (trained,) = [p for p in (local_run / "runs").iterdir()]
    (shared,) = [p for p in (out / "runs").iterdir() if p.name != trained.name]
    assert (shared / "log.csv").read_bytes() == (trained / "log.csv").read_bytes()
    assert "action_horizon: 3" in (shared / "config.yaml").read_text()
    for name in ("step_000030.pt", "step_000060.pt", "last.pt", "selected.pt"):
        a, b = load_checkpoint(trained / name), load_checkpoint(shared / name)
        assert (a.config.action_horizon, b.config.action_horizon) == (8, 3)
        assert training_key("d", a.config) == training_key("d", b.config) and a.step == b.step
        for key, tensor in a.policy.state_dict().items():
            assert torch.equal(b.policy.state_dict()[key], tensor)

    # Two methods that share a training, in a fresh folder: one training, two run folders.
    both = tmp_path / "both"
    shutil.copytree(local_run / "datasets", both / "datasets")
    twice = text.replace("methods:\n", "methods:\n  - name: k3\n    config: "
                         "legato_small_state.yaml\n    overrides: [action_horizon=3, "
                         "steps=60, valid_every=30, checkpoint_every=30, batch_size=8, "
                         "seq_length=4]\n")
    result = _cli("experiment", str(_grid(tmp_path, twice)), "--out", str(both), "--workers",
                  "2")
    assert result.returncode == 0, result.stderr
    assert "'trainings': 1," in result.stderr.split("ran ")[-1]
    assert sorted(p.name.split("-")[0] for p in (both / "runs").iterdir()) == ["k3", "legato"]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


RAY_ENV = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0", "RAY_AUTH_MODE": "token",
           "RAY_AUTH_TOKEN": secrets.token_hex(32),
           "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0", "RAY_worker_niceness": "0"}
"""A Ray cluster on the loopback interface only, with token authentication (a fresh token of
this test run's own, shared by the cluster and the driver through the environment: a fresh
machine has no ``~/.ray/auth_token``, and ``ray start`` makes none), whose workers run at the
tests' priority (Ray's default nice 15 starves them beside the other tests)."""


def _ray(*args: str) -> subprocess.CompletedProcess:
    ray = Path(sys.executable).with_name("ray")
    return subprocess.run([str(ray), *args], capture_output=True, text=True, timeout=180,
                          env=RAY_ENV)


def test_ray_backend_matches_local_and_survives_a_killed_worker(local_run, tmp_path):
    """On a local Ray cluster (``ray start --head``): one worker is killed while it runs a
    trial; the task is retried, the grid completes, and every trial's result equals the local
    backend's."""
    pytest.importorskip("ray")
    port = _free_port()
    started = _ray("start", "--head", "--port", str(port), "--num-cpus", "2",
                   "--include-dashboard", "false", "--disable-usage-stats")
    assert started.returncode == 0, started.stderr
    out = tmp_path / "ray"
    try:
        process = subprocess.Popen(
            [sys.executable, "-m", "legato_drake.cli", "experiment", str(SMOKE), "--out",
             str(out), "--backend", "ray", "--ray-address", f"127.0.0.1:{port}"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=RAY_ENV)
        killed = None
        deadline = time.monotonic() + 400
        while killed is None and process.poll() is None and time.monotonic() < deadline:
            trained = list(out.glob("runs/*/unit.json"))
            workers = subprocess.run(["pgrep", "-f", "ray::(run_unit|_apply)"],
                                     capture_output=True, text=True).stdout.split()
            if trained and workers:  # the training is done: a running unit is a trial
                killed = int(workers[0])
                os.kill(killed, signal.SIGKILL)
            time.sleep(0.05)
        stdout, stderr = process.communicate(timeout=400)
        assert killed is not None, f"no Ray worker ran a trial to kill: {stderr}"
        assert process.returncode == 0, stderr
        assert "| legato (0) |" in stdout
    finally:
        _ray("stop", "--force")
    assert _rows(out / "trials.jsonl") == _rows(local_run / "trials.jsonl")
