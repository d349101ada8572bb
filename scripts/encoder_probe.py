"""How precisely an image encoder can locate the task's objects: a quick probe, before a long
policy training, of which encoder settings (crop, resize, trunk) to train with.

    python scripts/encoder_probe.py DATA.hdf5 [--config configs/legato_small_image.yaml]
        --variant crop44 image_resize=0 image_crop=84 --variant play8 image_resize=92 \\
        image_crop=84 ...
        [--head linear|mlp] [--steps 2000] [--batch 64] [--seed 0] [--json FILE]

For each ``--variant NAME OVERRIDE...`` (overrides of the config, as ``legato-drake train
--set`` takes them; the small image config scales to 84² by default, so a crop of the whole
view needs ``image_resize=0``) the script trains, from scratch, the two cameras' encoders of
that config (``ImageEncoder.from_config``) and a read-out on their concatenated features
(``--head``: linear, as the policies' auxiliary head, or an MLP) to regress the normalised
``object_in_tcp`` of single frames (the image policies' auxiliary object loss, without the
policy: what the encoder alone can learn to locate), on the demos of the
``train`` split, with Adam and a learning rate decayed along a half cosine. It then prints,
over every frame of the ``valid`` split (evaluation mode: the centre crop), how far each
object body's position read by the head is from the true one (median and 90th percentile,
mm), the median over the validation frames taken while the demo holds the grasp closed
(carrying and placing the lid, where the pot matters), the same medians on as many training
frames (does it generalise or overfit?), and the training time per step. The same seed gives
every variant the same initialisation draws and the same batches.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import torch
from torch import nn
from torch.utils.data import DataLoader
from tqdm import tqdm

from legato_drake.data.derived import VALUES_PER_BODY
from legato_drake.data.layout import IMAGE_KEYS
from legato_drake.data.torch_dataset import DemoSequenceDataset
from legato_drake.errors import ConfigError
from legato_drake.learning.config import LearningConfig, apply_overrides, load_config
from legato_drake.learning.encoders import ImageEncoder
from legato_drake.learning.normalization import OBS_MIN_STD, Normalizer, compute_stats


def frames_of(path: Path, split: str) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Every step of ``split``'s demos: uint8 frames (N, 2, 1, H, W), ``object_in_tcp``
    (N, 9k) float32 and whether the step's action holds the grasp closed (N,), read once
    through the training dataset."""
    data = DemoSequenceDataset(path, (*IMAGE_KEYS, "object_in_tcp"), seq_length=1, split=split,
                               pad_seq_length=False, cache_images=True, image_dtype="uint8")
    frames, targets, closed = [], [], []
    for batch in DataLoader(data, batch_size=1024):
        frames.append(torch.stack([batch["obs"][k][:, 0] for k in IMAGE_KEYS], 1))
        targets.append(batch["obs"]["object_in_tcp"][:, 0])
        closed.append(batch["actions"][:, 0, 6] > 0.5)
    return torch.cat(frames), torch.cat(targets), torch.cat(closed)


class Probe(nn.Module):
    """The two cameras' encoders and a read-out of ``object_in_tcp`` (normalised): linear, as
    the policies' auxiliary head, or an MLP (2 x 256, ReLU: what a nonlinear reader such as
    the policy's LSTM and MLP could get from the same features)."""

    def __init__(self, config: LearningConfig, targets: torch.Tensor, head: str = "linear"):
        super().__init__()
        self.encoders = nn.ModuleList(ImageEncoder.from_config(config) for _ in IMAGE_KEYS)
        width = config.feature_dim * len(IMAGE_KEYS)
        self.head = nn.Linear(width, targets.shape[1]) if head == "linear" else nn.Sequential(
            nn.Linear(width, 256), nn.ReLU(), nn.Linear(256, 256), nn.ReLU(),
            nn.Linear(256, targets.shape[1]))
        stats = compute_stats([targets.numpy()], OBS_MIN_STD)  # as training normalises it
        self.normalizer = Normalizer(stats["mean"], stats["std"])

    def forward(self, frames: torch.Tensor) -> torch.Tensor:
        images = frames.float() / 255.0
        features = [enc(images[:, i]) for i, enc in enumerate(self.encoders)]
        return self.head(torch.cat(features, -1))


def position_errors(probe: Probe, frames: torch.Tensor, targets: torch.Tensor,
                    batch: int = 256) -> np.ndarray:
    """(N, bodies) position errors (mm) of the head's read-out on ``frames``."""
    probe.eval()
    with torch.no_grad():
        read = torch.cat([probe.normalizer.inverse(probe(frames[i:i + batch]))
                          for i in range(0, len(frames), batch)])
    n = VALUES_PER_BODY["object_in_tcp"]
    bodies = targets.shape[1] // n
    diff = (read - targets).reshape(len(targets), bodies, n)[..., :3]
    return 1000 * diff.norm(dim=-1).numpy()


def run_variant(config: LearningConfig, train: tuple, valid: tuple, steps: int, batch: int,
                seed: int, lr: float, head: str) -> tuple[np.ndarray, np.ndarray, float]:
    """Trains one probe; its position errors (N, bodies) on the validation frames and on as
    many training frames (whether it generalises or overfits), and seconds per step."""
    torch.manual_seed(seed)
    frames, targets, _ = train
    probe = Probe(config, targets, head)
    optimizer = torch.optim.Adam(probe.parameters(), lr=lr)
    goal = probe.normalizer(targets)
    generator = torch.Generator().manual_seed(seed)
    start = time.perf_counter()
    for step in tqdm(range(steps), desc=config.name, leave=False):
        for group in optimizer.param_groups:
            group["lr"] = lr * 0.5 * (1 + math.cos(math.pi * step / steps))
        pick = torch.randint(len(frames), (batch,), generator=generator)
        probe.train()
        loss = (probe(frames[pick]) - goal[pick]).pow(2).mean()
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        nn.utils.clip_grad_norm_(probe.parameters(), 1.0)
        optimizer.step()
    per_step = (time.perf_counter() - start) / steps
    seen = torch.randperm(len(frames), generator=generator)[:len(valid[0])]
    return (position_errors(probe, *valid[:2]),
            position_errors(probe, frames[seen], targets[seen]), per_step)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("data", type=Path, help="an image dataset (HDF5) with object poses")
    parser.add_argument("--config", type=Path, default=Path("configs/legato_small_image.yaml"))
    parser.add_argument("--variant", nargs="+", action="append", required=True,
                        metavar=("NAME", "OVERRIDE"),
                        help="a name, then config overrides (key=value); repeatable")
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--batch", type=int, default=64)
    parser.add_argument("--lr", type=float, default=1e-3)
    parser.add_argument("--head", choices=("linear", "mlp"), default="linear",
                        help="the read-out: linear (the policies' auxiliary head) or an MLP")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--json", type=Path, help="also write the rows to this file")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    if not args.data.is_file():
        parser.error(f"data: no dataset file {args.data}")
    if args.steps < 1 or args.batch < 1:
        parser.error("--steps and --batch must be at least 1")
    configs = []
    for name, *overrides in args.variant:
        try:
            configs.append(apply_overrides(load_config(args.config), [*overrides,
                                                                      f"name={name}"]))
        except ConfigError as e:
            parser.error(f"--variant {name}: {e}")
    torch.set_num_threads(args.threads)
    train, valid = frames_of(args.data, "train"), frames_of(args.data, "valid")
    with h5py.File(args.data, "r") as f:
        demo = next(iter(f["data"]))
        names = json.loads(f[f"data/{demo}"].attrs["object_bodies"])
    closed = valid[2].numpy()
    logging.info("%s: %d training frames, %d validation frames (%d with the grasp closed)",
                 args.data, len(train[0]), len(valid[0]), closed.sum())
    rows = []
    for config in configs:
        errors, fitted, per_step = run_variant(config, train, valid, args.steps, args.batch,
                                       args.seed, args.lr, args.head)
        rows.append({"variant": config.name, "head": args.head, "steps": args.steps,
                     "ms_per_step":
                     1000 * per_step, **{f"{body}_median_mm": float(np.median(errors[:, i]))
                                         for i, body in enumerate(names)},
                     **{f"{body}_p90_mm": float(np.percentile(errors[:, i], 90))
                        for i, body in enumerate(names)},
                     **{f"{body}_closed_median_mm": float(np.median(errors[closed, i]))
                        for i, body in enumerate(names)},
                     **{f"{body}_train_median_mm": float(np.median(fitted[:, i]))
                        for i, body in enumerate(names)}})
    header = ["variant", "ms/step", *[f"{b}, valid median (p90) / grasp closed / train "
                                      f"median, mm" for b in names]]
    print("| " + " | ".join(header) + " |")
    print("| " + " | ".join("---" for _ in header) + " |")
    for row in rows:
        cells = [row["variant"], f"{row['ms_per_step']:.0f}",
                 *[f"{row[f'{b}_median_mm']:.1f} ({row[f'{b}_p90_mm']:.1f}) / "
                   f"{row[f'{b}_closed_median_mm']:.1f} / {row[f'{b}_train_median_mm']:.1f}"
                   for b in names]]
        print("| " + " | ".join(cells) + " |")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
