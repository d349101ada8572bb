"""A copy of a dataset that robomimic's image path reads unchanged
(``legato-drake export --format robomimic``).

Our files already follow robomimic's HDF5 layout (``data/demo_<i>/{actions, rewards, dones,
states, obs/...}``, ``mask/train``, ``mask/valid``, ``data.attrs["env_args"]``) and its
low-dim path trains on them as they are. Its RGB processor, though, expects 3-channel
``(T, H, W, 3)`` uint8 images, and ours are 1-channel grayscale. The copy adds
``obs/left_rgb`` and ``obs/right_rgb``: the gray images repeated into 3 channels; list them
under ``observation.modalities.obs.rgb`` in a robomimic config (and e.g.
``delta_positions``, ``delta_eulers`` under ``low_dim``). Everything else is copied as it is.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np

from legato_drake.data.layout import DatasetError, open_dataset, sorted_demos
from legato_drake.errors import ConfigError

RGB_KEYS = {"left_gray": "left_rgb", "right_gray": "right_rgb"}
"""Our grayscale observation -> the 3-channel copy robomimic's image path reads."""


def export_robomimic(data: str | Path, out: str | Path, overwrite: bool = False) -> list[str]:
    """Writes ``out``: ``data`` with 3-channel copies of its images; returns the RGB keys
    written (none for a state-only dataset, which robomimic reads as it is)."""
    data, out = Path(data), Path(out)
    if out.exists() and not overwrite:
        raise ConfigError(f"--out {out} exists: choose another --out or pass --overwrite")
    if out.resolve() == data.resolve():
        raise ConfigError(f"--out {out} is the dataset itself: choose another --out")
    with open_dataset(data) as f:
        if not sorted_demos(f["data"]):
            raise DatasetError(f"{data}: no demonstrations to export")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.name}.tmp")
    written: list[str] = []
    try:
        shutil.copyfile(data, tmp)
        with h5py.File(tmp, "r+") as f:
            for name in sorted_demos(f["data"]):
                obs = f["data"][name]["obs"]
                for gray, rgb in RGB_KEYS.items():
                    if gray in obs and rgb not in obs:
                        images = obs[gray][()]
                        obs.create_dataset(rgb, data=np.repeat(images, 3, axis=3),
                                           compression="gzip", compression_opts=4,
                                           chunks=(1, *images.shape[1:3], 3))
                        if rgb not in written:
                            written.append(rgb)
        tmp.replace(out)
    finally:
        tmp.unlink(missing_ok=True)
    return written
