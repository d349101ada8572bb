"""Collecting a demonstration dataset: episodes in parallel, atomic and resumable.

Each episode (one seed, or one pose-stream file) is a ``CollectJob``, recorded through the
executor (in a worker process with ``workers`` > 1) and written atomically as its own small
HDF5 *part* file into the sibling folder ``<out>.parts/`` (named by its key, e.g.
``seed_000042.hdf5``); failed episodes get a part too, so that they are not retried. When
enough episodes are kept, the parts are merged into ``<out>`` (written atomically too), with a
manifest of every seed tried, kept and failed (and why), and the parts folder is removed.
Restarting an interrupted collection skips the parts already written, so no episode is lost
or duplicated; asking an existing dataset for more episodes extends it.

Which seeds are kept does not depend on the number of workers or on interruptions: seeds are
tried in order from ``seed0`` and the dataset holds the first ``episodes`` successful ones
(or, with ``keep_failures``, the first ``episodes`` seeds).
"""

from __future__ import annotations

import dataclasses
import json
import logging
import shutil
import tempfile
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

import h5py

from legato_drake import conventions
from legato_drake.data.layout import DatasetError, open_dataset, read_json_attr, sorted_demos
from legato_drake.data.pose_stream import find_pose_streams, load_pose_stream
from legato_drake.data.writer import Episode, env_args_for, merge_demos, write_dataset
from legato_drake.diagram import build_diagram
from legato_drake.episode import simulate
from legato_drake.executor import Executor, make_executor
from legato_drake.files import atomic_write_bytes, atomic_write_text
from legato_drake.progress import progress_bar
from legato_drake.scenario import ExpertNoiseConfig, Scenario
from legato_drake.tasks import TASKS

log = logging.getLogger(__name__)

PART_GROUP = "data/demo_0"
CONFIG_KEYS = ("task", "embodiment", "camera", "camera_model", "duration", "source",
               "keep_failures", "expert_noise", "stop_on_success", "demo_version")
"""Collect settings that change what an episode is: a resumed collection must match them."""
CONFIG_DEFAULTS = {"camera_model": "pinhole", "demo_version": 1}
"""What a setting was before collections recorded it (datasets written by older versions)."""
NOISE_DEFAULTS = {"full_speed": conventions.EXPERT_NOISE_FULL_SPEED}
"""The same for the fields of ``expert_noise``."""


def _setting(config: dict, key: str) -> object:
    """A collect setting of ``config`` (a recorded one: its default where it predates it)."""
    value = config.get(key, CONFIG_DEFAULTS.get(key))
    if key == "expert_noise" and isinstance(value, dict):
        return {**NOISE_DEFAULTS, **value}
    return value


def _changed(old: dict, config: dict, keys: tuple[str, ...] = CONFIG_KEYS) -> list[str]:
    """The settings of ``keys`` recorded in ``old`` that ``config`` asks otherwise."""
    return [k for k in keys if _setting(old, k) != config.get(k)]


def _differences(old: dict, config: dict, keys: list[str]) -> str:
    """The settings ``keys`` that differ, as recorded in ``old`` and as asked now."""
    return ", ".join(f"{k}={_setting(old, k)!r}, now {config.get(k)!r}" for k in keys)


@dataclass(frozen=True)
class CollectJob:
    """One episode to record: its part key, its scenario, the part file it is written to,
    extra demo attributes."""

    key: str
    scenario: Scenario
    part: Path
    attrs: dict = field(default_factory=dict)


@dataclass
class CollectReport:
    """What a collection did."""

    out: Path
    requested: int
    kept: list[dict]
    """Outcomes of the episodes in the dataset, in demo order."""
    outcomes: list[dict]
    """Outcomes of every episode tried (this run and earlier ones), by key."""
    wall_time: float

    @property
    def failed(self) -> list[dict]:
        """Outcomes of the episodes that did not succeed."""
        return [o for o in self.outcomes if not o["success"]]


def _keepable(outcome: dict, keep_failures: bool) -> bool:
    """Whether an episode goes into the dataset: successes, and failures that recorded
    samples with ``keep_failures``."""
    return outcome["success"] or (keep_failures and outcome["num_samples"] > 0 and
                                  not outcome.get("restored"))


def seed_key(seed: int) -> str:
    """Part key of a seeded episode."""
    return f"seed_{seed:06d}"


def parts_dir(out: Path) -> Path:
    """The folder of part files of the dataset ``out``."""
    return out.with_name(out.name + ".parts")


def record_episode(scenario: Scenario) -> tuple[dict, Episode]:
    """Simulates one recorded episode of ``scenario``; returns its result (as a dict) and the
    episode's samples."""
    built = build_diagram(scenario, record=True)
    simulator, result = simulate(built)
    recorder = built.recorder
    samples = recorder.log(recorder.GetMyContextFromRoot(simulator.get_context())).to_arrays()
    if "action" not in samples:
        raise DatasetError(f"seed {scenario.seed}: the episode ended before the first sample")
    obs = {key: samples[key] for key in ("tcp_commanded", "tcp_measured", "object", "fingers",
                                         "left_gray", "right_gray") if key in samples}
    attrs = dict(seed=scenario.seed, embodiment=scenario.embodiment, task=scenario.task,
                 controller=scenario.controller, reason=result.reason,
                 scenario=dataclasses.asdict(scenario),
                 success_time=result.success_time if result.success_time is not None
                 else float("nan"),
                 episode_time=result.episode_time, sim_time=result.sim_time,
                 wall_time=result.wall_time, tracking_rms_mm=result.tracking.rms_mm,
                 object_bodies=recorder.object_body_names)
    episode = Episode(actions=samples["action"], obs=obs, success=result.success,
                      states=samples["state"], attrs=attrs)
    return result.to_dict(), episode


def _outcome(job: CollectJob, success: bool, reason: str, samples: int, wall: float) -> dict:
    return dict(key=job.key, seed=job.scenario.seed, success=bool(success), reason=reason,
                num_samples=int(samples), wall_time=round(wall, 3),
                source=job.attrs.get("source", ""))


def run_job(job: CollectJob) -> tuple[dict, bytes]:
    """Records ``job`` (in a worker process, or here) and returns its outcome and the bytes of
    its part file, which the collecting process writes (workers write nothing of the
    dataset, so they may be on another machine). An episode that raises is a failure with
    the error as its reason."""
    start = time.perf_counter()
    try:
        _, episode = record_episode(job.scenario)
    except Exception as e:  # a bad seed must not stop the collection
        log.warning("%s failed with an error: %s", job.key, e)
        outcome = _outcome(job, False, f"error: {type(e).__name__}: {e}", 0,
                           time.perf_counter() - start)
        return outcome, _part_bytes([], outcome)
    episode.attrs.update(job.attrs, key=job.key)
    outcome = _outcome(job, episode.success, str(episode.attrs["reason"]), len(episode),
                       time.perf_counter() - start)
    return outcome, _part_bytes([episode], outcome)


def _part_bytes(episodes: list[Episode], outcome: dict) -> bytes:
    """A part file's bytes (written through a private temporary file)."""
    with tempfile.TemporaryDirectory(prefix="legato_drake_part_") as folder:
        path = Path(folder) / "part.hdf5"
        write_dataset(path, episodes, extra=dict(outcome=outcome))
        return path.read_bytes()


def read_part(path: Path) -> dict | None:
    """The outcome recorded in a part file (None if the file is unreadable or incomplete)."""
    try:
        with h5py.File(path, "r") as f:
            outcome = read_json_attr(f["data"], "outcome")
            if not isinstance(outcome, dict):
                return None
            if (outcome["success"] or outcome["num_samples"]) and \
                    "actions" not in f.get(PART_GROUP, {}) and not outcome.get("restored"):
                return None
            return outcome
    except (OSError, KeyError, ValueError, TypeError):
        return None


def scan_parts(folder: Path) -> dict[str, dict]:
    """Outcomes of the part files in ``folder`` by key; removes leftovers of interrupted
    writes (temporary files) and unreadable parts, which are then recorded again."""
    outcomes = {}
    for path in sorted(folder.glob(".*.tmp")):
        path.unlink(missing_ok=True)
    for path in sorted(folder.glob("*.hdf5")):
        outcome = read_part(path)
        if outcome is None or outcome.get("key") != path.stem:
            log.warning("removing unreadable part %s (it will be recorded again)", path)
            path.unlink(missing_ok=True)
            continue
        outcomes[path.stem] = outcome
    return outcomes


def _check_config(folder: Path, config: dict, out: Path) -> None:
    path = folder / "config.json"
    if path.is_file():
        old = json.loads(path.read_text())
        diff = _changed(old, config)
        if diff:
            raise DatasetError(
                f"{folder} holds episodes collected with other settings "
                f"({_differences(old, config, diff)}); collect into another "
                f"--out than {out} or delete that folder")
    else:
        atomic_write_text(path, json.dumps(config, indent=1))


def _restore_parts(out: Path, folder: Path, config: dict) -> None:
    """Turns an existing dataset back into parts (to extend it with more episodes)."""
    with open_dataset(out) as f:
        old = read_json_attr(f["data"], "config", {})
        diff = _changed(old, config)
        if diff:
            raise DatasetError(
                f"{out} exists and was collected with other settings "
                f"({_differences(old, config, diff)}); choose another --out "
                "or delete it")
        manifest = json.loads(f["meta/manifest"][()]) if "meta/manifest" in f else {}
        folder.mkdir(parents=True, exist_ok=True)
        atomic_write_text(folder / "config.json", json.dumps(config, indent=1))
        in_file = set()
        for name in sorted_demos(f["data"]):
            demo = f["data"][name]
            key = str(demo.attrs.get("key", ""))
            outcome = next((o for o in manifest.get("tried", []) if o["key"] == key), None)
            if not key or outcome is None:
                continue
            in_file.add(key)
            with h5py.File(folder / f".{key}.restore.tmp", "w") as part:
                f.copy(demo, part.require_group("data"), name="demo_0")
                part["data"].attrs["outcome"] = json.dumps(outcome)
            (folder / f".{key}.restore.tmp").replace(folder / f"{key}.hdf5")
        for outcome in manifest.get("tried", []):
            if outcome["key"] not in in_file and not outcome["success"]:
                write_dataset(folder / f"{outcome['key']}.hdf5", [],
                              extra=dict(outcome={**outcome, "restored": True}))


def _seed_jobs(base: Scenario, folder: Path, seed0: int, count: int) -> list[CollectJob]:
    return [CollectJob(seed_key(s), base.replace(seed=s), folder / f"{seed_key(s)}.hdf5")
            for s in range(seed0, seed0 + count)]


def _stream_jobs(base: Scenario, folder: Path, source: Path, seed0: int,
                 episodes: int) -> list[CollectJob]:
    jobs = []
    for i, path in enumerate(find_pose_streams(source)[:episodes]):
        stream = load_pose_stream(path)
        if stream.task and stream.task != base.task:
            raise DatasetError(f"pose stream {path} was recorded for task {stream.task!r}, "
                               f"not {base.task!r}")
        seed = stream.seed if stream.seed is not None else seed0 + i
        scenario = base.replace(controller="replay", pose_stream=str(path.resolve()), seed=seed)
        key = f"stream_{i:04d}_{path.stem}"[:80]
        jobs.append(CollectJob(key, scenario, folder / f"{key}.hdf5", dict(source=path.name)))
    return jobs


def _schedule(jobs: list[CollectJob], outcomes: dict[str, dict], needed: int,
              keep_failures: bool, executor: Executor, bar) -> None:
    """Runs jobs in order until ``needed`` episodes are kept among the first ones tried; as
    many at a time as the executor runs, never speculating past what may still be needed."""
    order = {job.key: i for i, job in enumerate(jobs)}
    pending = deque(job for job in jobs if job.key not in outcomes)

    def next_job(in_flight: int) -> CollectJob | None:
        if not pending:
            return None
        index = order[pending[0].key]
        kept = sum(1 for k, o in outcomes.items()
                   if k in order and order[k] < index and _keepable(o, keep_failures))
        if kept >= needed:
            pending.clear()  # every later job is unnecessary
            return None
        if kept + in_flight >= needed:
            return None  # wait: the episodes in flight may be enough
        return pending.popleft()

    parts = {job.key: job.part for job in jobs}

    def record(outcome: dict, part: bytes) -> None:
        atomic_write_bytes(parts[outcome["key"]], part)
        outcomes[outcome["key"]] = outcome
        if _keepable(outcome, keep_failures):
            bar.update(1)
        bar.set_postfix(tried=len(outcomes),
                        failed=sum(not o["success"] for o in outcomes.values()))

    for outcome, part in executor.stream(run_job, next_job):
        record(outcome, part)


def _up_to_date(out: Path, config: dict) -> dict | None:
    """The manifest of ``out`` if it already holds exactly what ``config`` asks for."""
    try:
        with open_dataset(out) as f:
            old = read_json_attr(f["data"], "config", {})
            manifest = json.loads(f["meta/manifest"][()]) if "meta/manifest" in f else None
    except (DatasetError, KeyError, ValueError, OSError):
        return None
    same = not _changed(old, config, (*CONFIG_KEYS, "seed0"))
    if same and manifest and len(manifest.get("kept", [])) == config["episodes"]:
        return manifest
    return None


def collect(task: str, embodiment: str, episodes: int, out: str | Path, workers: int = 1,
            keep_failures: bool = False, seed0: int = 0, source: str | Path | None = None,
            camera: bool = True, camera_model: str = "pinhole",
            duration: float | None = None, max_attempts: int | None = None,
            keep_parts: bool = False,
            progress: bool | None = None, expert_noise: ExpertNoiseConfig | None = None,
            stop_on_success: bool = False, executor: Executor | None = None
            ) -> CollectReport:
    """Collects ``episodes`` demonstrations of ``task`` on ``embodiment`` into ``out``.

    Seeds ``seed0, seed0 + 1, ..`` are tried in order (at most ``max_attempts``, default
    ``3 episodes + 10``) until ``episodes`` successful ones are kept (any ones with
    ``keep_failures``). With ``source`` (a pose-stream file or folder) each stream is one
    episode, replayed by ``controller: replay`` in the scene of its recorded seed (else
    ``seed0 + i``). ``camera=False`` records a state-only dataset, ``camera_model`` picks the
    lens of its images (``CameraConfig.model``); ``duration`` overrides the
    scenario's episode length. ``expert_noise`` perturbs the scripted expert (DART-style:
    the recorded actions are its corrections, ``ScriptedDemonstrator``). By default an
    episode is recorded to its end (the release, the hold and the retreat after success);
    ``stop_on_success`` ends it a few samples after the release instead. Episodes run in
    ``workers`` processes (or on ``executor``). Resumable; see the module docstring."""
    # Guard (issue 12): collecting never shrinks an existing dataset.
    if Path(out).is_file():
        try:
            with open_dataset(out) as f:
                held = len(sorted_demos(f["data"]))
        except (DatasetError, KeyError, OSError):
            held = 0  # not a readable dataset: the checks below name the problem
        if held > episodes:
            raise DatasetError(f"{out} already holds {held} episodes, more than --episodes "
                               f"{episodes}: collecting never shrinks a dataset; ask for at "
                               f"least {held}, choose another --out, or pass --overwrite to "
                               "replace it")
    start = time.perf_counter()
    out = Path(out)
    if episodes < 1:
        raise DatasetError(f"episodes must be at least 1, got {episodes}")
    base = Scenario(embodiment=embodiment, task=task, stop_on_success=stop_on_success,
                    expert_noise=expert_noise or ExpertNoiseConfig())
    base.camera.enabled = camera
    base.camera.model = camera_model
    if duration is not None:
        base = base.replace(duration=duration)
    base.validate()
    source_names = None
    if source is not None:
        source_names = [p.name for p in find_pose_streams(source)[:episodes]]
    config = dict(task=task, embodiment=base.embodiment, camera=camera,
                  camera_model=camera_model,
                  duration=base.duration, source=source_names, seed0=seed0,
                  keep_failures=keep_failures, episodes=episodes,
                  expert_noise=dataclasses.asdict(base.expert_noise),
                  stop_on_success=stop_on_success, demo_version=TASKS[task].demo_version)
    folder = parts_dir(out)
    # every stream is read (and refused, if bad) before anything is written
    if source is not None:
        jobs = _stream_jobs(base, folder, Path(source), seed0, episodes)
        needed, keep_all = len(jobs), True
    else:
        attempts = max_attempts if max_attempts is not None else 3 * episodes + 10
        jobs = _seed_jobs(base, folder, seed0, max(attempts, episodes))
        needed, keep_all = episodes, keep_failures
    if out.exists() and not folder.exists():
        manifest = _up_to_date(out, config)
        if manifest is not None and source is None:
            log.info("%s already holds the %d episodes asked for", out, episodes)
            return CollectReport(out, episodes, [o for o in manifest["tried"]
                                                 if o["key"] in set(manifest["kept"])],
                                 manifest["tried"], time.perf_counter() - start)
        _restore_parts(out, folder, config)
    folder.mkdir(parents=True, exist_ok=True)
    _check_config(folder, config, out)
    outcomes = scan_parts(folder)
    if outcomes:
        log.info("resuming: %d episode(s) already recorded in %s", len(outcomes), folder)
    order = {job.key: i for i, job in enumerate(jobs)}
    keepable = [k for k, o in outcomes.items() if k in order and _keepable(o, keep_all)]
    bar = progress_bar(progress=progress, total=needed, initial=min(len(keepable), needed),
                       desc="collect", unit="episode")
    try:
        _schedule(jobs, outcomes, needed, keep_all, executor or make_executor(workers), bar)
    finally:
        bar.close()

    tried = sorted((o for k, o in outcomes.items() if k in order), key=lambda o: order[o["key"]])
    kept = [o for o in tried if _keepable(o, keep_failures)][:needed]
    if source is None and len(kept) < episodes:
        log.warning("only %d of %d episodes succeeded in %d seeds", len(kept), episodes,
                    len(tried))
    if not kept:
        raise DatasetError(f"no episode kept ({len(tried)} tried, all failed); nothing "
                           f"written to {out} (use --keep-failures to keep failed episodes)")
    manifest = dict(config=config, requested=needed, kept=[o["key"] for o in kept],
                    tried=tried, failed=[o for o in tried if not o["success"]])
    env_args = env_args_for(dataclasses.asdict(base.replace(seed=seed0)))
    merge_demos(out, [(folder / f"{o['key']}.hdf5", PART_GROUP) for o in kept], env_args,
                config, manifest)
    atomic_write_text(out.with_name(out.name + ".manifest.json"), json.dumps(manifest, indent=1))
    if not keep_parts:
        shutil.rmtree(folder, ignore_errors=True)
    log.info("wrote %s: %d episodes kept of %d tried", out, len(kept), len(tried))
    return CollectReport(out, needed, kept, tried, time.perf_counter() - start)
