"""The README's learned-policy table (Markdown) from results files of ``legato-drake evaluate``.

    python scripts/eval_table.py results/lid/*.json [--task lid]

One row per method, one column per embodiment: successes out of trials and the 95 % Wilson
interval; below them the paper's LEGATO and LEGATO (SE3) rates for the task (SPEC §9, no
intervals reported) for comparison.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from legato_drake.embodiments import EMBODIMENTS
from legato_drake.evaluation import combine, summarize

PAPER = {  # success % (SPEC §9) per task: method -> embodiment -> rate
    "lid": {"LEGATO (paper)": dict(abstract=76, panda=88, spot=80, google=96, gr1=90),
            "LEGATO SE3 (paper)": dict(abstract=80, panda=86, spot=72, google=66, gr1=66)},
    "cup": {"LEGATO (paper)": dict(abstract=84, panda=68, spot=88, google=78, gr1=48),
            "LEGATO SE3 (paper)": dict(abstract=94, panda=48, spot=92, google=78, gr1=36)},
    "ladle": {"LEGATO (paper)": dict(abstract=80, panda=60, spot=76, google=64, gr1=72),
              "LEGATO SE3 (paper)": dict(abstract=68, panda=20, spot=14, google=2, gr1=10)},
}


def table(trials: list[dict], task: str) -> list[str]:
    """Markdown lines: methods x embodiments for ``task``."""
    cells = {(m, e): f"{k_of_n} ({interval} %)"
             for m, e, t, k_of_n, _, interval, *_ in summarize(trials) if t == task}
    embodiments = [e for e in EMBODIMENTS if any(key[1] == e for key in cells)]
    lines = ["| method | " + " | ".join(embodiments) + " |",
             "| --- " * (len(embodiments) + 1) + "|"]
    for method in dict.fromkeys(m for m, _ in cells):
        lines.append(f"| {method} | "
                     + " | ".join(cells.get((method, e), "-") for e in embodiments) + " |")
    for method, rates in PAPER.get(task, {}).items():
        lines.append(f"| {method} | " + " | ".join(f"{rates[e]} %" for e in embodiments) + " |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("json", nargs="+", type=Path, help="results files of `evaluate`")
    parser.add_argument("--task", default="lid", choices=sorted(PAPER))
    args = parser.parse_args()
    print("\n".join(table(combine(args.json), args.task)))


if __name__ == "__main__":
    main()
