"""Recorded 6-DoF gripper pose streams (CSV or NPZ): loading, checking, resampling, writing.

A pose stream is what a handheld tracking camera (a T265 on the LEGATO gripper) records: time
stamps, the gripper TCP pose in the tracker's own world frame, and the grasp command. Columns
(CSV header) or fields (NPZ arrays), all required::

    t, x, y, z, qw, qx, qy, qz, grasp

``t`` in seconds, strictly increasing (any origin); ``x, y, z`` in metres; the quaternion
``(qw, qx, qy, qz)`` unit length (within ``QUATERNION_TOLERANCE``; it is renormalised, and its
sign may flip between samples); ``grasp`` in [0, 1] (closed when >= 0.5). A CSV file may start
with metadata comment lines ``# key: value`` (``seed`` and ``task`` are read: the scene the
stream was recorded in); an NPZ file may hold the scalar fields ``seed`` and ``task``.

Replay convention (docs/data_format.md): the stream is resampled at the policy rate from its
first time stamp (lerp for positions, slerp for orientations, nearest sample for the grasp),
each resampled pose is expressed relative to the stream's first pose, and the first pose is
mapped onto the project's start pose: ``Q_k = START_POSE * X_0^-1 * X_k``. The tracker's world
frame therefore does not matter, only the gripper's motion relative to where it started.

Synthetic recordings, made by simulating the scripted demonstrator:
``legato_drake.pipelines.pose_streams.scripted_pose_stream``.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pydrake.math import RigidTransform

from legato_drake import conventions
from legato_drake.errors import ConfigError
from legato_drake.files import atomic_write_bytes, atomic_write_text
from legato_drake.poses import interpolate, pose_delta, pose_to_vector, vector_to_pose

COLUMNS = ("t", "x", "y", "z", "qw", "qx", "qy", "qz", "grasp")
"""Required columns (CSV) or fields (NPZ) of a pose stream, in this order when written."""

QUATERNION_TOLERANCE = 1e-2
"""Largest allowed deviation of a quaternion's norm from 1."""

SUFFIXES = (".csv", ".npz")


class PoseStreamError(ConfigError):
    """A pose stream file is missing or malformed (the message names the file and column)."""


@dataclass(frozen=True)
class PoseStream:
    """A recorded gripper pose trajectory (validated; quaternions unit length)."""

    t: np.ndarray
    """(N,) time stamps (s), strictly increasing."""
    positions: np.ndarray
    """(N, 3) TCP positions (m) in the tracker's world frame."""
    quaternions: np.ndarray
    """(N, 4) TCP orientations, unit quaternions wxyz."""
    grasp: np.ndarray
    """(N,) grasp command in [0, 1]."""
    source: str = ""
    """The file it was read from ('' if made in memory)."""
    seed: int | None = None
    """Seed of the scene it was recorded in, if the file says."""
    task: str | None = None
    """Task it was recorded for, if the file says."""

    def __len__(self) -> int:
        return len(self.t)

    @property
    def duration(self) -> float:
        """Seconds from the first to the last sample."""
        return float(self.t[-1] - self.t[0])

    def pose(self, i: int) -> RigidTransform:
        """The i-th recorded pose."""
        return vector_to_pose(np.concatenate([self.positions[i], self.quaternions[i]]))


def _fail(path: str, message: str) -> PoseStreamError:
    return PoseStreamError(f"pose stream {path}: {message}")


def _read_csv(path: Path) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    text = path.read_text()
    meta: dict[str, str] = {}
    lines = []
    for line in text.splitlines():
        stripped = line.strip()
        if stripped.startswith("#"):
            key, sep, value = stripped[1:].partition(":")
            if sep:
                meta[key.strip()] = value.strip()
        elif stripped:
            lines.append(line)
    if not lines:
        raise _fail(str(path), f"empty file (expected a header with columns {', '.join(COLUMNS)})")
    reader = csv.reader(io.StringIO("\n".join(lines)))
    header = [h.strip() for h in next(reader)]
    rows = list(reader)
    columns: dict[str, np.ndarray] = {}
    for name in COLUMNS:
        if name not in header:
            raise _fail(str(path), f"missing column {name!r} (header: {', '.join(header)}; "
                                   f"required: {', '.join(COLUMNS)})")
        j = header.index(name)
        values = []
        for i, row in enumerate(rows):
            try:
                values.append(float(row[j]))
            except (IndexError, ValueError):
                cell = row[j] if j < len(row) else "<missing>"
                raise _fail(str(path), f"column {name!r}, data row {i + 1}: not a number: "
                                       f"{cell!r}") from None
        columns[name] = np.array(values, dtype=float)
    return columns, meta


def _read_npz(path: Path) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    try:
        with np.load(path, allow_pickle=False) as npz:
            fields = {name: np.asarray(npz[name]) for name in npz.files}
    except (OSError, ValueError) as e:
        raise _fail(str(path), f"not a readable NPZ file ({e})") from None
    columns = {}
    for name in COLUMNS:
        if name not in fields:
            raise _fail(str(path), f"missing field {name!r} (fields: {', '.join(fields)}; "
                                   f"required: {', '.join(COLUMNS)})")
        value = fields[name]
        if value.ndim != 1 or not np.issubdtype(value.dtype, np.number):
            raise _fail(str(path), f"field {name!r} must be a 1-D numeric array, got "
                                   f"{value.dtype} with shape {value.shape}")
        columns[name] = value.astype(float)
    lengths = {len(v) for v in columns.values()}
    if len(lengths) != 1:
        raise _fail(str(path), "fields have different lengths: " +
                    ", ".join(f"{k}={len(v)}" for k, v in columns.items()))
    meta = {k: str(fields[k].item()) for k in ("seed", "task")
            if k in fields and fields[k].ndim == 0}
    return columns, meta


def check_columns(columns: dict[str, np.ndarray], where: str) -> None:
    """Raises PoseStreamError (naming ``where`` and the column) for NaNs, too few samples,
    non-increasing time, non-unit quaternions or grasp values outside [0, 1]."""
    n = len(columns["t"])
    if n < 2:
        raise _fail(where, f"needs at least 2 samples, got {n}")
    for name in COLUMNS:
        bad = np.flatnonzero(~np.isfinite(columns[name]))
        if bad.size:
            raise _fail(where, f"column {name!r} has {bad.size} non-finite value(s) (NaN or "
                               f"inf), first at data row {bad[0] + 1}")
    steps = np.diff(columns["t"])
    bad = np.flatnonzero(steps <= 0.0)
    if bad.size:
        i = bad[0] + 1
        raise _fail(where, f"column 't' is not strictly increasing: data row {i + 1} has "
                           f"t={columns['t'][i]!r} after t={columns['t'][i - 1]!r}")
    q = np.stack([columns[k] for k in ("qw", "qx", "qy", "qz")], axis=1)
    norms = np.linalg.norm(q, axis=1)
    bad = np.flatnonzero(np.abs(norms - 1.0) > QUATERNION_TOLERANCE)
    if bad.size:
        raise _fail(where, f"columns 'qw', 'qx', 'qy', 'qz' are not a unit quaternion at data "
                           f"row {bad[0] + 1} (norm {norms[bad[0]]:.4f}, tolerance "
                           f"{QUATERNION_TOLERANCE})")
    g = columns["grasp"]
    bad = np.flatnonzero((g < 0.0) | (g > 1.0))
    if bad.size:
        raise _fail(where, f"column 'grasp' must be in [0, 1]; data row {bad[0] + 1} has "
                           f"{g[bad[0]]!r}")


def check_pose_stream_file(path: str | Path) -> Path:
    """Checks, without reading it, that a pose stream file exists and has a known suffix
    (what a scenario's validation checks; the file is parsed where the diagram is built)."""
    path = Path(path)
    if not path.is_file():
        raise PoseStreamError(f"pose stream file not found: {path}")
    if path.suffix.lower() not in SUFFIXES:
        raise _fail(str(path), f"unknown format {path.suffix!r}; expected "
                               f"{' or '.join(SUFFIXES)}")
    return path


def load_pose_stream(path: str | Path) -> PoseStream:
    """Reads and checks a pose stream file (CSV or NPZ); errors name the file and column."""
    path = check_pose_stream_file(path)
    try:
        columns, meta = _read_csv(path) if path.suffix.lower() == ".csv" else _read_npz(path)
    except UnicodeDecodeError:
        raise _fail(str(path), "not a text CSV file") from None
    check_columns(columns, str(path))
    q = np.stack([columns[k] for k in ("qw", "qx", "qy", "qz")], axis=1)
    seed = meta.get("seed")
    try:
        seed_value = int(seed) if seed not in (None, "") else None
    except ValueError:
        raise _fail(str(path), f"metadata 'seed' must be an integer, got {seed!r}") from None
    return PoseStream(
        t=columns["t"], positions=np.stack([columns[k] for k in "xyz"], axis=1),
        quaternions=q / np.linalg.norm(q, axis=1, keepdims=True), grasp=columns["grasp"],
        source=str(path), seed=seed_value, task=meta.get("task") or None)


def find_pose_streams(source: str | Path) -> list[Path]:
    """The stream files of ``source``: the file itself, or every .csv/.npz file in a folder
    (sorted by name)."""
    source = Path(source)
    if source.is_dir():
        files = sorted(p for p in source.iterdir() if p.suffix.lower() in SUFFIXES)
        if not files:
            raise PoseStreamError(f"no pose stream files (*.csv, *.npz) in folder {source}")
        return files
    if not source.is_file():
        raise PoseStreamError(f"pose stream file or folder not found: {source}")
    return [source]


def resample(stream: PoseStream, period: float = conventions.POLICY_PERIOD
             ) -> tuple[list[RigidTransform], np.ndarray]:
    """Samples the stream every ``period`` from its first time stamp to its last (lerp +
    slerp for the pose, nearest sample thresholded at 0.5 for the grasp)."""
    t0 = stream.t[0]
    count = int(np.floor(stream.duration / period + 1e-9)) + 1
    times = t0 + period * np.arange(count)
    poses, grasps = [], []
    for t in times:
        i = int(np.clip(np.searchsorted(stream.t, t, side="right") - 1, 0, len(stream) - 2))
        s = float(np.clip((t - stream.t[i]) / (stream.t[i + 1] - stream.t[i]), 0.0, 1.0))
        poses.append(interpolate(stream.pose(i), stream.pose(i + 1), s))
        nearest = i if s < 0.5 else i + 1
        grasps.append(float(stream.grasp[nearest] >= 0.5))
    return poses, np.array(grasps)


def stream_to_actions(stream: PoseStream, X_start: RigidTransform = conventions.START_POSE,
                      period: float = conventions.POLICY_PERIOD,
                      X_TG: RigidTransform | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The policy actions that replay ``stream``, and the commanded poses they reach.

    Returns ``(actions (K, 7), poses (K + 1, 7))``: ``poses[k] = X_start * X_0^-1 * X_k`` for
    the K + 1 resampled stream poses X_k (so ``poses[0]`` is ``X_start``), and ``actions[k] =
    [pose_delta(poses[k], poses[k + 1]), grasp at sample k + 1]``, the same form the scripted
    demonstrator outputs. ``X_TG`` is the TCP's pose in the tracked frame when the stream
    tracks another frame rigidly attached to the gripper (default: the stream is the TCP).
    """
    samples, grasps = resample(stream, period)
    if X_TG is not None:
        samples = [X @ X_TG for X in samples]
    X_0_inv = samples[0].inverse()
    poses = [X_start @ (X_0_inv @ X) for X in samples]
    actions = np.array([[*pose_delta(poses[k], poses[k + 1]), grasps[k + 1]]
                        for k in range(len(poses) - 1)]).reshape(-1, 7)
    return actions, np.array([pose_to_vector(X) for X in poses])


def make_pose_stream(t: np.ndarray, poses: np.ndarray, grasp: np.ndarray,
                     seed: int | None = None, task: str | None = None) -> PoseStream:
    """A checked PoseStream from arrays: ``poses`` (N, 7) as [xyz, quaternion wxyz]."""
    poses = np.asarray(poses, dtype=float)
    columns = dict(t=np.asarray(t, dtype=float), grasp=np.asarray(grasp, dtype=float),
                   **{k: poses[:, i] for i, k in enumerate(("x", "y", "z", "qw", "qx", "qy",
                                                            "qz"))})
    check_columns(columns, "<in memory>")
    q = poses[:, 3:7]
    return PoseStream(columns["t"], poses[:, :3].copy(), q / np.linalg.norm(q, axis=1,
                                                                          keepdims=True),
                      columns["grasp"], seed=seed, task=task)


def write_pose_stream(path: str | Path, stream: PoseStream) -> Path:
    """Writes ``stream`` as CSV or NPZ (by the suffix of ``path``), atomically."""
    path = Path(path)
    table = np.column_stack([stream.t, stream.positions, stream.quaternions, stream.grasp])
    if path.suffix.lower() == ".npz":
        buffer = io.BytesIO()
        extra = {}
        if stream.seed is not None:
            extra["seed"] = np.array(stream.seed)
        if stream.task is not None:
            extra["task"] = np.array(stream.task)
        np.savez(buffer, **{name: table[:, i] for i, name in enumerate(COLUMNS)}, **extra)
        atomic_write_bytes(path, buffer.getvalue())
    elif path.suffix.lower() == ".csv":
        lines = [f"# {k}: {v}" for k, v in (("seed", stream.seed), ("task", stream.task))
                 if v is not None]
        lines.append(",".join(COLUMNS))
        lines += [",".join(f"{v:.10g}" for v in row) for row in table]
        atomic_write_text(path, "\n".join(lines) + "\n")
    else:
        raise PoseStreamError(f"pose stream {path}: unknown format {path.suffix!r}; expected "
                              f"{' or '.join(SUFFIXES)}")
    return path


def script_to_stream(poses: np.ndarray, grasps: np.ndarray,
                     X_start: RigidTransform = conventions.START_POSE,
                     period: float = conventions.POLICY_PERIOD, rate: float | None = None,
                     X_WT: RigidTransform | None = None, seed: int | None = None,
                     task: str | None = None) -> PoseStream:
    """A synthetic pose stream from a script of commanded poses (one per policy step after
    ``X_start``, as the scripted demonstrator's ``Script`` holds them).

    The stream starts at ``X_start`` (t = 0, open gripper) and reaches ``poses[k]`` at
    ``t = (k + 1) period``. With ``rate`` (Hz) it is densified by lerp/slerp between steps, as
    a tracking camera samples (e.g. 200 Hz); with ``X_WT`` it is expressed in a tracker world
    frame T posed at ``X_WT`` (the stream holds ``X_WT^-1 X``), which replay must undo."""
    keys = [X_start] + [vector_to_pose(p) for p in poses]
    key_grasps = np.concatenate([[grasps[0] if len(grasps) else 0.0], grasps])
    key_times = period * np.arange(len(keys))
    if rate is None:
        times, frames, gs = key_times, keys, key_grasps
    else:
        times = np.arange(0.0, key_times[-1] + 1e-9, 1.0 / rate)
        times[-1] = key_times[-1]
        frames, gs = [], []
        for t in times:
            i = int(min(np.floor(t / period + 1e-9), len(keys) - 2))
            s = float(np.clip(t / period - i, 0.0, 1.0))
            frames.append(interpolate(keys[i], keys[i + 1], s))
            gs.append(key_grasps[i + 1] if s > 0.5 else key_grasps[i])
    if X_WT is not None:
        X_TW = X_WT.inverse()
        frames = [X_TW @ X for X in frames]
    return make_pose_stream(times, np.array([pose_to_vector(X) for X in frames]),
                            np.array(gs), seed=seed, task=task)

