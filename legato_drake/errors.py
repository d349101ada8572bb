"""The project's exception types: each names what was wrong and what is allowed."""

from __future__ import annotations

from collections.abc import Iterable


class LegatoError(Exception):
    """Base class of every error this package raises on bad input."""


class ConfigError(LegatoError, ValueError):
    """A scenario, embodiment or configuration file (or field) is malformed."""


def unknown_name(kind: str, name: str, valid: Iterable[str], where: str = "") -> ConfigError:
    """Builds the error for a name that is not in a registry, listing the valid names."""
    place = f" in {where}" if where else ""
    choices = ", ".join(sorted(valid))
    return ConfigError(f"unknown {kind} {name!r}{place}; valid values: {choices}")


def one_line(message: object) -> str:
    """A message on one line: its non-empty lines joined by "; " (PyYAML's and Drake's
    messages span several lines, with source excerpts and carets)."""
    lines = [line.strip() for line in str(message).splitlines()]
    return "; ".join(line for line in lines if line and set(line) != {"^"})


def yaml_problem(error: Exception) -> str:
    """One line saying what is wrong in a YAML text, and where (line, column), for a PyYAML
    error; any other error's own message."""
    problem = getattr(error, "problem", None)
    mark = getattr(error, "problem_mark", None)
    if problem:
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        context = getattr(error, "context", None)
        return f"not valid YAML: {where}{problem}" + (f" ({context})" if context else "")
    return one_line(error) or type(error).__name__
