"""What every policy family implements: the seam between a network and the code that trains,
saves and runs it.

Training (``learning.train``) calls ``losses`` and logs whatever terms it returns;
checkpoints rebuild a policy from its config and normalisation statistics through the
registry (``learning.registry``); the ``PolicyController`` keeps the policy's rollout state
opaque and executes the first ``execute_steps`` actions of each predicted chunk before it asks
again (receding horizon). A recurrent policy predicts one action per call and carries its
LSTM state (``learning.policies``); a Diffusion Policy predicts a chunk of P actions and
carries its observation window (``learning.diffusion``).
"""

from __future__ import annotations

import abc
from collections.abc import Iterable, Mapping

import numpy as np
import torch
from torch import nn

from legato_drake.learning.config import LearningConfig

Stats = Mapping[str, Mapping[str, np.ndarray]]
"""Normalisation statistics: observation key (and ``actions``) -> ``mean``, ``std``; a
family's ``extra_stats`` may add entries of its own (the Diffusion Policy's action range:
``min``, ``max``)."""


class PolicyFamily(nn.Module, abc.ABC):
    """A policy family: built from ``(config, stats)``, trained through ``losses``, run
    through ``initial_state`` and ``act``. Subclasses register under an ``algo`` name in
    ``learning.registry``.

    A rollout state must be immutable or copied on update (the controller keeps it in a Drake
    abstract state, which contexts clone); numpy arrays and tuples of them are the usual.
    """

    loss_terms: tuple[str, ...] = ("total",)
    """The names ``losses`` returns, ``total`` (the optimised sum) last: the training log's
    columns."""
    execute_steps: int = 1
    """Actions of a predicted chunk executed before the next ``act`` (receding horizon)."""

    def __init__(self, config: LearningConfig, stats: Stats):
        super().__init__()
        self.config = config

    @classmethod
    def observed_steps(cls, config: LearningConfig) -> int:
        """How many leading steps of a training window (``seq_length`` long) the policy
        observes: training loads images for those alone. By default all of them."""
        return config.seq_length

    @classmethod
    def extra_stats(cls, config: LearningConfig, actions: list[np.ndarray],
                    planned: list[np.ndarray]) -> dict[str, dict[str, np.ndarray]]:
        """Statistics the family needs beyond the observations' and actions' mean and std,
        from the training demos' (T, 7) action arrays and their planned actions
        (``data.derived.planned_actions``), e.g. the range of its own action representation;
        they are stored in the checkpoint with the others."""
        return {}

    def rollout_state_dict(self) -> dict[str, torch.Tensor]:
        """The weights a rollout needs: what a shipped (``rollout_only``) checkpoint keeps.
        By default all of them; a family that trains one copy and runs another (an EMA)
        leaves the trained one out."""
        return self.state_dict()

    def load_rollout_state_dict(self, state: Mapping[str, torch.Tensor]) -> None:
        """Loads what ``rollout_state_dict`` kept (the inverse of it)."""
        self.load_state_dict(state)

    def after_step(self, step: int) -> None:
        """Called by training after each optimizer step (e.g. to update an EMA of the
        weights); ``step`` counts from 1."""

    def observe(self, obs: Mapping[str, torch.Tensor], state: object) -> object:
        """Called at every control step with that step's observation (B, ...), before an
        ``act`` if one is due; returns the next state (e.g. with the observation window
        advanced). By default the state is left as it is."""
        return state

    @abc.abstractmethod
    def losses(self, batch: Mapping) -> dict[str, torch.Tensor]:
        """The loss terms (``loss_terms``) of a collated batch of ``DemoSequenceDataset``
        items: ``obs`` (B, T, ...), ``actions`` and ``planned_actions`` (B, T, 7),
        ``pad_mask`` (B, T)."""

    @abc.abstractmethod
    def initial_state(self, scene_seed: int = 0) -> object:
        """The rollout state at the start of an episode in the scene of ``scene_seed`` (a
        stochastic policy may seed its rollout noise with it)."""

    @abc.abstractmethod
    def act(self, obs: Mapping[str, torch.Tensor], state: object
            ) -> tuple[torch.Tensor, object]:
        """One decision: raw observations (B, ...) without a time axis and the rollout state
        -> the predicted actions (B, P, 7) (P = 1 for a single-step policy; the first
        ``execute_steps`` are executed) and the next rollout state."""


@torch.no_grad()
def update_average(average: nn.Module, parameters: Iterable[torch.Tensor],
                   buffers: Iterable[torch.Tensor], step: int, max_decay: float) -> None:
    """One step of an exponential moving average of weights (a family's ``after_step``):
    the parameters of ``average`` move ``1 - decay`` of the way to ``parameters`` (the trained
    copy's, in the same order), its buffers take ``buffers``; the decay warms up as
    ``(1 + step) / (10 + step)`` to ``max_decay``, so early averages forget the random
    initialisation quickly."""
    decay = min(max_decay, (1 + step) / (10 + step))
    for mean, current in zip(average.parameters(), parameters, strict=True):
        mean.lerp_(current, 1 - decay)
    for mean, current in zip(average.buffers(), buffers, strict=True):
        mean.copy_(current)


def masked_mean(values: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """The mean of ``values`` over the entries ``mask`` (same shape, 0 or 1) keeps: a loss
    over the real steps of padded sequences (0 where the mask keeps nothing)."""
    mask = mask.to(values.dtype)
    return (values * mask).sum() / mask.sum().clamp(min=1.0)
