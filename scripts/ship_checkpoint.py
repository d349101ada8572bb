"""Copies a selected checkpoint into ``checkpoints/`` as a deployable policy.

    python scripts/ship_checkpoint.py experiments/paper/runs/legato-lid-seed0-*/selected.pt \\
        checkpoints/legato_state_lid.pt [--chosen-on 5010-5019]

The copy keeps the weights a rollout needs (``rollout_only``: a Diffusion Policy's EMA copy
without its trained one), its config, the normalisation statistics, the training and
selection seeds (so ``evaluate`` still refuses to reuse them) and drops the optimizer state;
its config is written beside it as ``<name>.yaml``. ``--chosen-on`` records the scene seeds
on which this training seed's file was preferred to the others' (evaluated on every robot),
so that ``evaluate`` refuses those too; they must lie below the evaluation seeds.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from legato_drake.cli import seed_list
from legato_drake.learning.checkpoint import load_checkpoint, save_checkpoint
from legato_drake.learning.config import save_config
from legato_drake.pipelines.evaluate import EVAL_SEED0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("source", type=Path, help="a run's selected.pt")
    parser.add_argument("target", type=Path, help="e.g. checkpoints/legato_state_lid.pt")
    parser.add_argument("--chosen-on", type=seed_list, default=[], metavar="SEEDS",
                        help="scene seeds (N, A-B or a,b) on which this file was chosen among "
                             "training seeds")
    args = parser.parse_args()
    if args.chosen_on and max(args.chosen_on) >= EVAL_SEED0:
        parser.error(f"--chosen-on: seeds from {EVAL_SEED0} on are evaluation seeds; choose "
                     f"among validation seeds below {EVAL_SEED0}")
    ckpt = load_checkpoint(args.source)
    if not ckpt.selection:
        parser.error(f"{args.source} was not chosen by `legato-drake select`")
    if args.chosen_on:
        ckpt.selection = {**ckpt.selection, "shipped_on": args.chosen_on}
    ckpt.optimizer = None
    ckpt.rollout_only = True
    ckpt.data = Path(ckpt.data).name
    save_checkpoint(args.target, ckpt)
    save_config(ckpt.config, args.target.with_suffix(".yaml"))
    print(f"wrote {args.target} ({args.target.stat().st_size / 1e6:.1f} MB) and its config")


if __name__ == "__main__":
    main()
