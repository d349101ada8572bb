"""Bring your own robot: an embodiment defined entirely in a YAML file.

Example (paths are relative to the YAML file; every angle in degrees)::

    name: my_arm
    model: my_arm.urdf                 # URDF or SDF, or package://...
    base_frame: base_link              # welded to the world (fixed) or carried by base joints
    base_type: fixed                   # fixed | planar (x, y, yaw) | floating (6 DoF)
    base_pose: {xyz: [-0.2, 0.0, 0.7], rpy_deg: [0, 0, 0]}
    base_range: {x: 0.3, y: 0.3, yaw: 180}   # planar/floating: half-ranges around base_pose
    base_gains: {translation: [20000, 2000], rotation: [5000, 500]}   # planar/floating
    mount_frame: tool0                 # the frame that holds the gripper
    mount: {xyz: [0, 0, 0], rpy_deg: [0, -90, 0]}   # gripper base pose in mount_frame
    home: {shoulder: 0.0, elbow: 1.2}  # radians or metres; unnamed joints home at 0
    pd_gains: {default: [400, 40], wrist: [100, 10]}  # [kp, kd] per joint
    ik: {tracking_gain: 24, posture_gain: 2, posture_joints: [shoulder],
         max_joint_speed: 2.5, max_joint_acceleration: 100,
         orientation_tasks: [{frame: head, gain: 20, weight: 0.05}]}   # optional

A legged robot laid out as Spot (four 3-DoF legs: hip_x, hip_y, knee) can let its legs follow
its body (``robot_types.LegFollower``): the IK then drives every other joint, and the legs get
their targets from analytic leg IK of the body's desired pose, feet fixed on the ground::

    base_type: floating                # or the model's own six body-pose joints
    leg_follower:
      body_joints: [base_x, base_y, base_z, base_roll, base_pitch, base_yaw]  # x y z r p y
      leg_joints: [fl_hip_x, fl_hip_y, fl_knee, fr_hip_x, fr_hip_y, fr_knee,
                   hl_hip_x, hl_hip_y, hl_knee, hr_hip_x, hr_hip_y, hr_knee]
      geometry: {hip_x_offset: [0.29785, 0.055, 0], hip_y_offset: 0.110945,
                 knee_offset: [0.025, -0.3205], lower_leg_length: 0.33,
                 hip_x_limits: [-0.7854, 0.7854], hip_y_limits: [-0.8988, 2.2951],
                 knee_limits: [-2.7929, -0.2471]}   # optional; defaults: Spot's (radians)
      ground_z: 0.0                    # optional: height of the foot points
    foot_frames: [fl_foot, fr_foot, hl_foot, hr_foot]   # optional: their drift is reported

The gripper frame's +x is its approach direction and +z its "up" (camera side); ``mount``
must put the gripper there on your robot. Loading checks the whole definition against the
model (frames, joints, gains, types and ranges of every number) and every error names the
file and the field.

A URDF model without ``<transmission>`` elements (as many arm URDFs come) gets every
revolute, continuous and prismatic joint actuated: the loader writes a copy of the URDF with
one transmission per such joint into the user cache (``$XDG_CACHE_HOME/legato_drake``, mesh
paths made absolute) and logs a note. Add transmissions to actuate only some joints.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import logging
import math
import os
import re
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
import yaml
from pydrake.common.yaml import yaml_load
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant

from legato_drake.embodiments.base import actuators_of, add_embodiment
from legato_drake.errors import ConfigError, yaml_problem
from legato_drake.files import atomic_write_text, read_text_file
from legato_drake.leg_kinematics import LEGS, LegGeometry
from legato_drake.models import add_package
from legato_drake.robot_types import (
    BASE_AXES,
    Embodiment,
    IkSettings,
    LegFollower,
    OrientationTask,
)

log = logging.getLogger(__name__)

REQUIRED = ("name", "model", "base_frame", "mount_frame", "pd_gains")
OPTIONAL = ("base_type", "base_pose", "base_range", "base_gains", "mount", "home", "ik",
            "leg_follower", "foot_frames", "description")
IK_SCALARS = {  # field: smallest allowed value, and whether it is allowed itself
    "tracking_gain": (0.0, False), "posture_gain": (0.0, True),
    "posture_weight": (0.0, True), "posture_task_weight": (0.0, True),
    "max_joint_speed": (0.0, False), "max_joint_acceleration": (0.0, False),
    "max_following_error": (0.0, False), "damping": (0.0, False)}
"""The IK's scalar fields and their ranges."""
IK_TABLES = ("joint_speed_limits", "joint_acceleration_limits", "joint_velocity_weights")
"""The IK's per-joint tables of positive numbers."""
IK_FIELDS = (*IK_SCALARS, "posture_joints", *IK_TABLES, "joint_position_limits",
             "orientation_tasks")
LEG_FOLLOWER_FIELDS = ("body_joints", "leg_joints", "geometry", "ground_z")
LEG_GEOMETRY_VECTORS = {"hip_x_offset": 3, "knee_offset": 2}
"""The leg geometry's vector fields and their lengths."""
LEG_GEOMETRY_LENGTHS = ("hip_y_offset", "lower_leg_length")
LEG_GEOMETRY_LIMITS = ("hip_x_limits", "hip_y_limits", "knee_limits")
MOVABLE_JOINTS = ("revolute", "prismatic")
"""Drake joint types that a URDF without transmissions gets actuated (continuous joints
are revolute in Drake)."""


def load_embodiment_file(path: str | Path) -> Embodiment:
    """Reads, checks and returns the embodiment defined in the YAML file ``path``: once per
    process and version of the file (a scenario's validation and its diagram share the
    result; an ``Embodiment`` is immutable)."""
    path = Path(path)
    try:
        stat = path.resolve().stat()
        version = (stat.st_mtime_ns, stat.st_size)
    except OSError:
        version = None  # read_text_file names the problem
    return _load_embodiment_file(path, version)


@functools.lru_cache(maxsize=32)
def _load_embodiment_file(path: Path, version: tuple[int, int] | None) -> Embodiment:
    text = read_text_file(path, "embodiment file")
    try:
        raw = yaml_load(data=text) if text.strip() else None
    except (yaml.YAMLError, RuntimeError, ValueError) as e:
        raise ConfigError(f"{path}: {yaml_problem(e)}") from None
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
        handles = add_embodiment(plant, add_package(Parser(plant)), emb)
        plant.Finalize()
    except ConfigError:
        raise
    except (RuntimeError, ValueError) as e:  # Drake's parser and plant errors
        raise ConfigError(f"model {emb.model}: {e}") from None
    for i, task in enumerate(emb.ik.orientation_tasks):
        if not plant.HasFrameNamed(task.frame, handles.robot):
            frames = sorted(plant.get_frame(f).name() for f in plant.GetFrameIndices(handles.robot))
            raise ConfigError(f"ik.orientation_tasks[{i}].frame {task.frame!r} is not a frame "
                              f"of {emb.model}; frames: {', '.join(frames)}")


def _check_fields(raw: dict, valid: tuple[str, ...] | list[str], where: str = "") -> None:
    """A ConfigError naming the unknown keys of mapping ``raw`` (at ``where``) and the valid
    ones."""
    unknown = set(raw) - set(valid)
    if unknown:
        place = f"{where}: " if where else ""
        raise ConfigError(f"{place}unknown field(s) {sorted(map(str, unknown))}; valid fields: "
                          f"{', '.join(valid)}")


def _parse(raw: object, folder: Path) -> Embodiment:
    if not isinstance(raw, dict):
        raise ConfigError("expected a mapping of fields at the top level, got "
                          f"{_short(raw)}")
    _check_fields(raw, (*REQUIRED, *OPTIONAL))
    missing = [k for k in REQUIRED if raw.get(k) is None]
    if missing:
        raise ConfigError(f"missing required field(s) {missing}")
    name = _name(raw["name"])
    model = _model_path(_string(raw["model"], "model"), folder)
    base_type = raw.get("base_type", "fixed")
    if base_type not in ("fixed", *BASE_AXES):
        raise ConfigError(f"base_type {base_type!r}; valid values: fixed, "
                          f"{', '.join(BASE_AXES)}")
    ranges = _mapping(raw, "base_range")
    for axis in ranges:
        if axis not in BASE_AXES.get(base_type, ()):
            raise ConfigError(f"base_range.{axis}: not an axis of a {base_type} base "
                              f"(axes: {', '.join(BASE_AXES.get(base_type, ())) or 'none'})")
    base_range = {}
    for axis, value in ranges.items():
        half = _number(value, f"base_range.{axis}", low=0.0)
        base_range[axis] = half if axis in ("x", "y", "z") else math.radians(half)
    extra = {}
    if raw.get("base_gains") is not None:
        extra["base_gains"] = _base_gains(raw["base_gains"], base_type)
    if raw.get("leg_follower") is not None:
        extra["leg_follower"] = _leg_follower(raw["leg_follower"])
    if raw.get("foot_frames") is not None:
        extra["foot_frames"] = _names(raw["foot_frames"], "foot_frames", "frame")
    gains = _mapping(raw, "pd_gains")
    default = gains.pop("default", None)
    pd_gains = {_string(j, "pd_gains (a joint name)"): _gain_pair(v, f"pd_gains.{j}")
                for j, v in gains.items()}
    home = {_string(j, "home (a joint name)"): _number(v, f"home.{j}")
            for j, v in _mapping(raw, "home").items()}
    model, actuated = _actuated_model(model, name)
    emb = Embodiment(
        name=name, model=model, base_frame=_string(raw["base_frame"], "base_frame"),
        base_pose=_pose(raw.get("base_pose"), "base_pose"),
        mount_frame=_string(raw["mount_frame"], "mount_frame"),
        X_mount_gripper=_pose(raw.get("mount"), "mount"), home=home, pd_gains=pd_gains,
        ik=parse_ik_settings(_mapping(raw, "ik")),
        description=_string(raw.get("description", ""), "description"),
        base_type=base_type, base_range=base_range, **extra)
    if default is not None:
        default = _gain_pair(default, "pd_gains.default")
        emb = dataclasses.replace(emb, pd_gains={**{n: default for n in actuated},
                                                 **emb.pd_gains})
    return emb


def _name(value: object) -> str:
    """The embodiment's name: a non-empty string that is not a built-in embodiment's."""
    from legato_drake.embodiments import EMBODIMENTS

    name = _string(value, "name")
    if not name.strip():
        raise ConfigError("name: must not be empty")
    if name in EMBODIMENTS:
        raise ConfigError(f"name {name!r} is a built-in embodiment's; choose another name "
                          f"(built-in: {', '.join(EMBODIMENTS)})")
    return name


def _model_path(model: str, folder: Path) -> str:
    if "://" in model:
        return model
    resolved = (folder / model).resolve()
    if not resolved.is_file():
        raise ConfigError(f"model: file not found: {resolved}")
    if resolved.suffix.lower() not in (".urdf", ".sdf", ".xml"):
        raise ConfigError(f"model {resolved}: expected a URDF (.urdf) or SDF (.sdf) file")
    return str(resolved)


def _model_joints(model: str) -> tuple[list[str], list[str]]:
    """Parses ``model`` alone: (its actuated joints, its revolute and prismatic joints)."""
    plant = MultibodyPlant(0.002)
    parser = add_package(Parser(plant))
    try:
        robots = (parser.AddModels(url=model) if "://" in model
                  else parser.AddModels(file_name=model))
    except (RuntimeError, ValueError) as e:
        raise ConfigError(f"model {model}: {e}") from None
    if len(robots) != 1:
        raise ConfigError(f"model {model} holds {len(robots)} models, expected exactly one")
    actuated = [a.joint().name() for a in actuators_of(plant, robots[0])]
    movable = [plant.get_joint(j).name() for j in plant.GetJointIndices(robots[0])
               if plant.get_joint(j).type_name() in MOVABLE_JOINTS]
    return actuated, movable


def _actuated_model(model: str, name: str) -> tuple[str, list[str]]:
    """The model to load and its actuated joints. A URDF file without transmissions is
    replaced by a cached copy that actuates every revolute and prismatic joint."""
    actuated, movable = _model_joints(model)
    if actuated:
        return model, actuated
    if "://" in model or not model.lower().endswith(".urdf"):
        raise ConfigError(f"model {model} has no actuated joints (add <transmission> "
                          "elements to a URDF, or actuators to an SDF)")
    if not movable:
        raise ConfigError(f"model {model} has no revolute, continuous or prismatic joint")
    copy = _write_actuated_copy(Path(model), movable)
    actuated, _ = _model_joints(str(copy))
    if not actuated:
        raise ConfigError(f"model {model} has no <transmission> elements and its joints "
                          "cannot be actuated (zero effort limits?)")
    if copy not in _NOTED:  # once per process: scenarios are validated often
        _NOTED.add(copy)
        log.info("embodiment %r: %s has no <transmission> elements; actuating its %d joints "
                 "(%s) through %s", name, model, len(actuated), ", ".join(actuated), copy)
    return str(copy), actuated


_NOTED: set[Path] = set()
"""The actuated copies whose note was logged."""


_FILENAME = re.compile(r"""(\bfilename\s*=\s*)(["'])(.*?)\2""")


def cache_dir() -> Path:
    """Where generated model copies go: ``$XDG_CACHE_HOME/legato_drake`` (or ~/.cache)."""
    root = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(root) / "legato_drake"


def _write_actuated_copy(urdf: Path, joints: list[str]) -> Path:
    """Writes (once, by content) a copy of ``urdf`` with one transmission per joint and its
    relative mesh paths made absolute; returns its path."""
    text = read_text_file(urdf, "model")
    end = text.rfind("</robot>")
    if end < 0:
        raise ConfigError(f"model {urdf}: no </robot> element")

    def absolute(match: re.Match) -> str:
        target = match.group(3)
        if "://" in target or os.path.isabs(target):
            return match.group(0)
        return f"{match.group(1)}{quoteattr(str((urdf.parent / target).resolve()))}"

    body = _FILENAME.sub(absolute, text[:end])
    transmissions = "".join(
        f"\n  <transmission name={quoteattr(j + '_legato_transmission')}>"
        "<type>transmission_interface/SimpleTransmission</type>"
        f"<joint name={quoteattr(j)}><hardwareInterface>EffortJointInterface"
        f"</hardwareInterface></joint><actuator name={quoteattr(j + '_legato_motor')}>"
        "<mechanicalReduction>1</mechanicalReduction></actuator></transmission>"
        for j in joints)
    copy_text = f"{body}{transmissions}\n{text[end:]}"
    digest = hashlib.sha256(f"{urdf.resolve()}\n{copy_text}".encode()).hexdigest()[:16]
    path = cache_dir() / "actuated" / f"{urdf.stem}-{digest}.urdf"
    if not path.is_file():
        try:
            atomic_write_text(path, copy_text)
        except OSError as e:
            raise ConfigError(f"model {urdf} has no <transmission> elements and the "
                              f"actuated copy cannot be written to {path} ({e}); set "
                              "XDG_CACHE_HOME or add transmissions") from None
    return path


def parse_ik_settings(raw: dict) -> IkSettings:
    """IkSettings from the ``ik`` mapping, every field checked for its type and range (a
    robot file's ``ik``; ``scripts/ik_variants.py``'s ``--set`` overrides)."""
    _check_fields(raw, IK_FIELDS, "ik")
    values: dict[str, object] = {}
    for key, value in raw.items():
        where = f"ik.{key}"
        if key in IK_SCALARS:
            low, inclusive = IK_SCALARS[key]
            values[key] = _number(value, where, low=low, inclusive=inclusive)
        elif key == "posture_joints":
            if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
                raise ConfigError(f"{where}: expected a list of joint names, got "
                                  f"{_short(value)}")
            values[key] = tuple(value)
        elif key in IK_TABLES:
            table = value or {}
            if not isinstance(table, dict):
                raise ConfigError(f"{where}: expected a mapping of joint names to numbers, "
                                  f"got {_short(value)}")
            values[key] = {_string(j, where): _number(v, f"{where}.{j}", low=0.0,
                                                      inclusive=False)
                           for j, v in table.items()}
        elif key == "joint_position_limits":
            table = value or {}
            if not isinstance(table, dict):
                raise ConfigError(f"{where}: expected a mapping of joint names to "
                                  f"[lower, upper], got {_short(value)}")
            values[key] = {_string(j, where): _range(v, f"{where}.{j}")
                           for j, v in table.items()}
        else:  # orientation_tasks
            values[key] = _orientation_tasks(value)
    return IkSettings(**values)


def _names(value: object, where: str, what: str = "joint", count: int | None = None,
           order: str = "") -> tuple[str, ...]:
    """A list of ``count`` (any number if None) distinct names (``order``: how they go)."""
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise ConfigError(f"{where}: expected a list of {what} names, got {_short(value)}")
    if count is not None and len(value) != count:
        raise ConfigError(f"{where}: expected {count} {what} names{order}, got {len(value)}")
    if len(set(value)) != len(value):
        raise ConfigError(f"{where}: names a {what} twice: {_short(value)}")
    return tuple(value)


def _leg_follower(value: object) -> LegFollower:
    """``leg_follower: {body_joints, leg_joints, geometry, ground_z}`` (the last two
    optional); the joints are checked against the model later, by ``add_embodiment``."""
    if not isinstance(value, dict):
        raise ConfigError("leg_follower: expected a mapping {body_joints: [...], leg_joints: "
                          f"[...], geometry: {{...}}, ground_z: Z}}, got {_short(value)}")
    _check_fields(value, LEG_FOLLOWER_FIELDS, "leg_follower")
    missing = [k for k in ("body_joints", "leg_joints") if value.get(k) is None]
    if missing:
        raise ConfigError(f"leg_follower: missing required field(s) {missing}")
    fields: dict[str, object] = {
        "body_joints": _names(value["body_joints"], "leg_follower.body_joints", count=6,
                              order=" (x, y, z, roll, pitch, yaw)"),
        "leg_joints": _names(value["leg_joints"], "leg_follower.leg_joints",
                             count=3 * len(LEGS),
                             order=f" (legs {', '.join(LEGS)}, each hip_x, hip_y, knee)")}
    if value.get("geometry") is not None:
        fields["geometry"] = _leg_geometry(value["geometry"])
    if "ground_z" in value:
        fields["ground_z"] = _number(value["ground_z"], "leg_follower.ground_z")
    return LegFollower(**fields)


def _leg_geometry(value: object) -> LegGeometry:
    """The legs' kinematics (metres) and joint limits (radians); unnamed fields: Spot's."""
    valid = (*LEG_GEOMETRY_VECTORS, *LEG_GEOMETRY_LENGTHS, *LEG_GEOMETRY_LIMITS)
    if not isinstance(value, dict):
        raise ConfigError(f"leg_follower.geometry: expected a mapping of {', '.join(valid)}, "
                          f"got {_short(value)}")
    _check_fields(value, valid, "leg_follower.geometry")
    fields: dict[str, object] = {}
    for key, item in value.items():
        where = f"leg_follower.geometry.{key}"
        if key in LEG_GEOMETRY_VECTORS:
            size = LEG_GEOMETRY_VECTORS[key]
            if not isinstance(item, list) or len(item) != size:
                raise ConfigError(f"{where}: expected {size} numbers, got {_short(item)}")
            fields[key] = tuple(_number(x, f"{where}[{i}]") for i, x in enumerate(item))
        elif key in LEG_GEOMETRY_LENGTHS:
            fields[key] = _number(item, where, low=0.0, inclusive=key == "hip_y_offset")
        else:
            fields[key] = _range(item, where)
    return LegGeometry(**fields)


def _orientation_tasks(value: object) -> tuple[OrientationTask, ...]:
    shape = "a list of {frame: NAME, gain: G, weight: W}"
    if not isinstance(value, list):
        raise ConfigError(f"ik.orientation_tasks: expected {shape}, got {_short(value)}")
    tasks = []
    for i, item in enumerate(value):
        where = f"ik.orientation_tasks[{i}]"
        if not isinstance(item, dict) or "frame" not in item or \
                set(item) - {"frame", "gain", "weight"}:
            raise ConfigError(f"{where}: expected {{frame: NAME, gain: G, weight: W}} (gain "
                              f"and weight optional), got {_short(item)}")
        fields = {"frame": _string(item["frame"], f"{where}.frame")}
        for key in ("gain", "weight"):
            if key in item:
                fields[key] = _number(item[key], f"{where}.{key}", low=0.0)
        tasks.append(OrientationTask(**fields))
    return tuple(tasks)


def _base_gains(value: object, base_type: str) -> tuple[tuple[float, float],
                                                         tuple[float, float]]:
    """``base_gains: {translation: [kp, kd], rotation: [kp, kd]}`` of the virtual base
    joints (either key optional)."""
    if base_type == "fixed":
        raise ConfigError("base_gains: only a planar or floating base has base joints "
                          "(base_type is fixed)")
    if not isinstance(value, dict) or set(value) - {"translation", "rotation"}:
        raise ConfigError("base_gains: expected {translation: [kp, kd], rotation: [kp, kd]}, "
                          f"got {_short(value)}")
    default = Embodiment.__dataclass_fields__["base_gains"].default
    return (_gain_pair(value["translation"], "base_gains.translation")
            if "translation" in value else default[0],
            _gain_pair(value["rotation"], "base_gains.rotation")
            if "rotation" in value else default[1])


def _short(value: object, limit: int = 80) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _string(value: object, where: str) -> str:
    if not isinstance(value, str):
        raise ConfigError(f"{where}: expected a string, got {_short(value)}")
    return value


def _number(value: object, where: str, low: float | None = None,
            inclusive: bool = True) -> float:
    """A finite number (not a boolean), at least (or above) ``low``."""
    if isinstance(value, bool) or not isinstance(value, int | float) or \
            not math.isfinite(value):
        raise ConfigError(f"{where}: expected a finite number, got {_short(value)}")
    if low is not None and (value < low or (value == low and not inclusive)):
        bound = ">=" if inclusive else ">"
        word = ("non-negative " if inclusive else "positive ") if low == 0 else ""
        raise ConfigError(f"{where}: must be {word}({bound} {low:g}), got {value!r}")
    return float(value)


def _range(value: object, where: str) -> tuple[float, float]:
    if not isinstance(value, list | tuple) or len(value) != 2:
        raise ConfigError(f"{where}: expected [lower, upper], got {_short(value)}")
    low, high = (_number(v, where) for v in value)
    if low > high:
        raise ConfigError(f"{where}: lower {low} is above upper {high}")
    return low, high


def _mapping(raw: dict, key: str) -> dict:
    value = raw.get(key, {}) or {}
    if not isinstance(value, dict):
        raise ConfigError(f"{key}: expected a mapping, got {_short(value)}")
    return dict(value)


def _gain_pair(value: object, where: str) -> tuple[float, float]:
    if (not isinstance(value, list | tuple) or len(value) != 2
            or not all(isinstance(v, int | float) and not isinstance(v, bool)
                       and math.isfinite(v) and v >= 0 for v in value)):
        raise ConfigError(f"{where}: expected [kp, kd] (two non-negative numbers), got "
                          f"{_short(value)}")
    return float(value[0]), float(value[1])


def _pose(value: object, where: str) -> RigidTransform:
    if value is None:
        return RigidTransform()
    if not isinstance(value, dict) or set(value) - {"xyz", "rpy_deg"}:
        raise ConfigError(f"{where}: expected {{xyz: [x, y, z], rpy_deg: [r, p, y]}}, got "
                          f"{_short(value)}")
    xyz = value.get("xyz", [0.0, 0.0, 0.0])
    rpy = value.get("rpy_deg", [0.0, 0.0, 0.0])
    for name, v in (("xyz", xyz), ("rpy_deg", rpy)):
        if not isinstance(v, list) or len(v) != 3:
            raise ConfigError(f"{where}.{name}: expected three numbers, got {_short(v)}")
        for i, x in enumerate(v):
            _number(x, f"{where}.{name}[{i}]")
    return RigidTransform(RollPitchYaw(np.radians(rpy)), np.asarray(xyz, dtype=float))
