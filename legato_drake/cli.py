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


def cmd_demo(args: argparse.Namespace) -> int:
    """Runs the scripted demonstrator per embodiment and task, writes replays, prints a table."""
    from tqdm import tqdm

    from legato_drake.embodiments import EMBODIMENTS
    from legato_drake.episode import run_episode
    from legato_drake.report import format_table
    from legato_drake.scenario import Scenario, load_scenario
    from legato_drake.tasks import TASKS

    base = load_scenario(args.scenario) if args.scenario else Scenario()
    embodiments = _names(args.embodiment, EMBODIMENTS, "embodiment")
    tasks = _names(args.task, TASKS, "task")
    if args.no_camera:
        base.camera.enabled = False
    out = Path(args.out)
    rows = []
    jobs = [(e, t) for e in embodiments for t in tasks]
    for embodiment, task in tqdm(jobs, desc="demo", unit="episode", disable=None):
        scenario = base.replace(embodiment=embodiment, task=task,
                                seed=base.seed if args.seed is None else args.seed)
        html = None if args.no_replay else out / f"{embodiment}-{task}-seed{scenario.seed}.html"
        result = run_episode(scenario, html=html)
        rows.append([embodiment, task, scenario.seed, result.success,
                     result.reason or "-", result.tracking.rms_mm, result.tracking.rms_deg,
                     result.sim_time, result.wall_time, result.real_time_factor])
        if html is not None:
            log.info("wrote %s", html)
    print(format_table(["embodiment", "task", "seed", "success", "why not", "rms mm",
                        "rms deg", "sim s", "wall s", "x real time"], rows))
    return 0 if all(r[3] for r in rows) else 1


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
    demo.add_argument("--embodiment", default="abstract,panda",
                      help="embodiment name, comma-separated names, or 'all' "
                           "(default: abstract,panda)")
    demo.add_argument("--task", default="lid", help="task name, names, or 'all' (default: lid)")
    demo.add_argument("--seed", type=int, default=None, help="episode seed (default: 0)")
    demo.add_argument("--out", default="replays", help="folder for the HTML replays")
    demo.add_argument("--scenario", help="scenario YAML to start from (fields: see README)")
    demo.add_argument("--no-camera", action="store_true", help="do not render the cameras")
    demo.add_argument("--no-replay", action="store_true", help="do not write HTML replays")
    demo.set_defaults(func=cmd_demo)
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
