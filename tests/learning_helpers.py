"""Small datasets and configs shared by the learning, controller and evaluation tests."""

from __future__ import annotations

from pathlib import Path

from legato_drake.data.synthetic import synthetic_episode
from legato_drake.data.writer import write_dataset
from legato_drake.learning.config import LearningConfig


def tiny_config(**changes) -> LearningConfig:
    """A state-mode LEGATO small enough to train in a second."""
    fields = dict(name="tiny", obs_mode="state", encoder="small", encoder_channels=[4, 8],
                  keypoints=4, feature_dim=8, rnn_layers=1, rnn_hidden=16, mlp_dims=[16],
                  seq_length=5, batch_size=4, lr=1e-3, steps=20, valid_every=10,
                  valid_batches=2, checkpoint_every=10, invariant_weight=0.005)
    fields.update(changes)
    return LearningConfig(**fields).validate()


def synthetic_dataset(path: Path, demos: int = 4, length: int = 24, images: bool = True
                      ) -> Path:
    """A valid dataset of synthetic episodes (3 object bodies, like the lid task)."""
    return write_dataset(path, [synthetic_episode(length, seed=i, images=images, size=16,
                                                  objects=3) for i in range(demos)])
