"""What an image policy sees: one demo's camera frames from one or more datasets, side by side.

    python scripts/dataset_frames.py DATA.hdf5 [DATA2.hdf5 ...] [--demo 0] [--steps 0,40,80,-1]
        [--camera left|right|both] [--out frames.png]

One row per dataset (and camera, with ``--camera both``), one column per step of demo
``--demo`` (negative steps count from its end). Datasets collected from the same scene seeds
and expert noise hold the same motions, so their rows differ only in how the images were
made (e.g. ``camera.model`` pinhole against fisheye: ``collect --camera-model``, a grid
dataset's ``camera_model``). The row titles give each dataset's file name and camera model.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from legato_drake.data.layout import recorded_camera  # noqa: E402

CAMERAS = {"left": ("left_gray",), "right": ("right_gray",), "both": ("left_gray", "right_gray")}


def _steps(text: str) -> list[int]:
    try:
        return [int(s) for s in text.split(",") if s.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated step indices such as 0,40,-1, got {text!r}") from None


def demo_frames(path: Path, demo: int, steps: list[int], key: str) -> tuple[list[np.ndarray],
                                                                           list[int], str]:
    """The frames of camera ``key`` at ``steps`` of ``demo`` in ``path``, the steps as
    non-negative indices, and the dataset's camera model."""
    with h5py.File(path, "r") as f:
        group = f.get(f"data/demo_{demo}")
        if group is None:
            raise SystemExit(f"{path}: no demo_{demo} (--demo)")
        if key not in group["obs"]:
            raise SystemExit(f"{path}: no camera images (a dataset collected with --no-camera)")
        images = group["obs"][key]
        n = images.shape[0]
        bad = [s for s in steps if not -n <= s < n]
        if bad:
            raise SystemExit(f"--steps {bad}: demo_{demo} of {path} has {n} steps")
        frames = [images[s % n][..., 0] for s in steps]
    return frames, [s % n for s in steps], recorded_camera(path).get("model", "pinhole")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("datasets", nargs="+", type=Path)
    parser.add_argument("--demo", type=int, default=0)
    parser.add_argument("--steps", type=_steps, default=[0, 40, 80, -1])
    parser.add_argument("--camera", choices=sorted(CAMERAS), default="left")
    parser.add_argument("--out", type=Path, default=Path("frames.png"))
    args = parser.parse_args(argv)
    for path in args.datasets:
        if not path.is_file():
            raise SystemExit(f"{path}: no such dataset")
    rows = [(path, key) for path in args.datasets for key in CAMERAS[args.camera]]
    fig, axes = plt.subplots(len(rows), len(args.steps), squeeze=False,
                             figsize=(2.0 * len(args.steps), 2.1 * len(rows)))
    for r, (path, key) in enumerate(rows):
        frames, indices, model = demo_frames(path, args.demo, args.steps, key)
        for c, (frame, step) in enumerate(zip(frames, indices, strict=True)):
            ax = axes[r][c]
            ax.imshow(frame, cmap="gray", vmin=0, vmax=255)
            ax.set_xticks([])
            ax.set_yticks([])
            if r == 0:
                ax.set_title(f"step {step} ({step / 10:.1f} s)", fontsize=9)
        axes[r][0].set_ylabel(f"{path.stem[:22]}\n{model}, {key.split('_')[0]}", fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(args.out)


if __name__ == "__main__":
    sys.exit(main())
