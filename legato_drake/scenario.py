"""The typed scenario: everything that defines one episode, loadable from YAML.

Example ``scenario.yaml`` (every field is optional; the defaults are shown)::

    embodiment: panda
    task: lid
    controller: scripted     # or replay (with pose_stream: poses.csv)
    pose_stream: ""
    checkpoint: ""           # controller: policy runs this trained checkpoint
    seed: 0
    duration: 40.0
    max_target_lead: 0.03    # policy only: bound on the commanded gripper's lead (metres)
    expert_noise: {position_std: 0.0, rotation_std_deg: 0.0, correlation: 0.8, full_speed: 0.15}
    camera: {enabled: true, width: 128, height: 128, fov_y_deg: 120.0}
    recording: {meshcat: false, fps: 30.0}
"""

# No ``from __future__ import annotations`` here: pydrake's YAML loader reads the field types.
import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path

import yaml
from pydrake.common.yaml import yaml_load, yaml_load_typed

from legato_drake import conventions
from legato_drake.data.pose_stream import check_pose_stream_file
from legato_drake.errors import ConfigError, unknown_name, yaml_problem
from legato_drake.files import read_text_file

DEFAULT_MAX_TARGET_LEAD = 0.03
"""How far (metres) a policy's commanded gripper may lead the measured one by default: two
10 Hz steps at the demonstrations' fastest cruise (15 cm/s), so a robot that keeps up seldom
meets the bound, while the target of one that stalls stops there instead of running away
(docs/results/state_policies.md)."""

CONTROLLERS = ("scripted", "replay", "policy", "external")
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
    model: str = "pinhole"
    """``pinhole`` (the reference's, the default) or ``fisheye``: the T265-like lens of
    ``systems.fisheye``, ``fisheye_fov_deg`` across its sensor's diagonal, centre-cropped
    and resized to ``width`` x ``height`` (a wider pinhole render remapped with OpenCV)."""
    fisheye_fov_deg: float = 163.0
    """The fisheye's diagonal field of view over the whole 848 x 800 sensor, in degrees."""


CAMERA_MODELS = ("pinhole", "fisheye")


@dataclass
class RecordingConfig:
    """What of the episode is recorded for replay."""

    meshcat: bool = False
    """Record the episode in Meshcat (needed for an HTML replay)."""
    fps: float = 30.0
    """Frames per second of the Meshcat recording."""


@dataclass
class ExpertNoiseConfig:
    """DART-style perturbations of the scripted expert (for collecting demonstrations that
    teach recovery). The executed commanded pose is the plan's pose times a small random
    offset that drifts from step to step (an AR(1) process per axis, in the gripper frame,
    scaled by the plan's speed: full at ``full_speed``, none where the plan is still);
    the *label* the dataset records is the expert's correction from where it is back to its
    plan. Zero (the default) plays the plan exactly."""

    position_std: float = 0.0
    """Standard deviation (m) of the offset's translation, per axis."""
    rotation_std_deg: float = 0.0
    """Standard deviation (degrees) of the offset's rotation vector, per axis."""
    correlation: float = 0.8
    """Step-to-step correlation of the offset, in [0, 1): 0 is white noise, near 1 a slow
    drift (the offset's time constant is about 1 / (1 - correlation) policy steps)."""
    full_speed: float = conventions.EXPERT_NOISE_FULL_SPEED
    """Plan speed (m/s) at and above which the offset has its full size; slower, it shrinks
    in proportion. At the default 0.15 the slow final moves into a grasp or a placement
    (0.05-0.06 m/s, slowing to a stop) are hardly perturbed; lower, they are too, and the
    demonstrations show corrections near the handle and above the pot."""

    @property
    def enabled(self) -> bool:
        """Whether the expert is perturbed at all."""
        return self.position_std > 0 or self.rotation_std_deg > 0


@dataclass
class Scenario:
    """One episode: which robot, which task, which controller, which seed."""

    embodiment: str = "panda"
    """Registered embodiment name (``legato_drake.embodiments.EMBODIMENTS``); ignored when
    ``embodiment_file`` is set."""
    embodiment_file: str = ""
    """An embodiment YAML file (bring your own robot; see ``embodiments/from_file.py``)."""
    task: str = "lid"
    """Registered task name (``legato_drake.tasks.TASKS``)."""
    controller: str = "scripted"
    """What produces the 10 Hz actions: ``scripted`` (the task's scripted demonstrator),
    ``replay`` (a recorded pose stream, ``pose_stream``), ``policy`` (a trained
    ``checkpoint``) or ``external`` (set from outside the diagram at each step, e.g. by the
    Gymnasium environments of ``legato_drake.envs``)."""
    pose_stream: str = ""
    """Recorded 6-DoF gripper pose stream (CSV or NPZ, docs/data_format.md) that
    ``controller: replay`` plays; required by it."""
    checkpoint: str = ""
    """Trained policy checkpoint (``legato-drake train``'s ``best.pt``/``last.pt``) that
    ``controller: policy`` runs; required by it."""
    seed: int = 0
    """Seeds the scene randomization and the demonstrator; same seed, same episode."""
    duration: float = 40.0
    """Simulated seconds the controller is given after homing (SPEC: 40 s)."""
    stop_on_success: bool = True
    """End the episode as soon as the task's success predicate holds."""
    max_target_lead: float = DEFAULT_MAX_TARGET_LEAD
    """``controller: policy`` only: how far (metres) the commanded gripper pose may lead the
    measured gripper; a step that would take it further is shortened along its direction to
    that distance (``GripperTargetIntegrator``). 0 leaves it unbounded: where a robot cannot
    follow, the target then keeps integrating the policy's deltas and runs away
    (docs/results/state_policies.md: 40 cm on Spot)."""
    expert_noise: ExpertNoiseConfig = field(default_factory=ExpertNoiseConfig)
    """Perturbations of ``controller: scripted`` (seeded by ``seed``); none by default."""
    camera: CameraConfig = field(default_factory=CameraConfig)
    recording: RecordingConfig = field(default_factory=RecordingConfig)

    def validate(self, where: str = "") -> "Scenario":
        """Checks every field against what is allowed; raises ConfigError naming the field.
        The pose stream and the checkpoint are only checked to exist (and the stream to
        have a known suffix): they are read where the diagram is built, once. An embodiment
        file is read for its robot's name, which becomes ``embodiment``."""
        from legato_drake.embodiments import EMBODIMENTS
        from legato_drake.tasks import TASKS

        if self.embodiment_file:
            from legato_drake.embodiments.from_file import load_embodiment_file

            self.embodiment = load_embodiment_file(self.embodiment_file).name
        elif self.embodiment not in EMBODIMENTS:
            raise unknown_name("embodiment", self.embodiment, EMBODIMENTS, where)
        if self.task not in TASKS:
            raise unknown_name("task", self.task, TASKS, where)
        if self.controller not in CONTROLLERS:
            raise unknown_name("controller", self.controller, CONTROLLERS, where)
        place = f" in {where}" if where else ""
        if self.controller == "replay" and not self.pose_stream:
            raise ConfigError(f"pose_stream{place} must name a pose stream file (CSV or NPZ) "
                              "when controller is 'replay'")
        if self.controller == "policy" and not self.checkpoint:
            raise ConfigError(f"checkpoint{place} must name a policy checkpoint file when "
                              "controller is 'policy'")
        if self.checkpoint and not Path(self.checkpoint).is_file():
            raise ConfigError(f"checkpoint{place}: file not found: {self.checkpoint}")
        if self.pose_stream:
            try:
                check_pose_stream_file(self.pose_stream)
            except ConfigError as e:
                raise ConfigError(f"pose_stream{place}: {e}") from None
        if not (math.isfinite(self.duration) and self.duration > 0):
            raise ConfigError(f"duration{place} must be a positive number of seconds, got "
                              f"{self.duration!r}")
        if not (math.isfinite(self.max_target_lead) and self.max_target_lead >= 0):
            raise ConfigError(f"max_target_lead{place} must be a non-negative number of "
                              f"metres (0: unbounded), got {self.max_target_lead!r}")
        if self.seed < 0:
            raise ConfigError(f"seed{place} must be a non-negative integer, got {self.seed}")
        cam = self.camera
        if cam.width < 8 or cam.height < 8:
            raise ConfigError(f"camera.width/height{place} must be >= 8 pixels, got "
                              f"{cam.width}x{cam.height}")
        if not 10.0 <= cam.fov_y_deg < 179.0:
            raise ConfigError(f"camera.fov_y_deg{place} must be in [10, 179), got "
                              f"{cam.fov_y_deg}")
        if cam.model not in CAMERA_MODELS:
            raise ConfigError(f"camera.model{place} must be one of {', '.join(CAMERA_MODELS)}, "
                              f"got {cam.model!r}")
        if not 60.0 <= cam.fisheye_fov_deg <= 200.0:
            raise ConfigError(f"camera.fisheye_fov_deg{place} must be in [60, 200], got "
                              f"{cam.fisheye_fov_deg}")
        noise = self.expert_noise
        for name in ("position_std", "rotation_std_deg"):
            value = getattr(noise, name)
            if not (math.isfinite(value) and value >= 0):
                raise ConfigError(f"expert_noise.{name}{place} must be a non-negative number, "
                                  f"got {value!r}")
        if not (math.isfinite(noise.correlation) and 0 <= noise.correlation < 1):
            raise ConfigError(f"expert_noise.correlation{place} must be in [0, 1), got "
                              f"{noise.correlation!r}")
        if not (math.isfinite(noise.full_speed) and noise.full_speed > 0):
            raise ConfigError(f"expert_noise.full_speed{place} must be a positive speed (m/s), "
                              f"got {noise.full_speed!r}")
        if not (math.isfinite(self.recording.fps) and self.recording.fps > 0):
            raise ConfigError(f"recording.fps{place} must be a positive number, got "
                              f"{self.recording.fps}")
        return self

    def replace(self, **changes) -> "Scenario":
        """Returns a copy with the given fields changed (and validated)."""
        return dataclasses.replace(self, **changes).validate()


_YAML_ERRORS = (yaml.YAMLError, RuntimeError, ValueError, TypeError, AssertionError, KeyError)


def _yaml_message(error: Exception) -> str:
    return yaml_problem(error)


def check_fields(raw: object, schema: type, prefix: str = "") -> None:
    """Checks parsed YAML against a dataclass schema; raises ConfigError naming the field
    path and what it allows (Drake's own messages name neither)."""
    where = prefix.rstrip(".") or "the scenario"
    if not isinstance(raw, dict):
        raise ConfigError(f"{where} must be a mapping of fields, got {raw!r}")
    fields = {f.name: f for f in dataclasses.fields(schema)}
    for key, value in raw.items():
        if key not in fields:
            raise ConfigError(f"unknown field {prefix}{key!r}; valid fields: "
                              f"{', '.join(fields)}")
        kind = fields[key].type
        if dataclasses.is_dataclass(kind):
            check_fields(value, kind, f"{prefix}{key}.")
        elif kind is bool and not isinstance(value, bool):
            raise ConfigError(f"{prefix}{key} must be true or false, got {value!r}")
        elif kind is int and (isinstance(value, bool) or not isinstance(value, int)):
            raise ConfigError(f"{prefix}{key} must be an integer, got {value!r}")
        elif kind is float and (isinstance(value, bool) or not isinstance(value, int | float)):
            raise ConfigError(f"{prefix}{key} must be a number, got {value!r}")
        elif kind is str and not isinstance(value, str):
            raise ConfigError(f"{prefix}{key} must be a string, got {value!r}")


def _load(data: str, where: str) -> "Scenario":
    try:
        raw = yaml_load(data=data) if data.strip() else {}
    except _YAML_ERRORS as e:
        raise ConfigError(f"malformed scenario {where}: {_yaml_message(e)}") from None
    try:
        check_fields(raw, Scenario)
    except ConfigError as e:
        raise ConfigError(f"malformed scenario {where}: {e}") from None
    try:
        scenario = yaml_load_typed(schema=Scenario, data=data, defaults=Scenario())
    except _YAML_ERRORS as e:
        raise ConfigError(f"malformed scenario {where}: {_yaml_message(e)}") from None
    return scenario.validate(where=where)


def load_scenario(path: str | Path) -> Scenario:
    """Loads and validates a scenario YAML file; errors name the file and the field."""
    path = Path(path)
    return _load(read_text_file(path, "scenario file"), str(path))


def scenario_from_yaml_text(text: str, where: str = "<string>") -> Scenario:
    """Parses a scenario from YAML text (for notebooks and tests)."""
    return _load(text, where)
