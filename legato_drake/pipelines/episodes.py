"""Independent episodes, each with an optional Meshcat replay (what ``demo`` runs)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from legato_drake.episode import run_episode
from legato_drake.executor import Executor, run_jobs
from legato_drake.scenario import Scenario


@dataclass(frozen=True)
class EpisodeJob:
    """One episode: its scenario and where its HTML replay goes (None: no replay)."""

    scenario: Scenario
    html: Path | None = None


def run_episode_job(job: EpisodeJob) -> dict:
    """Runs one episode (in a worker process, or here); its result as a dict with ``html``."""
    result = run_episode(job.scenario, html=job.html)
    return {**result.to_dict(), "html": str(job.html) if job.html else None}


def run_episodes(jobs: Sequence[EpisodeJob], workers: int = 1, desc: str = "episodes",
                 executor: Executor | None = None) -> list[dict]:
    """The results of ``jobs``, in order, in ``workers`` processes (or on ``executor``),
    with a progress bar."""
    return run_jobs(run_episode_job, jobs, workers, executor, desc, "episode")
