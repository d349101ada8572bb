"""Derived observations: computed from stored ones, the same in the Dataset and at rollout;
and the planned actions, the targets of action chunks."""

from __future__ import annotations

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw

from legato_drake.data.derived import (
    available_observations,
    object_in_tcp,
    planned_actions,
    read_observation,
)
from legato_drake.data.synthetic import synthetic_episode
from legato_drake.data.torch_dataset import DemoSequenceDataset
from legato_drake.data.writer import write_dataset
from legato_drake.poses import apply_delta, pose_delta, pose_to_vector


def test_object_in_tcp_matches_drake():
    rng = np.random.default_rng(0)
    X_WT = RigidTransform(RollPitchYaw(*rng.uniform(-1, 1, 3)), rng.uniform(-1, 1, 3))
    bodies = [RigidTransform(RollPitchYaw(*rng.uniform(-3, 3, 3)), rng.uniform(-1, 1, 3))
              for _ in range(3)]
    values = object_in_tcp(pose_to_vector(X_WT),
                           np.concatenate([pose_to_vector(X) for X in bodies]))
    assert values.shape == (27,)
    for k, X_WO in enumerate(bodies):
        X_TO = X_WT.inverse() @ X_WO
        np.testing.assert_allclose(values[9 * k:9 * k + 3], X_TO.translation(), atol=1e-12)
        np.testing.assert_allclose(values[9 * k + 3:9 * k + 9].reshape(2, 3).T,
                                   X_TO.rotation().matrix()[:, :2], atol=1e-12)
    # moving the whole scene (gripper and objects) by one transform changes nothing
    X = RigidTransform(RollPitchYaw(0.3, -0.2, 1.1), [0.5, -2.0, 0.1])
    moved = object_in_tcp(pose_to_vector(X @ X_WT),
                          np.concatenate([pose_to_vector(X @ B) for B in bodies]))
    np.testing.assert_allclose(moved, values, atol=1e-12)


def test_the_dataset_serves_it_as_the_controller_computes_it(tmp_path):
    episode = synthetic_episode(12, seed=3, images=False, objects=2)
    path = write_dataset(tmp_path / "d.hdf5", [episode])
    data = DemoSequenceDataset(path, obs_keys=["object_in_tcp", "fingers"], seq_length=12,
                               split="all")
    served = data[0]["obs"]["object_in_tcp"].numpy()
    step = 5  # one recorder sample, as the PolicyController reads it at rollout
    sample = {key: episode.obs[key][step] for key in ("tcp_measured", "object")}
    np.testing.assert_allclose(served[step], read_observation(sample, "object_in_tcp"),
                               rtol=1e-6, atol=1e-6)
    assert served.shape == (12, 18) and served.dtype == np.float32


def test_missing_sources_are_named():
    assert "object_in_tcp" in available_observations(["tcp_measured", "object"])
    assert "object_in_tcp" not in available_observations(["object"])


def test_planned_actions_are_the_actions_where_the_executed_pose_is_the_target():
    episode = synthetic_episode(30, images=False)  # commanded poses chain through the actions
    planned = planned_actions(episode.obs["tcp_commanded"], episode.actions)
    np.testing.assert_allclose(planned, episode.actions, atol=1e-9)


def test_a_chunk_of_planned_actions_reaches_the_targets_of_noisy_actions():
    """A DART-style expert: it aims at plan pose G_k from where it is (action ``C_k^-1 G_k``),
    and the executed pose is G_k perturbed. From any step t, the action then the planned
    actions compose into G_t, G_{t+1}, ...; the actions themselves do not."""
    rng = np.random.default_rng(3)
    plan = [RigidTransform(RollPitchYaw(*rng.uniform(-1, 1, 3)), rng.uniform(-1, 1, 3))]
    for _ in range(24):
        plan.append(plan[-1] @ RigidTransform(RollPitchYaw(*rng.normal(0, 0.05, 3)),
                                              rng.normal(0, 0.01, 3)))
    commanded, actions = [plan[0]], []
    for k, G in enumerate(plan[1:]):
        actions.append([*pose_delta(commanded[k], G), k % 2])
        commanded.append(G @ RigidTransform(RollPitchYaw(*rng.normal(0, 0.03, 3)),
                                            rng.normal(0, 0.005, 3)))
    actions = np.array(actions)
    C = np.array([pose_to_vector(X) for X in commanded[:-1]])
    planned = planned_actions(C, actions)
    np.testing.assert_array_equal(planned[:, 6], actions[:, 6])
    np.testing.assert_allclose(planned[0], actions[0])
    t = 5
    chunk = np.concatenate([actions[t:t + 1], planned[t + 1:t + 10]])
    X, drifted = commanded[t], commanded[t]
    for j in range(10):
        X = apply_delta(X, chunk[j, :6])
        drifted = apply_delta(drifted, actions[t + j, :6])
        np.testing.assert_allclose(X.GetAsMatrix4(), plan[t + j + 1].GetAsMatrix4(),
                                   atol=1e-9)
    assert np.linalg.norm(drifted.translation() - X.translation()) > 0.005
