"""Checkpoints: the config, the normalisation statistics, the step, the model and optimizer.

A checkpoint is a ``torch.save``d dict written atomically (a reader never sees half a file)::

    {"format": "legato_drake.checkpoint", "version": 1, "algo": str (the policy family),
     "config": {...LearningConfig...},
     "stats": {key: {"mean": [...], "std": [...]}}, "step": int, "best_valid": float,
     "model": state_dict, "optimizer": state_dict | None, "train_seeds": [int, ...],
     "data": str (the dataset it was trained on),
     "selection": {"seeds": [int, ...], ...} (only in a checkpoint chosen by rollouts;
                   "shipped_on": [int, ...], the scene seeds on which a shipped file was
                   chosen among training seeds, ``scripts/ship_checkpoint.py --chosen-on``),
     "camera": {CameraConfig fields} (an image policy's camera, from its dataset),
     "rollout_only": bool (a shipped file: "model" holds only what a rollout needs,
                     ``PolicyFamily.rollout_state_dict``; it cannot be trained further)}
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from pathlib import Path

import torch

from legato_drake.errors import ConfigError, LegatoError
from legato_drake.files import atomic_write_bytes, require_file
from legato_drake.learning.config import (
    ROLLOUT_FIELDS,
    LearningConfig,
    config_from_dict,
    load_config,
    save_config,
)
from legato_drake.learning.family import PolicyFamily
from legato_drake.learning.normalization import stats_from_lists, stats_to_lists
from legato_drake.learning.registry import build_policy

FORMAT = "legato_drake.checkpoint"
VERSION = 1


class CheckpointError(LegatoError):
    """A checkpoint file is missing, unreadable or not one of ours."""


@dataclass
class Checkpoint:
    """What a checkpoint holds (the model as a built policy)."""

    config: LearningConfig
    stats: dict
    policy: PolicyFamily
    step: int = 0
    best_valid: float = float("inf")
    optimizer: dict | None = None
    train_seeds: list[int] = field(default_factory=list)
    data: str = ""
    selection: dict = field(default_factory=dict)
    """How the checkpoint was chosen by rollouts (``legato-drake select``): its validation
    scene ``seeds`` (which evaluation must not reuse), the candidates and their successes;
    for a shipped file chosen among training seeds, also the scenes of that choice
    (``shipped_on``)."""
    camera: dict = field(default_factory=dict)
    """The camera an image policy's training images were rendered with (``CameraConfig``
    fields: model, field of view, size; empty for state policies or datasets that do not
    say): the diagram renders the policy's images with it."""
    rollout_only: bool = False
    """Keep only the weights a rollout needs (a shipped policy: a Diffusion Policy's EMA
    without its trained copy); such a checkpoint has no optimizer state."""

    @property
    def used_seeds(self) -> list[int]:
        """Scene seeds this checkpoint has seen: its training demos', its selection's and
        those it was shipped on."""
        return sorted({*self.train_seeds, *self.selection.get("seeds", []),
                       *self.selection.get("shipped_on", [])})


def save_checkpoint(path: str | Path, ckpt: Checkpoint,
                    optimizer: torch.optim.Optimizer | None = None) -> None:
    """Writes ``ckpt`` (with ``optimizer``'s state if given) to ``path`` atomically."""
    if ckpt.rollout_only:
        weights, optimizer_state = ckpt.policy.rollout_state_dict(), None
    else:
        weights = ckpt.policy.state_dict()
        optimizer_state = optimizer.state_dict() if optimizer is not None else ckpt.optimizer
    payload = {
        "format": FORMAT, "version": VERSION, "algo": ckpt.config.algo,
        "config": ckpt.config.to_dict(),
        "stats": stats_to_lists(ckpt.stats), "step": int(ckpt.step),
        "best_valid": float(ckpt.best_valid),
        "model": {k: v.detach().cpu() for k, v in weights.items()},
        "optimizer": optimizer_state,
        "train_seeds": [int(s) for s in ckpt.train_seeds], "data": str(ckpt.data),
        "selection": ckpt.selection, "camera": ckpt.camera,
        "rollout_only": bool(ckpt.rollout_only),
    }
    _write(Path(path), payload)


def _write(path: Path, payload: dict) -> None:
    """Writes a checkpoint's payload atomically (a reader never sees half a file)."""
    buffer = io.BytesIO()
    torch.save(payload, buffer)
    atomic_write_bytes(path, buffer.getvalue())


def _read(path: Path, device: str = "cpu") -> dict:
    """The raw payload of the checkpoint at ``path`` (checked to be one of ours)."""
    require_file(path, "checkpoint", CheckpointError)
    try:
        payload = torch.load(path, map_location=device, weights_only=False)
    except Exception as e:  # noqa: BLE001 - torch raises many kinds on a bad file
        raise CheckpointError(f"cannot read checkpoint {path}: not a file torch.save wrote "
                              f"({type(e).__name__}: {e})") from None
    if not isinstance(payload, dict) or payload.get("format") != FORMAT:
        raise CheckpointError(f"{path} is not a legato_drake checkpoint")
    if payload.get("version") != VERSION:
        raise CheckpointError(f"{path}: checkpoint version {payload.get('version')} is not "
                              f"{VERSION}")
    return payload


def with_rollout_settings(src: str | Path, dst: str | Path, config: LearningConfig) -> None:
    """Writes a copy of the checkpoint ``src`` to ``dst`` with ``config``'s
    ``ROLLOUT_FIELDS`` in its config and everything else (weights, statistics, step) as it
    was: the same trained network, acting as ``config`` says."""
    payload = _read(Path(src))
    settings = {name: getattr(config, name) for name in ROLLOUT_FIELDS}
    payload["config"] = config_from_dict({**payload["config"], **settings}, str(dst)).to_dict()
    _write(Path(dst), payload)


def set_rollout_settings(folder: str | Path, config: LearningConfig) -> bool:
    """Writes ``config``'s ``ROLLOUT_FIELDS`` into every checkpoint of the training run in
    ``folder`` and into its ``config.yaml`` (``with_rollout_settings``): the run then acts as
    ``config`` says. For runs that share one training (they differ in those fields alone).
    Returns whether anything changed."""
    folder = Path(folder)
    recorded = load_config(folder / "config.yaml")
    settings = {name: getattr(config, name) for name in ROLLOUT_FIELDS}
    if all(getattr(recorded, name) == value for name, value in settings.items()):
        return False
    for path in sorted(folder.glob("*.pt")):
        with_rollout_settings(path, path, config)
    save_config(config_from_dict({**recorded.to_dict(), **settings}, str(folder)),
                folder / "config.yaml")
    return True


def load_checkpoint(path: str | Path, device: str = "cpu") -> Checkpoint:
    """Reads a checkpoint and rebuilds its policy through the family registry (in eval mode,
    on ``device``); a family that is not registered is an error naming the registered
    ones."""
    path = Path(path)
    payload = _read(path, device)
    config = config_from_dict(payload["config"], str(path))
    stats = stats_from_lists(payload["stats"])
    try:
        policy = build_policy(config, stats).to(device)
    except ConfigError as e:
        raise CheckpointError(f"{path}: {e}") from None
    rollout_only = bool(payload.get("rollout_only", False))
    if rollout_only:
        policy.load_rollout_state_dict(payload["model"])
    else:
        policy.load_state_dict(payload["model"])
    policy.eval()
    return Checkpoint(config, stats, policy, payload["step"], payload["best_valid"],
                      payload["optimizer"], list(payload.get("train_seeds", [])),
                      payload.get("data", ""), payload.get("selection", {}),
                      payload.get("camera", {}), rollout_only)
