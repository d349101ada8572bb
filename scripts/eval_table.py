"""A learned-policy table (Markdown) from results files of ``legato-drake evaluate``.

The README and docs/results/ hold its output.

    python scripts/eval_table.py results/lid/*.json [--task lid]

Results files are grouped by the policy's config name (the method, e.g. ``legato_small_state``
or its ``_se3`` twin) and its training seed (``config.seed``), so several training runs of a
method make one row; the table is ``legato_drake.experiment.report.task_table`` (the one of
``legato-drake experiment``'s summary): mean across training seeds (range), pooled successes
with their 95 % Wilson interval, the cross-embodiment mean, and the paper's rates below.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from legato_drake.experiment.report import LEGEND, PAPER, task_table
from legato_drake.pipelines.evaluate import load_results


def trial_rows(paths: list[Path]) -> list[dict]:
    """The trials of the results files, each tagged with its config's name and seed."""
    rows = []
    for path in paths:
        doc = load_results(path)
        rows += [{**t, "method": doc["config"]["name"], "train_seed": int(doc["config"]["seed"])}
                 for t in doc["trials"]]
    return rows


def table(paths: list[Path], task: str) -> list[str]:
    """Markdown lines: methods x embodiments (+ the cross-embodiment mean) for ``task``."""
    return task_table(trial_rows(paths), task)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("json", nargs="+", type=Path, help="results files of `evaluate`")
    parser.add_argument("--task", default="lid", choices=sorted(PAPER))
    args = parser.parse_args()
    print(f"{LEGEND} Task: {args.task}.\n")
    print("\n".join(table(args.json, args.task)))


if __name__ == "__main__":
    main()
