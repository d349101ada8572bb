"""Per-dimension mean/std normalisation of low-dim observations and actions.

The statistics are computed once from the training split and saved in every checkpoint; the
policy normalises its raw inputs itself (``Normalizer`` is a module with buffers), so training
and rollout feed the same raw values.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import numpy as np
import torch
from torch import nn

MIN_STD = 1e-6
"""Dimensions with a smaller standard deviation (constants) are scaled by 1."""
OBS_MIN_STD = 1e-3
"""The smallest scale of an observation dimension (m, rad, or their per-step deltas). Inputs
that barely vary in the data, such as the settled pot's quaternion x and y (std 1e-5, contact
jitter), would otherwise be blown up 1e5-fold at rollout, where their jitter differs."""


def compute_stats(arrays: Iterable[np.ndarray], min_std: float = 0.0
                  ) -> dict[str, np.ndarray]:
    """``{"mean", "std"}`` (float32, per last-axis dim) over all rows of ``arrays``; the std
    of constant dimensions (below ``MIN_STD``) is 1, every other one at least ``min_std``
    (``OBS_MIN_STD`` for observations; 0 keeps actions at their own scale)."""
    data = np.concatenate([np.asarray(a, dtype=np.float64).reshape(-1, np.shape(a)[-1])
                           for a in arrays])
    std = data.std(0)
    std = np.where(std < MIN_STD, 1.0, np.maximum(std, min_std))
    return {"mean": data.mean(0).astype(np.float32), "std": std.astype(np.float32)}


def stats_to_lists(stats: Mapping[str, Mapping[str, np.ndarray]]) -> dict:
    """JSON/checkpoint-friendly copy of a ``{key: {"mean", "std"}}`` mapping."""
    return {k: {s: np.asarray(v).tolist() for s, v in d.items()} for k, d in stats.items()}


def stats_from_lists(raw: Mapping[str, Mapping[str, list]]) -> dict[str, dict[str, np.ndarray]]:
    """Inverse of ``stats_to_lists``."""
    return {k: {s: np.asarray(v, dtype=np.float32) for s, v in d.items()}
            for k, d in raw.items()}


class Normalizer(nn.Module):
    """``(x - mean) / std`` and back, for one vector quantity (buffers: saved with the model)."""

    def __init__(self, mean: np.ndarray, std: np.ndarray):
        super().__init__()
        self.register_buffer("mean", torch.as_tensor(np.asarray(mean), dtype=torch.float32))
        self.register_buffer("std", torch.as_tensor(np.asarray(std), dtype=torch.float32))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """Normalises ``x`` (..., D)."""
        return (x - self.mean) / self.std

    def inverse(self, y: torch.Tensor) -> torch.Tensor:
        """Un-normalises ``y`` (..., D)."""
        return y * self.std + self.mean
