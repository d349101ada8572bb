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
