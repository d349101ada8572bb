"""The retargeting benchmark: an Abstract trajectory replayed open-loop on another robot."""

from __future__ import annotations

import json

import pytest

from legato_drake.retarget import SUMMARY_HEADERS, run_benchmark, summarize, write_results


@pytest.mark.slow
def test_abstract_trajectory_retargets_onto_the_google_robot(tmp_path):
    rows = run_benchmark(["abstract", "google"], ["lid"], [0])
    assert [r["embodiment"] for r in rows] == ["abstract", "google"]
    for row in rows:
        assert row["success"], row["reason"]
        assert row["rms_mm"] < 5.0 and row["rms_deg"] < 2.0
        assert row["min_limit_margin"] > -1e-3
        assert 0.0 < row["ik_median_ms"] < 50.0
    table = summarize(rows)
    assert len(table) == 2 and len(table[0]) == len(SUMMARY_HEADERS)
    csv_path, json_path = write_results(rows, tmp_path)
    assert csv_path.read_text().splitlines()[0].startswith("embodiment,task,seed,success")
    assert json.loads(json_path.read_text()) == rows
