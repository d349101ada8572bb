"""Evaluation speed with the cameras: an image policy's closed-loop trials per worker.

Runs --trials lid trials per embodiment of --checkpoint (default: the shipped image LEGATO lid
policy) on scene seeds from 10000, as ``legato-drake evaluate`` runs them (the cameras on, one
torch thread per trial), through --workers worker processes, after one warm-up trial per
worker (start-up, imports; the same pool) that is not counted. Prints per embodiment the
successes, the median real-time factor per worker (a trial's simulated seconds, homing
included, over its wall seconds: issue 17 asks for 2x) and the trials per core-hour of the
whole run.

``--render-threads 1,2`` runs everything once per value of Mesa's ``LP_NUM_THREADS`` (the
software rasterizer's threads per process, where there is no GPU; Mesa's default is one per
core), the values interleaved embodiment by embodiment, and prints the ratio of each to the
first. Usage:

    python benchmarks/bench_evaluation.py [--trials 4] [--workers 2] [--embodiments all]
        [--checkpoint checkpoints/legato_image_lid.pt] [--render-threads 1,2] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
from pathlib import Path

from bench_backends import timed_after_warmup  # this folder: run as a script

from legato_drake import conventions
from legato_drake.embodiments import EMBODIMENTS
from legato_drake.executor import ProcessExecutor
from legato_drake.models import CHECKPOINTS_DIR
from legato_drake.pipelines.evaluate import EVAL_SEED0, TrialJob, run_trial, trial_scenario
from legato_drake.summary import format_table

DEFAULT_CHECKPOINT = CHECKPOINTS_DIR / "legato_image_lid.pt"


def jobs(embodiment: str, checkpoint: Path, seeds: range) -> list[TrialJob]:
    """One lid trial with the cameras per scene seed."""
    return [TrialJob("bench", i, trial_scenario(embodiment, "lid", seed, checkpoint,
                                                camera=True, duration=None))
            for i, seed in enumerate(seeds)]


def run(embodiment: str, checkpoint: Path, trials: int, workers: int,
        render_threads: str) -> dict:
    """One embodiment's trials in fresh workers, with ``LP_NUM_THREADS=render_threads``
    (empty: as this process has it)."""
    if render_threads:
        os.environ["LP_NUM_THREADS"] = render_threads  # spawned workers inherit it
    seconds, rows = timed_after_warmup(
        ProcessExecutor(workers), run_trial,
        jobs(embodiment, checkpoint, range(EVAL_SEED0 + 900, EVAL_SEED0 + 900 + workers)),
        jobs(embodiment, checkpoint, range(EVAL_SEED0, EVAL_SEED0 + trials)))
    rtf = [(r["episode_time"] + conventions.HOMING_DURATION) / r["wall_time"] for r in rows]
    return dict(embodiment=embodiment,
                render_threads=render_threads or os.environ.get("LP_NUM_THREADS", "Mesa's"),
                trials=trials, workers=workers, successes=sum(r["success"] for r in rows),
                rtf_per_worker=round(statistics.median(rtf), 3),
                trials_per_core_hour=round(trials * 3600 / (seconds * workers), 1),
                wall_s=round(seconds, 1))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--checkpoint", type=Path, default=DEFAULT_CHECKPOINT)
    parser.add_argument("--trials", type=int, default=4, help="per embodiment")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--embodiments", default="all",
                        help=f"comma-separated, or all ({', '.join(EMBODIMENTS)})")
    parser.add_argument("--render-threads", default="",
                        help="comma-separated values of LP_NUM_THREADS to compare (default: "
                             "leave it as it is)")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the rows there")
    args = parser.parse_args()
    embodiments = list(EMBODIMENTS) if args.embodiments == "all" else args.embodiments.split(",")
    unknown = [e for e in embodiments if e not in EMBODIMENTS]
    threads = args.render_threads.split(",")
    if unknown:
        sys.exit(f"--embodiments: unknown {', '.join(unknown)}; valid: {', '.join(EMBODIMENTS)}")
    if threads != [""] and not all(t.isdigit() for t in threads):
        sys.exit(f"--render-threads: must be comma-separated integers, got {args.render_threads}")
    if not args.checkpoint.is_file():
        sys.exit(f"--checkpoint: no such file {args.checkpoint}")
    if args.trials < 1 or args.workers < 1:
        sys.exit("--trials and --workers must be at least 1")
    records = [run(e, args.checkpoint, args.trials, args.workers, t)
               for e in embodiments for t in threads]
    first = {r["embodiment"]: r["rtf_per_worker"] for r in records[::len(threads)]}
    print(f"{args.checkpoint}, {args.trials} lid trials per embodiment from scene seed "
          f"{EVAL_SEED0}, {args.workers} workers, the cameras on")
    print(format_table(
        ["embodiment", "LP_NUM_THREADS", "successes", "x real time per worker",
         "ratio to the first", "trials / core-hour", "wall s"],
        [[r["embodiment"], r["render_threads"], f"{r['successes']}/{r['trials']}",
          r["rtf_per_worker"], f"{r['rtf_per_worker'] / first[r['embodiment']]:.2f}",
          r["trials_per_core_hour"], r["wall_s"]] for r in records]))
    if args.json is not None:
        args.json.write_text(json.dumps(dict(checkpoint=str(args.checkpoint), rows=records),
                                        indent=1))


if __name__ == "__main__":
    main()
