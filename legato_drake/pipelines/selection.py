"""Choosing a training run's checkpoint by closed-loop success on validation scene seeds.

Validation loss does not predict closed-loop success (we measured a lowest-loss checkpoint at
2/20 where a later one did far better), so, as robomimic does with its rollouts during
training, ``select_checkpoint`` rolls out every candidate of a run (its ``step_<N>.pt``
snapshots and ``last.pt``) on a few *validation* scene seeds, disjoint from the training
demos' seeds and from the evaluation seeds (``SELECT_SEED0`` = 5000 on; evaluation starts at
10000), and writes the most successful one (the later on ties) to ``<run>/selected.pt``.
That copy records its selection seeds, and ``evaluate`` refuses to reuse them. The rollouts
are ordinary ``evaluate`` results files in ``<run>/selection/`` (resumable, one per
candidate), summarised in ``<run>/selection.json``.
"""

from __future__ import annotations

import json
import logging
from pathlib import Path

from legato_drake.errors import ConfigError
from legato_drake.executor import Executor
from legato_drake.files import atomic_write_text
from legato_drake.pipelines.evaluate import evaluate

SELECTION_FILES = ("selected.pt", "selection.json", "selection")
"""What ``select_checkpoint`` writes into a run's folder."""

log = logging.getLogger(__name__)

SELECT_SEED0 = 5000
"""First validation scene seed (training demos use seeds from 0, evaluation from 10000)."""


def candidates(run: Path) -> list[Path]:
    """A run's candidate checkpoints: its snapshots in step order, then ``last.pt`` (unless a
    snapshot holds the same step)."""
    from legato_drake.learning.checkpoint import load_checkpoint

    snapshots = sorted(run.glob("step_*.pt"))
    last = run / "last.pt"
    if last.is_file():
        steps = {int(p.stem.split("_")[1]) for p in snapshots}
        if load_checkpoint(last).step not in steps:
            snapshots.append(last)
    return snapshots


def select_checkpoint(run: str | Path, task: str, embodiment: str = "abstract",
                      trials: int = 20, seed0: int = SELECT_SEED0, workers: int = 1,
                      progress: bool | None = None, executor: Executor | None = None) -> dict:
    """Rolls out each candidate of ``run`` for ``trials`` validation seeds from ``seed0`` on
    ``embodiment`` / ``task`` (in ``workers`` processes, or on ``executor``); writes
    ``selected.pt`` and ``selection.json``; returns the summary ``{"selected", "step",
    "seeds", "embodiment", "task", "candidates": [{"name", "step", "successes",
    "trials"}]}``."""
    run = Path(run)
    if not run.is_dir():
        raise ConfigError(f"--run {run}: not a training run folder")
    found = candidates(run)
    if not found:
        raise ConfigError(f"--run {run} holds no step_*.pt snapshots and no last.pt (train "
                          "with --set snapshot_every=N to keep snapshots)")
    if trials < 1:
        raise ConfigError(f"--trials must be at least 1, got {trials}")
    seeds = list(range(seed0, seed0 + trials))
    rows = []
    for path in found:
        doc = evaluate(path, [embodiment], [task], trials, run / "selection", workers=workers,
                       method=path.stem, seed0=seed0, progress=progress, executor=executor)
        successes = sum(bool(t["success"]) for t in doc["trials"])
        rows.append(dict(name=path.name, step=doc["checkpoint_step"], successes=successes,
                         trials=len(doc["trials"])))
        log.info("%s (step %d): %d/%d on validation seeds %d-%d", path.name,
                 doc["checkpoint_step"], successes, len(doc["trials"]), seeds[0], seeds[-1])
    return write_selection(run, rows, seeds, embodiment, task)


def write_selection(run: Path, rows: list[dict], seeds: list[int], embodiment: str,
                    task: str) -> dict:
    """Picks the candidate with the most successes (the later on ties) among ``rows``
    (``{"name", "step", "successes", "trials"}`` per candidate of ``run``), writes it as
    ``run/selected.pt`` recording its selection, and ``run/selection.json``; returns the
    summary."""
    from legato_drake.learning.checkpoint import load_checkpoint, save_checkpoint

    best = max(rows, key=lambda r: (r["successes"], r["step"]))
    summary = dict(selected=best["name"], step=best["step"], seeds=seeds,
                   embodiment=embodiment, task=task, candidates=rows)
    ckpt = load_checkpoint(run / best["name"])
    ckpt.selection = summary
    save_checkpoint(run / "selected.pt", ckpt)
    atomic_write_text(run / "selection.json", json.dumps(summary, indent=1))
    return summary
