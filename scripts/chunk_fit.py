"""How well a Diffusion Policy checkpoint fits its demonstrations, open loop.

    python scripts/chunk_fit.py RUN/step_020000.pt DATA.hdf5 [--split valid] [--windows 300]
                                [--phases | --phase-edges=-5,0,5,10] [--set FIELD=VALUE]

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

For an image checkpoint trained with the object loss (``object_aux_weight``), the script also
prints how far the objects' positions that its head reads from the latest observed frames
(through the rollout's EMA encoders) are from the true ones, per object body: whether the
encoder locates what the policy must reach. ``--phases`` breaks the gripper error and the
objects' down by where the window's latest observation lies relative to the demo's first
grasp command (``legato_fit.py``'s phases; ``--phase-edges`` sets the bins, in steps from
it), with how far the demonstrated and the sampled chunks move the gripper in each.
``--set`` changes how the policy samples, as ``evaluate --set`` does (e.g.
``rollout_noise=zero``, ``noise_scale=0.5``).

A policy that does not fit its training split is under-trained or under-informed; one that
fits but fails in closed loop is not.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import torch

# The sibling script (this one runs as ``python scripts/chunk_fit.py``, so scripts/ is on the
# path): its demo phases and its report of where an encoder locates the objects.
from legato_fit import grasp_steps, located_in, phases, position_errors_mm, print_located

from legato_drake.data.torch_dataset import SPLITS, DemoSequenceDataset
from legato_drake.errors import ConfigError
from legato_drake.learning.checkpoint import load_checkpoint
from legato_drake.learning.config import apply_rollout_overrides
from legato_drake.learning.diffusion import (
    DiffusionPolicy,
    DiffusionState,
    deltas_to_reltraj,
    training_chunks,
)


def _edges(text: str) -> list[int]:
    try:
        edges = [int(v) for v in text.split(",")]
    except ValueError:
        edges = []
    if len(edges) < 2 or edges != sorted(set(edges)):
        raise argparse.ArgumentTypeError(f"must be two or more increasing integers, e.g. "
                                         f"--phase-edges=-5,0,5,10; got {text!r}")
    return edges


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("checkpoint", type=Path, help="a Diffusion Policy checkpoint")
    parser.add_argument("data", type=Path, help="its demonstrations (HDF5)")
    parser.add_argument("--split", choices=SPLITS, default="valid")
    parser.add_argument("--windows", type=int, default=300, help="windows sampled (300)")
    parser.add_argument("--steps", type=int, default=None,
                        help="chunk steps compared (default: the config's action_horizon)")
    parser.add_argument("--phases", action="store_true",
                        help="the errors by phase, relative to the demo's first grasp command")
    parser.add_argument("--phase-edges", type=_edges, metavar="E0,E1,...",
                        help="--phases with these bins (steps from the first grasp command)")
    parser.add_argument("--set", action="append", metavar="FIELD=VALUE",
                        help="how the policy samples (repeatable), as evaluate --set")
    args = parser.parse_args()
    torch.set_num_threads(1)
    ckpt = load_checkpoint(args.checkpoint)
    try:
        ckpt.policy.config = apply_rollout_overrides(ckpt.config, args.set, "--set")
    except ConfigError as e:
        parser.error(str(e))
    policy, cfg = ckpt.policy, ckpt.policy.config
    if not isinstance(policy, DiffusionPolicy):
        parser.error(f"{args.checkpoint} is a {cfg.algo} checkpoint, not a Diffusion Policy "
                     f"(dp_velocity, dp_reltraj)")
    To, steps = cfg.obs_horizon, args.steps or cfg.action_horizon
    if not 1 <= steps <= cfg.pred_horizon:
        parser.error(f"--steps must be 1-{cfg.pred_horizon}, got {steps}")
    located = policy.object_head is not None
    keys = cfg.dataset_keys  # with object_in_tcp where the policy has an object head
    data = DemoSequenceDataset(args.data, keys, cfg.seq_length, args.split, image_steps=To)
    picks = np.random.default_rng(0).permutation(len(data))[:args.windows]
    errors, moves, sampled_moves, drifts, agree, agree_at_switch = [], [], [], [], [], []
    misplaced: list[np.ndarray] = []  # per window, each body's position error (mm)
    closes = grasp_steps(args.data, data.demos) if args.phases or args.phase_edges else {}
    from_grasp: list[int] = []  # per window, its latest observation relative to the grasp
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
        sampled_moves.append(1000 * float(torch.linalg.norm(end_sampled)))
        same = float((sampled[:, 6] == shown[:, 6]).double().mean())
        agree.append(same)
        grasps = torch.cat([item["actions"][To - 2:To - 1, 6].double(), shown[:, 6]])
        if To >= 2 and bool((grasps.diff() != 0).any()):
            agree_at_switch.append(same)
        if closes:
            name, start = data.window(int(i))
            from_grasp.append(start + To - 1 - closes[name])
        if located:
            latest_obs = {k: item["obs"][k][None, To - 1:To] for k in keys}
            misplaced.append(position_errors_mm(policy.estimate_objects(latest_obs)[0, 0],
                                                latest_obs["object_in_tcp"][0, 0]))
    at_switch = (f"{np.mean(agree_at_switch):.3f} (n = {len(agree_at_switch)})"
                 if agree_at_switch else "no window switches")
    print(f"{args.checkpoint} on the {args.split} demos, {len(errors)} windows, "
          f"{steps} steps each:\n"
          f"  gripper position at step {steps}: error median {np.median(errors):.1f} mm, "
          f"90th percentile {np.percentile(errors, 90):.1f} mm "
          f"(the demonstrations move {np.median(moves):.1f} mm, median; their recorded "
          f"actions composed end {np.median(drifts):.1f} mm from the plan, median)\n"
          f"  grasp agreement {np.mean(agree):.3f}; where the demo switches: {at_switch}")
    located_mm = np.array(misplaced) if misplaced else None
    if located_mm is not None:
        print_located(args.data, data.demos[0], located_mm, "the latest frames")
    if from_grasp:
        where, errors_mm = np.array(from_grasp), np.array(errors)
        shown_mm, sampled_mm = np.array(moves), np.array(sampled_moves)
        print("  by phase (the latest observation's steps from the demo's first grasp "
              "command):")
        for label, here in phases(where, args.phase_edges):
            line = (f"    {label}: {here.sum()} windows, gripper error median "
                    f"{np.median(errors_mm[here]):.1f} mm (moves: demo "
                    f"{np.median(shown_mm[here]):.1f}, sampled "
                    f"{np.median(sampled_mm[here]):.1f} mm)")
            print(line + (located_in(located_mm, here) if located_mm is not None else ""))


if __name__ == "__main__":
    main()
