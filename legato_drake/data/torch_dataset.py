"""A torch ``Dataset`` of training sequences from a demonstration file (robomimic-style).

Item ``i`` is a window of ``seq_length`` consecutive samples of one demo::

    {"obs": {key: tensor (L, ...)}, "actions": (L, 7) float32, "planned_actions": (L, 7),
     "rewards": (L,) float32, "dones": (L,) float32, "pad_mask": (L,) bool, "demo": str,
     "start": int}

``planned_actions`` (``data.derived.planned_actions``) are the motion between the poses the
actions aim at: the targets of action chunks.

Windows start at every step of every demo in the split. With ``pad_seq_length`` (default, as
robomimic) a window that runs past the end of its demo is padded by repeating the last sample
and ``pad_mask`` is False on the padding; without it, windows lie inside demos (demos shorter
than ``seq_length`` are skipped). Images ``left_gray``/``right_gray`` come channels-first,
``(L, 1, H, W)``: uint8 in [0, 255] with ``image_dtype="uint8"``, float32 in [0, 1] with
``"float"`` (default), by ``image_to_tensor``, the preprocessing the policy also sees at
rollout. Low-dim observations are float32; derived ones (``data.derived``, e.g.
``object_in_tcp``) are computed from the stored ones on load.

The file is validated on load (layout, format version, NaNs, masks, the requested keys) and
any problem is a DatasetError naming the file. Low-dim data is read into memory at once;
images are read per item from the file (opened lazily in each DataLoader worker), or cached
with ``cache_images=True``.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import h5py
import numpy as np
import torch
from torch.utils.data import Dataset

from legato_drake.data.derived import (
    available_observations,
    planned_actions,
    read_observation,
)
from legato_drake.data.layout import (
    IMAGE_KEYS,
    POLICY_OBS_KEYS,
    DatasetError,
    mask_names,
    open_dataset,
    sorted_demos,
    validate_file,
)

SPLITS = ("train", "valid", "all")
IMAGE_DTYPES = ("uint8", "float")


def image_to_tensor(image: np.ndarray, dtype: str = "float") -> torch.Tensor:
    """The one image preprocessing of training and rollout: uint8 grayscale images
    (..., H, W, 1), as recorded and as the cameras render them, -> channels-first
    (..., 1, H, W) tensors: float32 in [0, 1] (``dtype="float"``) or uint8 (``"uint8"``).
    ``DemoSequenceDataset`` returns its images through it, and the policy controller feeds
    the cameras' images to the policy through it (``image_to_tensor``)."""
    array = np.ascontiguousarray(np.moveaxis(np.asarray(image, dtype=np.uint8), -1, -3))
    tensor = torch.from_numpy(array)
    return tensor.float() / 255.0 if dtype == "float" else tensor


class DemoSequenceDataset(Dataset):
    """Fixed-length sequences of (observations, actions) for training a policy. With
    ``image_steps`` a window holds the images of its first ``image_steps`` steps alone: what a
    policy that observes only those loads (Diffusion Policy's ``obs_horizon``; the rest of
    its window is the chunk's actions)."""

    def __init__(self, path: str | Path, obs_keys: Sequence[str] = POLICY_OBS_KEYS,
                 seq_length: int = 20, split: str = "train", pad_seq_length: bool = True,
                 image_dtype: str = "float", cache_images: bool = False,
                 image_steps: int | None = None):
        if seq_length < 1:
            raise DatasetError(f"seq_length must be at least 1, got {seq_length}")
        if image_steps is not None and not 1 <= image_steps <= seq_length:
            raise DatasetError(f"image_steps must be 1-{seq_length} (seq_length), got "
                               f"{image_steps}")
        if split not in SPLITS:
            raise DatasetError(f"unknown split {split!r}; valid values: {', '.join(SPLITS)}")
        if image_dtype not in IMAGE_DTYPES:
            raise DatasetError(f"image_dtype must be 'uint8' or 'float', got {image_dtype!r}")
        self.path = Path(path)
        self.obs_keys = tuple(obs_keys)
        self.seq_length = seq_length
        self.split = split
        self.pad_seq_length = pad_seq_length
        self.image_dtype = image_dtype
        self.image_steps = seq_length if image_steps is None else image_steps
        self._image_keys = [k for k in self.obs_keys if k in IMAGE_KEYS]
        self._low_dim_keys = [k for k in self.obs_keys if k not in IMAGE_KEYS]
        self._file: h5py.File | None = None
        self._pid: int | None = None
        self.demos, self._data = self._load(cache_images)
        self._index: list[tuple[str, int]] = []
        for name in self.demos:
            T = len(self._data[name]["actions"])
            last = T if pad_seq_length else T - seq_length + 1
            self._index += [(name, start) for start in range(max(last, 0))]

    def _load(self, cache_images: bool) -> tuple[list[str], dict[str, dict[str, np.ndarray]]]:
        with open_dataset(self.path) as f:
            issues = validate_file(f)
            if issues:
                more = f" (and {len(issues) - 5} more)" if len(issues) > 5 else ""
                raise DatasetError(f"invalid dataset {self.path}:\n  " +
                                   "\n  ".join(issues[:5]) + more)
            names = sorted_demos(f["data"]) if self.split == "all" else \
                sorted(mask_names(f, self.split), key=lambda n: int(n.split("_")[1]))
            if not names:
                raise DatasetError(f"{self.path}: split {self.split!r} holds no demos")
            data = {}
            for name in names:
                demo = f["data"][name]
                available = available_observations(list(demo["obs"]))
                missing = [k for k in self.obs_keys if k not in available]
                if missing:
                    raise DatasetError(
                        f"{self.path}: {name} has no observation(s) {', '.join(missing)}; "
                        f"available: {', '.join(sorted(available))}")
                arrays = {key: demo[key][()].astype(np.float32)
                          for key in ("actions", "rewards", "dones")}
                arrays["planned_actions"] = planned_actions(
                    demo["obs"]["tcp_commanded"][()], demo["actions"][()]).astype(np.float32)
                for key in self._low_dim_keys:
                    arrays[f"obs/{key}"] = read_observation(demo["obs"], key).astype(np.float32)
                if cache_images:
                    for key in self._image_keys:
                        arrays[f"obs/{key}"] = demo["obs"][key][()]
                data[name] = arrays
        return names, data

    def __len__(self) -> int:
        return len(self._index)

    def window(self, i: int) -> tuple[str, int]:
        """Item ``i``'s demo and the index of its first sample in that demo."""
        return self._index[i]

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state["_file"], state["_pid"] = None, None  # h5py handles do not cross processes
        return state

    def _h5(self) -> h5py.File:
        if self._file is None or self._pid != os.getpid():
            try:
                self._file = h5py.File(self.path, "r")
            except OSError as e:
                raise DatasetError(f"cannot open dataset {self.path}: {e}") from None
            self._pid = os.getpid()
        return self._file

    def _images(self, name: str, key: str, start: int, stop: int) -> np.ndarray:
        cached = self._data[name].get(f"obs/{key}")
        if cached is not None:
            return cached[start:stop]
        try:
            return self._h5()["data"][name]["obs"][key][start:stop]
        except (OSError, KeyError) as e:
            raise DatasetError(f"{self.path}: cannot read {name}/obs/{key} "
                               f"({str(e).split('(')[0].strip()})") from None

    def __getitem__(self, i: int) -> dict:
        name, start = self._index[i]
        arrays = self._data[name]
        T = len(arrays["actions"])
        stop = min(start + self.seq_length, T)
        steps = np.minimum(np.arange(start, start + self.seq_length), T - 1) - start
        obs = {}
        for key in self._low_dim_keys:
            obs[key] = torch.from_numpy(arrays[f"obs/{key}"][start:stop][steps])
        seen = steps[:self.image_steps]  # the images of the steps a policy observes
        for key in self._image_keys:
            frames = self._images(name, key, start, start + int(seen[-1]) + 1)[seen]
            obs[key] = image_to_tensor(frames, self.image_dtype)  # (image_steps, 1, H, W)
        return {
            "obs": obs,
            "actions": torch.from_numpy(arrays["actions"][start:stop][steps]),
            "planned_actions": torch.from_numpy(arrays["planned_actions"][start:stop][steps]),
            "rewards": torch.from_numpy(arrays["rewards"][start:stop][steps]),
            "dones": torch.from_numpy(arrays["dones"][start:stop][steps]),
            "pad_mask": torch.from_numpy(np.arange(start, start + self.seq_length) < T),
            "demo": name,
            "start": start,
        }

    def close(self) -> None:
        """Closes the file handle (if open)."""
        if self._file is not None:
            self._file.close()
            self._file = None
