"""One training step: L_invar's share of it, and what the image levers buy.

Times one optimizer step (forward, loss, backward, Adam, the weight average where the family
keeps one) of a batch of the config's own shape (``batch_size`` windows of ``seq_length``
steps: 16 x 20 for LEGATO and BC-RNN, 64 x 17 for Diffusion Policy, whose windows hold images
for their ``obs_horizon`` steps alone, as training loads them) for each config, once with
``invariant_weight`` 0 and once with the config's weight (0.005 where it has none), on random
observations (the time does not depend on the data), and prints the ratio. For the image
configs it then times the step (without L_invar) at each image lever: the input size (the
whole 128² view, a crop of it, ``image_crop``, or the whole view scaled down,
``image_resize``) and the trunk's precision (``encoder_precision``), and prints ms per step,
images per second (2 cameras x the frames a step encodes) and the speed-up over the
uncropped float32 step. The paper config (ResNet-18 trunks) takes tens of seconds per step on
a 2-core CPU: it runs with ``--configs legato_paper`` (and ``--device cuda`` where there is a
GPU).
Usage:

    python benchmarks/bench_training_step.py [--steps 20] [--threads 1] [--device cpu]
        [--configs legato_small_state,legato_small_image] [--json FILE]
    python benchmarks/bench_training_step.py --configs dp_reltraj_state,dp_reltraj_image
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

import numpy as np
import torch

from legato_drake.data.derived import observation_sizes
from legato_drake.data.layout import HISTORY_KEYS, IMAGE_KEYS
from legato_drake.learning.config import load_config
from legato_drake.learning.hardware import cpu_model, native_bfloat16
from legato_drake.learning.registry import build_policy, extra_stats, observed_steps
from legato_drake.summary import format_table

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
DIMS = observation_sizes(3)  # the lid scene's stove, pot and lid


def random_batch(config, device: str) -> dict:
    """A batch of raw observations and actions shaped like ``DemoSequenceDataset``'s in
    training: ``batch_size`` windows of ``seq_length`` steps, images for the steps the family
    observes."""
    gen = torch.Generator().manual_seed(0)
    B, T = config.batch_size, config.seq_length
    # L_invar reads the commanded pose deltas whether or not the policy observes them.
    keys = list(dict.fromkeys([*config.dataset_keys, *HISTORY_KEYS]))
    obs = {}
    for key in keys:
        if key in IMAGE_KEYS:
            obs[key] = torch.rand(B, observed_steps(config), 1, 128, 128, generator=gen)
        else:
            obs[key] = 0.01 * torch.randn(B, T, DIMS[key], generator=gen)
    actions = 0.01 * torch.randn(B, T, 7, generator=gen)
    actions[..., 6] = (actions[..., 6] > 0).float()
    return {"obs": {k: v.to(device) for k, v in obs.items()}, "actions": actions.to(device),
            "planned_actions": actions.clone().to(device),
            "pad_mask": torch.ones(B, T, dtype=torch.bool, device=device)}


def time_steps(config, steps: int, device: str) -> float:
    """Median seconds per optimizer step of ``config`` (after two warm-up steps)."""
    stats = {k: {"mean": np.zeros(d, np.float32), "std": np.ones(d, np.float32)}
             for k, d in DIMS.items()}
    batch = random_batch(config, device)
    stats.update(extra_stats(config, list(batch["actions"].cpu().numpy())))
    torch.manual_seed(0)
    policy = build_policy(config, stats).to(device)
    optimizer = torch.optim.Adam(policy.parameters(), lr=config.lr)
    times = []
    for step in range(steps + 2):
        start = time.perf_counter()
        loss = policy.losses(batch)["total"]
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        optimizer.step()
        policy.after_step(step + 1)
        if device.startswith("cuda"):
            torch.cuda.synchronize()
        times.append(time.perf_counter() - start)
    return float(np.median(times[2:]))


IMAGE_LEVERS = [(0, 0, "float32"), (0, 0, "bfloat16"), (0, 96, "float32"), (0, 84, "float32"),
                (0, 84, "bfloat16"), (84, 0, "float32"), (84, 0, "bfloat16")]
"""(image_resize, image_crop, encoder_precision) triples timed for the image configs; the
last two are the small image config's own (the whole view scaled to 84², no crop) in float32
and in its bfloat16, which is faster only on a CPU with native bfloat16 (the header says)."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--configs", default="legato_small_state,legato_small_image")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the rows there")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    rows, levers, records = [], [], []
    for name in args.configs.split(","):
        config = load_config(CONFIGS / f"{name}.yaml")
        weight = config.invariant_weight or 0.005
        without = time_steps(dataclasses.replace(config, invariant_weight=0.0), args.steps,
                             args.device)
        with_invar = time_steps(dataclasses.replace(config, invariant_weight=weight),
                                args.steps, args.device)
        rows.append([f"{name} ({config.batch_size} x {config.seq_length})", 1e3 * without,
                     1e3 * with_invar, 100.0 * (with_invar - without) / without])
        records.append(dict(config=name, ms_without_invar=1e3 * without,
                            ms_with_invar=1e3 * with_invar))
        if config.obs_mode != "image":
            continue
        base = None
        for resize, crop, precision in IMAGE_LEVERS:
            seconds = time_steps(dataclasses.replace(
                config, invariant_weight=0.0, image_resize=resize, image_crop=crop,
                encoder_precision=precision), args.steps, args.device)
            base = base or seconds
            images = 2 * config.batch_size * observed_steps(config) / seconds
            size = ("scaled to " if resize else "crop " if crop else "whole ") + \
                str(resize or crop or 128)
            levers.append([name, size, precision, 1e3 * seconds, images,
                           f"{base / seconds:.1f}x"])
            records.append(dict(config=name, image_resize=resize, image_crop=crop,
                                encoder_precision=precision, ms_per_step=1e3 * seconds,
                                images_per_s=images))
    native, cpu = native_bfloat16(), cpu_model()
    said = "unknown" if native is None else "yes" if native else "no"
    print(f"each config's batch, {args.device}, torch {torch.__version__}, "
          f"{args.threads} thread(s), median of {args.steps} steps; {cpu}, native bfloat16: "
          f"{said}")
    print(format_table(["config", "ms/step without L_invar", "ms/step with L_invar",
                        "L_invar adds %"], rows))
    if levers:
        print()
        print(format_table(["config", "images", "precision", "ms/step", "images/s",
                            "speed-up"], levers))
    if args.json is not None:
        args.json.write_text(json.dumps(dict(threads=args.threads, device=args.device,
                                             cpu=cpu, native_bfloat16=native,
                                             rows=records), indent=1))


if __name__ == "__main__":
    main()
