"""Files: atomic writes (a reader never sees half a file, a crash never loses the old one),
reading the text files users write, and checking output locations before any work starts."""

from __future__ import annotations

import csv
import io
import os
import tempfile
from collections.abc import Iterable, Sequence
from pathlib import Path

from legato_drake.errors import ConfigError, LegatoError


def atomic_write_text(path: Path, text: str) -> None:
    """Writes ``text`` to ``path`` through a temporary file and an atomic rename."""
    atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_csv(path: Path, fields: Sequence[str], rows: Iterable[dict]) -> None:
    """Writes ``rows`` as CSV with the columns ``fields`` (other keys ignored), atomically."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=list(fields), extrasaction="ignore")
    writer.writeheader()
    writer.writerows(rows)
    atomic_write_text(path, buffer.getvalue())


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Writes ``data`` to ``path`` through a temporary file and an atomic rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes it private; give it the usual mode
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def require_file(path: str | Path, what: str,
                 error: type[LegatoError] = ConfigError) -> Path:
    """``path``, if it is an existing file; else ``error`` naming ``what`` (e.g. "--data
    dataset file") and the path: not found, or a folder where a file is expected."""
    path = Path(path)
    if path.is_dir():
        raise error(f"{what} {path} is a folder, not a file")
    if not path.is_file():
        raise error(f"{what} not found: {path}")
    return path


def read_text_file(path: str | Path, what: str) -> str:
    """The UTF-8 text of a file a user wrote; ConfigError naming ``what`` (e.g. "scenario
    file") and the path if it is missing, a folder, unreadable or not text."""
    path = require_file(path, what)
    try:
        data = path.read_bytes()
    except OSError as e:
        raise ConfigError(f"{what} {path}: cannot read it ({e.strerror or e})") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise ConfigError(f"{what} {path} is not a UTF-8 text file") from None
    if "\0" in text:
        raise ConfigError(f"{what} {path} is not a text file (it holds NUL bytes)")
    return text


def _check_ancestors(path: Path, flag: str) -> None:
    """The nearest existing ancestor of ``path`` must be a writable folder."""
    for parent in path.absolute().parents:
        if parent.exists():
            if not parent.is_dir():
                raise ConfigError(f"{flag} {path}: {parent} is a file, not a folder")
            if not os.access(parent, os.W_OK | os.X_OK):
                raise ConfigError(f"{flag} {path}: the folder {parent} is not writable")
            return


def check_output_dir(path: str | Path, flag: str) -> Path:
    """Checks (creating nothing) that ``path`` is, or can be made, a writable folder;
    ConfigError naming ``flag`` otherwise. Returns the path."""
    path = Path(path)
    if path.exists():
        if not path.is_dir():
            raise ConfigError(f"{flag} {path}: is an existing file, not a folder")
        if not os.access(path, os.W_OK | os.X_OK):
            raise ConfigError(f"{flag} {path}: the folder is not writable")
        return path
    _check_ancestors(path, flag)
    return path


def check_output_file(path: str | Path, flag: str) -> Path:
    """Checks (creating nothing) that a file can be written at ``path``: not a folder, no
    file where a parent folder must be; ConfigError naming ``flag`` otherwise."""
    path = Path(path)
    if path.is_dir():
        raise ConfigError(f"{flag} {path}: is a folder, not a file")
    if path.exists():
        check_output_dir(path.parent, flag)
    else:
        _check_ancestors(path, flag)
    return path
