"""The paper-style tables and figures of a study, from trial rows.

Rows are evaluation trials (``method``, ``train_seed``, ``embodiment``, ``task``,
``success``): ``legato-drake experiment``'s ``results.csv`` rows, or the trials of
``evaluate`` results files (``scripts/eval_table.py``). Each table cell holds the mean success
rate across training seeds, its range across seeds, and the pooled successes out of all trials
with their 95 % Wilson interval; the cross-embodiment mean is over the non-Abstract robots
(the paper's summary figure). The paper's own rates (SPEC §9, no intervals) sit below ours.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from legato_drake.embodiments import EMBODIMENTS
from legato_drake.experiment.grid import Grid
from legato_drake.summary import Rate, group_by

PAPER = {  # success % (SPEC §9) per task: method -> embodiment -> rate
    "lid": {"LEGATO (paper)": dict(abstract=76, panda=88, spot=80, google=96, gr1=90),
            "LEGATO SE3 (paper)": dict(abstract=80, panda=86, spot=72, google=66, gr1=66),
            "BC-RNN (paper)": dict(abstract=56, panda=54, spot=52, google=62, gr1=48),
            "DP velocity (paper)": dict(abstract=90, panda=88, spot=70, google=86, gr1=80)},
    "cup": {"LEGATO (paper)": dict(abstract=84, panda=68, spot=88, google=78, gr1=48),
            "LEGATO SE3 (paper)": dict(abstract=94, panda=48, spot=92, google=78, gr1=36),
            "BC-RNN (paper)": dict(abstract=94, panda=50, spot=54, google=46, gr1=34),
            "DP velocity (paper)": dict(abstract=100, panda=68, spot=72, google=90, gr1=52)},
    "ladle": {"LEGATO (paper)": dict(abstract=80, panda=60, spot=76, google=64, gr1=72),
              "LEGATO SE3 (paper)": dict(abstract=68, panda=20, spot=14, google=2, gr1=10),
              "BC-RNN (paper)": dict(abstract=92, panda=24, spot=16, google=12, gr1=18),
              "DP velocity (paper)": dict(abstract=98, panda=16, spot=40, google=14, gr1=26)},
}
LEGEND = ("Cells: mean success across training seeds (range across seeds); pooled "
          "successes/trials [95 % Wilson interval].")


def cells(rows: Sequence[dict]) -> dict[str, dict[int, dict[tuple[str, str], Rate]]]:
    """method -> training seed -> (task, embodiment) -> successes out of trials."""
    return {method: {seed: {(t, e): Rate.of(cell)
                            for (t, e), cell in group_by(run, "task", "embodiment").items()}
                     for (seed,), run in group_by(trials, "train_seed").items()}
            for (method,), trials in group_by(rows, "method").items()}


def _spread(rates: list[float]) -> str:
    mean = sum(rates) / len(rates)
    if len(rates) == 1:
        return f"{mean:.0f} %"
    return f"{mean:.0f} % ({min(rates):.0f}-{max(rates):.0f})"


def _order(rows: Sequence[dict]) -> list[str]:
    present = {r["embodiment"] for r in rows}
    return [e for e in EMBODIMENTS if e in present] + sorted(present - set(EMBODIMENTS))


def task_table(rows: Sequence[dict], task: str, paper: bool = True) -> list[str]:
    """Markdown lines: methods (with their training seeds) x embodiments, and the
    cross-embodiment mean, for ``task``; the paper's rates below (``paper``)."""
    rows = [r for r in rows if r["task"] == task]
    embodiments = _order(rows)
    others = [e for e in embodiments if e != "abstract"]
    lines = ["| method (training seeds) | " + " | ".join(embodiments) +
             " | cross-embodiment mean |", "| --- " * (len(embodiments) + 2) + "|"]
    for method, seeds in cells(rows).items():
        row = []
        for e in embodiments:
            per_seed = [c[task, e] for c in seeds.values() if (task, e) in c]
            if not per_seed:
                row.append("-")
                continue
            pooled = Rate(sum(r.successes for r in per_seed), sum(r.trials for r in per_seed))
            row.append(f"{_spread([r.percent for r in per_seed])}; {pooled.count_text} "
                       f"[{pooled.interval_text}]")
        cross = [sum(c[task, e].percent for e in others) / len(others)
                 for c in seeds.values() if others and all((task, e) in c for e in others)]
        lines.append(f"| {method} ({', '.join(str(s) for s in sorted(seeds))}) | " +
                     " | ".join(row) + f" | {_spread(cross) if cross else '-'} |")
    for method, rates in (PAPER.get(task, {}) if paper else {}).items():
        known = [e for e in embodiments if e in rates]
        cross = (f"{sum(rates[e] for e in others) / len(others):.0f} %"
                 if others and all(e in rates for e in others) else "-")
        lines.append(f"| {method} | " + " | ".join(f"{rates[e]} %" if e in known else "-"
                                                   for e in embodiments) + f" | {cross} |")
    return lines


def overall_table(rows: Sequence[dict]) -> list[str]:
    """Markdown lines: per method, the Abstract mean over tasks and the cross-embodiment mean
    over every non-Abstract (task, robot) cell (12 for the whole grid), as mean (range)
    across training seeds."""
    lines = ["| method | cells | Abstract mean | cross-embodiment mean |",
             "| --- | --- | --- | --- |"]
    for method, seeds in cells(rows).items():
        abstract, cross, counted = [], [], 0
        for per_seed in seeds.values():
            own = [r.percent for (_, e), r in per_seed.items() if e == "abstract"]
            other = [r.percent for (_, e), r in per_seed.items() if e != "abstract"]
            counted = max(counted, len(other))
            if own:
                abstract.append(sum(own) / len(own))
            if other:
                cross.append(sum(other) / len(other))
        lines.append(f"| {method} | {counted} | {_spread(abstract) if abstract else '-'} | "
                     f"{_spread(cross) if cross else '-'} |")
    return lines


def plot_cross_embodiment(rows: Sequence[dict], png: Path, title: str = "") -> Path:
    """Bars of the cross-embodiment mean per task (groups) and method (bars), with the
    range across training seeds as error bars (the paper's Fig. 10 in our setting)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    tasks = list(dict.fromkeys(r["task"] for r in rows))
    table = cells(rows)
    width = 0.8 / max(len(table), 1)
    fig, ax = plt.subplots(figsize=(max(4.0, 1.6 * len(tasks) * max(len(table), 1)), 3.5))
    for j, (method, seeds) in enumerate(table.items()):
        means, lows, highs = [], [], []
        for task in tasks:
            per_seed = [[r.percent for (t, e), r in c.items() if t == task and e != "abstract"]
                        for c in seeds.values()]
            per_seed = [sum(v) / len(v) for v in per_seed if v]
            mean = sum(per_seed) / len(per_seed) if per_seed else 0.0
            means.append(mean)
            lows.append(max(mean - min(per_seed), 0.0) if per_seed else 0.0)
            highs.append(max(max(per_seed) - mean, 0.0) if per_seed else 0.0)
        x = np.arange(len(tasks)) + (j - (len(table) - 1) / 2) * width
        ax.bar(x, means, width, yerr=[lows, highs], capsize=3, label=method)
    ax.set_xticks(np.arange(len(tasks)), tasks)
    ax.set_ylim(0, 105)
    ax.set_ylabel("cross-embodiment success %\n(range across training seeds)")
    ax.set_title(title or "cross-embodiment mean (non-Abstract robots)")
    ax.legend(fontsize="small")
    fig.tight_layout()
    png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=120)
    plt.close(fig)
    return png


def summary_markdown(name: str, rows: Sequence[dict], settings: str = "") -> str:
    """The summary of a study: the overall table, one table per task, links to figures."""
    tasks = list(dict.fromkeys(r["task"] for r in rows))
    lines = [f"# {name}", ""]
    if settings:
        lines += [settings, ""]
    if not rows:
        return "\n".join([*lines, "No evaluation trials yet.", ""])
    lines += [LEGEND, "", "## All tasks", "", *overall_table(rows), "",
              "![cross-embodiment](figures/cross_embodiment.png)", ""]
    for task in tasks:
        lines += [f"## {task}", "", *task_table(rows, task), "",
                  f"![{task}](figures/{task}.png)", ""]
    return "\n".join(lines)


def write_report(grid: Grid, rows: Sequence[dict], out: Path) -> Path:
    """Writes ``out/summary.md`` and its figures (``out/figures/``) for ``grid``'s
    evaluation rows; returns the summary's path."""
    from legato_drake.files import atomic_write_text
    from legato_drake.pipelines.evaluate import plot_success

    e, s, t = grid.evaluation, grid.selection, grid.training
    settings = (f"{e.trials} trials per method, training seed, robot and task (scene seeds "
                f"{e.seed0}-{e.seed0 + e.trials - 1}); training seeds "
                f"{', '.join(map(str, t.seeds))}; "
                + (f"checkpoint selected by {s.trials} rollouts on {s.embodiment} "
                   f"(validation seeds {s.seed0}-{s.seed0 + s.trials - 1})"
                   if s.trials else "the last checkpoint of each run")
                + "; datasets: " + ", ".join(f"{d.episodes} {d.embodiment} {d.task} demos"
                                              for d in grid.datasets) + ".")
    for task in dict.fromkeys(r["task"] for r in rows):
        plot_success([r for r in rows if r["task"] == task], out / "figures" / f"{task}.png",
                     title=f"{grid.name}: {task}")
    if rows:
        plot_cross_embodiment(rows, out / "figures" / "cross_embodiment.png",
                              title=f"{grid.name}: cross-embodiment mean")
    path = out / "summary.md"
    atomic_write_text(path, summary_markdown(grid.name, rows, settings))
    return path
