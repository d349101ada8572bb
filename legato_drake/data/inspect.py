"""Looking at a dataset: a summary, a validation, and plots of one episode."""

from __future__ import annotations

import io
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from legato_drake import conventions
from legato_drake.data.layout import (
    IMAGE_KEYS,
    DatasetError,
    mask_names,
    open_dataset,
    read_json_attr,
    sorted_demos,
    validate_file,
)
from legato_drake.files import atomic_write_bytes
from legato_drake.summary import format_table

ACTION_NAMES = ("dx", "dy", "dz", "droll", "dpitch", "dyaw", "grasp")


@dataclass
class Summary:
    """What a dataset holds, and what is wrong with it."""

    path: Path
    format_version: int | None = None
    env_name: str = ""
    episodes: int = 0
    samples: int = 0
    lengths: list[int] = field(default_factory=list)
    successes: int = 0
    train: int = 0
    valid: int = 0
    obs: dict[str, str] = field(default_factory=dict)
    """Observation key -> 'dtype (per-sample shape)' of the first demo."""
    action_stats: np.ndarray | None = None
    """(4, 7): mean, std, min, max of each action dimension over all samples."""
    config: dict = field(default_factory=dict)
    tried: int | None = None
    """Episodes the collection tried (from its manifest), if recorded."""
    issues: list[str] = field(default_factory=list)


def summarize(path: Path) -> Summary:
    """Reads and validates the dataset at ``path``; DatasetError if it cannot be read."""
    summary = Summary(Path(path))
    with open_dataset(path) as f:
        summary.issues = validate_file(f)
        try:
            data = f["data"]
            version = data.attrs.get("format_version")
            summary.format_version = int(version) if version is not None else None
            summary.env_name = str((read_json_attr(data, "env_args", {}) or {})
                                   .get("env_name", ""))
            summary.config = read_json_attr(data, "config", {}) or {}
            names = sorted_demos(data)
            summary.episodes = len(names)
            actions = []
            for name in names:
                demo = data[name]
                summary.lengths.append(int(demo["actions"].shape[0]))
                summary.successes += bool(demo.attrs.get("success", False))
                actions.append(demo["actions"][()])
            summary.samples = sum(summary.lengths)
            if actions:
                a = np.concatenate(actions)
                summary.action_stats = np.stack([a.mean(0), a.std(0), a.min(0), a.max(0)])
                obs = data[names[0]]["obs"]
                summary.obs = {k: f"{obs[k].dtype} {obs[k].shape[1:]}" for k in obs}
            if "mask" in f:
                summary.train = len(mask_names(f, "train")) if "train" in f["mask"] else 0
                summary.valid = len(mask_names(f, "valid")) if "valid" in f["mask"] else 0
            if "meta/manifest" in f:
                summary.tried = len(json.loads(f["meta/manifest"][()]).get("tried", []))
        except (OSError, KeyError, ValueError) as e:
            if not summary.issues:
                summary.issues.append(f"unreadable: {str(e).split('(')[0].strip()}")
    return summary


def format_summary(summary: Summary) -> str:
    """The summary as text tables (what ``legato-drake inspect`` prints)."""
    lengths = summary.lengths or [0]
    rows = [["file", str(summary.path)],
            ["format version", str(summary.format_version)],
            ["environment", summary.env_name or "-"],
            ["episodes", f"{summary.episodes} (train {summary.train}, valid {summary.valid})"],
            ["samples", str(summary.samples)],
            ["length min/mean/max", f"{min(lengths)} / {np.mean(lengths):.1f} / "
                                    f"{max(lengths)} steps"],
            ["successful", f"{summary.successes} of {summary.episodes}"]]
    if summary.tried is not None:
        rows.append(["collection tried", f"{summary.tried} episodes"])
    rows += [[f"obs/{k}", v] for k, v in summary.obs.items()]
    parts = [format_table(["dataset", ""], rows)]
    if summary.action_stats is not None:
        stats = summary.action_stats
        parts.append(format_table(
            ["action", "mean", "std", "min", "max"],
            [[name, *(f"{v:+.5f}" for v in stats[:, j])]
             for j, name in enumerate(ACTION_NAMES)]))
    if summary.issues:
        parts.append(f"INVALID: {len(summary.issues)} problem(s):\n  " +
                     "\n  ".join(summary.issues))
    else:
        parts.append("valid: layout, shapes, dtypes, masks and action history check out")
    return "\n\n".join(parts)


def _save(fig, path: Path) -> Path:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=100)
    atomic_write_bytes(path, buffer.getvalue())
    return path


def plot_episode(path: Path, episode: int, out: Path, frames: int = 8) -> list[Path]:
    """Writes ``demo_<episode>_frames.png`` (a strip of stereo frames, if the dataset has
    images) and ``demo_<episode>_trajectory.png`` (the gripper's commanded and measured path
    in 3D and x, y, z over time, grasp shaded) into ``out``; returns their paths."""
    from matplotlib.figure import Figure

    with open_dataset(path) as f:
        name = f"demo_{episode}"
        if name not in f.get("data", {}):
            count = len(sorted_demos(f["data"])) if "data" in f else 0
            raise DatasetError(f"{path} has no episode {episode} (it has {count}: "
                               f"0 to {count - 1})")
        try:
            demo = f["data"][name]
            commanded = demo["obs/tcp_commanded"][()]
            measured = demo["obs/tcp_measured"][()]
            grasp = demo["actions"][:, 6]
            T = len(commanded)
            steps = np.unique(np.linspace(0, T - 1, min(frames, T)).round().astype(int))
            images = {k: demo["obs"][k][steps] for k in IMAGE_KEYS if k in demo["obs"]}
        except (OSError, KeyError, ValueError) as e:
            raise DatasetError(f"{path}: cannot read episode {episode} "
                               f"({str(e).split('(')[0].strip()})") from None
    written = []
    if len(images) == len(IMAGE_KEYS):
        fig = Figure(figsize=(1.6 * len(steps), 3.6), layout="constrained")
        axes = fig.subplots(2, len(steps), squeeze=False)
        for row, key in enumerate(IMAGE_KEYS):
            for col, k in enumerate(steps):
                ax = axes[row, col]
                ax.imshow(images[key][col, :, :, 0], cmap="gray", vmin=0, vmax=255)
                ax.set_xticks([])
                ax.set_yticks([])
                if row == 0:
                    ax.set_title(f"step {k}", fontsize=8)
                if col == 0:
                    ax.set_ylabel(key.split("_")[0], fontsize=8)
        fig.suptitle(f"{path.name} {name}: stereo frames", fontsize=9)
        written.append(_save(fig, out / f"{name}_frames.png"))

    t = conventions.POLICY_PERIOD * np.arange(T)
    fig = Figure(figsize=(11, 4.2), layout="constrained")
    ax3 = fig.add_subplot(1, 2, 1, projection="3d")
    ax3.plot(*commanded[:, :3].T, label="commanded")
    ax3.plot(*measured[:, :3].T, "--", label="measured")
    closed = grasp > 0.5
    ax3.scatter(*commanded[closed, :3].T, s=6, c="tab:red", label="grasp closed")
    ax3.set_xlabel("x (m)")
    ax3.set_ylabel("y (m)")
    ax3.set_zlabel("z (m)")
    ax3.legend(fontsize=7)
    ax = fig.add_subplot(1, 2, 2)
    for j, axis in enumerate("xyz"):
        ax.plot(t, commanded[:, j], label=f"{axis} commanded")
        ax.plot(t, measured[:, j], ":", color=f"C{j}")
    for k in np.flatnonzero(closed):
        ax.axvspan(t[k] - 0.05, t[k] + 0.05, color="tab:red", alpha=0.12, lw=0)
    ax.set_xlabel("time after homing (s); shaded: grasp closed")
    ax.set_ylabel("TCP position (m)")
    ax.legend(fontsize=7)
    fig.suptitle(f"{path.name} {name}: gripper trajectory", fontsize=9)
    written.append(_save(fig, out / f"{name}_trajectory.png"))
    return written
