"""Bring your own robot: an embodiment defined entirely in a YAML file.

Example (paths are relative to the YAML file; every angle in degrees)::

    name: my_arm
    model: my_arm.urdf                 # URDF or SDF, or package://...
    base_frame: base_link              # welded to the world (fixed) or carried by base joints
    base_type: fixed                   # fixed | planar (x, y, yaw) | floating (6 DoF)
    base_pose: {xyz: [-0.2, 0.0, 0.7], rpy_deg: [0, 0, 0]}
    base_range: {x: 0.3, y: 0.3, yaw: 180}   # planar/floating: half-ranges around base_pose
    mount_frame: tool0                 # the frame that holds the gripper
    mount: {xyz: [0, 0, 0], rpy_deg: [0, -90, 0]}   # gripper base pose in mount_frame
    home: {shoulder: 0.0, elbow: 1.2}  # radians or metres; unnamed joints home at 0
    pd_gains: {default: [400, 40], wrist: [100, 10]}  # [kp, kd] per joint
    ik: {tracking_gain: 24, posture_gain: 2, posture_joints: [shoulder],
         max_joint_speed: 2.5, max_joint_acceleration: 100,
         orientation_tasks: [{frame: head, gain: 20, weight: 0.05}]}   # optional

The gripper frame's +x is its approach direction and +z its "up" (camera side); ``mount``
must put the gripper there on your robot. Loading checks the whole definition against the
model (frames, joints, gains) and every error names the file and the field.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
from pydrake.common.yaml import yaml_load
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant

from legato_drake.embodiments.base import (
    BASE_AXES,
    Embodiment,
    IkSettings,
    OrientationTask,
    actuators_of,
    add_embodiment,
)
from legato_drake.errors import ConfigError
from legato_drake.models import add_package

REQUIRED = ("name", "model", "base_frame", "mount_frame", "pd_gains")
OPTIONAL = ("base_type", "base_pose", "base_range", "base_gains", "mount", "home", "ik",
            "description")
IK_FIELDS = ("tracking_gain", "posture_gain", "posture_joints", "posture_weight",
             "posture_task_weight",
             "max_joint_speed", "max_joint_acceleration", "joint_speed_limits",
             "joint_acceleration_limits", "joint_position_limits", "joint_velocity_weights",
             "orientation_tasks")


def load_embodiment_file(path: str | Path) -> Embodiment:
    """Reads, checks and returns the embodiment defined in the YAML file ``path``."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"embodiment file not found: {path}")
    try:
        raw = yaml_load(filename=str(path))
    except RuntimeError as e:
        raise ConfigError(f"{path}: not valid YAML: {e}") from None
    try:
        emb = _parse(raw, path.parent)
        check_embodiment(emb)
    except ConfigError as e:
        raise ConfigError(f"{path}: {e}") from None
    return emb


def check_embodiment(emb: Embodiment) -> None:
    """Adds the embodiment to a scratch plant: raises ConfigError on any mismatch."""
    plant = MultibodyPlant(0.002)
    try:
        add_embodiment(plant, add_package(Parser(plant)), emb)
        plant.Finalize()
    except ConfigError:
        raise
    except (RuntimeError, ValueError) as e:  # Drake's parser and plant errors
        raise ConfigError(f"model {emb.model}: {e}") from None


def _parse(raw: object, folder: Path) -> Embodiment:
    if not isinstance(raw, dict):
        raise ConfigError("expected a mapping of fields at the top level")
    unknown = set(raw) - set(REQUIRED) - set(OPTIONAL)
    if unknown:
        raise ConfigError(f"unknown field(s) {sorted(unknown)}; valid fields: "
                          f"{', '.join(REQUIRED + OPTIONAL)}")
    missing = [k for k in REQUIRED if k not in raw]
    if missing:
        raise ConfigError(f"missing required field(s) {missing}")
    model = str(raw["model"])
    if "://" not in model:
        resolved = (folder / model).resolve()
        if not resolved.is_file():
            raise ConfigError(f"model: file not found: {resolved}")
        model = str(resolved)
    base_type = raw.get("base_type", "fixed")
    if base_type not in ("fixed", *BASE_AXES):
        raise ConfigError(f"base_type {base_type!r}; valid values: fixed, "
                          f"{', '.join(BASE_AXES)}")
    ranges = _mapping(raw, "base_range")
    for axis in ranges:
        if axis not in BASE_AXES.get(base_type, ()):
            raise ConfigError(f"base_range.{axis}: not an axis of a {base_type} base "
                              f"(axes: {', '.join(BASE_AXES.get(base_type, ())) or 'none'})")
    base_range = {a: float(v) if a in ("x", "y", "z") else np.radians(float(v))
                  for a, v in ranges.items()}
    gains = _mapping(raw, "pd_gains")
    default = gains.pop("default", None)
    pd_gains = {j: _gain_pair(v, f"pd_gains.{j}") for j, v in gains.items()}
    ik_raw = _mapping(raw, "ik")
    bad = set(ik_raw) - set(IK_FIELDS)
    if bad:
        raise ConfigError(f"ik: unknown field(s) {sorted(bad)}; valid fields: "
                          f"{', '.join(IK_FIELDS)}")
    if "posture_joints" in ik_raw:
        ik_raw["posture_joints"] = tuple(ik_raw["posture_joints"])
    if "orientation_tasks" in ik_raw:
        tasks = ik_raw["orientation_tasks"]
        try:
            ik_raw["orientation_tasks"] = tuple(OrientationTask(**t) for t in tasks)
        except TypeError:
            raise ConfigError("ik.orientation_tasks: expected a list of {frame: NAME, gain: "
                              f"G, weight: W}}, got {tasks!r}") from None
    emb = Embodiment(
        name=str(raw["name"]), model=model, base_frame=str(raw["base_frame"]),
        base_pose=_pose(raw.get("base_pose"), "base_pose"),
        mount_frame=str(raw["mount_frame"]), X_mount_gripper=_pose(raw.get("mount"), "mount"),
        home={j: float(v) for j, v in _mapping(raw, "home").items()},
        pd_gains=pd_gains, ik=IkSettings(**ik_raw), description=str(raw.get("description", "")),
        base_type=base_type, base_range=base_range)
    if default is not None:
        emb = _with_default_gains(emb, _gain_pair(default, "pd_gains.default"))
    return emb


def _with_default_gains(emb: Embodiment, gains: tuple[float, float]) -> Embodiment:
    """Fills ``default`` PD gains in for every actuated joint the file does not name."""
    plant = MultibodyPlant(0.002)
    parser = add_package(Parser(plant))
    try:
        (robot,) = (parser.AddModels(url=emb.model) if "://" in emb.model
                    else parser.AddModels(file_name=emb.model))
    except (RuntimeError, ValueError) as e:
        raise ConfigError(f"model {emb.model}: {e}") from None
    names = [a.joint().name() for a in actuators_of(plant, robot)]
    return dataclasses.replace(emb, pd_gains={**{n: gains for n in names}, **emb.pd_gains})


def _mapping(raw: dict, key: str) -> dict:
    value = raw.get(key, {}) or {}
    if not isinstance(value, dict):
        raise ConfigError(f"{key}: expected a mapping, got {value!r}")
    return dict(value)


def _gain_pair(value: object, where: str) -> tuple[float, float]:
    if (not isinstance(value, list | tuple) or len(value) != 2
            or not all(isinstance(v, int | float) and v >= 0 for v in value)):
        raise ConfigError(f"{where}: expected [kp, kd] (two non-negative numbers), got "
                          f"{value!r}")
    return float(value[0]), float(value[1])


def _pose(value: object, where: str) -> RigidTransform:
    if value is None:
        return RigidTransform()
    if not isinstance(value, dict) or set(value) - {"xyz", "rpy_deg"}:
        raise ConfigError(f"{where}: expected {{xyz: [x, y, z], rpy_deg: [r, p, y]}}, got "
                          f"{value!r}")
    xyz = value.get("xyz", [0.0, 0.0, 0.0])
    rpy = value.get("rpy_deg", [0.0, 0.0, 0.0])
    for name, v in (("xyz", xyz), ("rpy_deg", rpy)):
        if not isinstance(v, list) or len(v) != 3:
            raise ConfigError(f"{where}.{name}: expected three numbers, got {v!r}")
    return RigidTransform(RollPitchYaw(np.radians(rpy)), np.asarray(xyz, dtype=float))
