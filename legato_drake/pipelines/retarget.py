"""The retargeting benchmark: Abstract demonstrations replayed open-loop on every robot.

For each seed, the scripted demonstrator runs on the Abstract embodiment and its commanded
gripper trajectory (one pose and grasp per 10 Hz step) is kept. Each embodiment then replays
exactly that trajectory, open-loop, in the same seeded scene: what differs is only how well
its whole-body IK and PD realise the gripper motion. Reported per episode: gripper tracking
error, the smallest joint-limit margin, IK solve times, speed and task success (the table:
``legato_drake.summary.retarget_rows``).
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from legato_drake.diagram import build_diagram
from legato_drake.episode import simulate
from legato_drake.executor import Executor, run_jobs
from legato_drake.files import atomic_write_text
from legato_drake.scenario import Scenario
from legato_drake.systems.scripted_demonstrator import Script

SOURCE = "abstract"


def benchmark_scenario(embodiment: str, task: str, seed: int) -> Scenario:
    """The scene of one benchmark episode (no cameras: the benchmark needs no images)."""
    scenario = Scenario(embodiment=embodiment, task=task, seed=seed)
    scenario.camera.enabled = False
    return scenario


@dataclass(frozen=True)
class RecordJob:
    """Record the scripted demonstrator's commanded trajectory in ``scenario``."""

    scenario: Scenario


@dataclass(frozen=True)
class ReplayJob:
    """Replay ``script`` open-loop in ``scenario`` (another embodiment, the same scene)."""

    scenario: Scenario
    script: Script


def run_record_job(job: RecordJob) -> Script:
    """The commanded gripper trajectory of the scripted demonstrator in ``job.scenario``."""
    built = build_diagram(job.scenario)
    simulator, _ = simulate(built)
    script = built.controller.script(built.controller.GetMyContextFromRoot(
        simulator.get_context()))
    assert script is not None
    return script


def run_replay_job(job: ReplayJob) -> dict:
    """Replays ``job.script`` open-loop; returns one result row."""
    scenario = job.scenario
    built = build_diagram(scenario, script=job.script)
    built.ik.solve_times = []
    _, result = simulate(built)
    times = 1e3 * np.array(built.ik.solve_times)
    return dict(embodiment=scenario.embodiment, task=scenario.task, seed=scenario.seed,
                success=result.success, reason=result.reason, rms_mm=result.tracking.rms_mm,
                max_mm=result.tracking.max_mm, rms_deg=result.tracking.rms_deg,
                max_deg=result.tracking.max_deg,
                min_limit_margin=result.tracking.min_limit_margin,
                max_foot_drift_mm=result.tracking.max_foot_drift_mm,
                ik_median_ms=float(np.median(times)), ik_p95_ms=float(np.percentile(times, 95)),
                real_time_factor=result.real_time_factor)


def record_script(task: str, seed: int, source: str = SOURCE) -> Script:
    """The commanded gripper trajectory of the scripted demonstrator on ``source``."""
    return run_record_job(RecordJob(benchmark_scenario(source, task, seed)))


def replay(embodiment: str, task: str, seed: int, script: Script) -> dict:
    """Replays ``script`` open-loop on ``embodiment``; returns one result row."""
    return run_replay_job(ReplayJob(benchmark_scenario(embodiment, task, seed), script))


def run_benchmark(embodiments: Iterable[str], tasks: Iterable[str], seeds: Iterable[int],
                  workers: int = 1, executor: Executor | None = None) -> list[dict]:
    """Records Abstract trajectories and replays them on every embodiment (in ``workers``
    processes, or on ``executor``); returns the rows."""
    tasks, seeds, embodiments = list(tasks), list(seeds), list(embodiments)
    records = [RecordJob(benchmark_scenario(SOURCE, t, s)) for t in tasks for s in seeds]
    recorded = run_jobs(run_record_job, records, workers, executor, "record", "episode")
    scripts = {(job.scenario.task, job.scenario.seed): script
               for job, script in zip(records, recorded, strict=True)}
    replays = [ReplayJob(benchmark_scenario(e, t, s), scripts[t, s])
               for e in embodiments for t in tasks for s in seeds]
    return run_jobs(run_replay_job, replays, workers, executor, "replay", "episode")


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
