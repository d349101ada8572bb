"""How well a Diffusion Policy checkpoint fits its demonstrations, open loop.

    python scripts/chunk_fit.py RUN/step_020000.pt DATA.hdf5 [--split valid] [--windows 300]

For ``--windows`` random windows of the demos in ``--split`` (seeded), the policy samples a
chunk from the window's first ``obs_horizon`` observations, as it would at rollout. Over the
executed part of the chunk (``action_horizon`` steps, or ``--steps``) the script prints:

* the median and 90th percentile distance between where the sampled and the demonstrated
  chunk (the expert's plan from that step, ``data.derived.planned_actions``) put the
  gripper at its last step;
* beside it, the demonstration's own displacement there, and how far its recorded actions,
  composed, end from the plan (their DART corrections: the chunk that ``chunk_targets:
  actions`` trains on);
* how often the grasp commands agree (all windows, and the windows where the demonstration
  switches its grasp).

A policy that does not fit its training split is under-trained or under-informed; one that
fits but fails in closed loop is not.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import torch

from legato_drake.data.torch_dataset import SPLITS, DemoSequenceDataset
from legato_drake.learning.checkpoint import load_checkpoint
from legato_drake.learning.diffusion import (
    DiffusionPolicy,
    DiffusionState,
    deltas_to_reltraj,
    training_chunks,
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("checkpoint", type=Path, help="a Diffusion Policy checkpoint")
    parser.add_argument("data", type=Path, help="its demonstrations (HDF5)")
    parser.add_argument("--split", choices=SPLITS, default="valid")
    parser.add_argument("--windows", type=int, default=300, help="windows sampled (300)")
    parser.add_argument("--steps", type=int, default=None,
                        help="chunk steps compared (default: the config's action_horizon)")
    args = parser.parse_args()
    torch.set_num_threads(1)
    ckpt = load_checkpoint(args.checkpoint)
    policy, cfg = ckpt.policy, ckpt.config
    if not isinstance(policy, DiffusionPolicy):
        parser.error(f"{args.checkpoint} is a {cfg.algo} checkpoint, not a Diffusion Policy "
                     f"(dp_velocity, dp_reltraj)")
    To, steps = cfg.obs_horizon, args.steps or cfg.action_horizon
    if not 1 <= steps <= cfg.pred_horizon:
        parser.error(f"--steps must be 1-{cfg.pred_horizon}, got {steps}")
    data = DemoSequenceDataset(args.data, cfg.obs_keys, cfg.seq_length, args.split)
    picks = np.random.default_rng(0).permutation(len(data))[:args.windows]
    errors, moves, drifts, agree, agree_at_switch = [], [], [], [], []
    for n, i in enumerate(picks):
        item = data[int(i)]
        if not item["pad_mask"][To - 1:To - 1 + steps].all():
            continue  # the chunk would run past the demo's end
        window = tuple({k: item["obs"][k][t:t + 1].numpy() for k in cfg.obs_keys}
                       for t in range(To))
        latest = {k: item["obs"][k][To - 1:To] for k in cfg.obs_keys}
        chunk, _ = policy.act(latest, DiffusionState(window, n))
        sampled = chunk[0, :steps].double()
        batch = {k: item[k][None] for k in ("actions", "planned_actions")}
        shown = training_chunks(batch, To - 1, steps, "planned")[0].double()
        recorded = training_chunks(batch, To - 1, steps, "actions")[0].double()
        end_sampled = deltas_to_reltraj(sampled)[-1, :3]
        end_shown = deltas_to_reltraj(shown)[-1, :3]
        errors.append(1000 * float(torch.linalg.norm(end_sampled - end_shown)))
        drifts.append(1000 * float(torch.linalg.norm(deltas_to_reltraj(recorded)[-1, :3]
                                                     - end_shown)))
        moves.append(1000 * float(torch.linalg.norm(end_shown)))
        same = float((sampled[:, 6] == shown[:, 6]).double().mean())
        agree.append(same)
        grasps = torch.cat([item["actions"][To - 2:To - 1, 6].double(), shown[:, 6]])
        if To >= 2 and bool((grasps.diff() != 0).any()):
            agree_at_switch.append(same)
    at_switch = (f"{np.mean(agree_at_switch):.3f} (n = {len(agree_at_switch)})"
                 if agree_at_switch else "no window switches")
    print(f"{args.checkpoint} on the {args.split} demos, {len(errors)} windows, "
          f"{steps} steps each:\n"
          f"  gripper position at step {steps}: error median {np.median(errors):.1f} mm, "
          f"90th percentile {np.percentile(errors, 90):.1f} mm "
          f"(the demonstrations move {np.median(moves):.1f} mm, median; their recorded "
          f"actions composed end {np.median(drifts):.1f} mm from the plan, median)\n"
          f"  grasp agreement {np.mean(agree):.3f}; where the demo switches: {at_switch}")


if __name__ == "__main__":
    main()
