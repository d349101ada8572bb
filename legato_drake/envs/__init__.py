"""Gymnasium environments: every task on every robot, for policies of any framework.

``import legato_drake.envs`` (or ``gym.make("legato_drake.envs:LegatoDrake/Lid-Panda-v0")``,
which imports it first) registers

- ``LegatoDrake/<Task>-<Robot>-v0`` for Task in Lid, Cup, Ladle and Robot in Abstract, Panda,
  Spot, Google, GR1;
- ``LegatoDrake/<Task>-v0``: Abstract by default; a YAML robot with
  ``gym.make("LegatoDrake/Lid-v0", embodiment_file="my_robot.yaml")``.

Keyword arguments of ``gym.make`` go to ``LegatoEnv`` (``duration``, ``privileged``,
``render_mode="rgb_array"``).
"""

from __future__ import annotations

import gymnasium as gym

from legato_drake.envs.legato_env import LegatoEnv

TASK_NAMES = {"Lid": "lid", "Cup": "cup", "Ladle": "ladle"}
ROBOT_NAMES = {"Abstract": "abstract", "Panda": "panda", "Spot": "spot", "Google": "google",
               "GR1": "gr1"}
ENTRY_POINT = "legato_drake.envs.legato_env:LegatoEnv"


def env_ids() -> list[str]:
    """Every registered environment id, per task the robot-less one first."""
    return [i for task in TASK_NAMES for i in
            (f"LegatoDrake/{task}-v0", *(f"LegatoDrake/{task}-{r}-v0" for r in ROBOT_NAMES))]


def register_envs() -> None:
    """Registers the environments with Gymnasium (again: a no-op)."""
    for task, task_name in TASK_NAMES.items():
        ids = {f"LegatoDrake/{task}-v0": "abstract",
               **{f"LegatoDrake/{task}-{r}-v0": name for r, name in ROBOT_NAMES.items()}}
        for env_id, robot in ids.items():
            if env_id not in gym.registry:
                gym.register(id=env_id, entry_point=ENTRY_POINT,
                             kwargs=dict(task=task_name, embodiment=robot))


register_envs()

__all__ = ["LegatoEnv", "env_ids", "register_envs"]
