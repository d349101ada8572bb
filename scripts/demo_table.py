"""The scripted-expert table (Markdown) from the JSON files of ``legato-drake demo``.

docs/results/scripted_experts.md holds its output.

    legato-drake demo --embodiment all --task lid --seeds 0-49 --no-replay --no-camera \
        --workers 2 --json results/demo/lid.json
    python scripts/demo_table.py results/demo/*.json

One row per task and robot: successes with the 95 % Wilson interval, TCP tracking (median and
worst RMS over the seeds, how many seeds exceed 5 mm), the worst RMS angle and worst peak
error, the median time to success and the real-time factor. Failed seeds go to stderr.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path

from legato_drake.embodiments import EMBODIMENTS
from legato_drake.summary import Rate, group_by, real_time_factor
from legato_drake.tasks import TASKS

HEADER = ("| task | robot | success | 95 % CI % | RMS mm: median / worst (seeds > 5) "
          "| worst RMS deg | worst max mm | median time to success s | x real time |")


def table(rows: list[dict]) -> list[str]:
    """Markdown lines of the table for episode results ``rows`` (``EpisodeResult.to_dict``)."""
    lines = [HEADER, "| --- " * (HEADER.count("|") - 1) + "|"]
    groups = group_by(rows, "task", "embodiment")
    for task in TASKS:
        for embodiment in EMBODIMENTS:
            group = groups.get((task, embodiment))
            if not group:
                continue
            rate = Rate.of(group)
            times = [r["success_time"] for r in group if r["success_time"] is not None]
            rms = [r["tracking"]["rms_mm"] for r in group]
            lines.append(
                f"| {task} | {embodiment} | {rate.count_text} | {rate.interval_text} "
                f"| {statistics.median(rms):.2f} / {max(rms):.2f} ({sum(x > 5 for x in rms)}) "
                f"| {max(r['tracking']['rms_deg'] for r in group):.2f} "
                f"| {max(r['tracking']['max_mm'] for r in group):.1f} "
                f"| {statistics.median(times) if times else float('nan'):.1f} "
                f"| {real_time_factor(group):.2f} |")
            for r in group:
                if not r["success"]:
                    print(f"failed: {task} {embodiment} seed {r['seed']}: {r['reason']}",
                          file=sys.stderr)
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("json", nargs="+", type=Path, help="files of `legato-drake demo --json`")
    rows: list[dict] = []
    for path in parser.parse_args().json:
        rows += json.loads(path.read_text())
    print("\n".join(table(rows)))


if __name__ == "__main__":
    main()
