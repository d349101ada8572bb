"""The policy families by ``LearningConfig.algo``: where a new family is registered.

A new family subclasses ``family.PolicyFamily`` and is added to ``FAMILIES`` here (or, from
outside the package, with ``register_family``); training, checkpoints, selection and the
``PolicyController`` then work with it unchanged.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from legato_drake.errors import ConfigError
from legato_drake.learning.config import LearningConfig
from legato_drake.learning.diffusion import DiffusionPolicy
from legato_drake.learning.family import PolicyFamily, Stats
from legato_drake.learning.policies import RecurrentGMMPolicy

Builder = Callable[[LearningConfig, Stats], PolicyFamily]

FAMILIES: dict[str, Builder] = {
    "legato": RecurrentGMMPolicy,
    "bc_rnn": RecurrentGMMPolicy,
    "dp_velocity": DiffusionPolicy,
    "dp_reltraj": DiffusionPolicy,
}
"""``algo`` -> the class (or any callable) that builds the family's policy."""


def register_family(algo: str, builder: Builder) -> None:
    """Adds a policy family under ``algo`` (an existing name is an error)."""
    if algo in FAMILIES:
        raise ValueError(f"policy family {algo!r} is already registered")
    FAMILIES[algo] = builder


def check_algo(algo: str, where: str = "") -> None:
    """A ConfigError naming the registered families unless ``algo`` is one of them."""
    if algo not in FAMILIES:
        place = f" in {where}" if where else ""
        raise ConfigError(f"algo{place}: unknown policy family {algo!r}; registered: "
                          f"{', '.join(FAMILIES)}")


def extra_stats(config: LearningConfig, actions: list[np.ndarray],
                planned: list[np.ndarray] | None = None) -> dict[str, dict[str, np.ndarray]]:
    """The statistics ``config.algo``'s family computes for itself from the training demos'
    actions and planned actions (``PolicyFamily.extra_stats``; none for a builder without
    it). Without ``planned`` the actions are their own plan (demos without expert noise)."""
    check_algo(config.algo)
    compute = getattr(FAMILIES[config.algo], "extra_stats", None)
    return compute(config, actions, planned if planned is not None else actions) \
        if compute is not None else {}


def observed_steps(config: LearningConfig) -> int:
    """The leading steps of a training window ``config.algo``'s family observes
    (``PolicyFamily.observed_steps``; all ``seq_length`` for a builder without it)."""
    check_algo(config.algo)
    steps = getattr(FAMILIES[config.algo], "observed_steps", None)
    return steps(config) if steps is not None else config.seq_length


def build_policy(config: LearningConfig, stats: Stats) -> PolicyFamily:
    """The policy of ``config.algo``'s family, with freshly initialised weights."""
    check_algo(config.algo)
    return FAMILIES[config.algo](config, stats)
