"""``legato-drake <verb>``: a thin command line over the library."""

from __future__ import annotations

import argparse
import dataclasses
import logging
import math
import shutil
import signal
import sys
import threading
from collections.abc import Callable
from pathlib import Path
from typing import NoReturn

from legato_drake import __version__, conventions
from legato_drake.errors import ConfigError, LegatoError, one_line
from legato_drake.executor import BACKENDS
from legato_drake.files import check_output_dir, check_output_file, require_file

log = logging.getLogger("legato_drake")

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_INTERRUPTED = 0, 1, 2, 130
"""Exit codes: everything succeeded; some episode or trial failed; bad input (nothing was
done); interrupted (Ctrl-C)."""


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (and exit 2), like every other error."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {one_line(message)} "
                                  f"(see {self.prog} --help)\n")


def _int_at_least(low: int) -> Callable[[str], int]:
    """An argparse type: an integer >= ``low``."""
    def parse(value: str) -> int:
        try:
            number = int(value)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected an integer >= {low}, got {value!r}") from None
        if number < low:
            raise argparse.ArgumentTypeError(f"must be at least {low}, got {number}")
        return number

    parse.__name__ = f"integer >= {low}"
    return parse


def _seconds(value: str) -> float:
    """An argparse type: a positive, finite number of seconds."""
    try:
        number = float(value)
    except ValueError:
        number = math.nan
    if not (math.isfinite(number) and number > 0):
        raise argparse.ArgumentTypeError(
            f"expected a positive number of seconds, got {value!r}")
    return number


def _metres(value: str) -> float:
    """An argparse type: a non-negative, finite number of metres."""
    try:
        number = float(value)
    except ValueError:
        number = math.nan
    if not (math.isfinite(number) and number >= 0):
        raise argparse.ArgumentTypeError(
            f"expected a non-negative number of metres, got {value!r}")
    return number


def _names(value: str, registry: dict, kind: str) -> list[str]:
    if value == "all":
        return list(registry)
    names = [v.strip() for v in value.split(",") if v.strip()]
    for name in names:
        if name not in registry:
            valid = ", ".join(["all", *registry])
            raise argparse.ArgumentTypeError(f"unknown {kind} {name!r}; valid values: {valid}")
    return names


def seed_list(value: str) -> list[int]:
    """``7`` -> [7]; ``0-49`` -> [0, ..., 49]; ``1,5,9`` -> [1, 5, 9] (an argparse type: bad
    input is an ArgumentTypeError naming --seeds)."""
    try:
        if "-" in value:
            low, high = (int(v) for v in value.split("-", 1))
            if high < low:
                raise ValueError
            return list(range(low, high + 1))
        seeds = [int(v) for v in value.split(",")]
        if min(seeds) < 0:
            raise ValueError
        return seeds
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"--seeds {value!r}: expected N, A-B (0 <= A <= B) or a comma-separated list of "
            "non-negative seeds") from None


def _demo_checkpoint(args: argparse.Namespace, base, controller: str, task: str) -> str:
    """The checkpoint ``demo`` runs for ``task``: ``--checkpoint``, else the scenario's, else
    the shipped policy of the task ("" for the other controllers)."""
    from legato_drake.models import shipped_checkpoint

    if controller != "policy":
        return base.checkpoint
    if args.checkpoint:
        return str(require_file(args.checkpoint, "--checkpoint"))
    if base.checkpoint:
        return base.checkpoint
    shipped = shipped_checkpoint(task)
    if not shipped.is_file():
        raise ConfigError(f"no shipped policy for task {task!r} ({shipped} does not exist): "
                          "use --controller scripted, or --checkpoint FILE")
    return str(shipped)


def _controller_label(result: dict, checkpoints: dict[str, str]) -> str:
    """What drove an episode, for the demo table: ``scripted``, ``replay`` or the policy's
    checkpoint file name."""
    if result["controller"] != "policy":
        return result["controller"]
    return f"policy:{Path(checkpoints[result['task']]).name}"


def cmd_demo(args: argparse.Namespace) -> int:
    """Runs a controller (by default the shipped LEGATO policy of the task; ``--controller
    scripted``: the scripted expert) per embodiment, task and seed; writes replays; prints a
    table (one row per episode, or per embodiment and task with 95 % Wilson intervals)."""
    from legato_drake import summary
    from legato_drake.embodiments import EMBODIMENTS
    from legato_drake.files import atomic_write_text
    from legato_drake.pipelines import episodes
    from legato_drake.scenario import Scenario, load_scenario
    from legato_drake.tasks import TASKS

    if args.embodiment_file and args.embodiment is not None:
        raise ConfigError("--embodiment-file replaces --embodiment: give only one of them")
    # Flags given explicitly override the scenario file's fields; absent ones leave them.
    base = load_scenario(args.scenario) if args.scenario else Scenario()
    if args.embodiment_file:
        base = base.replace(embodiment_file=str(Path(args.embodiment_file).resolve()))
        embodiments = [base.embodiment]
    elif args.embodiment is not None:
        embodiments = _names(args.embodiment, EMBODIMENTS, "embodiment")
        base = dataclasses.replace(base, embodiment_file="")
    else:
        embodiments = [base.embodiment] if args.scenario else list(EMBODIMENTS)
    tasks = _names(args.task, TASKS, "task") if args.task is not None else [base.task]
    seeds = args.seeds if args.seeds is not None else [base.seed]
    controller = args.controller or (base.controller if args.scenario else "policy")
    checkpoints = {task: _demo_checkpoint(args, base, controller, task) for task in tasks}
    if controller == "policy":
        from legato_drake.learning.checkpoint import load_checkpoint

        for path in set(checkpoints.values()):
            load_checkpoint(path)  # a file that is not a policy is refused before any episode
    if args.no_camera:
        base.camera.enabled = False
    out = Path(args.out)
    if not args.no_replay:
        check_output_dir(out, "--out")
    if args.json:
        check_output_file(Path(args.json), "--json")
    jobs = []
    for embodiment in embodiments:
        for task in tasks:
            for seed in seeds:
                scenario = base.replace(embodiment=embodiment, task=task, seed=seed,
                                        controller=controller, checkpoint=checkpoints[task])
                html = None if args.no_replay else out / f"{embodiment}-{task}-seed{seed}.html"
                jobs.append(episodes.EpisodeJob(scenario, html))
    results = episodes.run_episodes(jobs, args.workers, desc="demo")
    for r in results:
        if r["html"]:
            log.info("wrote %s", r["html"])

    def label(result: dict) -> str:
        return _controller_label(result, checkpoints)

    if len(seeds) == 1:
        print(summary.format_table(summary.EPISODE_HEADERS,
                                   summary.episode_rows(results, label)))
    else:
        print(summary.format_table(summary.DEMO_HEADERS, summary.demo_rows(results, label)))
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
    from legato_drake.pipelines.retarget import run_benchmark, write_results
    from legato_drake.summary import RETARGET_HEADERS, format_table, retarget_rows
    from legato_drake.tasks import TASKS

    embodiments = _names(args.embodiments, EMBODIMENTS, "embodiment")
    tasks = _names(args.tasks, TASKS, "task")
    check_output_dir(Path(args.out), "--out")
    rows = run_benchmark(embodiments, tasks, args.seeds, args.workers)
    print(format_table(RETARGET_HEADERS, retarget_rows(rows)))
    for path in write_results(rows, Path(args.out)):
        log.info("wrote %s", path)
    return EXIT_OK if all(r["success"] for r in rows) else EXIT_FAILED


def cmd_collect(args: argparse.Namespace) -> int:
    """Collects a demonstration dataset (``legato_drake.pipelines.collect``) and prints a
    summary."""
    from legato_drake.embodiments import EMBODIMENTS
    from legato_drake.pipelines.collect import collect, parts_dir
    from legato_drake.scenario import CAMERA_MODELS, ExpertNoiseConfig
    from legato_drake.summary import format_table
    from legato_drake.tasks import TASKS

    _names(args.task, TASKS, "task")
    _names(args.embodiment, EMBODIMENTS, "embodiment")
    if args.camera_model not in CAMERA_MODELS:
        raise ConfigError(f"--camera-model must be one of {', '.join(CAMERA_MODELS)}, got "
                          f"{args.camera_model!r}")
    for flag, value, ok, allowed in (
            ("--noise-mm", args.noise_mm, args.noise_mm >= 0, "0 or more"),
            ("--noise-deg", args.noise_deg, args.noise_deg >= 0, "0 or more"),
            ("--noise-correlation", args.noise_correlation, 0 <= args.noise_correlation < 1,
             "in [0, 1)"),
            ("--noise-full-speed", args.noise_full_speed, args.noise_full_speed > 0,
             "a positive speed, m/s")):
        if not (math.isfinite(value) and ok):
            raise ConfigError(f"{flag} must be {allowed}, got {value}")
    out = check_output_file(Path(args.out), "--out")
    check_output_dir(parts_dir(out), "--out")
    if args.max_attempts is not None and args.max_attempts < args.episodes:
        raise ConfigError(f"--max-attempts {args.max_attempts} is below --episodes "
                          f"{args.episodes}")
    if args.source is not None and not Path(args.source).exists():
        raise ConfigError(f"--source {args.source}: no such file or folder")
    if args.overwrite:
        _set_aside(args, [out, parts_dir(out), out.with_name(out.name + ".manifest.json")],
                   out.with_name(f".{out.name}.overwritten"))
    report = collect(task=args.task, embodiment=args.embodiment, episodes=args.episodes,
                     out=Path(args.out), workers=args.workers,
                     keep_failures=args.keep_failures, seed0=args.seed0, source=args.source,
                     camera=not args.no_camera, camera_model=args.camera_model,
                     duration=args.duration, max_attempts=args.max_attempts,
                     expert_noise=ExpertNoiseConfig(args.noise_mm / 1000.0, args.noise_deg,
                                                    args.noise_correlation,
                                                    args.noise_full_speed),
                     stop_on_success=args.stop_on_success)
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

    out = Path(args.out) if args.out else Path(str(args.file) + ".inspect")
    check_output_dir(out, "--out")
    summary = summarize(Path(args.file))
    print(format_summary(summary))
    if summary.issues:
        return 1
    for path in plot_episode(Path(args.file), args.episode, out):
        print(f"wrote {path}")
    return 0


def cmd_train(args: argparse.Namespace) -> int:
    """Trains a policy (``legato_drake.learning.train``)."""
    import torch

    from legato_drake.learning.config import load_config
    from legato_drake.learning.train import RUN_FILES, SNAPSHOTS, train
    from legato_drake.pipelines.selection import SELECTION_FILES

    if args.resume and args.overwrite:
        raise ConfigError("--resume continues the run in --out, --overwrite replaces it: "
                          "give only one of them")
    try:
        torch.device(args.device)
    except RuntimeError:
        raise ConfigError(f"--device {args.device!r}: expected cpu, cuda or cuda:N") from None
    config = load_config(args.config, args.set)
    require_file(args.data, "--data dataset file")
    out = check_output_dir(Path(args.out), "--out")
    if args.overwrite and out.is_dir():
        # the run and what a selection made of it; nothing else in the folder
        _set_aside(args, [*(out / name for name in (*RUN_FILES, *SELECTION_FILES)),
                          *out.glob(SNAPSHOTS)], out / ".overwritten", new_files=(out, SNAPSHOTS))
    ckpt = train(config, Path(args.data), out, steps=args.steps, device=args.device,
                 resume=args.resume)
    log.info("step %d, best validation loss %.4f; wrote %s", ckpt.step, ckpt.best_valid,
             Path(args.out) / "best.pt")
    return 0


def cmd_select(args: argparse.Namespace) -> int:
    """Chooses a run's checkpoint by rollouts on validation seeds; prints the candidates."""
    from legato_drake.embodiments import EMBODIMENTS
    from legato_drake.pipelines.selection import select_checkpoint
    from legato_drake.summary import format_table
    from legato_drake.tasks import TASKS

    _names(args.task, TASKS, "task")
    _names(args.embodiment, EMBODIMENTS, "embodiment")
    summary = select_checkpoint(args.run, args.task, args.embodiment, args.trials, args.seed0,
                                args.workers)
    seeds = summary["seeds"]
    print(format_table(
        ["candidate", "step", f"success (seeds {seeds[0]}-{seeds[-1]})", "selected"],
        [[c["name"], c["step"], f"{c['successes']}/{c['trials']}",
          "yes" if c["name"] == summary["selected"] else ""] for c in summary["candidates"]]))
    log.info("wrote %s", Path(args.run) / "selected.pt")
    return 0


def _csv_list(value: str | None, flag: str, kind: type = str) -> list | None:
    """``"a,b"`` -> ``["a", "b"]`` (None stays None); ConfigError naming ``flag``."""
    if value is None:
        return None
    try:
        items = [kind(v.strip()) for v in value.split(",") if v.strip()]
    except ValueError:
        raise ConfigError(f"{flag}: expected a comma-separated list of {kind.__name__}s, got "
                          f"{value!r}") from None
    if not items:
        raise ConfigError(f"{flag}: no names given")
    return items


def cmd_experiment(args: argparse.Namespace) -> int:
    """Runs a grid (collect -> train -> select -> evaluate), resumable; prints its summary."""
    from legato_drake.executor import make_backend
    from legato_drake.experiment.grid import load_grid, subset
    from legato_drake.experiment.runner import run_experiment

    grid = subset(load_grid(args.grid), _csv_list(args.methods, "--methods"),
                  _csv_list(args.tasks, "--tasks"),
                  _csv_list(args.train_seeds, "--train-seeds", int), args.trials,
                  _csv_list(args.embodiments, "--embodiments"), args.seed0)
    check_output_dir(Path(args.out), "--out")
    executor = make_backend(args.backend, args.workers, args.ray_address)
    report = run_experiment(grid, args.out, executor)
    print((Path(args.out) / "summary.md").read_text())
    log.info("ran %s, already done %s; results in %s", report.ran, report.skipped,
             Path(args.out) / "results.csv")
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    """Writes a dataset in another framework's layout (LeRobot v3.0, or robomimic's image
    path) and reads it back."""
    data = require_file(args.data, "DATA dataset file")
    if args.format == "lerobot":
        from legato_drake.data.export_lerobot import export_lerobot

        check_output_dir(Path(args.out), "--out")
        info = export_lerobot(data, args.out, overwrite=args.overwrite)
        log.info("wrote %s: LeRobot %s, %d episodes, %d frames, features %s", args.out,
                 info["codebase_version"], info["total_episodes"], info["total_frames"],
                 ", ".join(info["features"]))
    else:
        from legato_drake.data.export_robomimic import export_robomimic

        check_output_file(Path(args.out), "--out")
        keys = export_robomimic(data, args.out, overwrite=args.overwrite)
        log.info("wrote %s (3-channel images: %s)", args.out, ", ".join(keys) or "none")
    return 0


def _trial_seeds(args: argparse.Namespace) -> tuple[int, int]:
    """evaluate's (seed0, trials) from ``--seeds A-B`` (demo's spelling) or ``--seed0`` and
    ``--trials`` (defaults 10000 and 50)."""
    from legato_drake.pipelines.evaluate import EVAL_SEED0

    if args.seeds is None:
        return (EVAL_SEED0 if args.seed0 is None else args.seed0,
                50 if args.trials is None else args.trials)
    if args.seed0 is not None or args.trials is not None:
        raise ConfigError("--seeds A-B replaces --seed0 and --trials: give one or the others")
    seeds = args.seeds
    if seeds != list(range(seeds[0], seeds[0] + len(seeds))):
        raise ConfigError(f"--seeds: evaluation seeds must be consecutive (N or A-B), got "
                          f"{seeds}")
    return seeds[0], len(seeds)


def cmd_evaluate(args: argparse.Namespace) -> int:
    """Evaluates a checkpoint closed-loop (or, with --plot, combines results files into one
    plot); prints the success table with 95 % Wilson intervals."""
    from legato_drake.embodiments import EMBODIMENTS
    from legato_drake.pipelines.evaluate import (
        combine,
        evaluate,
        plot_success,
        results_path,
        trial_order,
    )
    from legato_drake.summary import (
        FAILURE_HEADERS,
        TRIAL_HEADERS,
        failure_rows,
        format_table,
        trial_rows,
    )
    from legato_drake.tasks import TASKS

    out = check_output_dir(Path(args.out), "--out")
    if args.plot and args.checkpoint:
        raise ConfigError("--plot only combines results files: give --checkpoint or --plot")
    if args.plot:
        trials = combine(args.plot)
        png = plot_success(trials, out / "success_rates.png")
    elif args.checkpoint:
        seed0, trials = _trial_seeds(args)
        doc = evaluate(args.checkpoint, _names(args.embodiments, EMBODIMENTS, "embodiment"),
                       _names(args.tasks, TASKS, "task"), trials, out,
                       workers=args.workers, replays=args.replays, method=args.method,
                       seed0=seed0, duration=args.duration, overwrite=args.overwrite,
                       overrides=args.set, max_target_lead=args.max_target_lead,
                       seen_scenes=args.seen_scenes)
        trials = doc["trials"]
        png = plot_success(trials, out / f"{doc['method']}.png")
        log.info("wrote %s", results_path(out, doc["method"]))
    else:
        raise argparse.ArgumentTypeError("evaluate needs --checkpoint (or --plot FILES)")
    ordered = sorted(trials, key=trial_order)
    print(format_table(TRIAL_HEADERS, trial_rows(ordered)))
    print(format_table(FAILURE_HEADERS, failure_rows(ordered)))
    log.info("wrote %s", png)
    # A failed trial is a result; a trial that raised did not run as it should.
    errors = [t for t in trials if str(t.get("reason", "")).startswith("error:")]
    for t in errors:
        log.warning("trial %s/%s seed %s: %s", t["embodiment"], t["task"], t["seed"],
                    t["reason"])
    return EXIT_FAILED if errors else EXIT_OK


def _delete(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    elif path.exists() or path.is_symlink():
        path.unlink()


def _set_aside(args: argparse.Namespace, paths: list[Path], aside: Path,
               new_files: tuple[Path, str] | None = None) -> None:
    """For ``--overwrite``: moves the existing ``paths`` into the folder ``aside`` before the
    work starts. ``main`` deletes them when the verb returns, and puts them back when it
    fails or is interrupted (first removing what it wrote at those paths, and files matching
    ``new_files``: a folder and a glob), so a failed ``--overwrite`` loses nothing."""
    if aside.exists():
        raise ConfigError(f"--overwrite: {aside} holds the files set aside by an earlier "
                          "--overwrite that was cut short: move them back or delete it first")
    existing = [p for p in dict.fromkeys(paths) if p.exists() or p.is_symlink()]
    if not existing:
        return
    aside.mkdir(parents=True)
    moved = []
    for i, path in enumerate(existing):
        target = aside / f"{i}-{path.name}"
        path.rename(target)
        moved.append((path, target))
    args.set_aside = (moved, aside, paths, new_files)


def _settle_set_aside(args: argparse.Namespace, succeeded: bool) -> None:
    """Deletes what ``_set_aside`` moved (the verb succeeded) or puts it back (it failed)."""
    moved, aside, paths, new_files = getattr(args, "set_aside", ((), None, (), None))
    if aside is None:
        return
    if succeeded:
        for path, _ in moved:
            log.info("--overwrite: replaced %s", path)
        shutil.rmtree(aside)
        return
    written = [*paths, *(new_files[0].glob(new_files[1]) if new_files else ())]
    for path in written:
        _delete(path)
    for path, target in moved:
        target.rename(path)
    aside.rmdir()
    log.info("--overwrite: the work did not finish; the old files are back in place")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``legato-drake``."""
    from legato_drake.scenario import DEFAULT_MAX_TARGET_LEAD

    parser = _Parser(
        prog="legato-drake",
        description="LEGATO cross-embodiment imitation learning on Drake. Exit codes: 0 "
                    "everything succeeded, 1 some episode or trial failed, 2 bad input "
                    "(nothing was run), 130 interrupted.")
    parser.add_argument("-v", "--verbose", action="store_true", help="log debug messages")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    verbs = parser.add_subparsers(dest="verb", required=True)

    demo = verbs.add_parser(
        "demo", help="run the shipped policy (or the scripted expert) on every robot, write "
                     "HTML replays, print a table",
        description="Runs the task's shipped LEGATO policy (--controller policy, default) or "
                    "its scripted expert (--controller scripted) on each embodiment, writes "
                    "OUT/<embodiment>-<task>-seed<N>.html Meshcat replays and prints success, "
                    "gripper tracking error and speed. Exits 1 if any episode failed.")
    demo.add_argument("--embodiment", "--embodiments", dest="embodiment", default=None,
                      help="embodiment name, comma-separated names, or 'all' (default: "
                           "the --scenario file's, else all)")
    demo.add_argument("--embodiment-file", metavar="YAML",
                      help="a robot defined in a YAML file (see README, 'Bring your own "
                           "robot'); replaces --embodiment")
    demo.add_argument("--task", "--tasks", dest="task", default=None,
                      help="task name, names, or 'all' (default: the --scenario file's, "
                           "else lid)")
    demo.add_argument("--seeds", "--seed", type=seed_list, default=None, metavar="SEEDS",
                      help="seed N, range A-B or list A,B,C (default: the scenario's, 0)")
    demo.add_argument("--workers", type=_int_at_least(1), default=1,
                      help="worker processes for several episodes (default: 1)")
    demo.add_argument("--json", help="also write every episode's result to this JSON file")
    demo.add_argument("--out", default="replays", help="folder for the HTML replays")
    demo.add_argument("--scenario", help="scenario YAML to start from (fields: see README); "
                                         "flags given explicitly override its fields")
    demo.add_argument("--controller", choices=["policy", "scripted"], default=None,
                      help="policy: a trained LEGATO policy (default: --checkpoint, else the "
                           "shipped checkpoints/legato_state_<task>.pt); scripted: the task's "
                           "scripted expert (default: the --scenario file's, else policy)")
    demo.add_argument("--checkpoint", metavar="PT",
                      help="policy checkpoint to run with --controller policy")
    demo.add_argument("--no-camera", action="store_true", help="do not render the cameras")
    demo.add_argument("--no-replay", action="store_true", help="do not write HTML replays")
    demo.set_defaults(func=cmd_demo)

    retarget = verbs.add_parser(
        "retarget-benchmark", help="replay Abstract demonstrations open-loop on every robot",
        description="Records the scripted demonstrator's gripper trajectory on Abstract for "
                    "each seed, replays it open-loop on each embodiment in the same scene, and "
                    "prints tracking error, joint-limit margin, IK solve time, speed and "
                    "success per embodiment and task; writes OUT/retarget.csv and .json. "
                    "Exits 1 if any replay failed.")
    retarget.add_argument("--embodiments", "--embodiment", dest="embodiments", default="all",
                          help="names or 'all' (default)")
    retarget.add_argument("--tasks", "--task", dest="tasks", default="lid",
                          help="names or 'all' (default: lid)")
    retarget.add_argument("--seeds", type=seed_list, default=seed_list("0-4"),
                          help="N, A-B or A,B,C (default: 0-4)")
    retarget.add_argument("--workers", type=_int_at_least(1), default=1,
                          help="worker processes")
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
    collect.add_argument("--episodes", type=_int_at_least(1), default=150,
                         help="episodes to keep (default: 150)")
    collect.add_argument("--out", required=True, help="dataset file, e.g. data/lid.hdf5")
    collect.add_argument("--workers", type=_int_at_least(1), default=1,
                         help="worker processes (default 1)")
    collect.add_argument("--keep-failures", action="store_true",
                         help="keep failed episodes too (success is recorded per demo)")
    collect.add_argument("--seed0", type=_int_at_least(0), default=0,
                         help="first seed (default: 0)")
    collect.add_argument("--source", metavar="PATH",
                         help="pose-stream file (CSV/NPZ) or folder of them: one replayed "
                              "episode per file instead of the scripted demonstrator")
    collect.add_argument("--no-camera", action="store_true",
                         help="state-only dataset (no images; about twice as fast)")
    collect.add_argument("--camera-model", default="pinhole", metavar="MODEL",
                         help="the cameras' lens: pinhole (default) or fisheye (T265-like, "
                              "camera.model); an image policy trained on the dataset is "
                              "rendered the same way wherever it runs")
    collect.add_argument("--duration", type=_seconds, default=None,
                         help="seconds per episode after homing (default: the scenario's 40)")
    collect.add_argument("--max-attempts", type=_int_at_least(1), default=None,
                         help="most seeds to try (default: 3 x episodes + 10)")
    collect.add_argument("--overwrite", action="store_true",
                         help="replace an existing OUT (and its OUT.parts/) instead of "
                              "extending it; without it, asking an existing dataset for "
                              "fewer episodes than it holds is refused")
    collect.add_argument("--noise-mm", type=float, default=0.0, metavar="MM",
                         help="DART-style perturbation of the scripted expert: standard "
                              "deviation of the executed pose's offset per axis, mm; the "
                              "dataset records the expert's corrections (default 0)")
    collect.add_argument("--noise-deg", type=float, default=0.0, metavar="DEG",
                         help="the same for the rotation, degrees per axis (default 0)")
    collect.add_argument("--noise-correlation", type=float, default=0.8, metavar="RHO",
                         help="step-to-step correlation of the offset, in [0, 1) "
                              "(default 0.8)")
    collect.add_argument("--noise-full-speed", type=float,
                         default=conventions.EXPERT_NOISE_FULL_SPEED, metavar="M_PER_S",
                         help="plan speed at and above which the offset has its full size; "
                              "slower moves get less, holds none (default 0.15; lower "
                              "perturbs the slow moves into a grasp or a placement too)")
    collect.add_argument("--stop-on-success", action="store_true",
                         help="end each episode at success (by default the release, hold "
                              "and retreat after it are recorded too)")
    collect.set_defaults(func=cmd_collect)

    inspect = verbs.add_parser(
        "inspect", help="summarize and validate a dataset, plot one episode",
        description="Prints episodes, lengths, success and per-dimension action statistics, "
                    "validates the layout (shapes, dtypes, NaNs, masks, format version), and "
                    "writes a strip of stereo frames and a gripper-trajectory plot of one "
                    "episode. Exits 1 if the dataset is invalid, 2 if it cannot be read.")
    inspect.add_argument("file", help="dataset file")
    inspect.add_argument("--episode", type=_int_at_least(0), default=0,
                         help="demo index to plot (0)")
    inspect.add_argument("--out", help="folder for the plots (default: FILE.inspect/)")
    inspect.set_defaults(func=cmd_inspect)

    train = verbs.add_parser(
        "train",
        help="train a policy (LEGATO, BC-RNN or Diffusion Policy) on a demonstration dataset",
        description="Trains the policy of a learning config (configs/*.yaml) on a dataset; "
                    "writes OUT/log.csv (every loss term, validation losses), OUT/last.pt and "
                    "OUT/best.pt (config, normalisation, step, optimizer). Seeded; --resume "
                    "continues from OUT/last.pt. The L_invar ablation: --set "
                    "invariant_weight=0.")
    train.add_argument("--config", required=True, help="learning config YAML")
    train.add_argument("--data", required=True, help="dataset file, e.g. data/lid.hdf5")
    train.add_argument("--out", required=True, help="run folder, e.g. runs/legato")
    train.add_argument("--steps", type=_int_at_least(1), default=None,
                       help="steps in all (default: config)")
    train.add_argument("--device", default="cpu", help="cpu (default) or cuda")
    train.add_argument("--resume", action="store_true", help="continue from OUT/last.pt")
    train.add_argument("--overwrite", action="store_true",
                       help="replace the run already in OUT (checkpoints, log, config, "
                            "snapshots; kept until the new run finishes); without it (or "
                            "--resume), a run folder that holds one is refused")
    train.add_argument("--set", action="append", metavar="FIELD=VALUE",
                       help="override a config field (repeatable), e.g. invariant_weight=0")
    train.set_defaults(func=cmd_train)

    select = verbs.add_parser(
        "select", help="choose a run's checkpoint by rollouts on validation scene seeds",
        description="Rolls out each candidate of a training run (its step_<N>.pt snapshots, "
                    "kept with --set snapshot_every=N, and last.pt) for --trials validation "
                    "scene seeds from --seed0 (default 5000: disjoint from the training "
                    "demos and from evaluation's 10000 on) and writes the most successful "
                    "to RUN/selected.pt (the later on ties) and RUN/selection.json. "
                    "evaluate refuses to reuse the selection seeds.")
    select.add_argument("--run", required=True, help="training run folder, e.g. runs/legato")
    select.add_argument("--task", required=True, help="task the run was trained on")
    select.add_argument("--embodiment", default="abstract",
                        help="embodiment to roll out on (default: abstract)")
    select.add_argument("--trials", type=_int_at_least(1), default=20,
                        help="validation seeds (20)")
    select.add_argument("--seed0", type=_int_at_least(0), default=5000,
                        help="first validation seed (5000)")
    select.add_argument("--workers", type=_int_at_least(1), default=1,
                        help="worker processes (1)")
    select.set_defaults(func=cmd_select)

    evaluate = verbs.add_parser(
        "evaluate", help="closed-loop trials of a trained policy; success table and plot",
        description="Runs --trials trials (scene seeds --seed0, --seed0 + 1, ...) per "
                    "embodiment and task with the policy in place of the demonstrator; writes "
                    "OUT/<method>.json and .csv after every trial (a rerun resumes), "
                    "OUT/<method>.png (success with 95 % Wilson intervals) and Meshcat "
                    "replays of the first --replays trials. --plot FILES combines results "
                    "files into OUT/success_rates.png. Exits 0 when every trial ran (failed "
                    "trials are results), 1 if a trial raised an error.")
    evaluate.add_argument("--checkpoint", help="checkpoint, e.g. runs/legato/best.pt")
    evaluate.add_argument("--embodiments", "--embodiment", dest="embodiments", default="all",
                          help="names or 'all' (default)")
    evaluate.add_argument("--tasks", "--task", dest="tasks", default="lid",
                          help="names or 'all' (default: lid)")
    evaluate.add_argument("--trials", type=_int_at_least(1), default=None,
                          help="trials per cell (50)")
    evaluate.add_argument("--workers", type=_int_at_least(1), default=1,
                          help="worker processes (1)")
    evaluate.add_argument("--out", default="results", help="results folder (results/)")
    evaluate.add_argument("--replays", type=_int_at_least(0), default=0,
                          help="Meshcat HTML replays of the first K trials per cell (0)")
    evaluate.add_argument("--method", help="method name (default: the config's name)")
    evaluate.add_argument("--seed0", type=_int_at_least(0), default=None,
                          help="first trial seed (default 10000, past the training seeds)")
    evaluate.add_argument("--seeds", type=seed_list, default=None, metavar="A-B",
                          help="the trial seeds as demo spells them (N or A-B): the same as "
                               "--seed0 A --trials B-A+1")
    evaluate.add_argument("--duration", type=_seconds, default=None,
                          help="seconds per trial after homing (default: 40)")
    evaluate.add_argument("--max-target-lead", type=_metres, default=DEFAULT_MAX_TARGET_LEAD,
                          metavar="M",
                          help="bound how far the commanded gripper pose may lead the "
                               "measured one, in metres (scenario max_target_lead; default "
                               f"{DEFAULT_MAX_TARGET_LEAD}; 0: unbounded)")
    evaluate.add_argument("--plot", nargs="+", metavar="JSON",
                          help="only combine these results files into one plot and table")
    evaluate.add_argument("--set", action="append", metavar="FIELD=VALUE",
                          help="how the policy acts (repeatable): action_horizon (steps "
                               "executed per chunk), inference_steps (DDIM steps), "
                               "sample_seed (seeds a Diffusion Policy's rollout noise), "
                               "rollout_noise (policy, scene or zero: one draw for every "
                               "trial, each scene its own, or none), noise_scale (0-1: "
                               "the initial noise's scale, a sampling temperature) or "
                               "rnn_memory (reset or window: how an LSTM remembers) or "
                               "gmm_action (most_likely or mixture_mean: the GMM's point "
                               "acted on), e.g. "
                               "inference_steps=3; the trials run a copy of the checkpoint")
    evaluate.add_argument("--seen-scenes", action="store_true",
                          help="allow scene seeds the checkpoint was trained or selected on "
                               "(a diagnostic: success on its own training scenes, e.g. "
                               "--seeds 0-49); the results file lists them")
    evaluate.add_argument("--overwrite", action="store_true",
                          help="start OUT/<method>.json afresh; without it, a results file "
                               "of another checkpoint, --duration, --seed0, --set, "
                               "--max-target-lead or trial set is refused")
    evaluate.set_defaults(func=cmd_evaluate)
    export = verbs.add_parser(
        "export", help="a dataset in LeRobot's v3.0 layout, or for robomimic's image path",
        description="--format lerobot writes OUT/ in the LeRobot v3.0 layout (parquet frames, "
                    "one H.264 video per camera, meta/info.json, stats, tasks, episodes); "
                    "--format robomimic writes the HDF5 file OUT with 3-channel copies of "
                    "the images (obs/left_rgb, obs/right_rgb).")
    export.add_argument("data", help="dataset, e.g. data/lid.hdf5")
    export.add_argument("--format", required=True, choices=("lerobot", "robomimic"))
    export.add_argument("--out", required=True, help="folder (lerobot) or file (robomimic)")
    export.add_argument("--overwrite", action="store_true",
                        help="replace what OUT already holds")
    export.set_defaults(func=cmd_export)

    experiment = verbs.add_parser(
        "experiment", help="a whole study from a grid file: collect, train, select, evaluate",
        description="Runs every unit of GRID (configs/experiments/*.yaml) not yet done in "
                    "OUT: the datasets, one training run per method, task and training "
                    "seed, checkpoint selection by validation rollouts, and the evaluation "
                    "trials. Units are named by a hash of their inputs, so a rerun skips "
                    "what is done and a killed run resumes. Writes OUT/results.csv (one row "
                    "per trial), OUT/summary.md and OUT/figures/.")
    experiment.add_argument("grid", help="grid file, e.g. configs/experiments/smoke.yaml")
    experiment.add_argument("--out", required=True, help="experiment folder")
    experiment.add_argument("--backend", default="local", choices=BACKENDS,
                            help="local worker processes (default) or a Ray cluster")
    experiment.add_argument("--ray-address", default=None, metavar="ADDR",
                            help="an existing Ray cluster (HOST:PORT or auto); default with "
                                 "--backend ray: a local one of --workers CPUs")
    experiment.add_argument("--workers", type=_int_at_least(1), default=None,
                            help="jobs at a time (local default 1; Ray: the cluster's CPUs)")
    experiment.add_argument("--methods", help="only these methods of the grid (a,b)")
    experiment.add_argument("--tasks", help="only these tasks of the grid (a,b)")
    experiment.add_argument("--train-seeds", help="only these training seeds (0,1)")
    experiment.add_argument("--trials", type=_int_at_least(1), default=None,
                            help="only the first N evaluation scene seeds of the grid's")
    experiment.add_argument("--embodiments", help="only these evaluated robots (a,b)")
    experiment.add_argument("--seed0", type=_int_at_least(0), default=None, metavar="N",
                            help="evaluate on the scene seeds from N instead of the grid's "
                                 "(e.g. development seeds 20000 on which to compare recipes; "
                                 "never a training or selection seed)")
    experiment.set_defaults(func=cmd_experiment)
    for sub in verbs.choices.values():  # -v also after the verb
        sub.add_argument("-v", "--verbose", action="store_true", default=argparse.SUPPRESS,
                         help="log debug messages")
    return parser


def _terminated(signum: int, frame: object) -> NoReturn:
    """SIGTERM (``kill``, a job scheduler) stops a command as Ctrl-C does: its ``finally``
    blocks run, so worker processes are terminated with it rather than left training on."""
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``legato-drake`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.INFO,
                        format="%(levelname)s %(name)s: %(message)s", stream=sys.stderr)
    main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _terminated) if main_thread else None
    try:
        try:
            code = args.func(args)
        except BaseException:
            _settle_set_aside(args, succeeded=False)
            raise
        _settle_set_aside(args, succeeded=True)
        return code
    except KeyboardInterrupt:
        parser.exit(EXIT_INTERRUPTED, "legato-drake: interrupted\n")
    except (LegatoError, argparse.ArgumentTypeError, OSError) as e:
        if isinstance(e, OSError):  # not one of ours: its origin may matter (with -v)
            log.debug("the error's traceback:", exc_info=True)
        parser.exit(EXIT_BAD_INPUT, f"legato-drake: error: {one_line(e)}\n")
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":
    sys.exit(main())
