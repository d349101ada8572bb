"""Configs, training (seeded, logged), checkpoints and resuming, and their errors."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
import torch

from legato_drake.cli import main
from legato_drake.data.layout import DatasetError
from legato_drake.errors import ConfigError
from legato_drake.learning.checkpoint import CheckpointError, load_checkpoint, save_checkpoint
from legato_drake.learning.config import apply_overrides, load_config, save_config
from legato_drake.learning.train import learning_rate, train
from tests.learning_helpers import synthetic_dataset, tiny_config

CONFIGS = Path(__file__).resolve().parents[1] / "configs"


def _column(run: Path, name: str) -> list[float]:
    """Column ``name`` of a run's training log, the steps that have it."""
    with open(run / "log.csv", newline="") as f:
        return [float(row[name]) for row in csv.DictReader(f) if row[name]]


def _losses(run: Path) -> list[float]:
    return _column(run, "total")


@pytest.fixture(scope="module")
def data(tmp_path_factory) -> Path:
    return synthetic_dataset(tmp_path_factory.mktemp("data") / "d.hdf5")


@pytest.mark.parametrize("path", sorted(CONFIGS.glob("*.yaml")), ids=lambda p: p.stem)
def test_shipped_configs_load(path):
    config = load_config(path)
    assert config.name == path.stem.replace("_paper", "")
    if config.algo.startswith("dp_"):  # one window: the observations and the chunk
        assert config.seq_length == config.obs_horizon - 1 + config.pred_horizon
    else:
        assert config.seq_length == 20 and config.batch_size == 16
    if "paper" in path.stem:
        assert (config.rnn_layers, config.rnn_hidden, config.mlp_dims, config.lr) == \
            (3, 400, [2048, 2048, 2048], 1e-4)


def test_config_errors_name_the_field_and_the_file(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("algo: legato\nlstm_size: 3\n")
    with pytest.raises(ConfigError, match=r"unknown field 'lstm_size' in .*bad.yaml"):
        load_config(bad)
    bad.write_text("rnn_hidden: many\n")
    with pytest.raises(ConfigError, match=r"rnn_hidden in .*bad.yaml must be an integer"):
        load_config(bad)
    bad.write_text("obs_mode: lidar\n")
    with pytest.raises(ConfigError, match="obs_mode.*image, state"):
        load_config(bad)
    bad.write_text("encoder_precision: half\n")
    with pytest.raises(ConfigError, match="encoder_precision.*float32, bfloat16.*'half'"):
        load_config(bad)
    bad.write_text("image_crop: 200\n")
    with pytest.raises(ConfigError, match="image_crop.*0 .no crop. or 8-128"):
        load_config(bad)
    bad.write_text("image_resize: 4\n")
    with pytest.raises(ConfigError, match="image_resize.*0 .no resize. or 8-128"):
        load_config(bad)
    bad.write_text("image_resize: 88\nimage_crop: 96\n")
    with pytest.raises(ConfigError, match=r"image_crop.*at most image_resize \(88\), got 96"):
        load_config(bad)
    bad.write_text("lr_schedule: step\n")
    with pytest.raises(ConfigError, match="lr_schedule.*constant, cosine.*'step'"):
        load_config(bad)
    bad.write_text("obs_mode: state\nobject_aux_weight: 1\n")
    with pytest.raises(ConfigError, match="object_aux_weight.*needs obs_mode image"):
        load_config(bad)
    with pytest.raises(ConfigError, match="not found"):
        load_config(tmp_path / "missing.yaml")
    with pytest.raises(ConfigError, match="unknown field 'invariant'"):
        apply_overrides(tiny_config(), ["invariant=0"])
    assert apply_overrides(tiny_config(), ["invariant_weight=0"]).invariant_weight == 0.0
    assert apply_overrides(tiny_config(), ["lr=1e-4"]).lr == 1e-4  # YAML 1.1's string
    with pytest.raises(ConfigError, match="lr in --set must be a number"):
        apply_overrides(tiny_config(), ["lr=fast"])
    assert apply_overrides(tiny_config(), ["batch_seed=3"]).batch_seed == 3
    assert apply_overrides(tiny_config(batch_seed=3), ["batch_seed=null"]).batch_seed is None
    with pytest.raises(ConfigError, match="batch_seed in --set must be an integer or null"):
        apply_overrides(tiny_config(), ["batch_seed=first"])
    with pytest.raises(ConfigError, match="batch_seed in --set must be a non-negative"):
        apply_overrides(tiny_config(), ["batch_seed=-1"])
    with pytest.raises(ConfigError, match="seed in --set must be an integer, got None"):
        apply_overrides(tiny_config(), ["seed=null"])
    # tiny_config's trunk has two layers
    assert apply_overrides(tiny_config(), ["encoder_strides=[2,1]"]).encoder_strides == [2, 1]
    with pytest.raises(ConfigError, match=r"encoder_strides in --set must be one stride, 1 or "
                                          r"2, per encoder_channels entry \(2\), got \[2, 3\]"):
        apply_overrides(tiny_config(), ["encoder_strides=[2,3]"])
    with pytest.raises(ConfigError, match="per encoder_channels entry"):
        apply_overrides(tiny_config(), ["encoder_strides=[2]"])
    with pytest.raises(ConfigError, match="encoder_strides in --set must be a list of int or "
                                          "null"):
        apply_overrides(tiny_config(), ["encoder_strides=2"])
    save_config(tiny_config(), tmp_path / "round.yaml")
    assert load_config(tmp_path / "round.yaml") == tiny_config()


def test_data_errors(tmp_path, data):
    with pytest.raises(DatasetError, match="not found"):
        train(tiny_config(), tmp_path / "none.hdf5", tmp_path / "run", progress=False)
    state_only = synthetic_dataset(tmp_path / "s.hdf5", demos=2, length=6, images=False)
    with pytest.raises(ConfigError, match="left_gray.*lacks.*state-only"):
        train(tiny_config(obs_mode="image"), state_only, tmp_path / "run", progress=False)
    with pytest.raises(CheckpointError, match="not found"):
        load_checkpoint(tmp_path / "run" / "last.pt")
    with pytest.raises(ConfigError, match="resume"):
        train(tiny_config(), data, tmp_path / "empty", resume=True, progress=False)


def test_training_is_seeded_logged_and_checkpointed(tmp_path, data):
    config = tiny_config(steps=20)
    a = train(config, data, tmp_path / "a", progress=False)
    train(config, data, tmp_path / "b", progress=False)
    assert _losses(tmp_path / "a") == _losses(tmp_path / "b")
    with open(tmp_path / "a" / "log.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 20 and {"nll", "ce", "invar", "total", "valid_total"} <= set(rows[0])
    assert rows[9]["valid_total"] and not rows[8]["valid_total"]
    ckpt = load_checkpoint(tmp_path / "a" / "last.pt")
    assert ckpt.step == 20 and ckpt.config == config and ckpt.optimizer is not None
    assert ckpt.train_seeds == [0, 1, 2, 3]
    for key, value in a.stats.items():
        torch.testing.assert_close(torch.as_tensor(ckpt.stats[key]["mean"]),
                                   torch.as_tensor(value["mean"]))
    for name, tensor in a.policy.state_dict().items():
        torch.testing.assert_close(ckpt.policy.state_dict()[name], tensor)
    assert (tmp_path / "a" / "best.pt").is_file()
    assert load_config(tmp_path / "a" / "config.yaml") == config


def test_the_batch_order_can_have_a_seed_of_its_own(tmp_path, data):
    """``batch_seed`` moves the batches and leaves the initial weights: a run with the
    default's value is the default's run, bit for bit; another value takes other steps from
    the same weights (Adam's first step moves no weight by more than the learning rate, so
    after one step two runs from the same weights are within twice that)."""
    def run(name: str, steps: int | None = None, **seeds) -> Path:
        train(tiny_config(**seeds), data, tmp_path / name, steps=steps, progress=False)
        return tmp_path / name

    default, same, other = run("a"), run("b", batch_seed=0), run("c", batch_seed=1)
    assert _losses(same) == _losses(default)
    assert _losses(other)[0] != _losses(default)[0]
    a, c, d = (load_checkpoint(run(f"{name}1", 1, **seeds) / "last.pt").policy.state_dict()
               for name, seeds in (("a", {}), ("c", {"batch_seed": 1}), ("d", {"seed": 1})))
    lr = tiny_config().lr
    assert max(float((a[k] - c[k]).abs().max()) for k in a) <= 2 * lr * 1.001
    assert max(float((a[k] - d[k]).abs().max()) for k in a) > 10 * lr


def test_a_checkpoint_remembers_every_scene_it_was_chosen_on(tmp_path, data):
    train(tiny_config(steps=2), data, tmp_path / "run", progress=False)
    ckpt = load_checkpoint(tmp_path / "run" / "last.pt")
    ckpt.selection = {"seeds": [5000, 5001], "shipped_on": [5010, 5011]}
    save_checkpoint(tmp_path / "shipped.pt", ckpt)
    assert load_checkpoint(tmp_path / "shipped.pt").used_seeds == [0, 1, 2, 3, 5000, 5001,
                                                                    5010, 5011]


def test_an_image_policy_trains_with_the_object_loss_and_acts_without_the_poses(tmp_path,
                                                                                data):
    config = tiny_config(obs_mode="image", steps=10, object_aux_weight=1.0)
    assert "object_in_tcp" in config.dataset_keys and "object_in_tcp" not in config.obs_keys
    train(config, data, tmp_path / "run", progress=False)
    with open(tmp_path / "run" / "log.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert float(rows[0]["aux"]) > 0 and rows[-1]["valid_aux"]
    ckpt = load_checkpoint(tmp_path / "run" / "last.pt")
    obs = {k: torch.rand(1, 1, 16, 16) if k.endswith("_gray") else torch.zeros(1, 6)
           for k in config.obs_keys}
    action, _ = ckpt.policy.act(obs, ckpt.policy.initial_state())
    assert action.shape == (1, 1, 7)


def test_the_cosine_schedule_decays_to_zero_and_is_logged(tmp_path, data):
    config = tiny_config(steps=20, lr=1e-3, lr_schedule="cosine")
    assert learning_rate(config, 0) == 1e-3
    assert learning_rate(config, 10) == pytest.approx(5e-4)
    assert learning_rate(config, 20) == pytest.approx(0.0)
    assert learning_rate(tiny_config(steps=20, lr=1e-3), 15) == 1e-3
    train(config, data, tmp_path / "run", progress=False)
    with open(tmp_path / "run" / "log.csv", newline="") as f:
        lrs = [float(row["lr"]) for row in csv.DictReader(f)]
    assert lrs == pytest.approx([learning_rate(config, k) for k in range(20)])
    assert all(a > b for a, b in zip(lrs, lrs[1:], strict=False))
    train(config, data, tmp_path / "split", steps=10, progress=False)
    train(config, data, tmp_path / "split", resume=True, progress=False)
    assert _losses(tmp_path / "split") == pytest.approx(_losses(tmp_path / "run"), rel=1e-5)


def test_resume_continues_the_step_count_with_the_same_losses(tmp_path, data):
    config = tiny_config(steps=20)
    train(config, data, tmp_path / "full", progress=False)
    train(config, data, tmp_path / "split", steps=10, progress=False)
    assert load_checkpoint(tmp_path / "split" / "last.pt").step == 10
    resumed = train(config, data, tmp_path / "split", resume=True, progress=False)
    assert resumed.step == 20
    assert _losses(tmp_path / "split") == pytest.approx(_losses(tmp_path / "full"), rel=1e-5)
    # each start records the machine it trained on, from the step it started at
    starts = json.loads((tmp_path / "split" / "machine.json").read_text())
    assert [entry["step"] for entry in starts] == [0, 10]
    assert starts[0]["torch"] == torch.__version__ and starts[0]["cpu_capability"]


def test_a_weight_average_leaves_the_training_alone_and_survives_a_resume(tmp_path, data):
    """``ema``: the trained weights take the steps they take without it (the same losses,
    bit for bit), validation reads the average, and a resumed run's average is an
    uninterrupted one's."""
    train(tiny_config(), data, tmp_path / "plain", progress=False)
    config = tiny_config(ema=True, ema_decay=0.9)
    full = train(config, data, tmp_path / "full", progress=False)
    assert _losses(tmp_path / "full") == _losses(tmp_path / "plain")
    assert _column(tmp_path / "full", "valid_total") != _column(tmp_path / "plain", "valid_total")
    train(config, data, tmp_path / "split", steps=10, progress=False)
    resumed = train(config, data, tmp_path / "split", resume=True, progress=False)
    for mine, theirs in zip(resumed.policy.ema.parameters(), full.policy.ema.parameters(),
                            strict=True):
        torch.testing.assert_close(mine, theirs)
    loaded = load_checkpoint(tmp_path / "full" / "last.pt")
    torch.testing.assert_close(loaded.policy.ema.rnn.weight_hh_l0, full.policy.ema.rnn.weight_hh_l0)


def test_cli_train_with_an_override(tmp_path, data):
    cfg = tmp_path / "c.yaml"
    save_config(tiny_config(algo="bc_rnn", invariant_weight=0.0), cfg)
    assert main(["train", "--config", str(cfg), "--data", str(data), "--out",
                 str(tmp_path / "run"), "--steps", "3", "--set", "invariant_weight=0.01"]) == 0
    ckpt = load_checkpoint(tmp_path / "run" / "last.pt")
    assert ckpt.step == 3 and ckpt.config.invariant_weight == 0.01
    assert ckpt.config.algo == "bc_rnn"
    with pytest.raises(SystemExit):
        main(["train", "--config", str(cfg), "--data", str(tmp_path / "no.hdf5"), "--out",
              str(tmp_path / "run2")])


def test_a_bfloat16_image_trunk_warns_on_a_cpu_without_native_bfloat16(tmp_path, data,
                                                                         monkeypatch, caplog):
    config = tiny_config(obs_mode="image", steps=1, encoder_precision="bfloat16")
    monkeypatch.setattr("legato_drake.learning.train.native_bfloat16", lambda: False)
    with caplog.at_level("WARNING", logger="legato_drake.learning.train"):
        train(config, data, tmp_path / "run", progress=False)
    assert "no native bfloat16" in caplog.text and "encoder_precision=float32" in caplog.text
    caplog.clear()
    monkeypatch.setattr("legato_drake.learning.train.native_bfloat16", lambda: True)
    with caplog.at_level("WARNING", logger="legato_drake.learning.train"):
        train(config, data, tmp_path / "run2", progress=False)
    assert "bfloat16" not in caplog.text
    starts = json.loads((tmp_path / "run2" / "machine.json").read_text())
    assert "native_bfloat16" in starts[0]
