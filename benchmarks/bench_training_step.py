"""L_invar's share of one training step: the step with and without the regularizer.

Times one optimizer step (forward, loss, backward, Adam) of a batch of 16 sequences x 20 steps
for each config, once with ``invariant_weight`` 0 and once with the config's weight, on random
observations (the time does not depend on the data), and prints the ratio. The paper config
(ResNet-18 trunks on 2 x 320 images per step) takes tens of seconds per step on a 2-core CPU:
it runs with ``--configs legato_paper`` (and ``--device cuda`` where there is a GPU). Usage:

    python benchmarks/bench_training_step.py [--steps 20] [--threads 1] [--device cpu]
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np
import torch

from legato_drake.data.derived import observation_sizes
from legato_drake.learning.config import load_config
from legato_drake.learning.policies import IMAGE_KEYS, RecurrentGMMPolicy
from legato_drake.summary import format_table

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
DIMS = observation_sizes(3)  # the lid scene's stove, pot and lid
BATCH, SEQUENCE = 16, 20


def random_batch(keys: list[str], device: str) -> dict:
    """A batch of raw observations and actions shaped like ``DemoSequenceDataset``'s."""
    gen = torch.Generator().manual_seed(0)
    obs = {}
    for key in keys:
        if key in IMAGE_KEYS:
            obs[key] = torch.rand(BATCH, SEQUENCE, 1, 128, 128, generator=gen)
        else:
            obs[key] = 0.01 * torch.randn(BATCH, SEQUENCE, DIMS[key], generator=gen)
    actions = 0.01 * torch.randn(BATCH, SEQUENCE, 7, generator=gen)
    actions[..., 6] = (actions[..., 6] > 0).float()
    return {"obs": {k: v.to(device) for k, v in obs.items()}, "actions": actions.to(device),
            "pad_mask": torch.ones(BATCH, SEQUENCE, dtype=torch.bool, device=device)}


def time_steps(config, steps: int, device: str) -> float:
    """Median seconds per optimizer step of ``config`` (after two warm-up steps)."""
    stats = {k: {"mean": np.zeros(d, np.float32), "std": np.ones(d, np.float32)}
             for k, d in DIMS.items()}
    torch.manual_seed(0)
    policy = RecurrentGMMPolicy(config, stats).to(device)
    optimizer = torch.optim.Adam(policy.parameters(), lr=config.lr)
    batch = random_batch(config.obs_keys, device)
    times = []
    for _ in range(steps + 2):
        start = time.perf_counter()
        loss = policy.losses(batch)["total"]
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        optimizer.step()
        if device.startswith("cuda"):
            torch.cuda.synchronize()
        times.append(time.perf_counter() - start)
    return float(np.median(times[2:]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--configs", default="legato_small_state,legato_small_image")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    rows = []
    for name in args.configs.split(","):
        config = load_config(CONFIGS / f"{name}.yaml")
        weight = config.invariant_weight or 0.005
        without = time_steps(dataclasses.replace(config, invariant_weight=0.0), args.steps,
                             args.device)
        with_invar = time_steps(dataclasses.replace(config, invariant_weight=weight),
                                args.steps, args.device)
        rows.append([name, 1e3 * without, 1e3 * with_invar,
                     100.0 * (with_invar - without) / without])
    print(f"batch {BATCH} x {SEQUENCE} steps, {args.device}, torch {torch.__version__}, "
          f"{args.threads} thread(s), median of {args.steps} steps")
    print(format_table(["config", "ms/step without L_invar", "ms/step with L_invar",
                        "L_invar adds %"], rows))


if __name__ == "__main__":
    main()
