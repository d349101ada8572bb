"""How one method of an experiment fails, per training seed, and whether its training seeds
fail the same scenes.

    python scripts/trial_outcomes.py experiments/image_lid/trials.jsonl legato_image_cos_obj

Reads the evaluation trials (not the selection rollouts) of ``METHOD`` in an experiment's
``trials.jsonl`` and prints, per training seed, its successes and its failures by condition
(``summary.reason_kind``); for the lid, the trials failed by the lid's offset from the
pot's axis (``center_offset``) split at ``--carried-cm`` (20 cm: a lid that far from the
axis lies where it started, never carried), with the range and median of those below it;
and per robot, how far from the axis the carried lids were set down, successes included
(median and 90th percentile of ``center_offset`` below ``--carried-cm``): whether a robot
places the lid as precisely as another. Then, for each pair of training seeds, on how many
robot × scene cells both fail against how many would if their failures were independent at
their rates: whether failing is a property of hard scenes or of each closed loop.
"""

from __future__ import annotations

import argparse
import itertools
import json
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np

from legato_drake.summary import reason_kind


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("trials", type=Path, help="an experiment's trials.jsonl")
    parser.add_argument("method", help="a method of that experiment's grid")
    parser.add_argument("--carried-cm", type=float, default=20.0,
                        help="lid offsets from the axis at or past this were never carried (20)")
    args = parser.parse_args()
    if not args.trials.is_file():
        parser.error(f"{args.trials}: no such file (an experiment's trials.jsonl)")
    with args.trials.open() as f:
        rows = [json.loads(line) for line in f if line.strip()]
    trials = [r for r in rows if r.get("method") == args.method and r.get("phase") == "eval"]
    if not trials:
        methods = sorted({r.get("method", "") for r in rows})
        parser.error(f"{args.trials} has no evaluation trials of {args.method!r}; its methods: "
                     f"{', '.join(methods)}")
    by_seed: dict[int, list[dict]] = defaultdict(list)
    for t in trials:
        by_seed[t["train_seed"]].append(t)
    outcome: dict[int, dict[tuple[str, int], bool]] = {}
    for seed, group in sorted(by_seed.items()):
        failed = [t for t in group if not t["success"]]
        print(f"training seed {seed}: {len(group) - len(failed)}/{len(group)} succeeded")
        for kind, count in Counter(reason_kind(t["reason"]) for t in failed).most_common():
            print(f"  {count} {kind}")
        offsets = np.array([100 * t["metrics"]["center_offset"] for t in failed
                            if "from the pot axis" in t["reason"]])
        if len(offsets):
            far = offsets >= args.carried_cm
            near = offsets[~far]
            print(f"  of those, {far.sum()} at {args.carried_cm:g} cm or more from the axis "
                  f"(never carried)" + (f", {len(near)} at {near.min():.1f}-{near.max():.1f} cm "
                                        f"(median {np.median(near):.1f})" if len(near) else ""))
        placed: dict[str, list[float]] = defaultdict(list)
        for t in group:
            offset = 100 * (t.get("metrics") or {}).get("center_offset", np.inf)
            if offset < args.carried_cm:
                placed[t["embodiment"]].append(offset)
        if placed:
            print("  carried lids set down from the axis, median (p90) cm: " + ", ".join(
                f"{robot} {np.median(v):.2f} ({np.percentile(v, 90):.2f})"
                for robot, v in placed.items()))
        outcome[seed] = {(t["embodiment"], t["seed"]): t["success"] for t in group}
    for a, b in itertools.combinations(sorted(outcome), 2):
        cells = sorted(set(outcome[a]) & set(outcome[b]))
        both = sum(not outcome[a][c] and not outcome[b][c] for c in cells)
        fail_a = np.mean([not outcome[a][c] for c in cells])
        fail_b = np.mean([not outcome[b][c] for c in cells])
        print(f"training seeds {a} and {b}: both fail {both} of {len(cells)} robot x scene "
              f"cells; {fail_a * fail_b * len(cells):.0f} if independent")


if __name__ == "__main__":
    main()
