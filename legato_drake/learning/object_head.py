"""The auxiliary object head of the image policies (``object_aux_weight``).

In training only, a linear head regresses the objects' poses in the gripper's frame
(``object_in_tcp``, normalised by its training statistics) from a step's image features, and
its mean squared error, times ``object_aux_weight``, joins the loss: privileged supervision
that makes the image encoders find the objects in their views. A rollout never reads it; it
sees only its images. Every policy family with image encoders uses this one head
(``policies.RecurrentGMMPolicy``, ``diffusion.DiffusionPolicy``).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import torch
from torch import nn

from legato_drake.learning.family import Stats, masked_mean
from legato_drake.learning.normalization import Normalizer

TARGET_KEY = "object_in_tcp"
"""The observation the head regresses (and the statistics that normalise it)."""


class ObjectHead(nn.Module):
    """Image features (..., F) -> the normalised ``object_in_tcp`` (..., 9k)."""

    def __init__(self, feature_dim: int, stats: Stats):
        super().__init__()
        if TARGET_KEY not in stats:
            raise ValueError(f"normalisation statistics lack {TARGET_KEY} "
                             f"(object_aux_weight needs it)")
        mean, std = (np.asarray(stats[TARGET_KEY][s]) for s in ("mean", "std"))
        self.normalizer = Normalizer(mean, std)
        self.linear = nn.Linear(feature_dim, len(mean))

    def forward(self, features: torch.Tensor) -> torch.Tensor:
        """The normalised estimate from image features (their first ``F`` columns)."""
        return self.linear(features[..., :self.linear.in_features])

    def loss(self, features: torch.Tensor, obs: Mapping[str, torch.Tensor],
             mask: torch.Tensor) -> torch.Tensor:
        """The ``aux`` term: the squared error of the normalised estimate from ``features``
        (B, T, F) against the observed ``object_in_tcp`` (B, T, 9k), averaged over the pose
        values and the steps ``mask`` (B, T) keeps."""
        return masked_mean((self(features) - self.normalizer(obs[TARGET_KEY])).pow(2).mean(-1),
                           mask)

    def estimate(self, features: torch.Tensor) -> torch.Tensor:
        """The estimate in raw units (m and the rotation matrix's columns)."""
        return self.normalizer.inverse(self(features))


def rename_legacy_keys(state: dict, prefix: str, *_args) -> None:
    """A ``load_state_dict`` pre-hook: the names LEGATO checkpoints written before this module
    gave the head (``object_head.weight``, ``object_normalizer.mean``, ...) renamed in place to
    its own, so older runs and shipped checkpoints still load."""
    for old, new in (("object_head.weight", "object_head.linear.weight"),
                     ("object_head.bias", "object_head.linear.bias"),
                     ("object_normalizer.mean", "object_head.normalizer.mean"),
                     ("object_normalizer.std", "object_head.normalizer.std")):
        if prefix + old in state and prefix + new not in state:
            state[prefix + new] = state.pop(prefix + old)
