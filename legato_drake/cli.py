"""``legato-drake <verb>``: a thin command line over the library."""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from legato_drake.errors import LegatoError

log = logging.getLogger("legato_drake")


def _names(value: str, registry: dict, kind: str) -> list[str]:
    if value == "all":
        return list(registry)
    names = [v.strip() for v in value.split(",") if v.strip()]
    for name in names:
        if name not in registry:
            valid = ", ".join(["all", *registry])
            raise argparse.ArgumentTypeError(f"unknown {kind} {name!r}; valid values: {valid}")
    return names


def _seeds(value: str) -> list[int]:
    """``7`` -> [7]; ``0-49`` -> [0, ..., 49]; ``1,5,9`` -> [1, 5, 9]."""
    try:
        if "-" in value:
            low, high = (int(v) for v in value.split("-", 1))
            if high < low:
                raise ValueError
            return list(range(low, high + 1))
        return [int(v) for v in value.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"--seeds {value!r}: expected N, A-B (A <= B) or a comma-separated list") from None


def _demo_episode(job: tuple) -> dict:
    """Runs one demo episode (in a worker process) and returns its result as a dict."""
    from legato_drake.episode import run_episode

    scenario, html = job
    result = run_episode(scenario, html=html)
    return {**result.to_dict(), "html": str(html) if html else None}


def cmd_demo(args: argparse.Namespace) -> int:
    """Runs the scripted demonstrator per embodiment, task and seed; writes replays; prints a
    table (one row per episode, or per embodiment and task with 95 % Wilson intervals)."""
    from legato_drake.embodiments import EMBODIMENTS
    from legato_drake.files import atomic_write_text
    from legato_drake.parallel import parallel_map
    from legato_drake.report import format_table
    from legato_drake.scenario import Scenario, load_scenario
    from legato_drake.stats import wilson_interval
    from legato_drake.tasks import TASKS

    base = load_scenario(args.scenario) if args.scenario else Scenario()
    if args.embodiment_file:
        base = base.replace(embodiment_file=str(Path(args.embodiment_file).resolve()))
        embodiments = [base.embodiment]
    else:
        embodiments = _names(args.embodiment, EMBODIMENTS, "embodiment")
    tasks = _names(args.task, TASKS, "task")
    seeds = args.seeds if args.seeds is not None else [base.seed]
    if args.no_camera:
        base.camera.enabled = False
    out = Path(args.out)
    jobs = []
    for embodiment in embodiments:
        for task in tasks:
            for seed in seeds:
                scenario = base.replace(embodiment=embodiment, task=task, seed=seed)
                html = None if args.no_replay else out / f"{embodiment}-{task}-seed{seed}.html"
                jobs.append((scenario, html))
    results = parallel_map(_demo_episode, jobs, args.workers, desc="demo")
    for r in results:
        if r["html"]:
            log.info("wrote %s", r["html"])

    if len(seeds) == 1:
        rows = [[r["embodiment"], r["task"], r["seed"], r["success"], r["reason"] or "-",
                 r["tracking"]["rms_mm"], r["tracking"]["rms_deg"], r["sim_time"],
                 r["wall_time"], r["real_time_factor"]] for r in results]
        print(format_table(["embodiment", "task", "seed", "success", "why not", "rms mm",
                            "rms deg", "sim s", "wall s", "x real time"], rows))
    else:
        rows = []
        for embodiment in embodiments:
            for task in tasks:
                group = [r for r in results
                         if r["embodiment"] == embodiment and r["task"] == task]
                k = sum(r["success"] for r in group)
                low, high = wilson_interval(k, len(group))
                rows.append([embodiment, task, f"{k}/{len(group)}",
                             f"{100 * low:.0f}-{100 * high:.0f}",
                             max(r["tracking"]["rms_mm"] for r in group),
                             max(r["tracking"]["rms_deg"] for r in group),
                             max(r["tracking"]["max_mm"] for r in group),
                             sum(r["sim_time"] for r in group) /
                             sum(r["wall_time"] for r in group)])
        print(format_table(["embodiment", "task", "success", "95% CI %", "worst rms mm",
                            "worst rms deg", "worst max mm", "x real time"], rows))
        failures = [f"{r['embodiment']}/{r['task']}/seed {r['seed']}: {r['reason']}"
                    for r in results if not r["success"]]
        for line in failures:
            log.warning("failed: %s", line)
    if args.json:
        import json

        atomic_write_text(Path(args.json), json.dumps(results, indent=1))
    return 0 if all(r["success"] for r in results) else 1


def cmd_retarget_benchmark(args: argparse.Namespace) -> int:
    """Replays Abstract demonstrations open-loop on every embodiment and prints a table."""
    from legato_drake.embodiments import EMBODIMENTS
    from legato_drake.report import format_table
    from legato_drake.retarget import SUMMARY_HEADERS, run_benchmark, summarize, write_results
    from legato_drake.tasks import TASKS

    rows = run_benchmark(_names(args.embodiments, EMBODIMENTS, "embodiment"),
                         _names(args.tasks, TASKS, "task"), args.seeds, args.workers)
    print(format_table(SUMMARY_HEADERS, summarize(rows)))
    for path in write_results(rows, Path(args.out)):
        log.info("wrote %s", path)
    return 0


def cmd_collect(args: argparse.Namespace) -> int:
    """Collects a demonstration dataset (``legato_drake.data.collect``) and prints a summary."""
    from legato_drake.data.collect import collect
    from legato_drake.report import format_table

    report = collect(task=args.task, embodiment=args.embodiment, episodes=args.episodes,
                     out=Path(args.out), workers=args.workers,
                     keep_failures=args.keep_failures, seed0=args.seed0, source=args.source,
                     camera=not args.no_camera, duration=args.duration,
                     max_attempts=args.max_attempts)
    for outcome in report.failed:
        log.info("failed: %s (seed %d): %s", outcome["key"], outcome["seed"],
                 outcome["reason"])
    print(format_table(["dataset", "episodes kept", "asked", "tried", "failed", "minutes"],
                       [[str(report.out), len(report.kept), report.requested,
                         len(report.outcomes), len(report.failed),
                         report.wall_time / 60.0]]))
    return 0 if len(report.kept) >= report.requested else 1


def cmd_inspect(args: argparse.Namespace) -> int:
    """Prints a dataset's summary and validation; plots one episode."""
    from legato_drake.data.inspect import format_summary, plot_episode, summarize

    summary = summarize(Path(args.file))
    print(format_summary(summary))
    if summary.issues:
        return 1
    out = Path(args.out) if args.out else Path(str(args.file) + ".inspect")
    for path in plot_episode(Path(args.file), args.episode, out):
        print(f"wrote {path}")
    return 0


def cmd_train(args: argparse.Namespace) -> int:
    """Trains a policy (``legato_drake.learning.train``)."""
    from legato_drake.learning.config import load_config
    from legato_drake.learning.train import train

    config = load_config(args.config, args.set)
    ckpt = train(config, Path(args.data), Path(args.out), steps=args.steps, device=args.device,
                 resume=args.resume)
    log.info("step %d, best validation loss %.4f; wrote %s", ckpt.step, ckpt.best_valid,
             Path(args.out) / "best.pt")
    return 0


def cmd_evaluate(args: argparse.Namespace) -> int:
    """Evaluates a checkpoint closed-loop (or, with --plot, combines results files into one
    plot); prints the success table with 95 % Wilson intervals."""
    from legato_drake.embodiments import EMBODIMENTS
    from legato_drake.evaluation import (
        SUMMARY_HEADERS,
        combine,
        evaluate,
        failure_counts,
        plot_success,
        results_path,
        summarize,
    )
    from legato_drake.report import format_table
    from legato_drake.tasks import TASKS

    out = Path(args.out)
    if args.plot:
        trials = combine(args.plot)
        png = plot_success(trials, out / "success_rates.png")
    elif args.checkpoint:
        doc = evaluate(args.checkpoint, _names(args.embodiments, EMBODIMENTS, "embodiment"),
                       _names(args.tasks, TASKS, "task"), args.trials, out,
                       workers=args.workers, replays=args.replays, method=args.method,
                       seed0=args.seed0, duration=args.duration)
        trials = doc["trials"]
        png = plot_success(trials, out / f"{doc['method']}.png")
        log.info("wrote %s", results_path(out, doc["method"]))
    else:
        raise argparse.ArgumentTypeError("evaluate needs --checkpoint (or --plot FILES)")
    print(format_table(SUMMARY_HEADERS, summarize(trials)))
    print(format_table(["method", "embodiment", "task", "failures by condition"],
                       failure_counts(trials)))
    log.info("wrote %s", png)
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``legato-drake``."""
    parser = argparse.ArgumentParser(
        prog="legato-drake",
        description="LEGATO cross-embodiment imitation learning on Drake.")
    parser.add_argument("-v", "--verbose", action="store_true", help="log debug messages")
    verbs = parser.add_subparsers(dest="verb", required=True)

    demo = verbs.add_parser(
        "demo", help="run the scripted demonstrator, write HTML replays, print a table",
        description="Runs the task's scripted demonstrator on each embodiment, writes "
                    "OUT/<embodiment>-<task>-seed<N>.html Meshcat replays and prints success, "
                    "gripper tracking error and speed. Exits 1 if any episode failed.")
    demo.add_argument("--embodiment", default="all",
                      help="embodiment name, comma-separated names, or 'all' (default)")
    demo.add_argument("--embodiment-file", metavar="YAML",
                      help="a robot defined in a YAML file (see README, 'Bring your own "
                           "robot'); replaces --embodiment")
    demo.add_argument("--task", default="lid", help="task name, names, or 'all' (default: lid)")
    demo.add_argument("--seeds", "--seed", type=_seeds, default=None, metavar="SEEDS",
                      help="seed N, range A-B or list A,B,C (default: the scenario's, 0)")
    demo.add_argument("--workers", type=int, default=1,
                      help="worker processes for several episodes (default: 1)")
    demo.add_argument("--json", help="also write every episode's result to this JSON file")
    demo.add_argument("--out", default="replays", help="folder for the HTML replays")
    demo.add_argument("--scenario", help="scenario YAML to start from (fields: see README)")
    demo.add_argument("--no-camera", action="store_true", help="do not render the cameras")
    demo.add_argument("--no-replay", action="store_true", help="do not write HTML replays")
    demo.set_defaults(func=cmd_demo)

    retarget = verbs.add_parser(
        "retarget-benchmark", help="replay Abstract demonstrations open-loop on every robot",
        description="Records the scripted demonstrator's gripper trajectory on Abstract for "
                    "each seed, replays it open-loop on each embodiment in the same scene, and "
                    "prints tracking error, joint-limit margin, IK solve time, speed and "
                    "success per embodiment and task; writes OUT/retarget.csv and .json.")
    retarget.add_argument("--embodiments", default="all", help="names or 'all' (default)")
    retarget.add_argument("--tasks", default="lid", help="names or 'all' (default: lid)")
    retarget.add_argument("--seeds", type=_seeds, default=_seeds("0-4"),
                          help="N, A-B or A,B,C (default: 0-4)")
    retarget.add_argument("--workers", type=int, default=1, help="worker processes")
    retarget.add_argument("--out", default="results/retarget", help="folder for CSV and JSON")
    retarget.set_defaults(func=cmd_retarget_benchmark)

    collect = verbs.add_parser(
        "collect", help="record a demonstration dataset (robomimic-style HDF5)",
        description="Records scripted (or, with --source, replayed pose-stream) episodes and "
                    "writes them to OUT (layout: docs/data_format.md). Only successful "
                    "episodes are kept unless --keep-failures. Interrupted runs resume: "
                    "episodes already in OUT.parts/ are skipped. Exits 1 if fewer episodes "
                    "than asked (or than --source files) were kept.")
    collect.add_argument("--task", default="lid", help="task name (default: lid)")
    collect.add_argument("--embodiment", default="abstract",
                         help="embodiment name (default: abstract)")
    collect.add_argument("--episodes", type=int, default=150,
                         help="episodes to keep (default: 150)")
    collect.add_argument("--out", required=True, help="dataset file, e.g. data/lid.hdf5")
    collect.add_argument("--workers", type=int, default=1, help="worker processes (default 1)")
    collect.add_argument("--keep-failures", action="store_true",
                         help="keep failed episodes too (success is recorded per demo)")
    collect.add_argument("--seed0", type=int, default=0, help="first seed (default: 0)")
    collect.add_argument("--source", metavar="PATH",
                         help="pose-stream file (CSV/NPZ) or folder of them: one replayed "
                              "episode per file instead of the scripted demonstrator")
    collect.add_argument("--no-camera", action="store_true",
                         help="state-only dataset (no images; about twice as fast)")
    collect.add_argument("--duration", type=float, default=None,
                         help="seconds per episode after homing (default: the scenario's 40)")
    collect.add_argument("--max-attempts", type=int, default=None,
                         help="most seeds to try (default: 3 x episodes + 10)")
    collect.set_defaults(func=cmd_collect)

    inspect = verbs.add_parser(
        "inspect", help="summarize and validate a dataset, plot one episode",
        description="Prints episodes, lengths, success and per-dimension action statistics, "
                    "validates the layout (shapes, dtypes, NaNs, masks, format version), and "
                    "writes a strip of stereo frames and a gripper-trajectory plot of one "
                    "episode. Exits 1 if the dataset is invalid, 2 if it cannot be read.")
    inspect.add_argument("file", help="dataset file")
    inspect.add_argument("--episode", type=int, default=0, help="demo index to plot (0)")
    inspect.add_argument("--out", help="folder for the plots (default: FILE.inspect/)")
    inspect.set_defaults(func=cmd_inspect)

    train = verbs.add_parser(
        "train", help="train a policy (LEGATO or BC-RNN) on a demonstration dataset",
        description="Trains the policy of a learning config (configs/*.yaml) on a dataset; "
                    "writes OUT/log.csv (every loss term, validation losses), OUT/last.pt and "
                    "OUT/best.pt (config, normalisation, step, optimizer). Seeded; --resume "
                    "continues from OUT/last.pt. The L_invar ablation: --set "
                    "invariant_weight=0.")
    train.add_argument("--config", required=True, help="learning config YAML")
    train.add_argument("--data", required=True, help="dataset file, e.g. data/lid.hdf5")
    train.add_argument("--out", required=True, help="run folder, e.g. runs/legato")
    train.add_argument("--steps", type=int, default=None, help="steps in all (default: config)")
    train.add_argument("--device", default="cpu", help="cpu (default) or cuda")
    train.add_argument("--resume", action="store_true", help="continue from OUT/last.pt")
    train.add_argument("--set", action="append", metavar="FIELD=VALUE",
                       help="override a config field (repeatable), e.g. invariant_weight=0")
    train.set_defaults(func=cmd_train)

    evaluate = verbs.add_parser(
        "evaluate", help="closed-loop trials of a trained policy; success table and plot",
        description="Runs --trials trials (scene seeds --seed0, --seed0 + 1, ...) per "
                    "embodiment and task with the policy in place of the demonstrator; writes "
                    "OUT/<method>.json and .csv after every trial (a rerun resumes), "
                    "OUT/<method>.png (success with 95 % Wilson intervals) and Meshcat "
                    "replays of the first --replays trials. --plot FILES combines results "
                    "files into OUT/success_rates.png.")
    evaluate.add_argument("--checkpoint", help="checkpoint, e.g. runs/legato/best.pt")
    evaluate.add_argument("--embodiments", default="all", help="names or 'all' (default)")
    evaluate.add_argument("--tasks", default="lid", help="names or 'all' (default: lid)")
    evaluate.add_argument("--trials", type=int, default=50, help="trials per cell (50)")
    evaluate.add_argument("--workers", type=int, default=1, help="worker processes (1)")
    evaluate.add_argument("--out", default="results", help="results folder (results/)")
    evaluate.add_argument("--replays", type=int, default=0,
                          help="Meshcat HTML replays of the first K trials per cell (0)")
    evaluate.add_argument("--method", help="method name (default: the config's name)")
    evaluate.add_argument("--seed0", type=int, default=10000,
                          help="first trial seed (default 10000, past the training seeds)")
    evaluate.add_argument("--duration", type=float, default=None,
                          help="seconds per trial after homing (default: 40)")
    evaluate.add_argument("--plot", nargs="+", metavar="JSON",
                          help="only combine these results files into one plot and table")
    evaluate.set_defaults(func=cmd_evaluate)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``legato-drake`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.INFO,
                        format="%(levelname)s %(name)s: %(message)s", stream=sys.stderr)
    try:
        return args.func(args)
    except (LegatoError, argparse.ArgumentTypeError, FileNotFoundError) as e:
        parser.exit(2, f"legato-drake: error: {e}\n")


if __name__ == "__main__":
    sys.exit(main())
