"""How hard the chunk L_invar pulls on a Diffusion Policy against its denoising loss.

    python scripts/invariant_gradients.py DATA.hdf5 [--config configs/dp_reltraj_state.yaml]
        [--checkpoint RUN/step_020000.pt] [--weight 0.001] [--batch 64]

For one seeded training batch of DATA and each of a few noise levels t (every sample of the
batch at that level), prints the DDPM loss, L_invar, and the gradient norms (over the
network's trained weights) of the DDPM loss and of ``weight`` x L_invar: for a freshly
initialised network of ``--config`` and, with ``--checkpoint``, for a trained one. A term whose
gradient is orders of magnitude above the other's decides where Adam moves the weights.
"""

from __future__ import annotations

import argparse

import torch
from torch.utils.data import DataLoader

from legato_drake.data.torch_dataset import DemoSequenceDataset
from legato_drake.learning.checkpoint import load_checkpoint
from legato_drake.learning.config import load_config
from legato_drake.learning.diffusion import DiffusionPolicy
from legato_drake.learning.registry import build_policy
from legato_drake.learning.train import dataset_stats
from legato_drake.summary import format_table


def gradient_norm(loss: torch.Tensor, params: list[torch.nn.Parameter]) -> float:
    grads = torch.autograd.grad(loss, params, retain_graph=True, allow_unused=True)
    return float(torch.sqrt(sum((g ** 2).sum() for g in grads if g is not None)))


def rows(policy: DiffusionPolicy, batch: dict, weight: float, label: str) -> list[list]:
    policy.train()
    params = [p for p in policy.net.parameters() if p.requires_grad]
    out = []
    steps = policy.config.diffusion_steps
    for level in sorted({0, steps // 10, steps // 2, 9 * steps // 10, steps - 1}):
        losses = policy.losses(batch, torch.full((len(batch["actions"]),), level))
        out.append([label, level, f"{float(policy.train_scheduler.alphas_cumprod[level]):.2g}",
                    float(losses["mse"].detach()), float(losses["invar"].detach()),
                    gradient_norm(losses["mse"], params),
                    gradient_norm(weight * losses["invar"], params)])
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data")
    parser.add_argument("--config", default="configs/dp_reltraj_state.yaml")
    parser.add_argument("--checkpoint", help="a trained run's checkpoint of the same config")
    parser.add_argument("--weight", type=float, default=0.001, help="L_invar's weight")
    parser.add_argument("--batch", type=int, default=64)
    parser.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                        help="config overrides, e.g. invariant_eps=1e-3 (repeatable)")
    args = parser.parse_args()
    torch.set_num_threads(1)
    torch.manual_seed(0)
    # invariant_weight > 0 makes losses() compute L_invar; its value does not enter here.
    config = load_config(args.config, [f"invariant_weight={max(args.weight, 1e-9)}", *args.set])
    data = DemoSequenceDataset(args.data, config.dataset_keys, config.seq_length, "train")
    batch = next(iter(DataLoader(data, batch_size=args.batch, shuffle=True,
                                 generator=torch.Generator().manual_seed(0))))
    table = rows(build_policy(config, dataset_stats(args.data, config)), batch, args.weight,
                 "initial")
    if args.checkpoint:
        trained = load_checkpoint(args.checkpoint).policy
        trained.config = config
        table += rows(trained, batch, args.weight, "trained")
    print(format_table(["network", "level t", "alpha_bar", "DDPM loss", "L_invar",
                        "|grad DDPM|", f"|grad {args.weight:g} L_invar|"], table))


if __name__ == "__main__":
    main()
