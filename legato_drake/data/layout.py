"""The dataset's HDF5 layout (robomimic-compatible): names, format version, checks.

::

    data/                      attrs: total, env_args (JSON), format, format_version,
                                      config (JSON)
      demo_<i>/                attrs: num_samples, seed, success, reason, embodiment, task,
                                      controller, source, scenario (JSON),
                                      object_bodies (JSON), ...
        actions   (T, 7)  float64   [dx, dy, dz, droll, dpitch, dyaw, grasp]
        rewards   (T,)    float64   1 at the last step of a successful episode, else 0
        dones     (T,)    int64     1 at the last step
        states    (T, nq + nv) float64   the plant state (privileged; for resets)
        obs/left_gray, obs/right_gray  (T, H, W, 1) uint8   (absent in state-only datasets)
        obs/delta_positions (T, 6), obs/delta_eulers (T, 6)  float64   action history
        obs/tcp_commanded (T, 7), obs/tcp_measured (T, 7)     float64   [xyz, quat wxyz]
        obs/object (T, 7 n) float64, obs/fingers (T, 2) float64        privileged
    mask/train, mask/valid     demo names (bytes), 10 % validation
    meta/manifest              JSON text: what ``collect`` tried, kept and why it failed

See docs/data_format.md for the meaning of every field.
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Iterator
from pathlib import Path

import h5py
import numpy as np

from legato_drake.errors import LegatoError
from legato_drake.files import require_file

FORMAT = "legato_drake.demonstrations"
FORMAT_VERSION = 1
"""Bumped whenever the layout changes incompatibly; readers refuse other versions."""

HISTORY = 2
"""Number of previous actions in the ``delta_*`` observations (oldest first)."""

IMAGE_KEYS = ("left_gray", "right_gray")
HISTORY_KEYS = ("delta_positions", "delta_eulers")
LOW_DIM_KEYS = (*HISTORY_KEYS, "tcp_commanded", "tcp_measured", "object", "fingers")
POLICY_OBS_KEYS = (*IMAGE_KEYS, *HISTORY_KEYS)
"""What the policy sees (SPEC §7); the other observations are privileged."""

OBS_SHAPES: dict[str, tuple[int, ...] | None] = {
    "delta_positions": (3 * HISTORY,),
    "delta_eulers": (3 * HISTORY,),
    "tcp_commanded": (7,),
    "tcp_measured": (7,),
    "fingers": (2,),
    "object": None,  # 7 per object body
}
"""Per-sample shape of each low-dim observation (None: checked separately)."""

ACTION_DIM = 7
VALID_FRACTION = 0.1
SPLIT_SEED = 20241104
"""Seeds the (deterministic) choice of the validation demos."""


class DatasetError(LegatoError):
    """A dataset file is missing, unreadable, truncated or does not follow the layout."""


def demo_name(index: int) -> str:
    """``demo_<index>``, robomimic's group name."""
    return f"demo_{index}"


def demo_index(name: str) -> int:
    """The integer of ``demo_<index>`` (for sorting as robomimic does)."""
    return int(name.split("_", 1)[1])


def sorted_demos(data: h5py.Group) -> list[str]:
    """The demo group names of ``data`` in numeric order."""
    names = [n for n in data if n.startswith("demo_") and n[5:].isdigit()]
    return sorted(names, key=demo_index)


def delta_history(actions: np.ndarray, history: int = HISTORY) -> tuple[np.ndarray, np.ndarray]:
    """The ``delta_positions`` and ``delta_eulers`` observations derived from the actions.

    Observation k holds the pose deltas of actions k - history .. k - 1, oldest first, zeros
    where the index is negative: for history 2, ``delta_positions[k] = [a[k-2][0:3],
    a[k-1][0:3]]`` and ``delta_eulers[k] = [a[k-2][3:6], a[k-1][3:6]]``. Returns two
    ``(T, 3 history)`` arrays."""
    actions = np.asarray(actions, dtype=float).reshape(-1, ACTION_DIM)
    T = len(actions)
    padded = np.concatenate([np.zeros((history, ACTION_DIM)), actions])
    windows = np.stack([padded[j:j + T] for j in range(history)], axis=1)  # (T, history, 7)
    return (windows[:, :, 0:3].reshape(T, 3 * history).copy(),
            windows[:, :, 3:6].reshape(T, 3 * history).copy())


def split_masks(names: list[str], valid_fraction: float = VALID_FRACTION
                ) -> tuple[list[str], list[str]]:
    """Deterministic train/valid split: ``round(fraction * n)`` demos (at least one when
    there are two or more) chosen by a fixed-seed permutation; both lists in demo order."""
    n = len(names)
    n_valid = max(1, round(valid_fraction * n)) if n >= 2 else 0
    chosen = set(np.random.default_rng(SPLIT_SEED).permutation(n)[:n_valid].tolist())
    valid = [name for i, name in enumerate(names) if i in chosen]
    train = [name for i, name in enumerate(names) if i not in chosen]
    return train, valid


def read_json_attr(group: h5py.Group, name: str, default: object = None) -> object:
    """A JSON-encoded attribute, decoded (``default`` if absent)."""
    if name not in group.attrs:
        return default
    value = group.attrs[name]
    if isinstance(value, bytes):
        value = value.decode()
    return json.loads(str(value))


CAMERA_FIELDS = ("width", "height", "fov_y_deg", "model", "fisheye_fov_deg")
"""The ``CameraConfig`` fields that decide what a recorded image looks like."""


def recorded_camera(path: str | Path) -> dict:
    """The camera a dataset's images were rendered with: the ``CAMERA_FIELDS`` of the
    scenario it was collected in (``data`` attribute ``env_args``); empty if it does not
    say (a dataset written by other tools)."""
    with open_dataset(path) as f:
        env = read_json_attr(f["data"], "env_args", {}) or {}
    camera = env.get("env_kwargs", {}).get("camera", {})
    return {k: camera[k] for k in CAMERA_FIELDS if k in camera}


def mask_names(f: h5py.File, split: str) -> list[str]:
    """The demo names of ``mask/<split>``."""
    return [n.decode() if isinstance(n, bytes) else str(n) for n in f["mask"][split][()]]


@contextlib.contextmanager
def open_dataset(path: str | Path) -> Iterator[h5py.File]:
    """Opens a dataset file read-only; a missing, truncated or non-HDF5 file raises
    DatasetError naming it (instead of h5py's OSError)."""
    path = require_file(path, "dataset file", DatasetError)
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        hint = "truncated (an interrupted copy or write?)" if "truncated" in str(e) else \
            "not a readable HDF5 file"
        raise DatasetError(f"cannot open dataset {path}: the file is {hint} "
                           f"[{str(e).split('(')[0].strip()}]") from None
    try:
        yield f
    finally:
        f.close()


def _check_array(issues: list[str], where: str, ds: object, dtype_kind: str,
                 T: int | None, tail: tuple[int, ...] | None) -> None:
    if not isinstance(ds, h5py.Dataset):
        issues.append(f"{where}: expected a dataset")
        return
    if ds.dtype.kind not in dtype_kind:
        issues.append(f"{where}: dtype {ds.dtype} (expected kind {dtype_kind!r})")
    if T is not None and (ds.ndim == 0 or ds.shape[0] != T):
        issues.append(f"{where}: shape {ds.shape}, expected {T} samples")
    if tail is not None and ds.shape[1:] != tail:
        issues.append(f"{where}: shape {ds.shape}, expected (T, {', '.join(map(str, tail))})")


def validate_demo(demo: h5py.Group, name: str, deep: bool = True) -> list[str]:
    """Problems of one demo group (empty if none): required keys, shapes, dtypes, and with
    ``deep`` NaNs and the consistency of the action history with the actions."""
    issues: list[str] = []
    try:
        T = int(demo.attrs.get("num_samples", -1))
        for key in ("actions", "rewards", "dones", "obs"):
            if key not in demo:
                issues.append(f"{name}: missing '{key}'")
        if issues:
            return issues
        if T < 1 or demo["actions"].shape[0] != T:
            issues.append(f"{name}: num_samples={T} but actions has shape "
                          f"{demo['actions'].shape}")
            T = demo["actions"].shape[0]
        _check_array(issues, f"{name}/actions", demo["actions"], "f", T, (ACTION_DIM,))
        _check_array(issues, f"{name}/rewards", demo["rewards"], "fiu", T, ())
        _check_array(issues, f"{name}/dones", demo["dones"], "iub", T, ())
        if "states" in demo:
            _check_array(issues, f"{name}/states", demo["states"], "f", T, None)
        obs = demo["obs"]
        for key, tail in OBS_SHAPES.items():
            if key not in obs:
                issues.append(f"{name}: missing 'obs/{key}'")
                continue
            _check_array(issues, f"{name}/obs/{key}", obs[key], "f", T, tail)
        if "object" in obs and (obs["object"].ndim != 2 or obs["object"].shape[1] % 7):
            issues.append(f"{name}/obs/object: shape {obs['object'].shape}, expected (T, 7 n)")
        present = [k for k in IMAGE_KEYS if k in obs]
        if present and len(present) != len(IMAGE_KEYS):
            issues.append(f"{name}: has {present[0]} but not the other camera image")
        for key in present:
            ds = obs[key]
            _check_array(issues, f"{name}/obs/{key}", ds, "u", T, None)
            if ds.ndim != 4 or ds.shape[3] != 1 or ds.dtype != np.uint8:
                issues.append(f"{name}/obs/{key}: {ds.dtype} {ds.shape}, expected uint8 "
                              "(T, H, W, 1)")
        if issues or not deep:
            return issues
        actions = demo["actions"][()]
        for key in ("actions", "rewards", "states", *[f"obs/{k}" for k in OBS_SHAPES]):
            if key in demo and not np.all(np.isfinite(demo[key][()])):
                issues.append(f"{name}/{key}: contains NaN or inf")
        if not np.isin(actions[:, 6], (0.0, 1.0)).all():
            issues.append(f"{name}/actions: grasp (column 6) not in {{0, 1}}")
        positions, eulers = delta_history(actions)
        if not (np.allclose(obs["delta_positions"][()], positions) and
                np.allclose(obs["delta_eulers"][()], eulers)):
            issues.append(f"{name}/obs/delta_*: do not match the history of the actions")
        dones = demo["dones"][()]
        if dones[-1] != 1 or dones[:-1].any():
            issues.append(f"{name}/dones: expected 1 at the last step only")
    except (OSError, KeyError, ValueError, RuntimeError) as e:
        issues.append(f"{name}: unreadable ({str(e).split('(')[0].strip() or type(e).__name__})")
    return issues


def validate_file(f: h5py.File, deep: bool = True) -> list[str]:
    """Every problem found in an open dataset file (empty if it follows the layout)."""
    issues: list[str] = []
    try:
        if "data" not in f:
            return ["missing group 'data'"]
        data = f["data"]
        version = data.attrs.get("format_version")
        if version is None:
            issues.append("data: missing attribute 'format_version'")
        elif int(version) != FORMAT_VERSION:
            issues.append(f"data: format_version {int(version)} is not supported (this reader "
                          f"reads version {FORMAT_VERSION})")
        names = sorted_demos(data)
        total = 0
        for name in names:
            found = validate_demo(data[name], name, deep)
            issues += found
            if not found:
                total += int(data[name].attrs["num_samples"])
        if "total" not in data.attrs:
            issues.append("data: missing attribute 'total'")
        elif not issues and int(data.attrs["total"]) != total:
            issues.append(f"data: total={int(data.attrs['total'])} but the demos hold {total} "
                          "samples")
        if "mask" not in f or not all(k in f["mask"] for k in ("train", "valid")):
            issues.append("missing mask/train or mask/valid")
        else:
            train, valid = mask_names(f, "train"), mask_names(f, "valid")
            unknown = sorted(set(train + valid) - set(names))
            if unknown:
                issues.append(f"mask: names demos that do not exist: {unknown[:5]}")
            if set(train) & set(valid):
                issues.append("mask: train and valid overlap")
            if len(set(train) | set(valid)) != len(names) and not unknown:
                issues.append("mask: train and valid do not cover every demo")
    except (OSError, KeyError, ValueError, RuntimeError) as e:
        issues.append(f"unreadable file structure ({str(e).split('(')[0].strip()})")
    return issues


def check_file(path: str | Path, deep: bool = True) -> None:
    """Raises DatasetError listing the problems of the dataset at ``path`` (if any)."""
    with open_dataset(path) as f:
        issues = validate_file(f, deep)
    if issues:
        more = f" (and {len(issues) - 10} more)" if len(issues) > 10 else ""
        raise DatasetError(f"invalid dataset {path}:\n  " + "\n  ".join(issues[:10]) + more)
