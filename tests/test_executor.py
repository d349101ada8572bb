"""The one executor: the serial and the process backend give the same results, in order or as
completed; ``stream`` never starts a job that ``next_job`` holds back; errors propagate."""

from __future__ import annotations

import math
import os
import pickle
import time
from dataclasses import dataclass

import pytest

from legato_drake.errors import ConfigError
from legato_drake.executor import (
    Blob,
    Executor,
    ProcessExecutor,
    SerialExecutor,
    make_backend,
    make_executor,
    run_jobs,
)


@dataclass(frozen=True)
class SleepJob:
    """A picklable job record: sleep, then return the value (and the worker's pid)."""

    value: int
    seconds: float = 0.0


def run_sleep_job(job: SleepJob) -> tuple[int, int]:
    time.sleep(job.seconds)
    if job.value < 0:
        raise ValueError(f"negative job {job.value}")
    return job.value, os.getpid()


BACKENDS = [SerialExecutor(), ProcessExecutor(2)]


def test_make_executor_picks_the_backend():
    assert isinstance(make_executor(1), SerialExecutor)
    assert isinstance(make_executor(3, jobs=1), SerialExecutor)  # one job: no processes
    pool = make_executor(4, jobs=2)
    assert isinstance(pool, ProcessExecutor) and pool.workers == 2
    for bad in (0, -1, True, 1.5):
        with pytest.raises(ValueError, match="workers"):
            make_executor(bad)


@pytest.mark.parametrize("executor", BACKENDS, ids=["serial", "processes"])
def test_map_is_in_order_and_as_completed_yields_every_result(executor: Executor):
    slow = 2.0 if isinstance(executor, ProcessExecutor) else 0.0
    jobs = [SleepJob(i, slow if i == 0 else 0.0) for i in range(5)]
    results = list(executor.map(run_sleep_job, jobs))
    assert [value for value, _ in results] == [0, 1, 2, 3, 4]
    pids = {pid for _, pid in results}
    assert (pids == {os.getpid()}) == isinstance(executor, SerialExecutor)
    completed = [value for value, _ in executor.as_completed(run_sleep_job, jobs)]
    assert sorted(completed) == [0, 1, 2, 3, 4]
    if isinstance(executor, ProcessExecutor):
        assert completed[-1] == 0  # the slow first job finished last
    assert run_jobs(math.sqrt, [4.0, 9.0], executor=executor, progress=False) == [2.0, 3.0]


@pytest.mark.parametrize("executor", BACKENDS, ids=["serial", "processes"])
def test_stream_asks_for_jobs_with_what_is_in_flight(executor: Executor):
    """``next_job`` may hold back (None) while jobs run; the stream ends only when nothing
    runs and it has nothing more."""
    pending = list(range(6))
    asked, done = [], []

    def next_job(in_flight: int) -> SleepJob | None:
        asked.append(in_flight)
        if not pending or len(done) + in_flight >= 4:  # wait: those in flight may be enough
            return None
        return SleepJob(pending.pop(0))

    for value, _ in executor.stream(run_sleep_job, next_job):
        done.append(value)
    assert sorted(done) == [0, 1, 2, 3] and pending == [4, 5]
    assert max(asked) < executor.workers  # asked only when a worker is free


@pytest.mark.parametrize("executor", BACKENDS, ids=["serial", "processes"])
def test_a_job_that_raises_raises_here(executor: Executor):
    with pytest.raises(ValueError, match="negative job -1"):
        list(executor.map(run_sleep_job, [SleepJob(1), SleepJob(-1), SleepJob(2)]))


def test_stopping_early_terminates_the_jobs_in_flight():
    start = time.monotonic()
    results = ProcessExecutor(2).as_completed(
        run_sleep_job, [SleepJob(1), SleepJob(2, 60.0), SleepJob(3, 60.0)])
    assert next(results)[0] == 1
    results.close()  # what an error or Ctrl-C in the caller does
    assert time.monotonic() - start < 30.0


def test_make_backend_checks_its_flags():
    assert isinstance(make_backend("local"), SerialExecutor)
    assert make_backend("local", 2).workers == 2
    with pytest.raises(ConfigError, match="--backend: unknown 'slurm'; valid values: local, ray"):
        make_backend("slurm")
    with pytest.raises(ConfigError, match="--workers must be an integer >= 1, got 0"):
        make_backend("local", 0)
    with pytest.raises(ConfigError, match="--ray-address: only with --backend ray"):
        make_backend("local", 1, "127.0.0.1:6379")


def read_blob(blob: Blob) -> bytes:
    """In a worker: the bytes of the file the blob puts there."""
    return blob.path().read_bytes()


def test_a_blob_travels_with_its_job(tmp_path):
    """A worker that shares no files gets the blob's file, written once under its hash."""
    source = tmp_path / "policy.pt"
    source.write_bytes(b"weights" * 1000)
    blob = pickle.loads(pickle.dumps(Blob.of(source)))
    assert blob.path().name == "policy.pt" and blob.sha256 in str(blob.path())
    source.unlink()
    blob.path().unlink()  # the workers write it again from the bytes they were sent
    assert list(ProcessExecutor(2).map(read_blob, [blob, blob])) == [b"weights" * 1000] * 2
