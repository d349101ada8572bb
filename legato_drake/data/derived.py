"""Observations computed from recorded ones, by the same code in training and at rollout.

A derived observation is not stored in the dataset: ``read_observation`` computes it from the
stored keys it is made of, whether they come from a demo in a file (training) or from an
``EpisodeRecorder`` sample (the ``PolicyController`` at rollout). Old datasets so gain new
features without being collected again.

* ``object_in_tcp``: each object body's pose in the gripper's TCP frame where the gripper
  *is* (``tcp_measured``, where its camera is too), 9 values per body: its position, then the
  first two columns of its rotation matrix (continuous, unlike a quaternion's sign). It is
  what the gripper would see of the scene (the state analogue of the gripper camera) and,
  unlike world poses, does not change when the whole scene moves. Taken from the commanded
  pose instead, a robot's tracking lag would shift everything the policy sees.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from legato_drake.data.layout import ACTION_DIM, OBS_SHAPES
from legato_drake.invariants import quaternion_to_matrix

VALUES_PER_BODY = {"object": 7, "object_in_tcp": 9}
"""Values per object body of the observations that hold one pose per body."""


def object_in_tcp(tcp: np.ndarray, objects: np.ndarray) -> np.ndarray:
    """Object poses in the TCP frame: ``tcp`` (..., 7) and ``objects`` (..., 7k), both
    [xyz, quaternion wxyz] per pose -> (..., 9k): per body [p_TO, R_TO[:, 0], R_TO[:, 1]]."""
    bodies = objects.shape[-1] // 7
    poses = objects.reshape(*objects.shape[:-1], bodies, 7)
    R_WT = quaternion_to_matrix(tcp[..., 3:7])[..., None, :, :]
    R_TW = np.swapaxes(R_WT, -1, -2)
    p_TO = (R_TW @ (poses[..., :3] - tcp[..., None, :3])[..., None])[..., 0]
    R_TO = R_TW @ quaternion_to_matrix(poses[..., 3:7])
    values = np.concatenate([p_TO, R_TO[..., :, 0], R_TO[..., :, 1]], -1)
    return values.reshape(*objects.shape[:-1], 9 * bodies)


DERIVED: dict[str, tuple[tuple[str, ...], Callable[..., np.ndarray]]] = {
    "object_in_tcp": (("tcp_measured", "object"), object_in_tcp),
}
"""Each derived observation: the stored observations it is computed from, and how."""


def read_observation(source: Mapping, key: str) -> np.ndarray:
    """Observation ``key`` of ``source`` (a demo's ``obs`` group, or a recorder sample):
    stored, or derived from the stored ones."""
    if key in DERIVED:
        inputs, derive = DERIVED[key]
        return derive(*(np.asarray(source[k], dtype=float) for k in inputs))
    return np.asarray(source[key])


def available_observations(stored: set[str] | list[str]) -> set[str]:
    """The observations that can be read from a source that stores ``stored``."""
    stored = set(stored)
    return stored | {k for k, (inputs, _) in DERIVED.items() if set(inputs) <= stored}


def observation_sizes(object_bodies: int) -> dict[str, int]:
    """Values per sample of every low-dim observation, stored or derived, and of ``actions``,
    in a scene of ``object_bodies`` bodies (what synthetic batches and statistics need)."""
    sizes = {k: shape[0] for k, shape in OBS_SHAPES.items() if shape is not None}
    sizes.update({k: n * object_bodies for k, n in VALUES_PER_BODY.items()})
    return {**sizes, "actions": ACTION_DIM}
