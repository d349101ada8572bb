"""Writing a dataset in the LeRobot v3.0 layout (``legato-drake export --format lerobot``).

::

    OUT/meta/info.json                 codebase_version v3.0, fps 10, the features, paths
    OUT/meta/stats.json                min, max, mean, std, count of every feature
    OUT/meta/tasks.parquet             the task's description -> task_index
    OUT/meta/episodes/chunk-000/file-000.parquet   one row per episode: length, tasks,
                                       where its frames and video segments are
    OUT/data/chunk-000/file-000.parquet            one row per frame (all episodes)
    OUT/videos/observation.images.<left|right>/chunk-000/file-000.mp4   all episodes, one
                                       after the other (H.264 through PyAV)

Per frame: ``observation.images.left`` / ``right`` (the gripper's grayscale cameras as RGB
video frames), ``observation.state`` (the commanded gripper pose and the fingers),
``observation.environment_state`` (the objects' poses: privileged), ``observation.pose_deltas``
(the last two pose deltas, as the policy's input), ``action`` (7: pose delta in the previous
commanded gripper frame and grasp), and LeRobot's ``timestamp``, ``frame_index``,
``episode_index``, ``index``, ``task_index``. Needs ``pyarrow`` and ``av`` (``pip install
'legato-drake[export]'``).
"""

from __future__ import annotations

import json
from fractions import Fraction
from pathlib import Path

import numpy as np

from legato_drake.data.layout import DatasetError, open_dataset, sorted_demos
from legato_drake.errors import ConfigError

CODEBASE_VERSION = "v3.0"
FPS = 10
CHUNK = "chunk-000/file-000"
CAMERAS = {"observation.images.left": "left_gray", "observation.images.right": "right_gray"}
ACTION_NAMES = ["dx", "dy", "dz", "droll", "dpitch", "dyaw", "grasp"]
TASK_TEXT = {"lid": "put the lid on the pot", "cup": "put the cup in the shelf",
             "ladle": "put the ladle in the case"}


def _require() -> tuple:
    try:
        import av
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError as e:
        raise ConfigError(f"--format lerobot needs pyarrow and av ({e.name} is missing): pip "
                          "install 'legato-drake[export]'") from None
    return pa, pq, av


def _stats(values: np.ndarray) -> dict:
    """LeRobot's per-feature statistics over frames (axis 0)."""
    values = np.asarray(values, dtype=np.float64)
    return {"min": values.min(0).tolist(), "max": values.max(0).tolist(),
            "mean": values.mean(0).tolist(), "std": values.std(0).tolist(),
            "count": [len(values)]}


def _image_stats(frames: np.ndarray) -> dict:
    """Statistics of uint8 frames (T, H, W, 3) per channel, in [0, 1], shaped (3, 1, 1)."""
    scaled = frames.reshape(-1, 3).astype(np.float64) / 255.0
    shape = lambda v: [[[float(x)]] for x in v]  # noqa: E731 - (3, 1, 1)
    return {"min": shape(scaled.min(0)), "max": shape(scaled.max(0)),
            "mean": shape(scaled.mean(0)), "std": shape(scaled.std(0)),
            "count": [len(frames)]}


def _write_video(path: Path, frames: list[np.ndarray], av) -> dict:
    """Encodes RGB uint8 frames (H, W, 3) at ``FPS`` as H.264 (yuv420p); returns LeRobot's
    video info."""
    path.parent.mkdir(parents=True, exist_ok=True)
    height, width = frames[0].shape[:2]
    with av.open(str(path), "w") as container:
        stream = container.add_stream("libx264", rate=FPS)
        stream.width, stream.height, stream.pix_fmt = width, height, "yuv420p"
        stream.time_base = Fraction(1, FPS)
        stream.options = {"crf": "18", "g": "10"}
        for i, frame in enumerate(frames):
            video_frame = av.VideoFrame.from_ndarray(frame, format="rgb24")
            video_frame.pts = i
            for packet in stream.encode(video_frame):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)
    return {"video.height": height, "video.width": width, "video.codec": "h264",
            "video.pix_fmt": "yuv420p", "video.is_depth_map": False, "video.fps": FPS,
            "video.channels": 3, "has_audio": False}


def _tasks_table(pa, tasks: list[str]):
    """``meta/tasks.parquet`` as LeRobot writes it: a pandas frame indexed by the task's
    text with a ``task_index`` column (the pandas metadata says which column is the
    index)."""
    index = "__index_level_0__"
    table = pa.table({"task_index": pa.array(range(len(tasks)), pa.int64()),
                      index: pa.array(tasks, pa.string())})
    pandas = {"index_columns": [index], "column_indexes": [
        {"name": None, "field_name": None, "pandas_type": "unicode", "numpy_type": "object",
         "metadata": {"encoding": "UTF-8"}}],
        "columns": [{"name": "task_index", "field_name": "task_index", "pandas_type": "int64",
                     "numpy_type": "int64", "metadata": None},
                    {"name": None, "field_name": index, "pandas_type": "unicode",
                     "numpy_type": "object", "metadata": None}],
        "creator": {"library": "pyarrow", "version": pa.__version__},
        "pandas_version": "2.2.0"}
    return table.replace_schema_metadata({b"pandas": json.dumps(pandas).encode()})


def export_lerobot(data: str | Path, out: str | Path, overwrite: bool = False) -> dict:
    """Writes the dataset ``data`` in the LeRobot v3.0 layout under ``out``; returns the
    ``info.json`` document. ``out`` must not hold a dataset already unless ``overwrite``."""
    pa, pq, av = _require()
    out = Path(out)
    if (out / "meta" / "info.json").exists() and not overwrite:
        raise ConfigError(f"--out {out} already holds a LeRobot dataset: choose another --out "
                          "or pass --overwrite")
    with open_dataset(data) as f:
        demos = sorted_demos(f["data"])
        if not demos:
            raise DatasetError(f"{data}: no demonstrations to export")
        first = f["data"][demos[0]]
        task = str(first.attrs["task"])
        has_images = all(key in f["data"][name]["obs"] for name in demos
                         for key in CAMERAS.values())
        columns: dict[str, list] = {k: [] for k in (
            "observation.state", "observation.environment_state", "observation.pose_deltas",
            "action", "timestamp", "frame_index", "episode_index", "index", "task_index")}
        frames: dict[str, list[np.ndarray]] = {k: [] for k in CAMERAS}
        episodes = []
        total = 0
        for episode, name in enumerate(demos):
            demo = f["data"][name]
            obs = demo["obs"]
            actions = demo["actions"][()]
            n = len(actions)
            state = np.concatenate([obs["tcp_commanded"][()], obs["fingers"][()]], axis=1)
            deltas = np.concatenate([obs["delta_positions"][()], obs["delta_eulers"][()]],
                                    axis=1)
            columns["observation.state"] += list(state.astype(np.float32))
            columns["observation.environment_state"] += list(
                obs["object"][()].astype(np.float32))
            columns["observation.pose_deltas"] += list(deltas.astype(np.float32))
            columns["action"] += list(actions.astype(np.float32))
            columns["timestamp"] += [np.float32(i / FPS) for i in range(n)]
            columns["frame_index"] += list(range(n))
            columns["episode_index"] += [episode] * n
            columns["index"] += list(range(total, total + n))
            columns["task_index"] += [0] * n
            row = {"episode_index": episode, "tasks": [TASK_TEXT.get(task, task)], "length": n,
                   "data/chunk_index": 0, "data/file_index": 0, "dataset_from_index": total,
                   "dataset_to_index": total + n, "meta/episodes/chunk_index": 0,
                   "meta/episodes/file_index": 0, "legato/seed": int(demo.attrs["seed"]),
                   "legato/success": bool(demo.attrs["success"])}
            if has_images:
                start = sum(len(v) for v in frames["observation.images.left"]) / FPS
                for key, source in CAMERAS.items():
                    gray = obs[source][()]
                    frames[key].append(np.repeat(gray, 3, axis=3))
                    row[f"videos/{key}/chunk_index"] = 0
                    row[f"videos/{key}/file_index"] = 0
                    row[f"videos/{key}/from_timestamp"] = start
                    row[f"videos/{key}/to_timestamp"] = start + n / FPS
            episodes.append(row)
            total += n
        embodiment = str(first.attrs["embodiment"])
    width = {k: len(columns[k][0]) for k in ("observation.state",
                                             "observation.environment_state",
                                             "observation.pose_deltas")}
    features = {
        "observation.state": {"dtype": "float32", "shape": [width["observation.state"]],
                              "names": ["x", "y", "z", "qw", "qx", "qy", "qz", "finger_left",
                                        "finger_right"]},
        "observation.environment_state": {
            "dtype": "float32", "shape": [width["observation.environment_state"]],
            "names": None},
        "observation.pose_deltas": {"dtype": "float32",
                                    "shape": [width["observation.pose_deltas"]],
                                    "names": None},
        "action": {"dtype": "float32", "shape": [7], "names": ACTION_NAMES},
        "timestamp": {"dtype": "float32", "shape": [1], "names": None},
        "frame_index": {"dtype": "int64", "shape": [1], "names": None},
        "episode_index": {"dtype": "int64", "shape": [1], "names": None},
        "index": {"dtype": "int64", "shape": [1], "names": None},
        "task_index": {"dtype": "int64", "shape": [1], "names": None},
    }
    stats = {key: _stats(np.asarray(values).reshape(len(values), -1))
             for key, values in columns.items()}
    if has_images:
        for key in CAMERAS:
            video = np.concatenate(frames[key])
            info = _write_video(out / "videos" / key / f"{CHUNK}.mp4", list(video), av)
            features[key] = {"dtype": "video", "shape": list(video.shape[1:]),
                             "names": ["height", "width", "channels"], "info": info}
            stats[key] = _image_stats(video)
    vectors = {k: pa.array([np.asarray(v).tolist() for v in columns[k]],
                           pa.list_(pa.float32())) for k in
               ("observation.state", "observation.environment_state",
                "observation.pose_deltas", "action")}
    scalars = {"timestamp": pa.array(columns["timestamp"], pa.float32()),
               **{k: pa.array(columns[k], pa.int64()) for k in
                  ("frame_index", "episode_index", "index", "task_index")}}
    (out / "data" / "chunk-000").mkdir(parents=True, exist_ok=True)
    pq.write_table(pa.table({**vectors, **scalars}), out / "data" / f"{CHUNK}.parquet")
    (out / "meta" / "episodes" / "chunk-000").mkdir(parents=True, exist_ok=True)
    pq.write_table(pa.Table.from_pylist(episodes),
                   out / "meta" / "episodes" / f"{CHUNK}.parquet")
    pq.write_table(_tasks_table(pa, [TASK_TEXT.get(task, task)]),
                   out / "meta" / "tasks.parquet")
    info = {"codebase_version": CODEBASE_VERSION, "robot_type": f"legato_gripper_{embodiment}",
            "total_episodes": len(episodes), "total_frames": total, "total_tasks": 1,
            "chunks_size": 1000, "data_files_size_in_mb": 100, "video_files_size_in_mb": 200,
            "fps": FPS, "splits": {"train": f"0:{len(episodes)}"},
            "data_path": "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet",
            "video_path": ("videos/{video_key}/chunk-{chunk_index:03d}/"
                           "file-{file_index:03d}.mp4") if has_images else None,
            "features": features}
    (out / "meta" / "stats.json").write_text(json.dumps(stats, indent=1))
    (out / "meta" / "info.json").write_text(json.dumps(info, indent=1))
    return info
