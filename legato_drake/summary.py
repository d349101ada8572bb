"""Summaries of many episodes: group-by, success counts with Wilson intervals, the tables.

The paper reported no intervals; every table of ours has them. Everything here works on
plain result rows (dicts: ``EpisodeResult.to_dict()`` rows of ``demo``, the trial rows of
``evaluate``, the rows of ``retarget-benchmark``) and imports nothing of the robot side, so
any layer may use it. Rows are grouped in the order they are given (first appearance of each
key): callers sort first where an order matters (``pipelines.evaluate.trial_order``).

- ``wilson_interval``, ``Rate``: successes out of trials, the rate, the interval, as text;
- ``group_by``: rows grouped by fields, in order of first appearance;
- ``format_table``: an aligned plain-text table;
- the rows of the command line's tables: ``episode_rows`` / ``demo_rows`` (``demo``),
  ``trial_rows`` / ``failure_rows`` (``evaluate``), ``retarget_rows``
  (``retarget-benchmark``), each with its headers.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

Row = dict[str, Any]


def wilson_interval(successes: int, trials: int, z: float = 1.96) -> tuple[float, float]:
    """The Wilson score interval (95 % by default) of a success rate, as fractions."""
    if trials <= 0:
        return 0.0, 1.0
    p = successes / trials
    denominator = 1.0 + z * z / trials
    centre = (p + z * z / (2 * trials)) / denominator
    half = z * math.sqrt(p * (1 - p) / trials + z * z / (4 * trials * trials)) / denominator
    # The interval holds the rate: at 0/n and n/n the bound is exactly 0 or 1 (in floating
    # point it can land a hair inside, e.g. 0.9999999999999999 for 6/6).
    return max(0.0, min(centre - half, p)), min(1.0, max(centre + half, p))


@dataclass(frozen=True)
class Rate:
    """``successes`` out of ``trials``, with its 95 % Wilson interval."""

    successes: int
    trials: int

    @classmethod
    def of(cls, rows: Iterable[Row], field: str = "success") -> Rate:
        """The rate of the rows whose ``field`` is true."""
        rows = list(rows)
        return cls(sum(bool(r[field]) for r in rows), len(rows))

    @property
    def fraction(self) -> float:
        """successes / trials (0 without trials)."""
        return self.successes / self.trials if self.trials else 0.0

    @property
    def percent(self) -> float:
        """The rate in percent."""
        return 100.0 * self.successes / self.trials

    @property
    def interval(self) -> tuple[float, float]:
        """The Wilson interval, as fractions."""
        return wilson_interval(self.successes, self.trials)

    @property
    def count_text(self) -> str:
        """``"k/n"``."""
        return f"{self.successes}/{self.trials}"

    @property
    def interval_text(self) -> str:
        """The Wilson interval in whole percent, ``"low-high"``."""
        low, high = self.interval
        return f"{100 * low:.0f}-{100 * high:.0f}"


def group_by(rows: Iterable[Row], *fields: str,
             key: Callable[[Row], Hashable] | None = None) -> dict[Any, list[Row]]:
    """The rows grouped by the tuple of their ``fields`` (or by ``key(row)``), groups and
    rows in the order given."""
    if key is None:
        def key(row: Row) -> tuple:
            return tuple(row[f] for f in fields)
    groups: dict[Any, list[Row]] = {}
    for row in rows:
        groups.setdefault(key(row), []).append(row)
    return groups


def real_time_factor(rows: Sequence[Row]) -> float:
    """Simulated seconds per wall-clock second over episode rows."""
    return sum(r["sim_time"] for r in rows) / sum(r["wall_time"] for r in rows)


def format_table(headers: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    """Formats rows as an aligned text table (numbers right-aligned, text left-aligned)."""
    cells = [[_cell(v) for v in row] for row in rows]
    widths = [max([len(h)] + [len(r[i]) for r in cells]) for i, h in enumerate(headers)]
    numeric = [all(isinstance(row[i], int | float) and not isinstance(row[i], bool)
                   for row in rows) for i in range(len(headers))]

    def line(values: Sequence[str]) -> str:
        return "  ".join(v.rjust(w) if num else v.ljust(w)
                         for v, w, num in zip(values, widths, numeric, strict=True)).rstrip()

    rule = "  ".join("-" * w for w in widths)
    return "\n".join([line(list(headers)), rule, *(line(r) for r in cells)])


def _cell(value: object) -> str:
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:.2f}"
    return str(value)


# --- demo: episode rows (``EpisodeResult.to_dict()``) ---------------------------------------

EPISODE_HEADERS = ["embodiment", "task", "controller", "seed", "success", "why not", "rms mm",
                   "rms deg", "sim s", "wall s", "x real time"]
DEMO_HEADERS = ["embodiment", "task", "controller", "success", "95% CI %", "worst rms mm",
                "worst rms deg", "worst max mm", "x real time"]


def episode_rows(results: Iterable[Row], label: Callable[[Row], str]) -> list[list]:
    """One table row per episode; ``label(result)`` names what drove it."""
    return [[r["embodiment"], r["task"], label(r), r["seed"], r["success"], r["reason"] or "-",
             r["tracking"]["rms_mm"], r["tracking"]["rms_deg"], r["sim_time"], r["wall_time"],
             r["real_time_factor"]] for r in results]


def demo_rows(results: Iterable[Row], label: Callable[[Row], str]) -> list[list]:
    """One table row per embodiment and task: successes, the interval, the worst tracking
    errors and the real-time factor."""
    rows = []
    for (embodiment, task), group in group_by(results, "embodiment", "task").items():
        rate = Rate.of(group)
        rows.append([embodiment, task, label(group[0]), rate.count_text, rate.interval_text,
                     max(r["tracking"]["rms_mm"] for r in group),
                     max(r["tracking"]["rms_deg"] for r in group),
                     max(r["tracking"]["max_mm"] for r in group), real_time_factor(group)])
    return rows


# --- evaluate: trial rows -------------------------------------------------------------------

TRIAL_HEADERS = ["method", "embodiment", "task", "success", "rate %", "95% CI %",
                 "mean success s", "mean wall s"]
FAILURE_HEADERS = ["method", "embodiment", "task", "failures by condition"]
TRIAL_KEY = ("method", "embodiment", "task")
"""Trials are summarised per method, embodiment and task."""


def trial_rows(trials: Iterable[Row]) -> list[list]:
    """One row per (method, embodiment, task): successes, rate, Wilson 95 % interval, mean
    success time and mean wall time."""
    rows = []
    for key, group in group_by(trials, *TRIAL_KEY).items():
        rate = Rate.of(group)
        times = [t["success_time"] for t in group if t["success"] and t["success_time"]]
        rows.append([*key, rate.count_text, rate.percent, rate.interval_text,
                     sum(times) / len(times) if times else float("nan"),
                     sum(t["wall_time"] for t in group) / rate.trials])
    return rows


UNITS = ("m", "cm", "mm", "deg", "rad", "m/s", "s")
"""Unit words that follow a number in a failure reason."""


def reason_kind(reason: str) -> str:
    """A failure reason without its numbers, for counting: the predicate's condition that
    failed ("lid -1.4 cm from resting on the rim (allowed -1.0 to +1.5 cm)" -> "lid … from
    resting on the rim"; "lid still held: the fingers are open 0 mm" -> "lid still held")."""
    head = reason.split(" (")[0].split(":")[0]
    words: list[str] = []
    after_number = False
    for word in head.split():
        if any(c.isdigit() for c in word):
            words.append("…")
            after_number = True
        elif after_number and word in UNITS:
            after_number = False
        else:
            words.append(word)
            after_number = False
    return " ".join(words) or reason


def failure_rows(trials: Iterable[Row]) -> list[list]:
    """One row per (method, embodiment, task): how many trials failed by which condition."""
    rows = []
    for key, group in group_by(trials, *TRIAL_KEY).items():
        kinds = [reason_kind(t["reason"]) for t in group if not t["success"]]
        counts = sorted(((kinds.count(k), k) for k in set(kinds)), reverse=True)
        rows.append([*key, ", ".join(f"{k} x{n}" for n, k in counts) or "-"])
    return rows


# --- retarget-benchmark rows ----------------------------------------------------------------

RETARGET_HEADERS = ["embodiment", "task", "success", "95% CI %", "rms mm", "max mm",
                    "rms deg", "max deg", "min limit margin", "max foot drift mm",
                    "ik median ms", "ik p95 ms", "x real time"]


def retarget_rows(rows: Iterable[Row]) -> list[list]:
    """One row per embodiment and task: success with its 95 % interval and the worst
    errors."""
    out = []
    for key, group in group_by(rows, "embodiment", "task").items():
        rate = Rate.of(group)
        out.append([*key, rate.count_text, rate.interval_text,
                    float(np.mean([r["rms_mm"] for r in group])),
                    max(r["max_mm"] for r in group),
                    float(np.mean([r["rms_deg"] for r in group])),
                    max(r["max_deg"] for r in group),
                    min(r["min_limit_margin"] for r in group),
                    max(r["max_foot_drift_mm"] for r in group),
                    float(np.median([r["ik_median_ms"] for r in group])),
                    max(r["ik_p95_ms"] for r in group),
                    float(np.median([r["real_time_factor"] for r in group]))])
    return out
