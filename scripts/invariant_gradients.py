"""How hard the chunk L_invar pulls on a Diffusion Policy against its denoising loss, and why
its floor is where it is.

    python scripts/invariant_gradients.py DATA.hdf5 [--config configs/dp_reltraj_state.yaml]
        [--checkpoint RUN/step_020000.pt] [--weight 0.001] [--batch 64] [--set FIELD=VALUE]

For one seeded training batch of DATA and each of a few noise levels t (every sample of the
batch at that level), prints the DDPM loss, L_invar, and the gradient norms (over the
network's trained weights) of the DDPM loss and of ``weight`` x L_invar: for a freshly
initialised network of ``--config`` and, with ``--checkpoint``, for a trained one, whose rows
also give how far the clean chunk it implies at that level is from the demonstrated one (RMS
per step of the pose deltas, mm and mrad). A term whose gradient is orders of magnitude above
the other's decides where Adam moves the weights. A second table gives L_invar's floor on the
data alone: the demonstrated chunks with Gaussian noise of sigma (m and rad a step) added,
at the invariants' defaults and at the config's ``invariant_eps`` and ``invariant_turn_eps``.
"""

from __future__ import annotations

import argparse

import torch
from torch.utils.data import DataLoader

from legato_drake.data.torch_dataset import DemoSequenceDataset
from legato_drake.invariants import (
    DEFAULT_EPS,
    DEFAULT_TURN_EPS,
    invariant_loss,
)
from legato_drake.learning.checkpoint import load_checkpoint
from legato_drake.learning.config import load_config
from legato_drake.learning.diffusion import DiffusionPolicy, training_chunks
from legato_drake.learning.registry import build_policy
from legato_drake.learning.train import dataset_stats
from legato_drake.summary import format_table

SIGMAS = (1e-6, 1e-5, 1e-4, 1e-3)


def gradient_norm(loss: torch.Tensor, params: list[torch.nn.Parameter]) -> float:
    grads = torch.autograd.grad(loss, params, retain_graph=True, allow_unused=True)
    return float(torch.sqrt(sum((g ** 2).sum() for g in grads if g is not None)))


def demonstration(policy: DiffusionPolicy, batch: dict) -> tuple[torch.Tensor, torch.Tensor]:
    """The batch's demonstrated history (B, T, 6) and chunk (B, P, 7), as the loss reads them."""
    cfg = policy.config
    return (policy.demonstrated_history(batch),
            training_chunks(batch, cfg.obs_horizon - 1, cfg.pred_horizon, cfg.chunk_targets))


@torch.no_grad()
def clean_chunk_error(policy: DiffusionPolicy, batch: dict, level: int) -> tuple[float, float]:
    """RMS per step (mm, mrad) of the pose deltas of the clean chunk the policy's rollout
    network implies at ``level`` against the demonstrated chunk (the same noise for all)."""
    chunk = demonstration(policy, batch)[1]
    x0 = policy._scale(chunk)
    t = torch.full((len(x0),), level)
    noisy = policy.train_scheduler.add_noise(
        x0, torch.randn(x0.shape, generator=torch.Generator().manual_seed(1)), t)
    net = policy.ema
    predicted = net["unet"](noisy, t, net["conditioner"](
        {k: v[:, :policy.config.obs_horizon] for k, v in batch["obs"].items()}))
    error = policy._unscale(policy.clean_chunk(noisy, predicted, t))[..., :6] - chunk[..., :6]
    return (float(error[..., :3].pow(2).mean().sqrt()) * 1e3,
            float(error[..., 3:].pow(2).mean().sqrt()) * 1e3)


def rows(policy: DiffusionPolicy, batch: dict, weight: float, label: str) -> list[list]:
    policy.train()
    params = [p for p in policy.net.parameters() if p.requires_grad]
    out = []
    steps = policy.config.diffusion_steps
    for level in sorted({0, steps // 10, steps // 2, 9 * steps // 10, steps - 1}):
        losses = policy.losses(batch, torch.full((len(batch["actions"]),), level))
        error = clean_chunk_error(policy, batch, level) if label == "trained" else ("", "")
        out.append([label, level, f"{float(policy.train_scheduler.alphas_cumprod[level]):.2g}",
                    *error, float(losses["mse"].detach()), float(losses["invar"].detach()),
                    gradient_norm(losses["mse"], params),
                    gradient_norm(weight * losses["invar"], params)])
    return out


def floor_rows(policy: DiffusionPolicy, batch: dict) -> list[list]:
    """L_invar of the demonstrated chunks perturbed by sigma, per resolution."""
    config = policy.config
    history, chunk = demonstration(policy, batch)
    demo = chunk[..., :6].double()
    generator = torch.Generator().manual_seed(2)
    noise = torch.randn(demo.shape, generator=generator, dtype=demo.dtype)
    out = []
    for eps, turn_eps in {(DEFAULT_EPS, DEFAULT_TURN_EPS),
                          (config.invariant_eps, config.invariant_turn_eps)}:
        out.append([f"{eps:g}", f"{turn_eps:g}"] + [
            float(invariant_loss(history, demo + sigma * noise, demo, eps=eps,
                                 turn_eps=turn_eps)) for sigma in SIGMAS])
    return sorted(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data")
    parser.add_argument("--config", default="configs/dp_reltraj_state.yaml")
    parser.add_argument("--checkpoint", help="a trained run's checkpoint of the same config")
    parser.add_argument("--weight", type=float, default=0.001, help="L_invar's weight")
    parser.add_argument("--batch", type=int, default=64)
    parser.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                        help="config overrides, e.g. invariant_eps=0.005 (repeatable)")
    args = parser.parse_args()
    torch.set_num_threads(1)
    torch.manual_seed(0)
    # invariant_weight > 0 makes losses() compute L_invar; its value does not enter here.
    config = load_config(args.config, [f"invariant_weight={max(args.weight, 1e-9)}", *args.set])
    data = DemoSequenceDataset(args.data, config.dataset_keys, config.seq_length, "train")
    batch = next(iter(DataLoader(data, batch_size=args.batch, shuffle=True,
                                 generator=torch.Generator().manual_seed(0))))
    initial = build_policy(config, dataset_stats(args.data, config))
    table = rows(initial, batch, args.weight, "initial")
    if args.checkpoint:
        trained = load_checkpoint(args.checkpoint).policy
        trained.config = config
        table += rows(trained, batch, args.weight, "trained")
    print(format_table(["network", "level t", "alpha_bar", "clean chunk mm", "mrad",
                        "DDPM loss", "L_invar", "|grad DDPM|",
                        f"|grad {args.weight:g} L_invar|"], table))
    steps = demonstration(initial, batch)[1][..., :6]
    moves, turns = steps[..., :3].norm(dim=-1), steps[..., 3:].norm(dim=-1)
    print(f"\nthe demonstrated chunks' steps: {float((moves < 1e-6).double().mean()):.0%} "
          f"at rest, median {float(moves.median()) * 1e3:.1f} mm, "
          f"{float((turns < 1e-6).double().mean()):.0%} without rotation")
    print(format_table(["eps", "turn_eps"] + [f"L_invar, sigma {s:g}" for s in SIGMAS],
                       floor_rows(initial, batch)))


if __name__ == "__main__":
    main()
