"""Tiny synthetic episodes (no simulation) for tests, examples and format checks."""

from __future__ import annotations

import numpy as np

from legato_drake import conventions
from legato_drake.data.writer import Episode
from legato_drake.poses import apply_delta, pose_to_vector


def synthetic_episode(length: int, seed: int = 0, images: bool = True, size: int = 16,
                      success: bool = True, objects: int = 1) -> Episode:
    """A random but consistent episode: small random pose deltas (the commanded poses chain
    through them from the start pose), a grasp that closes half-way, random images of
    ``size`` x ``size`` pixels."""
    rng = np.random.default_rng(seed)
    actions = np.zeros((length, 7))
    actions[:, :3] = rng.normal(0.0, 0.01, (length, 3))
    actions[:, 3:6] = rng.normal(0.0, 0.02, (length, 3))
    actions[length // 2:, 6] = 1.0
    X = conventions.START_POSE
    commanded = []
    for a in actions:
        commanded.append(pose_to_vector(X))
        X = apply_delta(X, a[:6])
    commanded = np.array(commanded)
    measured = commanded + rng.normal(0.0, 1e-4, commanded.shape)
    obs = {"tcp_commanded": commanded, "tcp_measured": measured,
           "object": np.tile([0.6, 0.0, 0.72, 1.0, 0.0, 0.0, 0.0], (length, objects)),
           "fingers": np.full((length, 2), conventions.GRIPPER_OPEN)}
    if images:
        for key in ("left_gray", "right_gray"):
            obs[key] = rng.integers(0, 256, (length, size, size, 1), dtype=np.uint8)
    return Episode(actions=actions, obs=obs, success=success,
                   states=rng.normal(size=(length, 5)),
                   attrs=dict(seed=seed, embodiment="abstract", task="lid",
                              controller="scripted", reason="" if success else "synthetic",
                              scenario={"seed": seed}))
