"""The dataset layout: action history, masks, write/read round trip, validation, bad files."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest

from legato_drake.data.layout import (
    FORMAT_VERSION,
    DatasetError,
    check_file,
    delta_history,
    mask_names,
    open_dataset,
    split_masks,
    validate_file,
)
from legato_drake.data.synthetic import synthetic_episode
from legato_drake.data.writer import write_dataset


def test_delta_history_is_the_two_previous_actions_oldest_first():
    actions = np.arange(5 * 7, dtype=float).reshape(5, 7)
    positions, eulers = delta_history(actions)
    assert positions.shape == eulers.shape == (5, 6)
    np.testing.assert_array_equal(positions[0], np.zeros(6))
    np.testing.assert_array_equal(positions[1], [0, 0, 0, *actions[0, 0:3]])
    for k in range(2, 5):
        np.testing.assert_array_equal(positions[k], [*actions[k - 2, 0:3], *actions[k - 1, 0:3]])
        np.testing.assert_array_equal(eulers[k], [*actions[k - 2, 3:6], *actions[k - 1, 3:6]])
    np.testing.assert_array_equal(eulers[1], [0, 0, 0, *actions[0, 3:6]])


def test_split_masks_are_deterministic_ten_percent():
    names = [f"demo_{i}" for i in range(150)]
    train, valid = split_masks(names)
    assert len(valid) == 15 and len(train) == 135
    assert not set(train) & set(valid) and set(train) | set(valid) == set(names)
    assert (train, valid) == split_masks(names)
    assert split_masks(["demo_0"]) == (["demo_0"], [])
    assert len(split_masks(names[:2])[1]) == 1


@pytest.fixture
def dataset(tmp_path):
    episodes = [synthetic_episode(12, seed=0), synthetic_episode(7, seed=1, success=False),
                synthetic_episode(20, seed=2, objects=3)]
    path = write_dataset(tmp_path / "d.hdf5", episodes, env_args={"env_name": "x"},
                         config={"task": "lid"})
    return path, episodes


def test_round_trip(dataset):
    path, episodes = dataset
    check_file(path)
    with open_dataset(path) as f:
        data = f["data"]
        assert data.attrs["total"] == 39 and data.attrs["format_version"] == FORMAT_VERSION
        assert json.loads(data.attrs["env_args"]) == {"env_name": "x"}
        assert sorted(mask_names(f, "train") + mask_names(f, "valid")) == \
            ["demo_0", "demo_1", "demo_2"]
        for i, episode in enumerate(episodes):
            demo = data[f"demo_{i}"]
            T = len(episode)
            assert demo.attrs["num_samples"] == T and demo.attrs["seed"] == i
            assert bool(demo.attrs["success"]) == episode.success
            assert json.loads(demo.attrs["scenario"]) == {"seed": i}
            assert demo["actions"].dtype == np.float64 and demo["actions"].shape == (T, 7)
            np.testing.assert_array_equal(demo["actions"][()], episode.actions)
            np.testing.assert_array_equal(demo["states"][()], episode.states)
            rewards, dones = demo["rewards"][()], demo["dones"][()]
            assert rewards.shape == dones.shape == (T,)
            assert rewards[-1] == float(episode.success) and not rewards[:-1].any()
            assert dones[-1] == 1 and not dones[:-1].any()
            for key, value in episode.obs.items():
                assert demo["obs"][key].dtype == value.dtype, key
                np.testing.assert_array_equal(demo["obs"][key][()], value)
            image = demo["obs/left_gray"]
            assert image.chunks == (1, 16, 16, 1) and image.compression == "gzip"
            positions, eulers = delta_history(episode.actions)
            np.testing.assert_array_equal(demo["obs/delta_positions"][()], positions)
            np.testing.assert_array_equal(demo["obs/delta_eulers"][()], eulers)


def test_state_only_dataset_is_valid(tmp_path):
    path = write_dataset(tmp_path / "s.hdf5", [synthetic_episode(5, images=False)])
    check_file(path)
    with open_dataset(path) as f:
        assert "left_gray" not in f["data/demo_0/obs"]


@pytest.mark.parametrize("damage, words", [
    (lambda f: f["data/demo_1"].__delitem__("actions"), "demo_1: missing 'actions'"),
    (lambda f: f["data/demo_0/obs"].__delitem__("tcp_measured"), "missing 'obs/tcp_measured'"),
    (lambda f: f["data/demo_2/obs/delta_eulers"].__setitem__((3, 0), np.nan), "NaN"),
    (lambda f: f["data/demo_0/actions"].__setitem__((2, 0), 5.0), "history of the actions"),
    (lambda f: f["data"].attrs.__setitem__("format_version", 99), "format_version 99"),
    (lambda f: f["mask"].__delitem__("valid"), "mask/valid"),
    (lambda f: f["data/demo_0/obs"].__delitem__("right_gray"), "not the other camera"),
])
def test_validation_finds_damage(dataset, damage, words):
    path, _ = dataset
    with h5py.File(path, "a") as f:
        damage(f)
    with open_dataset(path) as f:
        issues = validate_file(f)
    assert any(words in issue for issue in issues), issues
    with pytest.raises(DatasetError, match="invalid dataset"):
        check_file(path)


def test_truncated_and_foreign_files(dataset, tmp_path):
    path, _ = dataset
    data = path.read_bytes()
    cut = tmp_path / "cut.hdf5"
    cut.write_bytes(data[:len(data) // 2])
    with pytest.raises(DatasetError, match="truncated"):
        check_file(cut)
    text = tmp_path / "text.hdf5"
    text.write_text("not hdf5")
    with pytest.raises(DatasetError, match="not a readable HDF5 file"):
        check_file(text)
    with pytest.raises(DatasetError, match="not found"):
        check_file(tmp_path / "none.hdf5")
