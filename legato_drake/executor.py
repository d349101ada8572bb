"""Running many independent jobs: in this process, or in worker processes.

Every many-episode command (``demo --workers``, ``retarget-benchmark``, ``collect``,
``evaluate`` and ``select``) runs through an ``Executor``. A *job* is a typed, picklable record
(a frozen dataclass of the pipeline that runs it, e.g. ``pipelines.collect.CollectJob``: a
scenario and the part file its episode goes to) and a module-level function runs one job and
returns its result (picklable too). Each episode builds its own Drake diagram, so workers
share nothing; a job's result is the same whichever backend ran it.

Backends, behind one interface:

- ``SerialExecutor``: one job at a time, in this process;
- ``ProcessExecutor``: up to ``workers`` jobs at a time in spawned worker processes (a
  ``concurrent.futures.ProcessPoolExecutor``; processes start as jobs need them). This module
  is the only place of the package that creates processes. A worker that dies (Drake can
  abort the process) raises ``BrokenProcessPool`` rather than hanging; when the caller stops
  early (an error, Ctrl-C), the jobs in flight are cancelled and their workers terminated
  (every pipeline writes its results per job, atomically, so a rerun resumes).

A distributed backend (e.g. Ray: ``ray.remote(function).remote(job)`` per job, completions
from ``ray.wait``) goes next to these two: it implements ``stream`` and ``make_executor``
returns it when asked for.

Three ways to run jobs, all on ``stream``:

- ``map(function, jobs)``: results in job order (``demo``, ``retarget-benchmark``; with a
  progress bar: ``run_jobs``);
- ``as_completed(function, jobs)``: results as jobs finish (``evaluate``, which saves each);
- ``stream(function, next_job)``: jobs chosen one at a time while others run (``collect``,
  which never starts an episode that may turn out unnecessary).
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from typing import Generic, TypeVar

from legato_drake.progress import progress_bar

Job = TypeVar("Job")
Result = TypeVar("Result")


class Executor(ABC):
    """Runs ``function(job)`` for many jobs, at most ``workers`` at a time."""

    workers: int = 1

    @abstractmethod
    def stream(self, function: Callable[[Job], Result],
               next_job: Callable[[int], Job | None]) -> Iterator[Result]:
        """Yields ``function(job)`` as each job finishes, for the jobs that ``next_job``
        hands out. Whenever fewer than ``workers`` jobs run, it asks ``next_job(in_flight)``
        for another; None means "none now": it waits for a running job to finish (its result
        is yielded, and may change what ``next_job`` decides) and asks again. The stream ends
        when nothing runs and ``next_job`` returns None. An exception of a job is raised
        here."""

    def as_completed(self, function: Callable[[Job], Result],
                     jobs: Iterable[Job]) -> Iterator[Result]:
        """Yields ``function(job)`` for every job, as the jobs finish."""
        pending = iter(jobs)
        return self.stream(function, lambda in_flight: next(pending, None))

    def map(self, function: Callable[[Job], Result], jobs: Iterable[Job]) -> Iterator[Result]:
        """Yields ``function(job)`` for every job, in the jobs' order."""
        finished: dict[int, Result] = {}
        following = 0
        for index, result in self.as_completed(_Indexed(function), enumerate(jobs)):
            finished[index] = result
            while following in finished:
                yield finished.pop(following)
                following += 1


@dataclass(frozen=True)
class _Indexed(Generic[Job, Result]):
    """``function`` over ``(index, job)`` pairs, returning ``(index, result)`` (picklable
    when ``function`` is)."""

    function: Callable[[Job], Result]

    def __call__(self, item: tuple[int, Job]) -> tuple[int, Result]:
        index, job = item
        return index, self.function(job)


class SerialExecutor(Executor):
    """One job at a time, in this process (what ``--workers 1`` means)."""

    workers = 1

    def stream(self, function: Callable[[Job], Result],
               next_job: Callable[[int], Job | None]) -> Iterator[Result]:
        while (job := next_job(0)) is not None:
            yield function(job)


class ProcessExecutor(Executor):
    """Up to ``workers`` jobs at a time, each in a spawned worker process (a fresh
    interpreter: nothing of this process's state is inherited). ``function``, the jobs and
    their results must be picklable (module-level functions, frozen dataclasses)."""

    def __init__(self, workers: int):
        if workers < 1:
            raise ValueError(f"workers must be at least 1, got {workers}")
        self.workers = workers

    def stream(self, function: Callable[[Job], Result],
               next_job: Callable[[int], Job | None]) -> Iterator[Result]:
        pool = cf.ProcessPoolExecutor(self.workers,
                                      mp_context=multiprocessing.get_context("spawn"))
        in_flight: list[cf.Future] = []  # in the order they were started
        completed = False
        try:
            while True:
                while len(in_flight) < self.workers and \
                        (job := next_job(len(in_flight))) is not None:
                    in_flight.append(pool.submit(function, job))
                if not in_flight:
                    completed = True
                    return
                done, _ = cf.wait(in_flight, return_when=cf.FIRST_COMPLETED)
                for future in [f for f in in_flight if f in done]:
                    in_flight.remove(future)
                    yield future.result()
        finally:
            if completed:
                pool.shutdown(wait=True)
            else:
                _stop(pool)


def _stop(pool: cf.ProcessPoolExecutor) -> None:
    """Cancels what has not started and terminates the workers (whose jobs are lost)."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        if process.is_alive():
            process.terminate()
    for process in processes:
        process.join(timeout=10.0)


def make_executor(workers: int = 1, jobs: int | None = None) -> Executor:
    """The executor for ``--workers N``: serial for one worker (or, when ``jobs`` says how
    many jobs there are, for at most one job), else ``N`` worker processes (never more than
    ``jobs``)."""
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    if jobs is not None:
        workers = min(workers, jobs)
    if workers <= 1:
        return SerialExecutor()
    return ProcessExecutor(workers)



def run_jobs(function: Callable[[Job], Result], jobs: Sequence[Job], workers: int = 1,
             executor: Executor | None = None, desc: str = "jobs", unit: str = "job",
             progress: bool | None = None) -> list[Result]:
    """``[function(job) for job in jobs]``, in order, through ``executor`` (default:
    ``make_executor(workers, len(jobs))``), with a progress bar (``progress_bar``)."""
    executor = executor or make_executor(workers, len(jobs))
    return list(progress_bar(executor.map(function, jobs), progress=progress,
                             total=len(jobs), desc=desc, unit=unit))
