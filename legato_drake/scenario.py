"""The typed scenario: everything that defines one episode, loadable from YAML.

Example ``scenario.yaml`` (every field is optional; the defaults are shown)::

    embodiment: panda
    task: lid
    controller: scripted
    seed: 0
    duration: 40.0
    camera: {enabled: true, width: 128, height: 128, fov_y_deg: 120.0}
    recording: {meshcat: false, fps: 30.0}
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path

from pydrake.common.yaml import yaml_load_typed

from legato_drake.errors import ConfigError, unknown_name

CONTROLLERS = ("scripted",)
"""Names accepted by ``Scenario.controller``."""


@dataclass
class CameraConfig:
    """The gripper's stereo camera (SPEC §3)."""

    enabled: bool = True
    """Render the two gripper cameras at 10 Hz. Off saves about half the wall time when no
    policy or dataset needs images."""
    width: int = 128
    """Image width in pixels."""
    height: int = 128
    """Image height in pixels."""
    fov_y_deg: float = 120.0
    """Vertical field of view of the pinhole model, in degrees."""


@dataclass
class RecordingConfig:
    """What of the episode is recorded for replay."""

    meshcat: bool = False
    """Record the episode in Meshcat (needed for an HTML replay)."""
    fps: float = 30.0
    """Frames per second of the Meshcat recording."""


@dataclass
class Scenario:
    """One episode: which robot, which task, which controller, which seed."""

    embodiment: str = "panda"
    """Registered embodiment name (``legato_drake.embodiments.EMBODIMENTS``)."""
    task: str = "lid"
    """Registered task name (``legato_drake.tasks.TASKS``)."""
    controller: str = "scripted"
    """What produces the 10 Hz actions: ``scripted`` (the task's scripted demonstrator)."""
    seed: int = 0
    """Seeds the scene randomization and the demonstrator; same seed, same episode."""
    duration: float = 40.0
    """Simulated seconds the controller is given after homing (SPEC: 40 s)."""
    stop_on_success: bool = True
    """End the episode as soon as the task's success predicate holds."""
    camera: CameraConfig = field(default_factory=CameraConfig)
    recording: RecordingConfig = field(default_factory=RecordingConfig)

    def validate(self, where: str = "") -> Scenario:
        """Checks every field against what is allowed; raises ConfigError naming the field."""
        from legato_drake.embodiments import EMBODIMENTS
        from legato_drake.tasks import TASKS

        if self.embodiment not in EMBODIMENTS:
            raise unknown_name("embodiment", self.embodiment, EMBODIMENTS, where)
        if self.task not in TASKS:
            raise unknown_name("task", self.task, TASKS, where)
        if self.controller not in CONTROLLERS:
            raise unknown_name("controller", self.controller, CONTROLLERS, where)
        place = f" in {where}" if where else ""
        if not (math.isfinite(self.duration) and self.duration > 0):
            raise ConfigError(f"duration{place} must be a positive number of seconds, got "
                              f"{self.duration!r}")
        if self.seed < 0:
            raise ConfigError(f"seed{place} must be a non-negative integer, got {self.seed}")
        cam = self.camera
        if cam.width < 8 or cam.height < 8:
            raise ConfigError(f"camera.width/height{place} must be >= 8 pixels, got "
                              f"{cam.width}x{cam.height}")
        if not 10.0 <= cam.fov_y_deg < 179.0:
            raise ConfigError(f"camera.fov_y_deg{place} must be in [10, 179), got "
                              f"{cam.fov_y_deg}")
        if self.recording.fps <= 0:
            raise ConfigError(f"recording.fps{place} must be positive, got {self.recording.fps}")
        return self

    def replace(self, **changes) -> Scenario:
        """Returns a copy with the given fields changed (and validated)."""
        return dataclasses.replace(self, **changes).validate()


def load_scenario(path: str | Path) -> Scenario:
    """Loads and validates a scenario YAML file; errors name the file and the field."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"scenario file not found: {path}")
    try:
        scenario = yaml_load_typed(schema=Scenario, filename=str(path), defaults=Scenario())
    except RuntimeError as e:  # Drake's YAML errors name the key; keep its words
        raise ConfigError(f"malformed scenario file {path}: {e}") from None
    return scenario.validate(where=str(path))


def scenario_from_yaml_text(text: str, where: str = "<string>") -> Scenario:
    """Parses a scenario from YAML text (for notebooks and tests)."""
    try:
        scenario = yaml_load_typed(schema=Scenario, data=text, defaults=Scenario())
    except RuntimeError as e:
        raise ConfigError(f"malformed scenario {where}: {e}") from None
    return scenario.validate(where=where)
