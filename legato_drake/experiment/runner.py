"""Running a grid: collect -> train -> select -> evaluate, on any executor backend, resumable.

``run_experiment(grid, out, executor)`` lays out ``out`` as::

    grid.json                          the grid as run last
    datasets/<task>-<robot>-<key>.hdf5 one per task (``collect``, itself resumable)
    runs/<method>-<task>-seed<s>-<key>/ one per method, task and training seed: the run's
                                       files, selection.json and selected.pt; unit.json last
                                       (runs that differ in ``ROLLOUT_FIELDS`` alone share
                                       one training: the others get copies of its files
                                       with their own rollout settings written in)
    runs/.training/<key>/              a training under way (workers on this machine), until
                                       its files are in its run folder
    trials.jsonl                       every finished trial (selection and evaluation), one
                                       JSON row per line, appended and flushed as each ends
    results.csv                        the evaluation trials (rewritten atomically)
    summary.md, figures/*.png          the tables and figures (``experiment.report``)

Datasets are collected first (their episodes run on the executor); then one stream of jobs
holds the trainings, each run's selection trials once its training is there, and its
evaluation trials once its selection is done. A unit is done when its record exists (a
run's ``unit.json``, a trial's row under its key: the key names the checkpoint's hash, so
retrained weights are never credited with old trials), so a rerun of a finished grid runs
nothing, and a killed one resumes: only the units in flight are lost. A training in flight
resumes from its last checkpoint (``checkpoint_every`` steps) where the workers run on this
machine (the local backend, a Ray cluster on this machine); on a remote Ray node it restarts
from its beginning.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import shutil
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

from legato_drake.errors import ConfigError
from legato_drake.executor import Blob, Executor, RayExecutor
from legato_drake.experiment.grid import EvaluationSpec, Grid, MethodSpec, grid_dict
from legato_drake.experiment.units import TrainUnit, TrialUnit, run_unit, unit_key
from legato_drake.files import atomic_write_bytes, atomic_write_csv, atomic_write_text
from legato_drake.learning.checkpoint import set_rollout_settings
from legato_drake.learning.config import (
    ROLLOUT_FIELDS,
    LearningConfig,
    key_fields,
)
from legato_drake.learning.train import RUN_FILES, SNAPSHOTS
from legato_drake.pipelines.collect import collect
from legato_drake.pipelines.evaluate import TrialJob, trial_order, trial_scenario
from legato_drake.pipelines.selection import candidates, write_selection
from legato_drake.progress import progress_bar
from legato_drake.tasks import TASKS

log = logging.getLogger(__name__)

RESULT_FIELDS = ("method", "train_seed", "embodiment", "task", "seed", "max_target_lead",
                 "success", "reason", "success_time", "episode_time", "wall_time",
                 "checkpoint_step", "run", "key")
"""The columns of ``results.csv``."""


@dataclass
class RunPlan:
    """One training run of the grid and what follows it (its trials)."""

    method: MethodSpec
    task: str
    seed: int
    config: LearningConfig
    data: Path
    key: str
    folder: Path
    selection: dict[str, list[str]] = field(default_factory=dict)
    """Candidate checkpoint name -> the keys of its selection trials."""
    pending: set[str] = field(default_factory=set)
    """Keys of its selection trials not yet finished."""

    @property
    def training_key(self) -> str:
        """What its weights depend on: its dataset and config but the ``ROLLOUT_FIELDS``
        (runs that share it share one training)."""
        return training_key(self.data.name, self.config)

    @property
    def done(self) -> bool:
        """Whether its training is recorded (``unit.json`` is written last)."""
        path = self.folder / "unit.json"
        return path.is_file() and json.loads(path.read_text()).get("key") == self.key


class TrialLedger:
    """The finished trials of an experiment, by key: ``trials.jsonl``, one row per line,
    appended and flushed to disk as each trial ends (a line cut short by a kill is
    ignored on reading, and its trial runs again)."""

    def __init__(self, path: Path):
        self.path = path
        self.rows: dict[str, dict] = {}
        if path.is_file():
            text = path.read_text()
            for line in text.splitlines():
                try:
                    row = json.loads(line)
                except ValueError:
                    continue
                self.rows.setdefault(row["key"], row)
            if text and not text.endswith("\n"):
                with open(path, "a") as f:
                    f.write("\n")  # end the line cut short: the next row starts afresh

    def __contains__(self, key: str) -> bool:
        return key in self.rows

    def add(self, row: dict) -> None:
        """Records a finished trial."""
        self.rows[row["key"]] = row
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with open(self.path, "a") as f:
            f.write(json.dumps(row) + "\n")
            f.flush()
            os.fsync(f.fileno())


@dataclass
class ExperimentReport:
    """What ``run_experiment`` did: units run now, units found done, the evaluation rows."""

    out: Path
    ran: dict[str, int]
    skipped: dict[str, int]
    results: list[dict]


def dataset_path(grid: Grid, task: str, out: Path) -> Path:
    """Where the dataset of ``task`` goes (named by its unit key: the dataset's spec, and the
    version of the task's expert past the first, so that the datasets of version 1 keep
    their keys)."""
    spec = grid.dataset_for(task)
    version = TASKS[task].demo_version
    key = unit_key("dataset", spec.key_fields(), *([version] if version != 1 else []))
    return out / "datasets" / f"{task}-{spec.embodiment}-{key[:10]}.hdf5"


def plan_runs(grid: Grid, out: Path) -> list[RunPlan]:
    """The training runs of the grid: every method x evaluated task x training seed."""
    runs = []
    for task in grid.evaluation.tasks:
        data = dataset_path(grid, task, out)
        for method in grid.methods:
            for seed in grid.training.seeds:
                config = grid.learning_config(method, seed)
                key = unit_key("run", data.name, key_fields(config))
                folder = out / "runs" / f"{method.name}-{task}-seed{seed}-{key[:10]}"
                runs.append(RunPlan(method, task, seed, config, data, key, folder))
    return runs


def trial_key(run: RunPlan, blob: Blob, embodiment: str, seed: int,
              evaluation: EvaluationSpec) -> str:
    """The key of one trial (selection or evaluation): the weights it runs, where, and how.
    Unbounded trials (``max_target_lead`` 0, the only kind before the bound existed) keep the
    keys of that time; a bound is part of the key, so bounded and unbounded trials never
    count for one another."""
    lead = [evaluation.max_target_lead] if evaluation.max_target_lead else []
    return unit_key("trial", run.key, blob.sha256, embodiment, run.task, seed,
                    evaluation.duration, *lead)


def training_key(data: str, config: LearningConfig | dict) -> str:
    """The key of the training of ``config`` (or a config's ``to_dict``, as a run folder's
    ``unit.json`` records it) on the dataset named ``data``."""
    return unit_key("training", data,
                    {k: v for k, v in key_fields(config).items() if k not in ROLLOUT_FIELDS})


def trained_runs(out: Path) -> dict[str, Path]:
    """The finished run folders under ``out/runs``, by their training key (from the config
    as recorded: a run of an older config format, without a field added since, shares
    nothing, although the field's default may be what it meant, unless the field is one of
    ``NEUTRAL_VALUES`` at a neutral value)."""
    found = {}
    for unit in sorted((out / "runs").glob("*/unit.json")):
        record = json.loads(unit.read_text())
        found.setdefault(training_key(record["data"], record["config"]), unit.parent)
    return found


def copy_training(src: Path, dst: Path, config: LearningConfig) -> None:
    """Writes into ``dst`` the files of the finished run ``src`` for a run of ``config``
    that differs from it only in ``ROLLOUT_FIELDS``: its checkpoints and config with
    ``config``'s rollout settings written in (``set_rollout_settings``), the rest (the log,
    the machine record, TensorBoard's events) as it is. What a selection made of ``src``
    (``selected.pt``, ``selection.json``) and the grid's ``unit.json`` stay behind."""
    dst.mkdir(parents=True, exist_ok=True)
    for path in [*sorted(src.glob(SNAPSHOTS)), *(src / name for name in RUN_FILES)]:
        if path.is_dir():
            shutil.copytree(path, dst / path.name, dirs_exist_ok=True)
        elif path.is_file():
            atomic_write_bytes(dst / path.name, path.read_bytes())
    set_rollout_settings(dst, config)
    log.info("%s: the training of %s, with its rollout settings (%s)", dst.name, src.name,
             ", ".join(f"{n}={getattr(config, n)}" for n in ROLLOUT_FIELDS))


def _device(grid: Grid, executor: Executor) -> str:
    if grid.training.device != "auto":
        return grid.training.device
    if isinstance(executor, RayExecutor):
        return "cuda" if executor.gpus else "cpu"
    import torch

    return "cuda" if torch.cuda.is_available() else "cpu"


class _Scheduler:
    """Hands out the jobs that are ready and records what finishes."""

    def __init__(self, grid: Grid, out: Path, runs: list[RunPlan], device: str,
                 scratch: Path | None = None):
        self.grid, self.out, self.runs, self.device = grid, out, runs, device
        self.scratch = scratch
        """Where trainings keep their checkpoints while they run (None: in the worker's
        temporary folder, lost with a kill)."""
        self.ledger = TrialLedger(out / "trials.jsonl")
        self.ready: deque = deque()
        self.datasets: dict[Path, Blob] = {}
        self.by_key: dict[str, tuple[RunPlan, dict | None]] = {}
        """Units handed out or queued: their run, and a trial's row fields (None: the
        training)."""
        self.eval_keys: list[str] = []
        """The keys of the grid's evaluation trials (known once each run is selected)."""
        self.sharing: dict[str, list[RunPlan]] = {}
        """Training key -> the runs waiting for the training under way with that key."""
        self.ran = {"trainings": 0, "trials": 0}
        self.skipped = {"trainings": 0, "trials": 0}
        self.bar = None

    def start(self) -> None:
        """Queues what can start: the trainings not done, the trials of the runs that are.
        A run whose training another run shares (they differ in ``ROLLOUT_FIELDS`` alone)
        takes that run's files instead of training, now if it is finished, else once it
        is."""
        trainings = []
        trained = trained_runs(self.out)
        for run in self.runs:
            if run.done:
                self.skipped["trainings"] += 1
                self._after_training(run)
            elif run.training_key in trained:
                self._share_training(trained[run.training_key], run)
            elif run.training_key in self.sharing:
                self.sharing[run.training_key].append(run)
            else:
                self.sharing[run.training_key] = []
                if run.data not in self.datasets:
                    self.datasets[run.data] = Blob.of(run.data)  # one copy for all its runs
                scratch = str(self._scratch_of(run)) if self.scratch else ""
                trainings.append(TrainUnit(run.key, run.config.to_dict(),
                                           self.datasets[run.data],
                                           self.grid.training.threads, self.device, scratch))
                self.by_key[run.key] = (run, None)
        self.ready.extendleft(reversed(trainings))  # trainings first: the longest units

    def _scratch_of(self, run: RunPlan) -> Path:
        """The scratch folder of ``run``'s training, named by its training key, so that any
        run sharing the training resumes it (a killed ``dp_x`` training is resumed by
        ``dp_x_zero``, which differs in its rollout settings alone). A folder named by the
        run's own key (how they were named before) is renamed to it."""
        folder, before = self.scratch / run.training_key, self.scratch / run.key
        if before.is_dir() and not folder.exists():
            before.rename(folder)
        return folder

    def next_job(self, in_flight: int) -> TrainUnit | TrialUnit | None:
        return self.ready.popleft() if self.ready else None

    def expected(self) -> int:
        """Units still to run, for the progress bar (the selection trials of runs not
        trained yet are estimated from their configs' snapshots)."""
        evaluation = len(self.grid.evaluation.embodiments) * self.grid.evaluation.trials
        total = len(self.ready)
        for run in self.runs:
            if not run.done:
                snapshots = run.config.steps // run.config.snapshot_every \
                    if run.config.snapshot_every else 0
                total += max(snapshots, 1) * self.grid.selection.trials + evaluation
            elif run.pending:  # its evaluation is queued once its selection is done
                total += evaluation
        return total

    def record(self, key: str, result: object) -> None:
        run, info = self.by_key.pop(key)
        if info is not None:
            row = {**result, **info, "key": key}
            self.ledger.add(row)
            self.ran["trials"] += 1
            if row["phase"] == "select":
                run.pending.discard(key)
                if not run.pending:
                    self._after_selection(run)
        else:
            self._write_run(run, result)
            log.info("trained %s (%s, seed %d) into %s", run.method.name, run.task, run.seed,
                     run.folder)
            self.ran["trainings"] += 1
            self._after_training(run)
            for other in self.sharing.pop(run.training_key, []):
                self._share_training(run.folder, other)
        if self.bar is not None:
            self.bar.update(1)

    def _share_training(self, src: Path, run: RunPlan) -> None:
        copy_training(src, run.folder, run.config)
        self._write_run(run, {})  # its unit.json, last
        self.skipped["trainings"] += 1
        self._after_training(run)

    def _write_run(self, run: RunPlan, files: dict[str, bytes]) -> None:
        for name, data in files.items():
            atomic_write_bytes(run.folder / name, data)
        unit = dict(key=run.key, method=run.method.name, task=run.task, seed=run.seed,
                    data=run.data.name, config=run.config.to_dict())
        atomic_write_text(run.folder / "unit.json", json.dumps(unit, indent=1))
        if self.scratch is not None:
            shutil.rmtree(self.scratch / run.training_key, ignore_errors=True)
            with contextlib.suppress(OSError):  # another training still under way
                self.scratch.rmdir()

    def _after_training(self, run: RunPlan) -> None:
        selection = self.grid.selection
        if not selection.trials:
            self._queue_evaluation(run, run.folder / "last.pt")
            return
        seeds = range(selection.seed0, selection.seed0 + selection.trials)
        for path in candidates(run.folder):
            blob = Blob.of(path)  # a trial's key names the weights it runs, by their hash
            keys = [trial_key(run, blob, selection.embodiment, seed, self.grid.evaluation)
                    for seed in seeds]
            run.selection[path.name] = keys
            for i, (seed, key) in enumerate(zip(seeds, keys, strict=True)):
                if key in self.ledger:
                    self.skipped["trials"] += 1
                    continue
                run.pending.add(key)
                self._queue_trial(run, key, path, blob, selection.embodiment, seed, i,
                                  dict(phase="select", candidate=path.name,
                                       checkpoint_step=_step(path)))
        if not run.pending:
            self._after_selection(run)

    def _after_selection(self, run: RunPlan) -> None:
        selection = self.grid.selection
        seeds = list(range(selection.seed0, selection.seed0 + selection.trials))
        rows = []
        for name, keys in run.selection.items():
            trials = [self.ledger.rows[k] for k in keys if k in self.ledger]
            rows.append(dict(name=name, step=_step(run.folder / name),
                             successes=sum(bool(t["success"]) for t in trials),
                             trials=len(trials)))
        recorded = run.folder / "selection.json"
        if recorded.is_file() and (run.folder / "selected.pt").is_file() and \
                json.loads(recorded.read_text()).get("candidates") == rows:
            self._queue_evaluation(run, run.folder / "selected.pt")  # chosen before
            return
        summary = write_selection(run.folder, rows, seeds, selection.embodiment, run.task)
        log.info("%s: selected %s (%d/%d on validation seeds %d-%d)", run.folder.name,
                 summary["selected"], max(r["successes"] for r in rows), len(seeds),
                 seeds[0], seeds[-1])
        self._queue_evaluation(run, run.folder / "selected.pt")

    def _queue_evaluation(self, run: RunPlan, checkpoint: Path) -> None:
        evaluation = self.grid.evaluation
        blob, step = Blob.of(checkpoint), _step(checkpoint)
        for embodiment in evaluation.embodiments:
            for i in range(evaluation.trials):
                seed = evaluation.seed0 + i
                key = trial_key(run, blob, embodiment, seed, evaluation)
                self.eval_keys.append(key)
                if key in self.ledger:
                    self.skipped["trials"] += 1
                    continue
                self._queue_trial(run, key, checkpoint, blob, embodiment, seed, i,
                                  dict(phase="eval", candidate=checkpoint.name,
                                       checkpoint_step=step))

    def _queue_trial(self, run: RunPlan, key: str, checkpoint: Path, blob: Blob,
                     embodiment: str, seed: int, index: int, info: dict) -> None:
        evaluation = self.grid.evaluation
        scenario = trial_scenario(embodiment, run.task, seed, checkpoint,
                                  run.config.obs_mode == "image", evaluation.duration or None,
                                  evaluation.max_target_lead)
        job = TrialJob(run.method.name, index, scenario)
        self.by_key[key] = (run, {**info, "method": run.method.name, "train_seed": run.seed,
                                  "run": run.folder.name, "checkpoint_sha256": blob.sha256})
        self.ready.append(TrialUnit(key, job, blob))


def _step(checkpoint: Path) -> int:
    """The training step of a checkpoint (a snapshot's is in its name)."""
    from legato_drake.learning.checkpoint import load_checkpoint

    if checkpoint.stem.startswith("step_"):
        return int(checkpoint.stem.split("_")[1])
    return load_checkpoint(checkpoint).step


def run_experiment(grid: Grid, out: str | Path, executor: Executor,
                   progress: bool | None = None) -> ExperimentReport:
    """Runs every unit of ``grid`` not yet done in ``out`` on ``executor``; writes the
    results and the summary; returns what it did."""
    from legato_drake.experiment.report import write_report

    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ConfigError(f"--out {out}: is an existing file, not an experiment folder")
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "grid.json", json.dumps(grid_dict(grid), indent=1))
    collected = 0
    for task in grid.evaluation.tasks:
        spec = grid.dataset_for(task)
        path = dataset_path(grid, task, out)
        if not path.is_file():
            collected += 1
        collect(spec.task, spec.embodiment, spec.episodes, path, seed0=spec.seed0,
                camera=spec.cameras, camera_model=spec.camera_model, progress=progress,
                executor=executor, expert_noise=spec.expert_noise())
    runs = plan_runs(grid, out)
    # absolute: a Ray worker on this machine runs in a folder of its own
    scratch = (out / "runs" / ".training").resolve() if executor.shares_files else None
    scheduler = _Scheduler(grid, out, runs, _device(grid, executor), scratch)
    scheduler.start()
    scheduler.bar = progress_bar(progress=progress, total=scheduler.expected(),
                                 desc=f"experiment {grid.name}", unit="unit")
    for key, result in executor.stream(run_unit, scheduler.next_job):
        scheduler.record(key, result)
    scheduler.bar.close()
    results = evaluation_rows(scheduler.ledger.rows, scheduler.eval_keys, runs)
    write_results_csv(out / "results.csv", results)
    write_report(grid, results, out)
    ran = {"datasets": collected, **scheduler.ran}
    skipped = {"datasets": len(grid.evaluation.tasks) - collected, **scheduler.skipped}
    log.info("experiment %s: ran %s; already done %s", grid.name, ran, skipped)
    return ExperimentReport(out, ran, skipped, results)


def evaluation_rows(rows: dict[str, dict], keys: Iterable[str],
                    runs: list[RunPlan]) -> list[dict]:
    """The recorded evaluation trials among ``keys`` (the grid's: not those of units the grid
    no longer has), in method, training seed, embodiment, task and seed order."""
    order = {run.folder.name: i for i, run in enumerate(runs)}
    chosen = [rows[k] for k in keys if k in rows]
    return sorted(chosen, key=lambda r: (order[r["run"]], *trial_order(r)))


def write_results_csv(path: Path, rows: list[dict]) -> None:
    """``results.csv``: one row per evaluation trial (atomically)."""
    atomic_write_csv(path, RESULT_FIELDS, rows)
