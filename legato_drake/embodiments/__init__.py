"""Registry of embodiments: each robot is data (an ``Embodiment``, ``legato_drake/robot_types.py``),
added to a plant by one function (``add_embodiment``)."""

from __future__ import annotations

from legato_drake.embodiments.abstract import ABSTRACT
from legato_drake.embodiments.base import add_embodiment
from legato_drake.embodiments.google_robot import GOOGLE_ROBOT
from legato_drake.embodiments.gr1 import GR1
from legato_drake.embodiments.panda import PANDA
from legato_drake.embodiments.spot import SPOT
from legato_drake.errors import unknown_name
from legato_drake.robot_types import Embodiment, IkSettings, LegFollower, RobotHandles

EMBODIMENTS: dict[str, Embodiment] = {
    e.name: e for e in (ABSTRACT, PANDA, SPOT, GOOGLE_ROBOT, GR1)}


def resolve_embodiment(name: str, file: str = "") -> Embodiment:
    """The embodiment of a scenario: loaded from ``file`` if given, else registered."""
    if file:
        from legato_drake.embodiments.from_file import load_embodiment_file

        return load_embodiment_file(file)
    return get_embodiment(name)


def get_embodiment(name: str) -> Embodiment:
    """Returns the registered embodiment called ``name`` (ConfigError lists valid names)."""
    try:
        return EMBODIMENTS[name]
    except KeyError:
        raise unknown_name("embodiment", name, EMBODIMENTS) from None


__all__ = ["EMBODIMENTS", "Embodiment", "IkSettings", "LegFollower", "RobotHandles",
           "add_embodiment", "get_embodiment", "resolve_embodiment"]
