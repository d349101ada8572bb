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

And one derived training target, ``planned_actions`` (for chunk policies), below.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from legato_drake.data.layout import ACTION_DIM, OBS_SHAPES
from legato_drake.invariants import poses_to_deltas, quaternion_to_matrix, rpy_to_matrix

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


def planned_actions(tcp_commanded: np.ndarray, actions: np.ndarray) -> np.ndarray:
    """The motion between the poses a demo's actions aim at: ``tcp_commanded`` (T, 7) and
    ``actions`` (T, 7) -> (T, 7). Action k moves the commanded pose ``C_k`` to its target
    ``G_k = C_k a_k``; item 0 is action 0, item k >= 1 the delta ``G_{k-1}^-1 G_k`` with action
    k's grasp.

    A chunk of the next P actions from step t is ``[a_t, planned_{t+1}, ..., planned_{t+P-1}]``:
    the poses the expert aims at from where it is, relative to ``C_t``. Without expert noise
    every ``C_{k+1} = G_k`` and this equals ``actions``. With DART-style noise the executed
    pose is ``G_k`` perturbed and each action corrects the last perturbation, so composing the
    actions themselves drifts from the plan by every correction of perturbations still to come
    (on the noisy lid demos, a median 14 mm after 8 steps, where the plan moves 39 mm:
    ``scripts/chunk_fit.py``); this is the chunk a policy can predict from the present."""
    C = np.asarray(tcp_commanded, dtype=float)
    a = np.asarray(actions, dtype=float)
    R_C = quaternion_to_matrix(C[:, 3:7])
    positions = C[:, :3] + (R_C @ a[:, :3, None])[..., 0]
    rotations = R_C @ rpy_to_matrix(a[:, 3:6])
    deltas = np.concatenate([a[:1, :6], poses_to_deltas(positions, rotations)])
    return np.concatenate([deltas, a[:, 6:7]], -1)


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
