"""Progress of long work: a tqdm bar on a terminal, log lines in batch jobs.

When stderr is not a terminal (a batch job, CI, ``2> log``), tqdm's bars are disabled and
nothing would say how far the work is; ``progress_bar`` then logs a line every tenth of the
work (and at least once a minute while it advances) instead.
"""

from __future__ import annotations

import logging
import sys
import time
from collections.abc import Iterable, Iterator

from tqdm import tqdm

log = logging.getLogger(__name__)


class LogProgress:
    """The part of tqdm's interface this package uses, as INFO log lines."""

    def __init__(self, iterable: Iterable | None = None, total: int | None = None,
                 desc: str = "", unit: str = "it", initial: int = 0,
                 every_s: float = 60.0, **_: object):
        self.iterable = iterable
        if total is None and hasattr(iterable, "__len__"):
            total = len(iterable)  # type: ignore[arg-type]
        self.total, self.desc, self.unit, self.n = total, desc, unit, initial
        self.every_s = every_s
        self.start = self.last = time.monotonic()
        self.step = max(1, (total or 0) // 10)
        self.next_n = initial + self.step
        self.postfix = ""

    def update(self, n: int = 1) -> None:
        """Counts ``n`` more done; logs a line at each tenth, or after ``every_s``."""
        self.n += n
        now = time.monotonic()
        if self.n >= self.next_n or now - self.last >= self.every_s or \
                (self.total is not None and self.n >= self.total):
            log.info("%s: %d/%s %ss done, %.1f min%s", self.desc or "progress", self.n,
                     self.total if self.total is not None else "?", self.unit,
                     (now - self.start) / 60.0, self.postfix)
            self.last = now
            self.next_n = self.n + self.step

    def set_postfix(self, **values: object) -> None:
        """Extra fields for the next lines (as tqdm shows them after the bar)."""
        self.postfix = "".join(f", {k} {v}" for k, v in values.items())

    def close(self) -> None:
        """Nothing to release (tqdm's interface)."""

    def __iter__(self) -> Iterator:
        for item in self.iterable or ():
            yield item
            self.update(1)

    def __enter__(self) -> LogProgress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def progress_bar(iterable: Iterable | None = None, progress: bool | str | None = None,
                 **kwargs: object) -> tqdm | LogProgress:
    """``tqdm(iterable, **kwargs)`` on a terminal (or with ``progress=True``), log lines when
    stderr is not a terminal (``progress=None``) or always (``progress="log"``: work in a
    worker process, whose bars would garble the driver's), nothing with ``progress=False``."""
    kwargs.pop("disable", None)
    if progress is False:
        return tqdm(iterable, disable=True, **kwargs)
    if progress == "log":
        return LogProgress(iterable, **kwargs)
    if progress or sys.stderr.isatty():
        return tqdm(iterable, **kwargs)
    return LogProgress(iterable, **kwargs)
