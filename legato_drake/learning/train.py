"""The training loop: seeded, resumable, logged, checkpointed atomically.

``train(config, data, out)`` writes into ``out``:

* ``config.yaml``: the run's config (also inside every checkpoint);
* ``machine.json``: where the run was trained, one entry per start (a resumed run adds one):
  the step it started from, the CPU model, torch's CPU instruction set, the versions and the
  device, since float results can differ between machines (docs/results/state_policies.md);
* ``log.csv``: one row per step (``step``, the family's loss terms, e.g. ``nll, ce, invar,
  total`` for the recurrent GMM policies, and ``lr``) and, every ``valid_every`` steps, the
  validation losses (``valid_*`` columns; empty otherwise),
  appended at every checkpoint (a resumed run first cuts it back to its checkpoint's step);
* ``last.pt`` (every ``checkpoint_every`` steps and at the end) and ``best.pt`` (lowest
  validation total loss), each with the config, the normalisation statistics, the step and
  the optimizer state; with ``snapshot_every``, ``step_<N>.pt`` snapshots (no optimizer
  state), the candidates of ``legato-drake select``; TensorBoard events too if
  ``tensorboard`` happens to be installed.

The batch of step s is drawn by ``numpy.random.default_rng([batch_order_seed, s])`` (the
config's ``batch_seed``, else its ``seed``), so a run resumed from
``last.pt`` sees exactly the batches an uninterrupted run would have seen (and, on CPU, gives
the same losses).
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import logging
import math
import platform
import random
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import torch
from torch.utils.data import DataLoader, Sampler

from legato_drake.data.derived import available_observations, planned_actions, read_observation
from legato_drake.data.layout import (
    IMAGE_KEYS,
    DatasetError,
    mask_names,
    open_dataset,
    recorded_camera,
    sorted_demos,
)
from legato_drake.data.torch_dataset import DemoSequenceDataset
from legato_drake.errors import ConfigError
from legato_drake.files import atomic_write_text, require_file
from legato_drake.learning.checkpoint import Checkpoint, load_checkpoint, save_checkpoint
from legato_drake.learning.config import LearningConfig, config_from_dict, save_config
from legato_drake.learning.family import PolicyFamily
from legato_drake.learning.hardware import cpu_model, native_bfloat16
from legato_drake.learning.normalization import OBS_MIN_STD, compute_stats
from legato_drake.learning.registry import (
    build_policy,
    check_algo,
    extra_stats,
    observed_steps,
)
from legato_drake.progress import progress_bar

log = logging.getLogger(__name__)

VALID_SEED = 7919
"""Seeds the (fixed) validation batches."""


class StepBatchSampler(Sampler[list[int]]):
    """The batches of steps ``start .. stop - 1``: batch s = ``batch_size`` distinct indices
    drawn by ``default_rng([seed, s])``, ``seed`` the config's ``batch_order_seed``
    (independent of where a run was resumed)."""

    def __init__(self, n: int, batch_size: int, seed: int, start: int, stop: int):
        self.n, self.batch_size, self.seed = n, batch_size, seed
        self.start, self.stop = start, stop

    def __len__(self) -> int:
        return max(self.stop - self.start, 0)

    def __iter__(self) -> Iterator[list[int]]:
        for step in range(self.start, self.stop):
            rng = np.random.default_rng([self.seed, step])
            yield rng.choice(self.n, self.batch_size, replace=self.n < self.batch_size).tolist()


RUN_FILES = ("last.pt", "best.pt", "log.csv", "config.yaml", "machine.json", "tensorboard")
"""What ``train`` writes into its run folder besides its snapshots (``SNAPSHOTS``)."""
SNAPSHOTS = "step_*.pt"
"""The pattern of a run's ``snapshot_path`` files."""


def snapshot_path(out: Path, step: int) -> Path:
    """Where a run keeps its snapshot of ``step`` (``LearningConfig.snapshot_every``)."""
    return out / f"step_{step:06d}.pt"


def seed_everything(seed: int) -> None:
    """Seeds Python, numpy and torch (parameter initialisation)."""
    random.seed(seed)
    np.random.seed(seed % 2**32)
    torch.manual_seed(seed)


def check_data(path: Path, config: LearningConfig) -> list[int]:
    """Clear errors before training: a missing file, observations the config needs but the
    file lacks (e.g. images in a state-only dataset). Returns the demos' scene seeds."""
    require_file(path, "dataset file", DatasetError)
    with open_dataset(path) as f:
        names = sorted_demos(f["data"])
        if not names:
            raise DatasetError(f"{path} holds no demos")
        available = available_observations(list(f["data"][names[0]]["obs"]))
        missing = [k for k in config.dataset_keys if k not in available]
        if missing:
            hint = (" (a state-only dataset: collect with the camera, or use obs_mode: state)"
                    if any(k in IMAGE_KEYS for k in missing) else "")
            raise ConfigError(f"obs_mode {config.obs_mode!r} needs observation(s) "
                              f"{', '.join(missing)}, which {path} lacks{hint}; it has "
                              f"{', '.join(sorted(available))}")
        return [int(f["data"][n].attrs.get("seed", -1)) for n in names]


def dataset_stats(path: Path, config: LearningConfig) -> dict[str, dict[str, np.ndarray]]:
    """Normalisation statistics of the low-dim observations and actions of the train split,
    and the family's own (``registry.extra_stats``)."""
    keys = [k for k in config.dataset_keys if k not in IMAGE_KEYS]
    with open_dataset(path) as f:
        names = mask_names(f, "train") or sorted_demos(f["data"])
        stats = {k: compute_stats([read_observation(f["data"][n]["obs"], k) for n in names],
                                  OBS_MIN_STD) for k in keys}
        actions = [f["data"][n]["actions"][()] for n in names]
        planned = [planned_actions(f["data"][n]["obs"]["tcp_commanded"][()], a)
                   for n, a in zip(names, actions, strict=True)]
        stats["actions"] = compute_stats(actions)
    stats.update(extra_stats(config, actions, planned))
    return stats


def learning_rate(config: LearningConfig, step: int) -> float:
    """The learning rate of the step after ``step`` steps (``config.lr_schedule``): a
    function of the step alone, so that a resumed run continues the schedule exactly."""
    if config.lr_schedule == "cosine":
        return config.lr * 0.5 * (1.0 + math.cos(math.pi * min(step, config.steps)
                                                 / config.steps))
    return config.lr


def _to_device(batch: dict, device: str) -> dict:
    """The batch on ``device`` (from pinned memory on a GPU: the copy overlaps the step)."""
    def move(v: torch.Tensor) -> torch.Tensor:
        return v.to(device, non_blocking=True)

    return {"obs": {k: move(v) for k, v in batch["obs"].items()},
            **{k: move(batch[k]) for k in ("actions", "planned_actions", "pad_mask")}}


def _read_log(path: Path, upto: int) -> list[dict]:
    if not path.is_file():
        return []
    with open(path, newline="") as f:
        return [row for row in csv.DictReader(f) if int(row["step"]) <= upto]


def log_columns(policy: PolicyFamily) -> tuple[str, ...]:
    """The training log's columns for ``policy``'s loss terms."""
    terms = policy.loss_terms
    return ("step", *terms, "lr", *(f"valid_{t}" for t in terms))


def _record_machine(path: Path, step: int, device: str) -> None:
    """Appends where this (re)start of the run trains to ``machine.json``."""
    entries = json.loads(path.read_text()) if path.is_file() else []
    entries.append({"step": step, "cpu": cpu_model(), "machine": platform.machine(),
                    "cpu_capability": torch.backends.cpu.get_cpu_capability(),
                    "native_bfloat16": native_bfloat16(),
                    "threads": torch.get_num_threads(), "device": str(device),
                    "python": platform.python_version(), "torch": torch.__version__,
                    "numpy": np.__version__})
    atomic_write_text(path, json.dumps(entries, indent=1))


def _write_log(path: Path, rows: list[dict], columns: tuple[str, ...]) -> None:
    """Rewrites the log with ``rows`` (atomically): once per run, to cut a resumed run's log
    back to its checkpoint's step."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=columns)
    writer.writeheader()
    writer.writerows(rows)
    atomic_write_text(path, buffer.getvalue())


def _append_log(path: Path, rows: list[dict], columns: tuple[str, ...]) -> None:
    """Appends ``rows`` to the log (before the checkpoint of their last step is written, so a
    resume that cuts the log back to the checkpoint never loses or repeats a row)."""
    with open(path, "a", newline="") as f:
        csv.DictWriter(f, fieldnames=columns).writerows(rows)


def _tensorboard(out: Path):
    try:
        from torch.utils.tensorboard import SummaryWriter
    except ImportError:
        return None
    return SummaryWriter(str(out / "tensorboard"))


def validation_losses(policy: PolicyFamily, dataset: DemoSequenceDataset,
                      config: LearningConfig, device: str) -> dict[str, float]:
    """Mean loss terms over ``valid_batches`` fixed batches of ``dataset``."""
    sampler = StepBatchSampler(len(dataset), config.batch_size, VALID_SEED, 0,
                               config.valid_batches)
    loader = DataLoader(dataset, batch_sampler=sampler, num_workers=0)
    totals: dict[str, float] = {}
    policy.eval()
    with torch.no_grad():
        for batch in loader:
            for k, v in policy.losses(_to_device(batch, device)).items():
                totals[k] = totals.get(k, 0.0) + float(v) / config.valid_batches
    policy.train()
    return totals


def train(config: LearningConfig, data: str | Path, out: str | Path, steps: int | None = None,
          device: str = "cpu", resume: bool = False, progress: bool | str | None = None
          ) -> Checkpoint:
    """Trains a policy on the demonstrations in ``data``; writes the run into ``out``.

    ``steps`` overrides ``config.steps``; ``resume`` continues from ``out/last.pt`` (its config
    wins over ``config``, except for ``steps``). Returns the final checkpoint."""
    # Bad input fails before any work; a new run never overwrites another.
    if steps is not None and (isinstance(steps, bool) or steps < 1):
        raise ConfigError(f"--steps must be at least 1, got {steps!r}")
    if Path(out).exists() and not Path(out).is_dir():
        raise ConfigError(f"--out {out}: is an existing file, not a run folder")
    if not resume and any((Path(out) / n).exists() for n in ("last.pt", "best.pt", "log.csv")):
        raise ConfigError(f"--out {out} already holds a training run (last.pt, best.pt or "
                          "log.csv): pass --resume to continue it, --overwrite to replace "
                          "it, or choose another --out")
    check_algo(config.algo)
    data, out = Path(data), Path(out)
    if device.startswith("cuda") and not torch.cuda.is_available():
        raise ConfigError("--device cuda: no CUDA device is available")
    last = out / "last.pt"
    previous = None
    if resume:
        if not last.is_file():
            raise ConfigError(f"--resume: no checkpoint {last} to resume from")
        previous = load_checkpoint(last, device)
        if previous.rollout_only:
            raise ConfigError(f"--resume: {last} is a shipped (rollout-only) checkpoint "
                              "without the trained weights; resume from a run's own last.pt")
        raw = previous.config.to_dict()
        if steps is None:
            raw["steps"] = config.steps
        config = config_from_dict(raw, str(last))
    total_steps = steps if steps is not None else config.steps
    train_seeds = check_data(data, config)
    if device == "cpu" and config.cpu_threads > 0:
        torch.set_num_threads(config.cpu_threads)
    if device == "cpu" and config.obs_mode == "image" \
            and config.encoder_precision == "bfloat16" and native_bfloat16() is False:
        log.warning("encoder_precision bfloat16: this CPU (%s) has no native bfloat16, so "
                    "the image trunk trains several times slower than in float32 here; "
                    "--set encoder_precision=float32 is faster", cpu_model())
    seed_everything(config.seed)
    image_steps = observed_steps(config)
    dataset = DemoSequenceDataset(data, config.dataset_keys, config.seq_length, "train",
                                  cache_images=config.cache_images, image_steps=image_steps)
    try:
        valid = DemoSequenceDataset(data, config.dataset_keys, config.seq_length, "valid",
                                    cache_images=config.cache_images, image_steps=image_steps)
    except DatasetError:
        valid = None  # too few demos for a validation split
    if previous is not None:
        ckpt = previous
        ckpt.policy.train()
    else:
        stats = dataset_stats(data, config)
        ckpt = Checkpoint(config, stats, build_policy(config, stats).to(device),
                          train_seeds=train_seeds, data=str(data),
                          camera=recorded_camera(data) if config.obs_mode == "image" else {})
    ckpt.config = config
    policy = ckpt.policy
    trained = [p for p in policy.parameters() if p.requires_grad]  # not an EMA copy
    optimizer = torch.optim.Adam(trained, lr=config.lr,
                                 weight_decay=config.weight_decay)
    if ckpt.optimizer is not None:
        optimizer.load_state_dict(ckpt.optimizer)
    out.mkdir(parents=True, exist_ok=True)
    save_config(config, out / "config.yaml")
    _record_machine(out / "machine.json", ckpt.step, device)
    log_path = out / "log.csv"
    columns = log_columns(policy)
    _write_log(log_path, _read_log(log_path, ckpt.step), columns)
    rows: list[dict] = []  # not yet in the log file
    board = _tensorboard(out)
    sampler = StepBatchSampler(len(dataset), config.batch_size, config.batch_order_seed,
                               ckpt.step, total_steps)
    loader = DataLoader(dataset, batch_sampler=sampler, num_workers=config.num_workers,
                        persistent_workers=False, pin_memory=device.startswith("cuda"))
    bar = progress_bar(progress=progress, total=total_steps, initial=ckpt.step,
                       desc=f"train {config.name} (seed {config.seed})", unit="step")
    policy.train()
    for batch in loader:
        losses = policy.losses(_to_device(batch, device))
        row = {k: float(v.detach()) for k, v in losses.items()}
        optimizer.zero_grad(set_to_none=True)
        losses["total"].backward()
        grad_norm = torch.nn.utils.clip_grad_norm_(
            trained, config.grad_clip if config.grad_clip > 0 else math.inf)
        if not (math.isfinite(row["total"]) and math.isfinite(float(grad_norm))):
            # before the step: the weights (and the checkpoints) stay finite
            raise FloatingPointError(f"non-finite loss or gradient at step {ckpt.step + 1}: "
                                     f"{row}, gradient norm {float(grad_norm)}")
        lr = learning_rate(config, ckpt.step)
        for group in optimizer.param_groups:
            group["lr"] = lr
        optimizer.step()
        ckpt.step += 1
        policy.after_step(ckpt.step)
        row.update(step=ckpt.step, lr=lr)
        if valid is not None and ckpt.step % config.valid_every == 0:
            scores = validation_losses(policy, valid, config, device)
            row.update({f"valid_{k}": v for k, v in scores.items()})
            if scores["total"] < ckpt.best_valid:
                ckpt.best_valid = scores["total"]
                save_checkpoint(out / "best.pt", ckpt, optimizer)
        rows.append(row)
        if board is not None:
            for k, v in row.items():
                if k != "step":
                    board.add_scalar(k, v, ckpt.step)
        bar.update(1)
        bar.set_postfix(loss=f"{row['total']:.3f}")
        if config.snapshot_every and ckpt.step % config.snapshot_every == 0:
            save_checkpoint(snapshot_path(out, ckpt.step),
                            dataclasses.replace(ckpt, optimizer=None))
        if ckpt.step % config.checkpoint_every == 0 or ckpt.step == total_steps:
            _append_log(log_path, rows, columns)
            rows.clear()
            save_checkpoint(last, ckpt, optimizer)
    bar.close()
    if board is not None:
        board.close()
    _append_log(log_path, rows, columns)
    if valid is None or not (out / "best.pt").is_file():
        save_checkpoint(out / "best.pt", ckpt, optimizer)
    save_checkpoint(last, ckpt, optimizer)
    ckpt.optimizer = optimizer.state_dict()
    policy.eval()
    log.info("trained %s to step %d; checkpoints in %s", config.name, ckpt.step, out)
    return ckpt
