"""Registry of tasks: name -> Task class (instantiated once per plant)."""

from __future__ import annotations

from legato_drake.errors import unknown_name
from legato_drake.tasks.base import SuccessReport, Task, Waypoint
from legato_drake.tasks.cup import CupTask
from legato_drake.tasks.ladle import LadleTask
from legato_drake.tasks.lid import LidTask

TASKS: dict[str, type[Task]] = {t.name: t for t in (LidTask, CupTask, LadleTask)}


def make_task(name: str) -> Task:
    """Returns a new task object for ``name`` (ConfigError lists the valid names)."""
    try:
        return TASKS[name]()
    except KeyError:
        raise unknown_name("task", name, TASKS) from None


__all__ = ["TASKS", "SuccessReport", "Task", "Waypoint", "make_task"]
