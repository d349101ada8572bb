"""Evaluating a trained policy: closed-loop trials per embodiment and task, resumable results,
success tables with 95 % Wilson intervals, plots like the paper's figures, Meshcat replays.

``evaluate(...)`` runs trial i of each (embodiment, task) with the scene seed ``seed0 + i``
(default seeds 10000, 10001, ..., disjoint from the training demonstrations' seeds, which the
checkpoint records and which are checked). After every trial the results file
``OUT/<method>.json`` (and ``OUT/<method>.csv``) is rewritten atomically, so an interrupted
evaluation loses at most the trials in flight and a second run skips the trials already done
(it refuses to resume with another checkpoint, identified by its SHA-256, or another
``duration``). Trials load a frozen copy of the checkpoint, ``OUT/<method>.pt``. A trial that
raises is recorded as a failure with the error as its reason.

``OUT/<method>.json``::

    {"format": "legato_drake.evaluation", "method": str, "checkpoint": str,
     "checkpoint_sha256": str, "checkpoint_step": int,
     "config": {...the policy's LearningConfig...}, "seed0": int, "duration": float | None,
     "trials": [{"method", "embodiment", "task", "trial", "seed", "success", "reason",
                 "success_time", "episode_time", "wall_time", "html", "metrics"}, ...]}
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import logging
import multiprocessing
from collections.abc import Iterable, Sequence
from pathlib import Path

from legato_drake.errors import ConfigError
from legato_drake.files import atomic_write_bytes, atomic_write_text
from legato_drake.stats import wilson_interval

log = logging.getLogger(__name__)

FORMAT = "legato_drake.evaluation"
EVAL_SEED0 = 10000
"""First scene seed of evaluation trials (training data uses seeds from 0)."""
TRIAL_FIELDS = ("method", "embodiment", "task", "trial", "seed", "success", "reason",
                "success_time", "episode_time", "wall_time", "html")
SUMMARY_HEADERS = ["method", "embodiment", "task", "success", "rate %", "95% CI %",
                   "mean success s", "mean wall s"]


def _run_trial(job: dict) -> dict:
    """Runs one trial (in a worker process: one torch thread) and returns its row. A trial
    that raises (a policy can drive the simulation somewhere it fails) is a failure whose
    reason is the error, so that the evaluation still finishes."""
    import time

    import torch

    from legato_drake.episode import run_episode
    from legato_drake.scenario import Scenario

    torch.set_num_threads(1)
    row = {"method": job["method"], "embodiment": job["embodiment"], "task": job["task"],
           "trial": job["trial"], "seed": job["seed"]}
    scenario = Scenario(embodiment=job["embodiment"], task=job["task"], controller="policy",
                        checkpoint=job["checkpoint"], seed=job["seed"])
    scenario.camera.enabled = job["camera"]
    if job["duration"] is not None:
        scenario.duration = job["duration"]
    html = job["html"]
    start = time.perf_counter()
    try:
        result = run_episode(scenario.validate(), html=html)
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
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=TRIAL_FIELDS, extrasaction="ignore")
    writer.writeheader()
    writer.writerows(doc["trials"])
    atomic_write_text(path.with_suffix(".csv"), buffer.getvalue())


def evaluate(checkpoint: str | Path, embodiments: Sequence[str], tasks: Sequence[str],
             trials: int, out: str | Path, workers: int = 1, replays: int = 0,
             method: str | None = None, seed0: int = EVAL_SEED0,
             duration: float | None = None, progress: bool | None = None,
             overwrite: bool = False) -> dict:
    """Runs ``trials`` closed-loop trials of the policy per embodiment and task (skipping
    those already in the results file); returns the results document. The first ``replays``
    trials of each cell also get a Meshcat HTML replay in ``OUT/replays/``. A results file
    of another checkpoint, ``duration``, ``seed0`` or trial set is refused unless
    ``overwrite`` (which starts it afresh)."""
    from legato_drake.learning.checkpoint import load_checkpoint
    from legato_drake.progress import progress_bar

    check_inputs(embodiments, tasks, trials, workers, replays, method, seed0, duration)
    checkpoint = Path(checkpoint).resolve()
    ckpt = load_checkpoint(checkpoint)
    sha = file_sha256(checkpoint)
    method = method or ckpt.config.name
    seeds = [seed0 + i for i in range(trials)]
    overlap = sorted(set(seeds) & set(ckpt.used_seeds))
    if overlap:
        raise ConfigError(f"evaluation seeds {overlap[:5]} were used for training or "
                          f"checkpoint selection ({checkpoint}); choose --seed0 past "
                          f"{max(ckpt.used_seeds)}")
    out = Path(out)
    path = results_path(out, method)
    doc = {"format": FORMAT, "method": method, "checkpoint": str(checkpoint),
           "checkpoint_sha256": sha, "checkpoint_step": ckpt.step,
           "config": ckpt.config.to_dict(), "seed0": seed0, "duration": duration,
           "trials": []}
    if path.is_file() and not overwrite:
        old = load_results(path)
        for key, what in (("checkpoint", "checkpoint"), ("checkpoint_sha256", "checkpoint"),
                          ("duration", "--duration"), ("seed0", "--seed0")):
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
    if not frozen.is_file() or file_sha256(frozen) != sha:
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
                jobs.append(dict(method=method, embodiment=embodiment, task=task, trial=i,
                                 seed=seed, checkpoint=str(frozen),
                                 camera=ckpt.config.obs_mode == "image", duration=duration,
                                 html=html))
    if len(jobs) < len(embodiments) * len(tasks) * len(seeds):
        log.info("%s: %d trials already done, %d to run", path, len(doc["trials"]), len(jobs))
    bar = dict(total=len(jobs), desc=f"evaluate {method}", unit="trial", progress=progress)

    def record(row: dict) -> None:
        doc["trials"].append(row)
        doc["trials"].sort(key=trial_order)
        write_results(path, doc)

    if not jobs:
        write_results(path, doc)
    elif workers > 1 and len(jobs) > 1:
        with multiprocessing.get_context("spawn").Pool(min(workers, len(jobs))) as pool:
            for row in progress_bar(pool.imap_unordered(_run_trial, jobs), **bar):
                record(row)
    else:
        for job in progress_bar(jobs, **bar):
            record(_run_trial(job))
    return doc


def check_inputs(embodiments: Sequence[str], tasks: Sequence[str], trials: int, workers: int,
                 replays: int, method: str | None, seed0: int,
                 duration: float | None) -> None:
    """Checks evaluate's arguments before any work; ConfigError naming the flag."""
    import math

    from legato_drake.embodiments import EMBODIMENTS
    from legato_drake.tasks import TASKS

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
    from legato_drake.embodiments import EMBODIMENTS
    from legato_drake.tasks import TASKS

    def rank(name: str, registry: dict) -> tuple[int, str]:
        return (list(registry).index(name) if name in registry else len(registry), name)

    return (rank(trial["embodiment"], EMBODIMENTS), rank(trial["task"], TASKS), trial["seed"])


def summarize(trials: Iterable[dict]) -> list[list]:
    """One row per (method, embodiment, task): successes, rate, Wilson 95 % interval, mean
    success time and mean wall time."""
    trials = sorted(trials, key=trial_order)
    rows = []
    for key in dict.fromkeys((t["method"], t["embodiment"], t["task"]) for t in trials):
        group = [t for t in trials if (t["method"], t["embodiment"], t["task"]) == key]
        k, n = sum(bool(t["success"]) for t in group), len(group)
        low, high = wilson_interval(k, n)
        times = [t["success_time"] for t in group if t["success"] and t["success_time"]]
        rows.append([*key, f"{k}/{n}", 100.0 * k / n, f"{100 * low:.0f}-{100 * high:.0f}",
                     sum(times) / len(times) if times else float("nan"),
                     sum(t["wall_time"] for t in group) / n])
    return rows


UNITS = ("m", "cm", "mm", "deg", "rad", "m/s", "s")
"""Unit words that follow a number in a failure reason."""


def reason_kind(reason: str) -> str:
    """A failure reason without its numbers, for counting: the predicate's condition that
    failed ("lid -1.4 cm from resting on the rim (allowed -1.0 to +1.5 cm)" -> "lid … from
    resting on the rim"; "lid still held: the fingers are open 0 mm" -> "lid still held")."""
    head = reason.split(" (")[0].split(":")[0]
    words: list[str] = []
    after_number = False
    for word in head.split():
        if any(c.isdigit() for c in word):
            words.append("…")
            after_number = True
        elif after_number and word in UNITS:
            after_number = False
        else:
            words.append(word)
            after_number = False
    return " ".join(words) or reason


def failure_counts(trials: Iterable[dict]) -> list[list]:
    """One row per (method, embodiment, task): how many trials failed by which condition."""
    trials = sorted(trials, key=trial_order)
    rows = []
    for key in dict.fromkeys((t["method"], t["embodiment"], t["task"]) for t in trials):
        kinds = [reason_kind(t["reason"]) for t in trials
                 if (t["method"], t["embodiment"], t["task"]) == key and not t["success"]]
        counts = sorted(((kinds.count(k), k) for k in set(kinds)), reverse=True)
        rows.append([*key, ", ".join(f"{k} x{n}" for n, k in counts) or "-"])
    return rows


def plot_success(trials: Iterable[dict], png: str | Path, title: str = "") -> Path:
    """A bar chart of success rate per embodiment (groups) and method (bars) with 95 %
    Wilson intervals, like the paper's figures; several tasks become ``embodiment/task``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    trials = sorted(trials, key=trial_order)
    tasks = list(dict.fromkeys(t["task"] for t in trials))
    cells = list(dict.fromkeys(
        t["embodiment"] if len(tasks) == 1 else f"{t['embodiment']}/{t['task']}"
        for t in trials))
    methods = list(dict.fromkeys(t["method"] for t in trials))
    width = 0.8 / max(len(methods), 1)
    fig, ax = plt.subplots(figsize=(max(4.0, 1.2 * len(cells) * max(len(methods), 1)), 3.5))
    for j, method in enumerate(methods):
        rates, lows, highs, labels = [], [], [], []
        for cell in cells:
            group = [t for t in trials if t["method"] == method and
                     (t["embodiment"] if len(tasks) == 1
                      else f"{t['embodiment']}/{t['task']}") == cell]
            k, n = sum(bool(t["success"]) for t in group), len(group)
            low, high = wilson_interval(k, n)
            rate = k / n if n else 0.0
            rates.append(100 * rate)
            labels.append(f"{k}/{n}" if n else "")
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
