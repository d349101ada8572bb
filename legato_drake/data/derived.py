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
  pose instead, a robot's tracking lag shifts everything the policy sees: on the Google
  Robot, whose base is slow, that put every lid 3-5 cm off the pot.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from legato_drake.invariants import quaternion_to_matrix

DERIVED_KEYS: dict[str, tuple[str, ...]] = {"object_in_tcp": ("tcp_measured", "object")}
"""Each derived observation and the stored observations it is computed from."""
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


def read_observation(source: Mapping, key: str) -> np.ndarray:
    """Observation ``key`` of ``source`` (a demo's ``obs`` group, or a recorder sample):
    stored, or derived from the stored ones."""
    if key == "object_in_tcp":
        return object_in_tcp(np.asarray(source["tcp_measured"], dtype=float),
                             np.asarray(source["object"], dtype=float))
    return np.asarray(source[key])


def available_observations(stored: set[str] | list[str]) -> set[str]:
    """The observations that can be read from a source that stores ``stored``."""
    stored = set(stored)
    return stored | {k for k, sources in DERIVED_KEYS.items() if set(sources) <= stored}
