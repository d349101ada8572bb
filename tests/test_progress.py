"""Progress of long work: log lines when stderr is not a terminal."""

from __future__ import annotations

import io
import logging

from tqdm import tqdm

from legato_drake.progress import LogProgress, progress_bar


def test_log_lines_every_tenth(caplog):
    with caplog.at_level(logging.INFO, logger="legato_drake.progress"):
        items = list(LogProgress(range(50), desc="demo", unit="episode"))
    assert items == list(range(50))
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 10
    assert lines[0].startswith("demo: 5/50 episodes done") and lines[-1].startswith("demo: 50/50")


def test_updates_and_postfix(caplog):
    with caplog.at_level(logging.INFO, logger="legato_drake.progress"):
        bar = LogProgress(total=3, desc="collect", unit="episode", initial=1)
        bar.set_postfix(tried=4, failed=1)
        bar.update(2)
        bar.close()
    (line,) = [r.getMessage() for r in caplog.records]
    assert line.startswith("collect: 3/3 episodes done") and line.endswith("tried 4, failed 1")


def test_progress_bar_picks_by_terminal(monkeypatch):
    monkeypatch.setattr("sys.stderr", io.StringIO())  # not a terminal
    assert isinstance(progress_bar(range(3), total=3, disable=None), LogProgress)
    quiet = progress_bar(range(3), progress=False)
    assert isinstance(quiet, tqdm) and quiet.disable
    assert isinstance(progress_bar(range(3), progress=True), tqdm)


def test_log_progress_even_on_a_terminal(monkeypatch):
    """``progress="log"`` (a worker process's training) logs lines where a bar would show."""

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    monkeypatch.setattr("sys.stderr", Terminal())
    assert isinstance(progress_bar(range(3)), tqdm)
    assert isinstance(progress_bar(range(3), progress="log"), LogProgress)
