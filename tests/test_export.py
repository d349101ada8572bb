"""Exports for other frameworks, read back: the LeRobot v3.0 layout (frames, actions, episode
boundaries, videos decoded and compared with the recorded images) and robomimic's 3-channel
image keys."""

from __future__ import annotations

import json
import subprocess
import sys

import h5py
import numpy as np
import pytest

from legato_drake.data.layout import check_file, open_dataset, sorted_demos
from legato_drake.errors import ConfigError
from legato_drake.pipelines.collect import collect

av = pytest.importorskip("av")
pq = pytest.importorskip("pyarrow.parquet")


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """Two short real episodes with the gripper cameras (different lengths)."""
    path = tmp_path_factory.mktemp("export") / "d.hdf5"
    collect("lid", "abstract", 2, path, keep_failures=True, duration=1.5, camera=True,
            progress=False)
    return path


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "legato_drake.cli", *args],
                          capture_output=True, text=True, timeout=300)


def test_lerobot_round_trip(dataset, tmp_path):
    out = tmp_path / "lerobot"
    result = _cli("export", str(dataset), "--format", "lerobot", "--out", str(out))
    assert result.returncode == 0, result.stderr
    info = json.loads((out / "meta" / "info.json").read_text())
    with open_dataset(dataset) as f:
        demos = [f["data"][n] for n in sorted_demos(f["data"])]
        actions = [d["actions"][()] for d in demos]
        left = np.concatenate([d["obs"]["left_gray"][()] for d in demos])
        commanded = np.concatenate([d["obs"]["tcp_commanded"][()] for d in demos])
    total = sum(len(a) for a in actions)
    assert info["codebase_version"] == "v3.0" and info["fps"] == 10
    assert info["total_episodes"] == 2 and info["total_frames"] == total
    assert info["features"]["observation.images.left"]["dtype"] == "video"
    frames = pq.read_table(out / "data" / "chunk-000" / "file-000.parquet").to_pydict()
    np.testing.assert_allclose(np.array(frames["action"]), np.concatenate(actions),
                               rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(np.array(frames["observation.state"])[:, :7], commanded,
                               rtol=1e-6, atol=1e-7)
    assert frames["index"] == list(range(total))
    assert frames["frame_index"] == [*range(len(actions[0])), *range(len(actions[1]))]
    episodes = pq.read_table(out / "meta" / "episodes" / "chunk-000" /
                             "file-000.parquet").to_pylist()
    assert [(e["dataset_from_index"], e["dataset_to_index"]) for e in episodes] == \
        [(0, len(actions[0])), (len(actions[0]), total)]
    assert episodes[1]["videos/observation.images.left/from_timestamp"] == \
        pytest.approx(len(actions[0]) / 10)
    with av.open(str(out / "videos" / "observation.images.left" / "chunk-000" /
                     "file-000.mp4")) as container:
        decoded = np.stack([f.to_ndarray(format="rgb24") for f in container.decode(video=0)])
    assert len(decoded) == total  # every frame, none dropped or duplicated
    error = np.abs(decoded[..., :1].astype(int) - left.astype(int)).mean()
    assert error < 3.0, f"mean pixel error of the lossy video: {error:.2f} of 255"
    stats = json.loads((out / "meta" / "stats.json").read_text())
    assert stats["action"]["count"] == [total] and len(stats["action"]["mean"]) == 7
    tasks = pq.read_table(out / "meta" / "tasks.parquet").to_pydict()
    assert tasks["task_index"] == [0]
    again = _cli("export", str(dataset), "--format", "lerobot", "--out", str(out))
    assert again.returncode == 2 and "already holds a LeRobot dataset" in again.stderr


def test_lerobot_tasks_read_as_pandas_does(dataset, tmp_path):
    pandas = pytest.importorskip("pandas")
    from legato_drake.data.export_lerobot import export_lerobot

    export_lerobot(dataset, tmp_path / "lr")
    tasks = pandas.read_parquet(tmp_path / "lr" / "meta" / "tasks.parquet")
    assert list(tasks.index) == ["put the lid on the pot"]
    assert int(tasks.loc["put the lid on the pot"].task_index) == 0


def test_robomimic_copy_has_three_channel_images(dataset, tmp_path):
    out = tmp_path / "robomimic.hdf5"
    result = _cli("export", str(dataset), "--format", "robomimic", "--out", str(out))
    assert result.returncode == 0, result.stderr
    check_file(out)  # still a valid dataset of ours
    with h5py.File(dataset) as src, h5py.File(out) as dst:
        for name in sorted_demos(src["data"]):
            gray = src["data"][name]["obs"]["left_gray"][()]
            rgb = dst["data"][name]["obs"]["left_rgb"][()]
            assert rgb.shape == (*gray.shape[:3], 3) and rgb.dtype == np.uint8
            np.testing.assert_array_equal(rgb[..., 2:], gray)
        assert dst["data"].attrs["env_args"] == src["data"].attrs["env_args"]
    from legato_drake.data.export_robomimic import export_robomimic

    with pytest.raises(ConfigError, match="exists"):
        export_robomimic(dataset, out)


def test_robomimic_sequence_dataset_reads_the_copy(dataset, tmp_path):
    """robomimic's own loader on the copy: its image path (3-channel RGB processing) and the
    low-dim keys, unchanged. Runs where robomimic is importable beside this torch (here:
    ``pip install --no-deps robomimic termcolor``; its full install would replace torch)."""
    pytest.importorskip("robomimic")
    import robomimic.utils.obs_utils as obs_utils
    from robomimic.utils.dataset import SequenceDataset

    from legato_drake.data.export_robomimic import export_robomimic

    out = tmp_path / "robomimic.hdf5"
    export_robomimic(dataset, out)
    obs_utils.initialize_obs_utils_with_obs_specs({"obs": {
        "low_dim": ["delta_positions", "delta_eulers"], "rgb": ["left_rgb", "right_rgb"]}})
    loader = SequenceDataset(str(out), obs_keys=("delta_positions", "delta_eulers",
                                                 "left_rgb", "right_rgb"),
                             dataset_keys=("actions",), seq_length=5, hdf5_cache_mode=None,
                             filter_by_attribute=None, load_next_obs=False)
    item = loader[0]
    with h5py.File(out) as f:
        images = f["data/demo_0/obs/left_rgb"][0:5]
        actions = f["data/demo_0/actions"][0:5]
    np.testing.assert_array_equal(item["obs"]["left_rgb"], images)
    np.testing.assert_allclose(item["actions"], actions, atol=1e-6)
    # robomimic's RGB processor (which asserted 3 channels on our gray images): CHW in [0, 1]
    processed = obs_utils.process_obs_dict(item["obs"])
    assert processed["left_rgb"].shape == (5, 3, 128, 128)
    np.testing.assert_allclose(processed["left_rgb"][0], images[0].transpose(2, 0, 1) / 255.0,
                               atol=1e-6)
