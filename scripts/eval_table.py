"""The README's learned-policy table (Markdown) from results files of ``legato-drake evaluate``.

    python scripts/eval_table.py results/lid/*.json [--task lid]

Results files are grouped by the policy's config name (the method, e.g. ``legato_small_state``
or its ``_se3`` twin) and its training seed (``config.seed``), so several training runs of a
method make one row. Each cell: the mean success rate across training seeds, the range across
seeds, and the pooled successes out of all trials with their 95 % Wilson interval; the last
column is the cross-embodiment mean over the non-Abstract robots (the paper's summary
figure), with its range across seeds. Below them the paper's rates (SPEC §9, no intervals).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from legato_drake.embodiments import EMBODIMENTS
from legato_drake.pipelines.evaluate import load_results
from legato_drake.summary import Rate, group_by

PAPER = {  # success % (SPEC §9) per task: method -> embodiment -> rate
    "lid": {"LEGATO (paper)": dict(abstract=76, panda=88, spot=80, google=96, gr1=90),
            "LEGATO SE3 (paper)": dict(abstract=80, panda=86, spot=72, google=66, gr1=66),
            "BC-RNN (paper)": dict(abstract=56, panda=54, spot=52, google=62, gr1=48)},
    "cup": {"LEGATO (paper)": dict(abstract=84, panda=68, spot=88, google=78, gr1=48),
            "LEGATO SE3 (paper)": dict(abstract=94, panda=48, spot=92, google=78, gr1=36),
            "BC-RNN (paper)": dict(abstract=94, panda=50, spot=54, google=46, gr1=34)},
    "ladle": {"LEGATO (paper)": dict(abstract=80, panda=60, spot=76, google=64, gr1=72),
              "LEGATO SE3 (paper)": dict(abstract=68, panda=20, spot=14, google=2, gr1=10),
              "BC-RNN (paper)": dict(abstract=92, panda=24, spot=16, google=12, gr1=18)},
}


def runs(paths: list[Path], task: str) -> dict[str, dict[int, dict[str, Rate]]]:
    """method -> training seed -> embodiment -> successes out of trials for ``task``."""
    trials: dict[str, dict[int, list[dict]]] = {}
    for path in paths:
        doc = load_results(path)
        method, seed = doc["config"]["name"], int(doc["config"]["seed"])
        trials.setdefault(method, {}).setdefault(seed, []).extend(
            t for t in doc["trials"] if t["task"] == task)
    return {method: {seed: {e: Rate.of(cell) for (e,), cell in group_by(run, "embodiment").items()}
                     for seed, run in seeds.items()} for method, seeds in trials.items()}


def _spread(rates: list[float]) -> str:
    mean = sum(rates) / len(rates)
    if len(rates) == 1:
        return f"{mean:.0f} %"
    return f"{mean:.0f} % ({min(rates):.0f}-{max(rates):.0f})"


def table(paths: list[Path], task: str) -> list[str]:
    """Markdown lines: methods x embodiments (+ the cross-embodiment mean) for ``task``."""
    data = runs(paths, task)
    present = {e for seeds in data.values() for cells in seeds.values() for e in cells}
    embodiments = [e for e in EMBODIMENTS if e in present]
    others = [e for e in embodiments if e != "abstract"]
    lines = ["| method (training seeds) | " + " | ".join(embodiments) +
             " | cross-embodiment mean |", "| --- " * (len(embodiments) + 2) + "|"]
    for method, seeds in data.items():
        cells = []
        for e in embodiments:
            per_seed = [c[e] for c in seeds.values() if e in c]
            if not per_seed:
                cells.append("-")
                continue
            pooled = Rate(sum(r.successes for r in per_seed), sum(r.trials for r in per_seed))
            cells.append(f"{_spread([r.percent for r in per_seed])}; {pooled.count_text} "
                         f"[{pooled.interval_text}]")
        cross = [sum(c[e].percent for e in others) / len(others)
                 for c in seeds.values() if others and all(e in c for e in others)]
        lines.append(f"| {method} ({', '.join(str(s) for s in sorted(seeds))}) | " +
                     " | ".join(cells) + f" | {_spread(cross) if cross else '-'} |")
    for method, rates in PAPER.get(task, {}).items():
        cross = f"{sum(rates[e] for e in others) / len(others):.0f} %" if others else "-"
        lines.append(f"| {method} | " + " | ".join(f"{rates[e]} %" for e in embodiments) +
                     f" | {cross} |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("json", nargs="+", type=Path, help="results files of `evaluate`")
    parser.add_argument("--task", default="lid", choices=sorted(PAPER))
    args = parser.parse_args()
    print(f"Cells: mean success across training seeds (range); pooled successes/trials "
          f"[95 % Wilson interval]. Task: {args.task}.\n")
    print("\n".join(table(args.json, args.task)))


if __name__ == "__main__":
    main()
