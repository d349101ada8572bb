"""Throughput of the experiment's backends: the same closed-loop trials on the local process
pool and on a local Ray cluster (the overhead of Ray on one machine).

Runs --trials lid trials of the shipped LEGATO lid policy on --embodiment (scene seeds from
10000) as ``experiment`` units (each carries its checkpoint) through each backend with
--workers workers, after one warm-up trial per worker (process start-up, imports) that is not
counted. Prints trials per core-hour per backend and their ratio (``--json FILE`` also
writes them there).
Checks that both backends give the same result for every trial. Usage:

    python benchmarks/bench_backends.py [--trials 20] [--workers 2] [--embodiment panda]
        [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable
from pathlib import Path

from legato_drake.executor import Blob, Executor, ProcessExecutor, RayExecutor
from legato_drake.experiment.units import TrialUnit, run_unit
from legato_drake.models import shipped_checkpoint
from legato_drake.pipelines.evaluate import EVAL_SEED0, TrialJob, trial_scenario
from legato_drake.summary import format_table


def units(embodiment: str, seeds: range, blob: Blob) -> list[TrialUnit]:
    """One trial unit per scene seed."""
    return [TrialUnit(f"seed{seed}", TrialJob("legato", i, trial_scenario(
        embodiment, "lid", seed, "unused.pt", camera=False, duration=None)), blob)
        for i, seed in enumerate(seeds)]


def timed_after_warmup(executor: Executor, function: Callable, warmup: list,
                       jobs: list) -> tuple[float, list]:
    """(wall seconds, results) of ``function`` over ``jobs``, run after ``warmup`` (one job
    per worker) in the same stream: a local process pool lives for one stream, so a warm-up
    stream of its own would leave the measured one to start its workers again."""
    results = executor.map(function, warmup + jobs)
    for _ in warmup:  # in order: the clock starts once every worker has run its warm-up
        next(results)
    start = time.perf_counter()
    rows = list(results)
    return time.perf_counter() - start, rows


def measure(executor: Executor, jobs: list[TrialUnit], warmup: list[TrialUnit]) -> tuple:
    """(wall seconds, {key: (success, reason)}) of ``jobs`` after ``warmup``."""
    seconds, rows = timed_after_warmup(executor, run_unit, warmup, jobs)
    return seconds, {k: (r["success"], r["reason"]) for k, r in rows}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=20)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--embodiment", default="panda")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the rows there")
    args = parser.parse_args()
    blob = Blob.of(shipped_checkpoint("lid"))
    jobs = units(args.embodiment, range(EVAL_SEED0, EVAL_SEED0 + args.trials), blob)
    warmup = units(args.embodiment, range(EVAL_SEED0 + 900, EVAL_SEED0 + 900 + args.workers),
                   blob)
    rows, outcomes = [], {}
    for name, make in (("local", lambda: ProcessExecutor(args.workers)),
                       ("ray", lambda: RayExecutor(None, args.workers))):
        seconds, outcomes[name] = measure(make(), jobs, warmup)
        rows.append(dict(backend=name, workers=args.workers, trials=args.trials,
                         wall_s=round(seconds, 1),
                         trials_per_core_hour=round(args.trials * 3600 /
                                                    (seconds * args.workers), 1)))
    same = outcomes["local"] == outcomes["ray"]
    ratio = rows[1]["trials_per_core_hour"] / rows[0]["trials_per_core_hour"]
    print(format_table(["backend", "workers", "trials", "wall s", "trials / core-hour"],
                       [list(r.values()) for r in rows]))
    print(f"\nRay / local throughput: {ratio:.2f}; same result for every trial: "
          f"{'yes' if same else 'NO'}")
    if args.json is not None:
        args.json.write_text(json.dumps(dict(rows=rows, ray_over_local=round(ratio, 3),
                                             same_results=same), indent=1))


if __name__ == "__main__":
    main()
