"""The one summary module: Wilson intervals, counts, group-by and the tables' rows."""

from __future__ import annotations

import math

import pytest

from legato_drake.summary import (
    DEMO_HEADERS,
    TRIAL_HEADERS,
    Rate,
    demo_rows,
    format_table,
    group_by,
    trial_rows,
    wilson_interval,
)


def test_wilson_interval():
    low, high = wilson_interval(5, 10)
    assert low == pytest.approx(0.2366, abs=1e-4) and high == pytest.approx(0.7634, abs=1e-4)
    assert wilson_interval(0, 10)[0] == 0.0 and wilson_interval(10, 10)[1] == 1.0
    assert wilson_interval(0, 0) == (0.0, 1.0)
    # Exactly 0 and 1 at the ends for every n (6/6 once gave 0.9999999999999999, and the
    # plots' error bars, rate - bound, went negative).
    assert all(wilson_interval(n, n)[1] == 1.0 and wilson_interval(0, n)[0] == 0.0
               for n in range(1, 301))
    assert all(lo <= k / n <= hi for n in range(1, 60) for k in range(n + 1)
               for lo, hi in [wilson_interval(k, n)])


def test_rates_and_groups():
    rows = [dict(e="a", t="x", success=True), dict(e="b", t="x", success=False),
            dict(e="a", t="x", success=False), dict(e="a", t="y", success=True)]
    groups = group_by(rows, "e", "t")
    assert list(groups) == [("a", "x"), ("b", "x"), ("a", "y")]  # first appearance
    rate = Rate.of(groups["a", "x"])
    assert (rate.count_text, rate.percent, rate.interval_text) == ("1/2", 50.0, "9-91")
    assert Rate.of([]).fraction == 0.0
    assert list(group_by(rows, key=lambda r: r["t"])) == ["x", "y"]


def test_tables():
    result = dict(embodiment="panda", task="lid", controller="scripted", seed=0, success=True,
                  reason="", tracking=dict(rms_mm=1.0, rms_deg=0.5, max_mm=2.0),
                  sim_time=10.0, wall_time=5.0, real_time_factor=2.0)
    rows = demo_rows([result, {**result, "seed": 1, "success": False, "wall_time": 15.0}],
                     lambda r: r["controller"])
    assert rows == [["panda", "lid", "scripted", "1/2", "9-91", 1.0, 0.5, 2.0, 1.0]]
    text = format_table(DEMO_HEADERS, rows).splitlines()
    assert text[0].split()[:3] == ["embodiment", "task", "controller"]
    assert text[2].split() == ["panda", "lid", "scripted", "1/2", "9-91", "1.00", "0.50",
                               "2.00", "1.00"]
    trial = dict(method="m", embodiment="panda", task="lid", success=False, success_time=None,
                 wall_time=2.0)
    (row,) = trial_rows([trial])
    assert len(row) == len(TRIAL_HEADERS) and row[3] == "0/1" and math.isnan(row[6])
