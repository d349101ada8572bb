"""The grid file of ``legato-drake experiment``: what to collect, train and evaluate.

A grid is a typed dataclass read from YAML like a scenario (unknown fields, wrong types and
unknown names are one-line errors naming the file and the field, before any work)::

    name: smoke
    datasets:                       # one per task that is evaluated
      - {task: lid, embodiment: abstract, episodes: 150, noise_mm: 5.0, noise_deg: 2.0}
    methods:                        # a learning config (+ overrides) under a name
      - {name: legato, config: legato_small_state.yaml}
      - {name: legato_se3, config: legato_small_state.yaml, overrides: [invariant_weight=0]}
    training: {seeds: [0, 1, 2], snapshot_every: 5000}
    selection: {trials: 10}         # validation rollouts per snapshot; 0: use last.pt
    evaluation: {embodiments: [abstract, panda, spot, google, gr1], tasks: [lid], trials: 50}

Every method is trained on the dataset of every evaluated task, with every training seed,
and evaluated on every embodiment of that task. A method's ``config`` is looked up next to
the grid file, then in the checkout's ``configs/``.
"""

from __future__ import annotations

import dataclasses
import typing
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from legato_drake import conventions
from legato_drake.embodiments import EMBODIMENTS
from legato_drake.errors import ConfigError, yaml_problem
from legato_drake.files import read_text_file
from legato_drake.learning.config import LearningConfig, load_config
from legato_drake.pipelines.evaluate import EVAL_SEED0
from legato_drake.pipelines.selection import SELECT_SEED0
from legato_drake.scenario import CAMERA_MODELS, DEFAULT_MAX_TARGET_LEAD, ExpertNoiseConfig
from legato_drake.tasks import TASKS

CONFIGS_DIR = Path(__file__).resolve().parents[2] / "configs"
"""The checkout's learning configs (a method's ``config`` may name one of them)."""
DEVICES = ("cpu", "cuda", "auto")


@dataclass
class DatasetSpec:
    """Scripted demonstrations to collect (state only unless ``cameras``)."""

    task: str = "lid"
    embodiment: str = "abstract"
    episodes: int = 150
    cameras: bool = False
    camera_model: str = "pinhole"
    """The cameras' lens (``camera.model``: pinhole or fisheye); only with ``cameras``."""
    noise_mm: float = 5.0
    """DART-style expert noise (position, millimetres); 0 for none."""
    noise_deg: float = 2.0
    noise_full_speed: float = conventions.EXPERT_NOISE_FULL_SPEED
    """The plan speed (m/s) at and above which the noise has its full size
    (``ExpertNoiseConfig.full_speed``); lower perturbs the slow final moves too."""
    seed0: int = 0

    def key_fields(self) -> dict:
        """The fields that name the dataset in its unit key: all of them, but
        ``noise_full_speed`` and ``camera_model`` at their defaults (so that the datasets of
        grids written before them keep their keys)."""
        fields = dataclasses.asdict(self)
        if self.noise_full_speed == conventions.EXPERT_NOISE_FULL_SPEED:
            del fields["noise_full_speed"]
        if self.camera_model == "pinhole":
            del fields["camera_model"]
        return fields

    def expert_noise(self) -> ExpertNoiseConfig:
        """The scripted expert's perturbation that collects this dataset."""
        return ExpertNoiseConfig(self.noise_mm / 1000, self.noise_deg,
                                 full_speed=self.noise_full_speed)


@dataclass
class MethodSpec:
    """A method: a learning config file and overrides (``key=value``, as ``--set``)."""

    name: str = ""
    config: str = ""
    overrides: list[str] = field(default_factory=list)


@dataclass
class TrainingSpec:
    """How every method is trained: its seeds, snapshots for selection, threads, device
    (``auto``: a GPU where the backend has one)."""

    seeds: list[int] = field(default_factory=lambda: [0, 1, 2])
    snapshot_every: int = 5000
    threads: int = 1
    device: str = "cpu"


@dataclass
class SelectionSpec:
    """Checkpoint selection by rollouts on validation scene seeds (0 trials: ``last.pt``)."""

    trials: int = 10
    embodiment: str = "abstract"
    seed0: int = SELECT_SEED0


@dataclass
class EvaluationSpec:
    """The evaluation: trials per embodiment and task, scene seeds from ``seed0``;
    ``duration`` 0 keeps each task's own episode length; ``max_target_lead`` bounds the
    commanded gripper's lead in these trials and the selection's (``Scenario``; 0: none)."""

    embodiments: list[str] = field(default_factory=lambda: list(EMBODIMENTS))
    tasks: list[str] = field(default_factory=lambda: ["lid"])
    trials: int = 50
    seed0: int = EVAL_SEED0
    duration: float = 0.0
    max_target_lead: float = DEFAULT_MAX_TARGET_LEAD


@dataclass
class Grid:
    """A whole study: datasets, methods, training, selection and evaluation."""

    name: str = "experiment"
    datasets: list[DatasetSpec] = field(default_factory=list)
    methods: list[MethodSpec] = field(default_factory=list)
    training: TrainingSpec = field(default_factory=TrainingSpec)
    selection: SelectionSpec = field(default_factory=SelectionSpec)
    evaluation: EvaluationSpec = field(default_factory=EvaluationSpec)
    where: str = field(default="", compare=False, repr=False)
    """The grid file (configs are found relative to it); not a YAML field."""

    def dataset_for(self, task: str) -> DatasetSpec:
        """The dataset the methods of ``task`` train on."""
        return next(d for d in self.datasets if d.task == task)

    def config_path(self, method: MethodSpec) -> Path:
        """The learning config file of ``method``."""
        here = Path(self.where).parent / method.config if self.where else None
        if here is not None and here.is_file():
            return here
        return CONFIGS_DIR / method.config

    def learning_config(self, method: MethodSpec, seed: int) -> LearningConfig:
        """``method``'s learning config for training seed ``seed``."""
        return load_config(self.config_path(method),
                           [*method.overrides, f"seed={seed}",
                            f"snapshot_every={self.training.snapshot_every}"])


def _build(schema: type, raw: object, prefix: str) -> object:
    """``schema`` built from parsed YAML, checking every field's type (ConfigError naming
    the field path)."""
    where = prefix.rstrip(".") or "the grid"
    if not isinstance(raw, dict):
        raise ConfigError(f"{where} must be a mapping of fields, got {raw!r}")
    hints = typing.get_type_hints(schema)
    fields = [f.name for f in dataclasses.fields(schema) if f.name != "where"]
    values = {}
    for key, value in raw.items():
        if key not in fields:
            raise ConfigError(f"unknown field '{prefix}{key}'; valid fields: "
                              f"{', '.join(fields)}")
        values[key] = _value(hints[key], value, f"{prefix}{key}")
    return schema(**values)


def _value(kind: object, value: object, name: str) -> object:
    if dataclasses.is_dataclass(kind):
        return _build(kind, value, f"{name}.")
    if typing.get_origin(kind) is list:
        (item,) = typing.get_args(kind)
        if not isinstance(value, list):
            raise ConfigError(f"{name} must be a list, got {value!r}")
        return [_value(item, v, f"{name}[{i}]") for i, v in enumerate(value)]
    if kind is bool and not isinstance(value, bool):
        raise ConfigError(f"{name} must be true or false, got {value!r}")
    if kind is int and (isinstance(value, bool) or not isinstance(value, int)):
        raise ConfigError(f"{name} must be an integer, got {value!r}")
    if kind is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"{name} must be a number, got {value!r}")
        return float(value)
    if kind is str and not isinstance(value, str):
        raise ConfigError(f"{name} must be a string, got {value!r}")
    return value


def _one_of(name: str, value: str, allowed: typing.Iterable[str]) -> None:
    allowed = list(allowed)
    if value not in allowed:
        raise ConfigError(f"{name}: unknown {value!r}; valid values: {', '.join(allowed)}")


def _at_least(name: str, value: float, low: float) -> None:
    if value < low:
        raise ConfigError(f"{name} must be at least {low}, got {value!r}")


def validate(grid: Grid) -> Grid:
    """Checks names, counts and references across the grid (and that every method's config
    loads); returns the grid."""
    if not grid.datasets or not grid.methods:
        raise ConfigError("a grid needs at least one entry in datasets and in methods")
    for i, d in enumerate(grid.datasets):
        _one_of(f"datasets[{i}].task", d.task, TASKS)
        _one_of(f"datasets[{i}].embodiment", d.embodiment, EMBODIMENTS)
        _at_least(f"datasets[{i}].episodes", d.episodes, 1)
        _one_of(f"datasets[{i}].camera_model", d.camera_model, CAMERA_MODELS)
        if d.camera_model != "pinhole" and not d.cameras:
            raise ConfigError(f"datasets[{i}].camera_model {d.camera_model!r} needs "
                              "cameras: true")
        _at_least(f"datasets[{i}].noise_mm", d.noise_mm, 0)
        _at_least(f"datasets[{i}].noise_deg", d.noise_deg, 0)
        if not d.noise_full_speed > 0:
            raise ConfigError(f"datasets[{i}].noise_full_speed must be a positive speed (m/s), "
                              f"got {d.noise_full_speed!r}")
        _at_least(f"datasets[{i}].seed0", d.seed0, 0)
    tasks = [d.task for d in grid.datasets]
    for task in set(tasks):
        if tasks.count(task) > 1:
            raise ConfigError(f"datasets: two datasets of task {task!r}; one per task")
    names = [m.name for m in grid.methods]
    resolved: list[dict] = []
    for i, m in enumerate(grid.methods):
        if not m.name or any(c in m.name for c in "/\\ ") or names.count(m.name) > 1:
            raise ConfigError(f"methods[{i}].name {m.name!r}: expected a unique plain name "
                              "(no spaces or slashes)")
        if not grid.config_path(m).is_file():
            raise ConfigError(f"methods[{i}].config: no learning config {m.config!r} next to "
                              f"the grid file or in {CONFIGS_DIR}")
        try:
            config = grid.learning_config(m, 0).to_dict()
        except ConfigError as e:
            raise ConfigError(f"methods[{i}] ({m.name}): {e}") from None
        if config in resolved:
            raise ConfigError(f"methods[{i}] ({m.name}) trains exactly what methods"
                              f"[{resolved.index(config)}] trains: give it other overrides "
                              "(e.g. name=...) or remove it")
        resolved.append(config)
    t = grid.training
    if not t.seeds or len(set(t.seeds)) != len(t.seeds) or min(t.seeds) < 0:
        raise ConfigError(f"training.seeds must be distinct integers >= 0, got {t.seeds}")
    _at_least("training.snapshot_every", t.snapshot_every, 0)
    _at_least("training.threads", t.threads, 1)
    _one_of("training.device", t.device, DEVICES)
    s = grid.selection
    _at_least("selection.trials", s.trials, 0)
    _one_of("selection.embodiment", s.embodiment, EMBODIMENTS)
    e = grid.evaluation
    if not e.embodiments or not e.tasks:
        raise ConfigError("evaluation.embodiments and evaluation.tasks must not be empty")
    for i, name in enumerate(e.embodiments):
        _one_of(f"evaluation.embodiments[{i}]", name, EMBODIMENTS)
    for i, name in enumerate(e.tasks):
        _one_of(f"evaluation.tasks[{i}]", name, TASKS)
        if name not in tasks:
            raise ConfigError(f"evaluation.tasks[{i}]: no dataset of task {name!r} to train "
                              f"on (datasets: {', '.join(tasks)})")
    _at_least("evaluation.trials", e.trials, 1)
    _at_least("evaluation.duration", e.duration, 0)
    _at_least("evaluation.max_target_lead", e.max_target_lead, 0)
    _check_evaluation_seeds(grid, "evaluation.seed0")
    return grid


def _check_evaluation_seeds(grid: Grid, flag: str) -> None:
    """Refuses evaluation scene seeds that a training demo or a selection trial used."""
    s, e = grid.selection, grid.evaluation
    _at_least(flag, e.seed0, 0)
    selection = set(range(s.seed0, s.seed0 + s.trials)) if s.trials else set()
    evaluation = set(range(e.seed0, e.seed0 + e.trials))
    training = set()
    for d in grid.datasets:
        training |= set(range(d.seed0, d.seed0 + 3 * d.episodes + 10))  # collect's attempts
    for what, seeds in (("selection", selection), ("training", training)):
        if seeds & evaluation:
            raise ConfigError(f"{flag} {e.seed0}: evaluation seeds overlap the "
                              f"{what} seeds (from {min(seeds)} to {max(seeds)})")


def load_grid(path: str | Path) -> Grid:
    """Loads and validates a grid file; errors name the file and the field."""
    path = Path(path)
    text = read_text_file(path, "grid file")
    try:
        raw = yaml.safe_load(text) if text.strip() else {}
    except yaml.YAMLError as e:
        raise ConfigError(f"malformed grid file {path}: {yaml_problem(e)}") from None
    try:
        grid = _build(Grid, raw, "")
        grid.where = str(path)
        return validate(grid)
    except ConfigError as e:
        raise ConfigError(f"grid file {path}: {e}") from None


def grid_dict(grid: Grid) -> dict:
    """The grid as plain data (what ``DIR/grid.json`` records)."""
    raw = dataclasses.asdict(grid)
    raw.pop("where")
    return raw


def subset(grid: Grid, methods: list[str] | None = None, tasks: list[str] | None = None,
           seeds: list[int] | None = None, trials: int | None = None,
           embodiments: list[str] | None = None, seed0: int | None = None) -> Grid:
    """The part of ``grid`` with only these methods, evaluated tasks, training seeds and
    evaluated robots, and the first ``trials`` evaluation scene seeds (``--methods``,
    ``--tasks``, ``--train-seeds``, ``--trials``, ``--embodiments``; None: all). Its units
    are the grid's own, so running the part first and the whole later reuses them.

    ``seed0`` (``--seed0``) moves the evaluation to other scene seeds (never a training or
    selection seed): e.g. development seeds on which to compare recipes, so that the
    evaluation seeds judge only the one chosen. The trainings and selections stay the
    grid's own."""
    if trials is not None and not 1 <= trials <= grid.evaluation.trials:
        raise ConfigError(f"--trials must be between 1 and the grid's evaluation.trials "
                          f"({grid.evaluation.trials}), got {trials}")
    for flag, chosen, present in (
            ("--methods", methods, [m.name for m in grid.methods]),
            ("--tasks", tasks, grid.evaluation.tasks),
            ("--train-seeds", seeds, grid.training.seeds),
            ("--embodiments", embodiments, grid.evaluation.embodiments)):
        unknown = [c for c in chosen or [] if c not in present]
        if unknown:
            raise ConfigError(f"{flag}: {unknown} not in the grid {grid.where or grid.name}; "
                              f"it has: {', '.join(map(str, present))}")
    part = dataclasses.replace(grid)
    if methods:
        part.methods = [m for m in grid.methods if m.name in methods]
    if tasks:
        part.evaluation = dataclasses.replace(
            grid.evaluation, tasks=[t for t in grid.evaluation.tasks if t in tasks])
        part.datasets = [d for d in grid.datasets if d.task in part.evaluation.tasks]
    if seeds:
        part.training = dataclasses.replace(
            grid.training, seeds=[s for s in grid.training.seeds if s in seeds])
    if trials:
        part.evaluation = dataclasses.replace(part.evaluation, trials=trials)
    if embodiments:
        part.evaluation = dataclasses.replace(
            part.evaluation, embodiments=[e for e in grid.evaluation.embodiments
                                          if e in embodiments])
    if seed0 is not None:
        part.evaluation = dataclasses.replace(part.evaluation, seed0=seed0)
        _check_evaluation_seeds(part, "--seed0")
    return part
