"""The units of work of an experiment, as jobs for any executor backend.

A unit is identified by ``unit_key``: a hash of everything its result depends on (a
dataset's spec; a training run's dataset and resolved learning config; a trial's run, the
SHA-256 of the checkpoint it runs, embodiment, task, scene seed and duration). Finished
units are recorded under their key, so a rerun skips them, and changing one input reruns
only what depends on it.

Jobs carry the files they need (``Blob``: a dataset, a checkpoint; the Ray backend passes
them by reference into its object store, ``SharedBlob``) and return what they made
(a training run's files as bytes, a trial's row), so a worker may be a process here or a Ray
task on a node that shares no files; the driver alone writes the experiment folder. Where
the workers run on the driver's machine, a training keeps its checkpoints in a scratch folder
the driver names (``TrainUnit.scratch``), so that a killed one resumes from its last
checkpoint instead of step 0.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from legato_drake.executor import Blob, SharedBlob
from legato_drake.pipelines.evaluate import TrialJob, run_trial

if TYPE_CHECKING:
    from legato_drake.learning.config import LearningConfig

log = logging.getLogger(__name__)


def unit_key(*parts: object) -> str:
    """The key of a unit: the SHA-256 (hex, 16 digits) of its inputs as canonical JSON."""
    text = json.dumps(parts, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclass(frozen=True)
class TrainUnit:
    """One training run: its key, the resolved learning config (as a dict), the dataset, the
    torch threads and the device it asks for (the run's ``cpu_threads`` becomes
    ``threads``: how many cores a worker may use is the backend's business, not the
    method's)."""

    key: str
    config: dict
    data: Blob | SharedBlob
    threads: int = 1
    device: str = "cpu"
    scratch: str = ""
    """Where it trains when it runs on the driver's machine, resuming from the ``last.pt``
    found there (training resumes exactly: the same losses and weights as a run never
    interrupted); the driver removes it once the run's files are recorded."""

    @property
    def resources(self) -> dict:
        """What a Ray task of this unit asks for."""
        return {"num_cpus": self.threads, "num_gpus": 1 if self.device == "cuda" else 0}


@dataclass(frozen=True)
class TrialUnit:
    """One closed-loop trial: its key, the trial (its scenario's checkpoint is replaced by
    the blob's copy on the worker) and the checkpoint it runs."""

    key: str
    trial: TrialJob
    checkpoint: Blob | SharedBlob

    @property
    def resources(self) -> dict:
        """What a Ray task of this unit asks for."""
        return {"num_cpus": 1}


def run_unit(unit: TrainUnit | TrialUnit) -> tuple[str, object]:
    """Runs one unit (in a worker, or here); returns ``(key, result)``: a training run's
    files ``{name: bytes}``, or a trial's row."""
    if isinstance(unit, TrialUnit):
        scenario = unit.trial.scenario.replace(checkpoint=str(unit.checkpoint.path()))
        return unit.key, run_trial(dataclasses.replace(unit.trial, scenario=scenario))
    return unit.key, _train(unit)


def _train(unit: TrainUnit) -> dict[str, bytes]:
    from legato_drake.learning.config import config_from_dict

    config = config_from_dict({**unit.config, "cpu_threads": unit.threads}, unit.key)
    if not logging.getLogger().handlers:  # a worker process: its log lines reach stderr
        logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    if unit.scratch:
        return _train_in(Path(unit.scratch), config, unit)
    with tempfile.TemporaryDirectory(prefix="legato_drake_train_") as folder:
        return _train_in(Path(folder), config, unit)


def _train_in(folder: Path, config: LearningConfig, unit: TrainUnit) -> dict[str, bytes]:
    """Trains (or resumes) the run in ``folder``; returns its files."""
    from legato_drake.learning.checkpoint import set_rollout_settings
    from legato_drake.learning.train import train

    resume = (folder / "last.pt").is_file()
    if resume:
        log.info("resuming the training of %s from %s", unit.key, folder / "last.pt")
        if set_rollout_settings(folder, config):  # started by a run that shares it
            log.info("%s: with the rollout settings of %s", folder, unit.key)
    else:  # a fresh folder, or one killed before its first checkpoint: nothing to keep
        shutil.rmtree(folder, ignore_errors=True)
    # How far an hour-long training is, as a log line a minute (a bar per worker would
    # garble the driver's).
    train(config, unit.data.path(), folder, device=unit.device, resume=resume,
          progress="log")
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}
