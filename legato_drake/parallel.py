"""Running independent episodes in worker processes, with a progress bar (log lines when
stderr is not a terminal)."""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable, Sequence
from typing import TypeVar

from legato_drake.progress import progress_bar

Job = TypeVar("Job")
Result = TypeVar("Result")


def parallel_map(function: Callable[[Job], Result], jobs: Sequence[Job], workers: int = 1,
                 desc: str = "episodes") -> list[Result]:
    """``[function(job) for job in jobs]`` in order, in ``workers`` spawned processes when
    there are several (each episode builds its own Drake diagram, so nothing is shared)."""
    progress = dict(total=len(jobs), desc=desc, unit="episode")
    if workers > 1 and len(jobs) > 1:
        with multiprocessing.get_context("spawn").Pool(workers) as pool:
            return list(progress_bar(pool.imap(function, jobs), **progress))
    return [function(job) for job in progress_bar(jobs, **progress)]
