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

- ``RayExecutor``: jobs as Ray tasks on a Ray cluster (``pip install legato-drake[ray]``):
  a local one started for this run, or an existing one at ``address`` (``ray start
  --head``). Each job asks for the resources its ``resources`` attribute names (default one
  CPU); a task whose worker dies is retried (``max_retries``), so a lost worker costs only its
  job. Jobs and results travel by pickling, so nodes need only the installed package (jobs
  that need files carry them: ``Blob``).

Three ways to run jobs, all on ``stream``:

- ``map(function, jobs)``: results in job order (``demo``, ``retarget-benchmark``; with a
  progress bar: ``run_jobs``);
- ``as_completed(function, jobs)``: results as jobs finish (``evaluate``, which saves each);
- ``stream(function, next_job)``: jobs chosen one at a time while others run (``collect``,
  which never starts an episode that may turn out unnecessary).
"""

from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import hashlib
import logging
import multiprocessing
import os
import tempfile
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Generic, TypeVar

from legato_drake.errors import ConfigError
from legato_drake.files import atomic_write_bytes
from legato_drake.progress import progress_bar

Job = TypeVar("Job")
Result = TypeVar("Result")


class Executor(ABC):
    """Runs ``function(job)`` for many jobs, at most ``workers`` at a time."""

    workers: int = 1
    shares_files: bool = True
    """Whether every job runs on this machine, so that a job may keep files in the driver's
    folders (a training's checkpoints, to resume from after a kill)."""

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


class RayExecutor(Executor):
    """Jobs as Ray tasks: on the cluster at ``address`` (``"auto"``, ``"HOST:PORT"``), or on a
    local one started for this executor (``address=None``, ``workers`` CPUs). At most
    ``workers`` jobs are in flight (default: the cluster's CPUs); each asks for
    ``job.resources`` (a dict such as ``{"num_cpus": 1, "num_gpus": 1}``; default one CPU).
    A task whose worker process dies is run again, up to ``max_retries`` times."""

    def __init__(self, address: str | None = None, workers: int | None = None,
                 max_retries: int = 3):
        try:
            import ray
        except ImportError:
            raise ConfigError("--backend ray: Ray is not installed (pip install "
                              "'legato-drake[ray]')") from None
        os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")  # no network calls
        self.shares_files = address is None or \
            address.split(":")[0] in ("127.0.0.1", "localhost")
        if self.shares_files:
            # A cluster on this machine: keep every Ray socket on the loopback interface.
            os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
        if address is None:
            # Ray lowers its workers' priority (nice 15) by default; on a machine shared
            # with other work that starves the trials, which are the work here.
            os.environ.setdefault("RAY_worker_niceness", "0")
        if not ray.is_initialized():
            options = dict(log_to_driver=False, logging_level=logging.WARNING,
                           include_dashboard=False, configure_logging=True)
            try:
                if address is None:
                    ray.init(num_cpus=workers, **options)
                else:
                    ray.init(address=address, **options)
            except (ConnectionError, RuntimeError, ValueError) as e:
                if address is None:
                    raise ConfigError(f"--backend ray: cannot start a local Ray cluster: "
                                      f"{e}") from None
                raise ConfigError(f"--ray-address {address}: cannot connect to a Ray "
                                  f"cluster ({e}); a cluster with token authentication "
                                  "needs RAY_AUTH_MODE=token here too") from None
        self._ray = ray
        self._refs: dict[str, object] = {}  # Blob hash -> its bytes in the object store
        self.max_retries = max_retries
        cpus = int(ray.cluster_resources().get("CPU", 1))
        self.workers = workers or max(cpus, 1)

    def _shared(self, job: Job) -> Job:
        """``job`` with each of its ``Blob`` fields put into Ray's object store once (by
        hash) and passed by reference, so a checkpoint that a thousand trials need travels
        once per node, not once per trial."""
        if not dataclasses.is_dataclass(job):
            return job
        changes = {}
        for f in dataclasses.fields(job):
            value = getattr(job, f.name)
            if isinstance(value, Blob):
                if value.sha256 not in self._refs:
                    self._refs[value.sha256] = self._ray.put(value.data)
                changes[f.name] = SharedBlob(value.name, value.sha256,
                                             self._refs[value.sha256])
        return dataclasses.replace(job, **changes) if changes else job

    @property
    def gpus(self) -> int:
        """GPUs in the cluster (training jobs ask for one where there are any)."""
        return int(self._ray.cluster_resources().get("GPU", 0))

    def stream(self, function: Callable[[Job], Result],
               next_job: Callable[[int], Job | None]) -> Iterator[Result]:
        ray = self._ray
        remote = ray.remote(max_retries=self.max_retries)(_apply)  # any picklable callable
        inner = getattr(function, "function", function)  # Executor.map's _Indexed wraps it
        name = getattr(inner, "__name__", type(inner).__name__)  # the tasks' name in Ray
        in_flight: list = []  # object refs, in the order they were started
        completed = False
        try:
            while True:
                while len(in_flight) < self.workers and \
                        (job := next_job(len(in_flight))) is not None:
                    resources = dict(getattr(job, "resources", None) or {"num_cpus": 1})
                    in_flight.append(remote.options(name=name, **resources).remote(
                        function, self._shared(job)))
                if not in_flight:
                    completed = True
                    return
                done, _ = ray.wait(in_flight, num_returns=1)
                for ref in done:
                    in_flight.remove(ref)
                    yield ray.get(ref)
        finally:
            if not completed:
                for ref in in_flight:
                    ray.cancel(ref, force=True)


@dataclass(frozen=True, eq=False)
class Blob:
    """A file that travels with a job (a dataset, a checkpoint): its name, SHA-256 and bytes.
    ``path()`` writes it once per worker machine into a cache folder named by its hash and
    returns where it is, so a job runs the same on a node that shares no files."""

    name: str
    sha256: str
    data: bytes

    @classmethod
    def of(cls, path: str | Path) -> Blob:
        """The blob of a file."""
        data = Path(path).read_bytes()
        return cls(Path(path).name, hashlib.sha256(data).hexdigest(), data)

    def path(self) -> Path:
        """The file on this machine (written on first use; atomic, so workers may race)."""
        return _cached(self.sha256, self.name, lambda: self.data)


@dataclass(frozen=True, eq=False)
class SharedBlob:
    """A ``Blob`` whose bytes are in Ray's object store (``RayExecutor`` passes these)."""

    name: str
    sha256: str
    ref: object

    def path(self) -> Path:
        """The file on this machine (fetched from the object store on first use)."""
        def fetch() -> bytes:
            import ray

            return ray.get(self.ref)

        return _cached(self.sha256, self.name, fetch)


def _cached(sha256: str, name: str, data: Callable[[], bytes]) -> Path:
    """``TMP/legato_drake_blobs/<sha256>/<name>``, written from ``data()`` if absent."""
    target = Path(tempfile.gettempdir()) / "legato_drake_blobs" / sha256 / name
    if not target.is_file():
        atomic_write_bytes(target, data())
    return target


def _apply(function: Callable[[Job], Result], job: Job) -> Result:
    """``function(job)`` (what a Ray task runs: ``ray.remote`` takes functions, not the
    callable objects that ``Executor.map`` wraps)."""
    return function(job)


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


BACKENDS = ("local", "ray")


def make_backend(backend: str = "local", workers: int | None = None,
                 address: str | None = None) -> Executor:
    """The executor of ``--backend local|ray [--workers N] [--ray-address ADDR]``: the local
    process pool (``workers`` processes, default 1: serial), or Ray (a local cluster of
    ``workers`` CPUs, or the cluster at ``address``)."""
    if backend not in BACKENDS:
        raise ConfigError(f"--backend: unknown {backend!r}; valid values: {', '.join(BACKENDS)}")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int)
                                or workers < 1):
        raise ConfigError(f"--workers must be an integer >= 1, got {workers!r}")
    if backend == "ray":
        return RayExecutor(address, workers)
    if address is not None:
        raise ConfigError("--ray-address: only with --backend ray")
    return make_executor(workers or 1)



def run_jobs(function: Callable[[Job], Result], jobs: Sequence[Job], workers: int = 1,
             executor: Executor | None = None, desc: str = "jobs", unit: str = "job",
             progress: bool | None = None) -> list[Result]:
    """``[function(job) for job in jobs]``, in order, through ``executor`` (default:
    ``make_executor(workers, len(jobs))``), with a progress bar (``progress_bar``)."""
    executor = executor or make_executor(workers, len(jobs))
    return list(progress_bar(executor.map(function, jobs), progress=progress,
                             total=len(jobs), desc=desc, unit=unit))
