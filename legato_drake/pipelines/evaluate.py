"""Evaluating a trained policy: closed-loop trials per embodiment and task, resumable results,
plots like the paper's figures with 95 % Wilson intervals, Meshcat replays (the success
tables: ``legato_drake.summary.trial_rows`` and ``failure_rows``).

``evaluate(...)`` runs trial i of each (embodiment, task) with the scene seed ``seed0 + i``
(default seeds 10000, 10001, ..., disjoint from the training demonstrations' seeds, which the
checkpoint records and which are checked). After every trial the results file
``OUT/<method>.json`` (and ``OUT/<method>.csv``) is rewritten atomically, so an interrupted
evaluation loses at most the trials in flight and a second run skips the trials already done
(it refuses to resume with another checkpoint, identified by its SHA-256, or another
``duration`` or ``max_target_lead``). Trials load a frozen copy of the checkpoint,
``OUT/<method>.pt``. A trial that raises is recorded as a failure with the error as its reason.

``OUT/<method>.json``::

    {"format": "legato_drake.evaluation", "method": str, "checkpoint": str,
     "checkpoint_sha256": str, "checkpoint_step": int,
     "config": {...the policy's LearningConfig...}, "seed0": int, "duration": float | None,
     "max_target_lead": float,
     "trials": [{"method", "embodiment", "task", "trial", "seed", "success", "reason",
                 "success_time", "episode_time", "wall_time", "html", "metrics"}, ...]}
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from legato_drake.embodiments import EMBODIMENTS
from legato_drake.episode import run_episode
from legato_drake.errors import ConfigError
from legato_drake.executor import Executor, make_executor
from legato_drake.files import atomic_write_bytes, atomic_write_csv, atomic_write_text
from legato_drake.learning.config import (
    ROLLOUT_FIELDS,
    LearningConfig,
    apply_rollout_overrides,
)
from legato_drake.progress import progress_bar
from legato_drake.scenario import DEFAULT_MAX_TARGET_LEAD, Scenario
from legato_drake.summary import Rate, group_by
from legato_drake.tasks import TASKS

log = logging.getLogger(__name__)

FORMAT = "legato_drake.evaluation"
EVAL_SEED0 = 10000
"""First scene seed of evaluation trials (training data uses seeds from 0)."""
TRIAL_FIELDS = ("method", "embodiment", "task", "trial", "seed", "max_target_lead", "success",
                "reason", "success_time", "episode_time", "wall_time", "html")


@dataclass(frozen=True)
class TrialJob:
    """One trial: the method it counts for, its index in its cell, its scenario (the policy
    on one embodiment, task and scene seed) and where its HTML replay goes (None: none)."""

    method: str
    trial: int
    scenario: Scenario
    html: Path | None = None


def trial_scenario(embodiment: str, task: str, seed: int, checkpoint: str | Path,
                   camera: bool, duration: float | None,
                   max_target_lead: float = DEFAULT_MAX_TARGET_LEAD) -> Scenario:
    """The scenario of one trial: the checkpoint's policy in the scene of ``seed``."""
    scenario = Scenario(embodiment=embodiment, task=task, controller="policy",
                        checkpoint=str(checkpoint), seed=seed,
                        max_target_lead=max_target_lead)
    scenario.camera.enabled = camera
    if duration is not None:
        scenario.duration = duration
    return scenario


def run_trial(job: TrialJob) -> dict:
    """Runs one trial (in a worker process, or here: one torch thread) and returns its row.
    A trial that raises (a policy can drive the simulation somewhere it fails) is a failure
    whose reason is the error, so that the evaluation still finishes."""
    import torch

    torch.set_num_threads(1)
    scenario, html = job.scenario, job.html
    row = {"method": job.method, "embodiment": scenario.embodiment, "task": scenario.task,
           "trial": job.trial, "seed": scenario.seed,
           "max_target_lead": scenario.max_target_lead}
    start = time.perf_counter()
    try:
        result = run_episode(scenario, html=html)
    except Exception as e:  # noqa: BLE001 - recorded in the results, not raised
        log.warning("trial %s failed with an error: %s", row, e)
        return {**row, "success": False, "reason": f"error: {type(e).__name__}: {e}",
                "success_time": None, "episode_time": 0.0,
                "wall_time": time.perf_counter() - start, "html": None, "metrics": {}}
    return {**row, "success": bool(result.success), "reason": result.reason,
            "success_time": result.success_time, "episode_time": result.episode_time,
            "wall_time": result.wall_time, "html": str(html) if html else None,
            "metrics": {k: float(v) for k, v in result.metrics.items()}}


def file_sha256(path: Path) -> str:
    """The SHA-256 of a file's bytes (identifies a checkpoint across runs)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def results_path(out: str | Path, method: str) -> Path:
    """Where ``evaluate`` writes the results of ``method``."""
    return Path(out) / f"{method}.json"


def load_results(path: str | Path) -> dict:
    """Reads an evaluation results file (error naming the file if it is not one)."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except (OSError, ValueError) as e:
        raise ConfigError(f"cannot read evaluation results {path}: {e}") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise ConfigError(f"{path} is not a legato_drake evaluation results file")
    return doc


def write_results(path: Path, doc: dict) -> None:
    """Writes the JSON results and the CSV of its trials, both atomically."""
    atomic_write_text(path, json.dumps(doc, indent=1))
    atomic_write_csv(path.with_suffix(".csv"), TRIAL_FIELDS, doc["trials"])


def evaluate(checkpoint: str | Path, embodiments: Sequence[str], tasks: Sequence[str],
             trials: int, out: str | Path, workers: int = 1, replays: int = 0,
             method: str | None = None, seed0: int = EVAL_SEED0,
             duration: float | None = None, progress: bool | None = None,
             overwrite: bool = False, executor: Executor | None = None,
             overrides: list[str] | None = None,
             max_target_lead: float = DEFAULT_MAX_TARGET_LEAD,
             seen_scenes: bool = False) -> dict:
    """Runs ``trials`` closed-loop trials of the policy per embodiment and task (skipping
    those already in the results file), in ``workers`` processes (or on ``executor``);
    returns the results document, rewritten after every trial. The first ``replays`` trials
    of each cell also get a Meshcat HTML replay in ``OUT/replays/``. ``overrides``
    (``["inference_steps=3"]``) change how the policy acts (its config's ``ROLLOUT_FIELDS``
    only). ``max_target_lead`` bounds the commanded gripper's lead (``Scenario``). A results
    file of another checkpoint, ``duration``, ``seed0``, rollout settings, target lead
    or trial set is refused unless ``overwrite`` (which starts it afresh). Scene seeds the
    checkpoint was trained, selected or shipped on are refused unless ``seen_scenes`` (a
    diagnostic: how the policy does on its own training scenes); the results file lists
    those it ran under ``seen_scenes``."""
    from legato_drake.learning.checkpoint import (  # torch: only when needed
        load_checkpoint,
        with_rollout_settings,
    )

    check_inputs(embodiments, tasks, trials, workers, replays, method, seed0, duration)
    checkpoint = Path(checkpoint).resolve()
    ckpt = load_checkpoint(checkpoint)
    config = apply_rollout_overrides(ckpt.config, overrides)
    sha = file_sha256(checkpoint)
    method = method or ckpt.config.name
    seeds = [seed0 + i for i in range(trials)]
    overlap = sorted(set(seeds) & set(ckpt.used_seeds))
    if overlap and seen_scenes:
        log.warning("%d of the %d scene seeds were seen by %s in training or selection: a "
                    "diagnostic, not an evaluation", len(overlap), len(seeds), checkpoint)
    elif overlap:
        raise ConfigError(f"evaluation seeds {overlap[:5]} were used for training or "
                          f"checkpoint selection ({checkpoint}); choose scene seeds past "
                          f"{max(ckpt.used_seeds)} (--seeds or --seed0), or --seen-scenes "
                          "for a diagnostic")
    out = Path(out)
    path = results_path(out, method)
    doc = {"format": FORMAT, "method": method, "checkpoint": str(checkpoint),
           "checkpoint_sha256": sha, "checkpoint_step": ckpt.step,
           "config": config.to_dict(), "seed0": seed0, "duration": duration,
           "max_target_lead": max_target_lead,
           "rollout": {name: getattr(config, name) for name in ROLLOUT_FIELDS},
           "seen_scenes": sorted(overlap), "trials": []}
    if path.is_file() and not overwrite:
        old = {"max_target_lead": 0.0, **load_results(path)}  # older files: unbounded
        if "rollout" in old:  # older files lack the rollout fields added since: defaults
            defaults = LearningConfig()
            old["rollout"] = {**{n: getattr(defaults, n) for n in ROLLOUT_FIELDS},
                              **old["rollout"]}
        for key, what in (("checkpoint", "checkpoint"), ("checkpoint_sha256", "checkpoint"),
                          ("duration", "--duration"), ("seed0", "--seed0"),
                          ("rollout", "--set"), ("max_target_lead", "--max-target-lead")):
            if old.get(key, doc[key]) != doc[key]:
                raise ConfigError(f"{path} holds results of another {what} ({key} "
                                  f"{old.get(key)}, not {doc[key]}): use another --method or "
                                  "--out, the same settings to resume, or --overwrite")
        outside = sorted({t["seed"] for t in old["trials"]} - set(seeds))
        if outside:
            raise ConfigError(f"{path} holds trials of seeds up to {outside[-1]}, outside "
                              f"--seed0 {seed0} --trials {trials} (seeds {seeds[0]}-"
                              f"{seeds[-1]}): ask for at least as many trials to resume, use "
                              "another --method or --out, or --overwrite")
        doc["trials"] = old["trials"]
    # Trials read a frozen copy, so a checkpoint rewritten meanwhile (training goes on) cannot
    # mix two models into one success rate.
    frozen = path.with_suffix(".pt")
    if config != ckpt.config:
        with_rollout_settings(checkpoint, frozen, config)
    elif not frozen.is_file() or file_sha256(frozen) != sha:
        atomic_write_bytes(frozen, checkpoint.read_bytes())
    done = {(t["embodiment"], t["task"], t["seed"]) for t in doc["trials"]}
    jobs = []
    for embodiment in embodiments:
        for task in tasks:
            for i, seed in enumerate(seeds):
                if (embodiment, task, seed) in done:
                    continue
                html = (out / "replays" / f"{method}-{embodiment}-{task}-seed{seed}.html"
                        if i < replays else None)
                scenario = trial_scenario(embodiment, task, seed, frozen,
                                          ckpt.config.obs_mode == "image", duration,
                                          max_target_lead)
                jobs.append(TrialJob(method, i, scenario, html))
    if len(jobs) < len(embodiments) * len(tasks) * len(seeds):
        log.info("%s: %d trials already done, %d to run", path, len(doc["trials"]), len(jobs))
    bar = dict(total=len(jobs), desc=f"evaluate {method}", unit="trial", progress=progress)

    def record(row: dict) -> None:
        doc["trials"].append(row)
        doc["trials"].sort(key=trial_order)
        write_results(path, doc)

    if not jobs:
        write_results(path, doc)
        return doc
    executor = executor or make_executor(workers, len(jobs))
    for row in progress_bar(executor.as_completed(run_trial, jobs), **bar):
        record(row)
    return doc


def check_inputs(embodiments: Sequence[str], tasks: Sequence[str], trials: int, workers: int,
                 replays: int, method: str | None, seed0: int,
                 duration: float | None) -> None:
    """Checks evaluate's arguments before any work; ConfigError naming the flag."""
    for flag, names, registry in (("--embodiments", embodiments, EMBODIMENTS),
                                  ("--tasks", tasks, TASKS)):
        if not names:
            raise ConfigError(f"{flag}: no names given")
        unknown = [n for n in names if n not in registry]
        if unknown:
            raise ConfigError(f"{flag}: unknown {unknown}; valid values: "
                              f"{', '.join(registry)}")
    for flag, value, low in (("--trials", trials, 1), ("--workers", workers, 1),
                             ("--replays", replays, 0), ("--seed0", seed0, 0)):
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            raise ConfigError(f"{flag} must be an integer >= {low}, got {value!r}")
    if duration is not None and not (isinstance(duration, int | float)
                                     and math.isfinite(duration) and duration > 0):
        raise ConfigError(f"--duration must be a positive number of seconds, got "
                          f"{duration!r}")
    if method is not None and (not method or method.strip() != method or
                               any(c in method for c in "/\\\0") or method in (".", "..")):
        raise ConfigError(f"--method {method!r}: expected a plain name (it names the results "
                          "files), without slashes or surrounding spaces")


def trial_order(trial: dict) -> tuple:
    """Sort key of trials: embodiments and tasks in their registries' order (the paper's:
    Abstract, Panda, Spot, Google Robot, GR-1), then the seed."""
    def rank(name: str, registry: dict) -> tuple[int, str]:
        return (list(registry).index(name) if name in registry else len(registry), name)

    return (rank(trial["embodiment"], EMBODIMENTS), rank(trial["task"], TASKS), trial["seed"])


def plot_success(trials: Iterable[dict], png: str | Path, title: str = "") -> Path:
    """A bar chart of success rate per embodiment (groups) and method (bars) with 95 %
    Wilson intervals, like the paper's figures; several tasks become ``embodiment/task``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    trials = sorted(trials, key=trial_order)
    tasks = list(dict.fromkeys(t["task"] for t in trials))

    def cell_of(trial: dict) -> str:
        return trial["embodiment"] if len(tasks) == 1 else \
            f"{trial['embodiment']}/{trial['task']}"

    groups = group_by(trials, key=lambda t: (t["method"], cell_of(t)))
    cells = list(dict.fromkeys(cell for _, cell in groups))
    methods = list(dict.fromkeys(method for method, _ in groups))
    width = 0.8 / max(len(methods), 1)
    fig, ax = plt.subplots(figsize=(max(4.0, 1.2 * len(cells) * max(len(methods), 1)), 3.5))
    for j, method in enumerate(methods):
        rates, lows, highs, labels = [], [], [], []
        for cell in cells:
            counts = Rate.of(groups.get((method, cell), []))
            low, high = counts.interval
            rate, n = counts.fraction, counts.trials
            rates.append(100 * rate)
            labels.append(counts.count_text if n else "")
            lows.append(100 * (rate - low) if n else 0.0)
            highs.append(100 * (high - rate) if n else 0.0)
        x = np.arange(len(cells)) + (j - (len(methods) - 1) / 2) * width
        ax.bar(x, rates, width, yerr=[lows, highs], capsize=3, label=method)
        for xi, label in zip(x, labels, strict=True):
            ax.text(xi, 1.0, label, ha="center", va="bottom", fontsize="x-small")
    ax.set_xticks(np.arange(len(cells)), cells)
    ax.set_ylim(0, 105)
    ax.set_ylabel("success rate % (95 % Wilson CI)")
    ax.set_title(title or f"task: {', '.join(tasks)}")
    ax.legend(fontsize="small")
    fig.tight_layout()
    png = Path(png)
    png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=120)
    plt.close(fig)
    return png


def combine(paths: Iterable[str | Path]) -> list[dict]:
    """The trials of several results files (each tagged with its file's method)."""
    trials = []
    for path in paths:
        doc = load_results(path)
        trials += [{**t, "method": t.get("method", doc["method"])} for t in doc["trials"]]
    return trials
