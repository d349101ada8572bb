"""The retargeting benchmark: Abstract demonstrations replayed open-loop on every robot.

For each seed, the scripted demonstrator runs on the Abstract embodiment and its commanded
gripper trajectory (one pose and grasp per 10 Hz step) is kept. Each embodiment then replays
exactly that trajectory, open-loop, in the same seeded scene: what differs is only how well
its whole-body IK and PD realise the gripper motion. Reported per episode: gripper tracking
error, the smallest joint-limit margin, IK solve times, speed and task success.
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from legato_drake.diagram import build_diagram
from legato_drake.episode import simulate
from legato_drake.files import atomic_write_text
from legato_drake.parallel import parallel_map
from legato_drake.scenario import Scenario
from legato_drake.stats import wilson_interval
from legato_drake.systems.scripted_demonstrator import Script

SOURCE = "abstract"


def record_script(task: str, seed: int, source: str = SOURCE) -> Script:
    """The commanded gripper trajectory of the scripted demonstrator on ``source``."""
    scenario = Scenario(embodiment=source, task=task, seed=seed)
    scenario.camera.enabled = False
    built = build_diagram(scenario.validate())
    simulator, _ = simulate(built)
    script = built.controller.script(built.controller.GetMyContextFromRoot(
        simulator.get_context()))
    assert script is not None
    return script


def replay(embodiment: str, task: str, seed: int, script: Script) -> dict:
    """Replays ``script`` open-loop on ``embodiment``; returns one result row."""
    scenario = Scenario(embodiment=embodiment, task=task, seed=seed)
    scenario.camera.enabled = False
    built = build_diagram(scenario.validate(), script=script)
    built.ik.solve_times = []
    _, result = simulate(built)
    times = 1e3 * np.array(built.ik.solve_times)
    return dict(embodiment=embodiment, task=task, seed=seed, success=result.success,
                reason=result.reason, rms_mm=result.tracking.rms_mm,
                max_mm=result.tracking.max_mm, rms_deg=result.tracking.rms_deg,
                max_deg=result.tracking.max_deg,
                min_limit_margin=result.tracking.min_limit_margin,
                max_foot_drift_mm=result.tracking.max_foot_drift_mm,
                ik_median_ms=float(np.median(times)), ik_p95_ms=float(np.percentile(times, 95)),
                real_time_factor=result.real_time_factor)


def _record_job(job: tuple[str, int]) -> tuple[str, int, Script]:
    task, seed = job
    return task, seed, record_script(task, seed)


def _replay_job(job: tuple[str, str, int, Script]) -> dict:
    return replay(*job)


def run_benchmark(embodiments: Iterable[str], tasks: Iterable[str], seeds: Iterable[int],
                  workers: int = 1) -> list[dict]:
    """Records Abstract trajectories and replays them on every embodiment; returns rows."""
    tasks, seeds, embodiments = list(tasks), list(seeds), list(embodiments)
    scripts = {(t, s): script for t, s, script in
               parallel_map(_record_job, [(t, s) for t in tasks for s in seeds], workers, "record")}
    jobs = [(e, t, s, scripts[t, s]) for e in embodiments for t in tasks for s in seeds]
    return parallel_map(_replay_job, jobs, workers, "replay")


def summarize(rows: list[dict]) -> list[list]:
    """One row per embodiment and task: success with its 95 % interval and the worst errors."""
    out = []
    for key in dict.fromkeys((r["embodiment"], r["task"]) for r in rows):
        group = [r for r in rows if (r["embodiment"], r["task"]) == key]
        k = sum(r["success"] for r in group)
        low, high = wilson_interval(k, len(group))
        out.append([*key, f"{k}/{len(group)}", f"{100 * low:.0f}-{100 * high:.0f}",
                    float(np.mean([r["rms_mm"] for r in group])),
                    max(r["max_mm"] for r in group),
                    float(np.mean([r["rms_deg"] for r in group])),
                    max(r["max_deg"] for r in group),
                    min(r["min_limit_margin"] for r in group),
                    max(r["max_foot_drift_mm"] for r in group),
                    float(np.median([r["ik_median_ms"] for r in group])),
                    max(r["ik_p95_ms"] for r in group),
                    float(np.median([r["real_time_factor"] for r in group]))])
    return out


SUMMARY_HEADERS = ["embodiment", "task", "success", "95% CI %", "rms mm", "max mm",
                   "rms deg", "max deg", "min limit margin", "max foot drift mm",
                   "ik median ms", "ik p95 ms",
                   "x real time"]


def write_results(rows: list[dict], out: Path) -> tuple[Path, Path]:
    """Writes every row to ``out/retarget.csv`` and ``out/retarget.json`` (atomically)."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=list(rows[0]))
    writer.writeheader()
    writer.writerows(rows)
    csv_path, json_path = out / "retarget.csv", out / "retarget.json"
    atomic_write_text(csv_path, buffer.getvalue())
    atomic_write_text(json_path, json.dumps(rows, indent=1))
    return csv_path, json_path
