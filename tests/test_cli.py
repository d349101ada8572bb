"""The command line: the demo writes replays and a table; bad input gives clear errors."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from legato_drake.cli import main


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "legato_drake.cli", *args],
                          capture_output=True, text=True, timeout=600)


def test_unknown_embodiment_lists_the_valid_ones():
    result = _cli("demo", "--embodiment", "r2d2")
    assert result.returncode == 2
    assert "unknown embodiment 'r2d2'" in result.stderr and "panda" in result.stderr
    assert "Traceback" not in result.stderr


def test_malformed_scenario_file(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("embodiment: panda\ncamera: {fps: 3}\n")
    result = _cli("demo", "--scenario", str(bad))
    assert result.returncode == 2
    assert str(bad) in result.stderr and "fps" in result.stderr
    assert "Traceback" not in result.stderr


def test_bad_seeds():
    with pytest.raises(SystemExit) as exit_info:
        main(["demo", "--seeds", "9-3"])
    assert exit_info.value.code == 2


@pytest.mark.slow
def test_demo_writes_a_replay_and_a_table(tmp_path):
    result = _cli("demo", "--embodiment", "abstract", "--out", str(tmp_path / "replays"),
                  "--json", str(tmp_path / "r.json"))
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0].split()[:4] == ["embodiment", "task", "seed", "success"]
    assert lines[2].split()[:4] == ["abstract", "lid", "0", "yes"]
    html = (tmp_path / "replays" / "abstract-lid-seed0.html").read_text()
    assert html.lstrip().lower().startswith("<!doctype html") or "<html" in html[:200].lower()
    assert "http://" not in html.split("<script", 1)[0]  # no remote assets in the head
    assert len(html) > 1_000_000  # the viewer and the recording are inlined
    (record,) = json.loads((tmp_path / "r.json").read_text())
    assert record["success"] and record["tracking"]["rms_mm"] < 5.0
