"""Writing datasets: one episode into a demo group, whole files atomically, merging parts."""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from legato_drake.data.layout import (
    ACTION_DIM,
    FORMAT,
    FORMAT_VERSION,
    IMAGE_KEYS,
    delta_history,
    demo_name,
    split_masks,
)

IMAGE_COMPRESSION = dict(compression="gzip", compression_opts=4)
"""Images: gzip level 4, one chunk per frame."""


@dataclass
class Episode:
    """One recorded episode, as the writer takes it."""

    actions: np.ndarray
    """(T, 7) float: [pose delta, grasp] per step."""
    obs: dict[str, np.ndarray]
    """Recorded observations, first axis = step: ``tcp_commanded``, ``tcp_measured``,
    ``object``, ``fingers`` and, with cameras, ``left_gray``, ``right_gray``. The
    ``delta_positions``/``delta_eulers`` history is derived from ``actions`` when written."""
    success: bool
    states: np.ndarray | None = None
    """(T, nq + nv) plant states, or None."""
    attrs: dict[str, object] = field(default_factory=dict)
    """Per-demo attributes (seed, embodiment, task, scenario, reason, ...): scalars or
    strings; dicts and lists are stored as JSON text."""

    def __len__(self) -> int:
        return len(self.actions)


def _attr_value(value: object) -> object:
    if value is None:
        return ""
    if isinstance(value, dict | list | tuple):
        return json.dumps(value)
    return value


def write_demo(group: h5py.Group, episode: Episode) -> None:
    """Writes ``episode`` into an empty demo group (robomimic layout, see layout.py)."""
    actions = np.asarray(episode.actions, dtype=np.float64).reshape(-1, ACTION_DIM)
    T = len(actions)
    if T == 0:
        raise ValueError("cannot write an episode with no samples")
    group.create_dataset("actions", data=actions)
    rewards = np.zeros(T)
    rewards[-1] = float(episode.success)
    group.create_dataset("rewards", data=rewards)
    dones = np.zeros(T, dtype=np.int64)
    dones[-1] = 1
    group.create_dataset("dones", data=dones)
    if episode.states is not None:
        group.create_dataset("states", data=np.asarray(episode.states, dtype=np.float64))
    obs = group.create_group("obs")
    positions, eulers = delta_history(actions)
    obs.create_dataset("delta_positions", data=positions)
    obs.create_dataset("delta_eulers", data=eulers)
    for key, value in episode.obs.items():
        value = np.asarray(value)
        if len(value) != T:
            raise ValueError(f"observation {key!r} has {len(value)} samples, actions {T}")
        if key in IMAGE_KEYS:
            obs.create_dataset(key, data=value.astype(np.uint8),
                               chunks=(1, *value.shape[1:]), **IMAGE_COMPRESSION)
        else:
            obs.create_dataset(key, data=value.astype(np.float64))
    group.attrs["num_samples"] = T
    group.attrs["success"] = bool(episode.success)
    for key, value in episode.attrs.items():
        group.attrs[key] = _attr_value(value)


@contextlib.contextmanager
def atomic_h5(path: str | Path) -> Iterator[h5py.File]:
    """A new HDF5 file that appears at ``path`` only once complete: written to a temporary
    file in the same folder, flushed to disk, then renamed over ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    try:
        with h5py.File(tmp, "w") as f:
            yield f
        with open(tmp, "rb+") as raw:
            os.fsync(raw.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_header(f: h5py.File, env_args: dict, config: dict, total: int,
                 manifest: dict | None = None, extra: dict | None = None) -> None:
    """Writes the ``data`` attributes (robomimic's plus ours) and the masks."""
    data = f.require_group("data")
    data.attrs["total"] = int(total)
    data.attrs["env_args"] = json.dumps(env_args)
    data.attrs["format"] = FORMAT
    data.attrs["format_version"] = FORMAT_VERSION
    data.attrs["config"] = json.dumps(config)
    for key, value in (extra or {}).items():
        data.attrs[key] = _attr_value(value)
    names = [n for n in data if n.startswith("demo_")]
    names.sort(key=lambda n: int(n[5:]))
    train, valid = split_masks(names)
    mask = f.require_group("mask")
    for split, members in (("train", train), ("valid", valid)):
        if split in mask:
            del mask[split]
        mask.create_dataset(split, data=np.array(members, dtype="S"))
    if manifest is not None:
        meta = f.require_group("meta")
        meta.create_dataset("manifest", data=json.dumps(manifest, indent=1),
                            dtype=h5py.string_dtype())


def env_args_for(scenario: dict) -> dict:
    """robomimic's ``env_args``: the environment name and the scenario as its kwargs."""
    return {"env_name": f"legato_drake/{scenario.get('task', '')}", "type": "legato_drake",
            "env_kwargs": scenario}


def write_dataset(path: str | Path, episodes: Sequence[Episode], env_args: dict | None = None,
                  config: dict | None = None, manifest: dict | None = None,
                  extra: dict | None = None) -> Path:
    """Writes ``episodes`` as ``demo_0 .. demo_{n-1}`` into a new dataset file, atomically."""
    path = Path(path)
    with atomic_h5(path) as f:
        data = f.create_group("data")
        for i, episode in enumerate(episodes):
            write_demo(data.create_group(demo_name(i)), episode)
        write_header(f, env_args or {}, config or {}, sum(len(e) for e in episodes),
                     manifest, extra)
    return path


def merge_demos(path: str | Path, sources: Sequence[tuple[Path, str]], env_args: dict,
                config: dict, manifest: dict | None = None, extra: dict | None = None) -> Path:
    """Copies demo groups (``(file, group path)`` pairs, in order) into a new dataset file at
    ``path`` as ``demo_0 ..``, atomically; chunking and compression are kept."""
    path = Path(path)
    total = 0
    with atomic_h5(path) as f:
        data = f.create_group("data")
        for i, (source, group) in enumerate(sources):
            with h5py.File(source, "r") as src:
                src.copy(src[group], data, name=demo_name(i))
                total += int(src[group].attrs["num_samples"])
        write_header(f, env_args, config, total, manifest, extra)
    return path
