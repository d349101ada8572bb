"""The torch Dataset: sequences, padding, image formats, splits, validation on load."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
import torch
from torch.utils.data import DataLoader

from legato_drake.data.layout import DatasetError, mask_names, open_dataset
from legato_drake.data.synthetic import synthetic_episode
from legato_drake.data.torch_dataset import DemoSequenceDataset
from legato_drake.data.writer import write_dataset


@pytest.fixture
def dataset(tmp_path):
    episodes = [synthetic_episode(6 + i, seed=i) for i in range(10)]
    return write_dataset(tmp_path / "d.hdf5", episodes), episodes


def test_sequences_with_padding(dataset):
    path, episodes = dataset
    data = DemoSequenceDataset(path, seq_length=4, split="all")
    assert len(data) == sum(len(e) for e in episodes)
    item = data[0]
    assert set(item["obs"]) == {"left_gray", "right_gray", "delta_positions", "delta_eulers"}
    assert item["obs"]["left_gray"].shape == (4, 1, 16, 16)
    assert item["obs"]["left_gray"].dtype == torch.float32
    assert item["obs"]["left_gray"].min() >= 0.0 and item["obs"]["left_gray"].max() <= 1.0
    assert item["actions"].shape == (4, 7) and item["actions"].dtype == torch.float32
    np.testing.assert_allclose(item["actions"].numpy(), episodes[0].actions[:4], rtol=1e-6)
    np.testing.assert_allclose(item["obs"]["left_gray"][2, 0].numpy() * 255.0,
                               episodes[0].obs["left_gray"][2, :, :, 0], atol=1e-3)
    last = data[len(episodes[0]) - 2]  # starts 2 before the end of demo_0
    assert last["demo"] == "demo_0" and last["start"] == 4
    assert last["pad_mask"].tolist() == [True, True, False, False]
    np.testing.assert_array_equal(last["actions"][2].numpy(), last["actions"][1].numpy())
    assert last["dones"].tolist() == [0.0, 1.0, 1.0, 1.0]


def test_uint8_images_without_padding_and_custom_keys(dataset):
    path, episodes = dataset
    data = DemoSequenceDataset(path, obs_keys=("right_gray", "tcp_commanded"), seq_length=7,
                               split="all", pad_seq_length=False, image_dtype="uint8",
                               cache_images=True)
    assert len(data) == sum(max(len(e) - 6, 0) for e in episodes)
    item = data[0]
    assert item["obs"]["right_gray"].dtype == torch.uint8
    assert item["pad_mask"].all()
    assert item["demo"] == "demo_1"  # demo_0 is shorter than the window
    np.testing.assert_array_equal(item["obs"]["right_gray"].numpy()[:, 0],
                                  episodes[1].obs["right_gray"][:7, :, :, 0])


@pytest.mark.parametrize("cache_images", [False, True])
def test_a_window_can_hold_the_images_of_its_observed_steps_alone(dataset, cache_images):
    path, episodes = dataset
    full = DemoSequenceDataset(path, seq_length=5, split="all", cache_images=cache_images)
    seen = DemoSequenceDataset(path, seq_length=5, split="all", cache_images=cache_images,
                               image_steps=2)
    for i in (0, 3, len(episodes[0]) - 1):  # the last starts at demo_0's final step: padded
        a, b = full[i], seen[i]
        for key in ("left_gray", "right_gray"):
            assert b["obs"][key].shape == (2, 1, 16, 16)
            torch.testing.assert_close(b["obs"][key], a["obs"][key][:2])
        torch.testing.assert_close(b["obs"]["delta_positions"], a["obs"]["delta_positions"])
        torch.testing.assert_close(b["actions"], a["actions"])
    with pytest.raises(DatasetError, match="image_steps must be 1-5"):
        DemoSequenceDataset(path, seq_length=5, split="all", image_steps=6)


def test_splits_follow_the_masks_and_batch(dataset):
    path, _ = dataset
    train = DemoSequenceDataset(path, seq_length=3, split="train")
    valid = DemoSequenceDataset(path, seq_length=3, split="valid")
    with open_dataset(path) as f:
        assert train.demos == sorted(mask_names(f, "train"), key=lambda n: int(n[5:]))
        assert valid.demos == mask_names(f, "valid") and len(valid.demos) == 1
    batch = next(iter(DataLoader(train, batch_size=5, shuffle=True)))
    assert batch["obs"]["left_gray"].shape == (5, 3, 1, 16, 16)
    assert batch["actions"].shape == (5, 3, 7)


def test_clear_errors_on_load(dataset, tmp_path):
    path, _ = dataset
    with pytest.raises(DatasetError, match="has no observation.*object_pose.*available"):
        DemoSequenceDataset(path, obs_keys=("object_pose",))
    with pytest.raises(DatasetError, match="unknown split"):
        DemoSequenceDataset(path, split="test")
    cut = tmp_path / "cut.hdf5"
    cut.write_bytes(path.read_bytes()[:path.stat().st_size // 2])
    with pytest.raises(DatasetError, match="truncated"):
        DemoSequenceDataset(cut)
    with h5py.File(path, "a") as f:
        del f["data/demo_3/dones"]
    with pytest.raises(DatasetError, match="demo_3: missing 'dones'"):
        DemoSequenceDataset(path)


@pytest.mark.parametrize("image_dtype", ["float", "uint8"])
def test_training_and_rollout_preprocess_images_alike(dataset, image_dtype):
    """The dataset's images are ``image_to_tensor`` of the recorded frames, exactly, and the
    policy controller's preprocessing is that same function: a policy sees at rollout what
    it was trained on."""
    from legato_drake.data.torch_dataset import image_to_tensor
    from legato_drake.systems import policy_controller

    assert policy_controller.image_to_tensor is image_to_tensor
    path, episodes = dataset
    item = DemoSequenceDataset(path, seq_length=3, split="all", image_dtype=image_dtype)[1]
    for key in ("left_gray", "right_gray"):
        frames = episodes[0].obs[key][1:4]  # (3, H, W, 1) uint8, as recorded
        expected = image_to_tensor(frames, image_dtype)
        assert expected.shape == (3, 1, *frames.shape[1:3])
        assert item["obs"][key].dtype == expected.dtype
        torch.testing.assert_close(item["obs"][key], expected, rtol=0, atol=0)
        for step in range(3):  # one camera frame at a time, as at rollout
            torch.testing.assert_close(image_to_tensor(frames[step], image_dtype),
                                       expected[step], rtol=0, atol=0)
    frame = episodes[0].obs["left_gray"][0]
    assert image_to_tensor(frame).dtype == torch.float32
    assert float(image_to_tensor(frame).max()) <= 1.0
    assert torch.equal(image_to_tensor(frame, "uint8")[0], torch.from_numpy(frame[..., 0]))
