"""Copies a selected checkpoint into ``checkpoints/`` as a deployable policy.

    python scripts/ship_checkpoint.py experiments/paper/runs/legato-lid-seed0-*/selected.pt \\
        checkpoints/legato_state_lid.pt

The copy keeps the weights a rollout needs (``rollout_only``: a Diffusion Policy's EMA copy
without its trained one), its config, the normalisation statistics, the training and
selection seeds (so ``evaluate`` still refuses to reuse them) and drops the optimizer state;
its config is written beside it as ``<name>.yaml``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from legato_drake.learning.checkpoint import load_checkpoint, save_checkpoint
from legato_drake.learning.config import save_config


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("source", type=Path, help="a run's selected.pt")
    parser.add_argument("target", type=Path, help="e.g. checkpoints/legato_state_lid.pt")
    args = parser.parse_args()
    ckpt = load_checkpoint(args.source)
    if not ckpt.selection:
        parser.error(f"{args.source} was not chosen by `legato-drake select`")
    ckpt.optimizer = None
    ckpt.rollout_only = True
    ckpt.data = Path(ckpt.data).name
    save_checkpoint(args.target, ckpt)
    save_config(ckpt.config, args.target.with_suffix(".yaml"))
    print(f"wrote {args.target} ({args.target.stat().st_size / 1e6:.1f} MB) and its config")


if __name__ == "__main__":
    main()
