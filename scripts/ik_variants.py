"""The retargeting benchmark's replays on one robot with some of its IK settings changed: a
quick way to measure what an ``IkSettings`` field does to tracking before changing a robot.

    python scripts/ik_variants.py --embodiment google --tasks lid,cup,ladle --seeds 0-4 \\
        --set max_joint_speed=3.0 [--set posture_gain=0.5 ...]

It records the scripted demonstrator's gripper trajectory on Abstract once per task and seed
(as ``legato-drake retarget-benchmark`` does), replays each on the robot with its registered
settings and then with the ``--set`` overrides (values read as YAML), and prints per task the
successes, the RMS and worst tracking error of every seed (mm) and the smallest joint-limit
margin, one line per setting. One process, one core.
"""

from __future__ import annotations

import argparse
import dataclasses
import logging

import yaml

import legato_drake.embodiments as embodiments
from legato_drake.cli import seed_list
from legato_drake.embodiments.from_file import parse_ik_settings
from legato_drake.errors import ConfigError
from legato_drake.pipelines import retarget
from legato_drake.tasks import TASKS


def overrides(parser: argparse.ArgumentParser, items: list[str]) -> dict:
    """``FIELD=VALUE`` items (values read as YAML) as ``IkSettings`` fields, checked as a robot
    file's ``ik`` mapping is (``parse_ik_settings``); a bad one is a parser error naming it."""
    raw = {}
    for item in items:
        name, sep, text = item.partition("=")
        if not sep:
            parser.error(f"--set {item!r}: expected FIELD=VALUE")
        raw[name] = yaml.safe_load(text)
    try:
        parsed = parse_ik_settings(raw)
    except ConfigError as e:
        parser.error(f"--set: {e}")
    return {name: getattr(parsed, name) for name in raw}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--embodiment", required=True,
                        choices=sorted(set(embodiments.EMBODIMENTS) - {"abstract"}))
    parser.add_argument("--tasks", default="lid", help="comma-separated task names (lid)")
    parser.add_argument("--seeds", type=seed_list, default="0-4", help="N, A-B or A,B,C (0-4)")
    parser.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                        help="an IkSettings field to change (repeatable)")
    args = parser.parse_args()
    tasks = args.tasks.split(",")
    for task in tasks:
        if task not in TASKS:
            parser.error(f"--tasks: unknown task {task!r}; choose from {', '.join(TASKS)}")
    changed = overrides(parser, args.set)
    logging.basicConfig(level=logging.WARNING)
    registered = embodiments.EMBODIMENTS[args.embodiment]
    scripts = {(t, s): retarget.record_script(t, s) for t in tasks for s in args.seeds}
    label = " ".join(args.set) or "(nothing changed)"
    try:
        for name, settings in (("registered", registered.ik),
                               (label, dataclasses.replace(registered.ik, **changed))):
            # replay() resolves the robot by name: register the variant under it for the run.
            embodiments.EMBODIMENTS[args.embodiment] = dataclasses.replace(registered,
                                                                           ik=settings)
            replay_tasks(args.embodiment, tasks, args.seeds, scripts, name)
    finally:
        embodiments.EMBODIMENTS[args.embodiment] = registered


def replay_tasks(embodiment: str, tasks: list[str], seeds: list[int], scripts: dict,
                 name: str) -> None:
    """Replays every task's scripts on ``embodiment`` as registered now; a line per task."""
    for task in tasks:
        rows = [retarget.replay(embodiment, task, s, scripts[task, s]) for s in seeds]
        rms = " ".join(f"{r['rms_mm']:.2f}" for r in rows)
        worst = " ".join(f"{r['max_mm']:.0f}" for r in rows)
        print(f"{name}: {task} {sum(r['success'] for r in rows)}/{len(rows)} successes; "
              f"RMS mm {rms} (mean {sum(r['rms_mm'] for r in rows) / len(rows):.2f}); "
              f"worst mm {worst}; smallest limit margin "
              f"{min(r['min_limit_margin'] for r in rows):.3f}", flush=True)

if __name__ == "__main__":
    main()
