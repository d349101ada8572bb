"""The policy-family seam: the registry, checkpoints through it, training logging a family's
own loss terms, and the PolicyController executing action chunks (receding horizon)."""

from __future__ import annotations

import csv
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pytest
import torch
from pydrake.systems.analysis import Simulator

from legato_drake import conventions
from legato_drake.cli import main
from legato_drake.data.derived import observation_sizes
from legato_drake.diagram import object_bodies
from legato_drake.errors import ConfigError
from legato_drake.learning import registry
from legato_drake.learning.checkpoint import (
    Checkpoint,
    CheckpointError,
    load_checkpoint,
    save_checkpoint,
)
from legato_drake.learning.family import PolicyFamily
from legato_drake.learning.policies import RecurrentGMMPolicy
from legato_drake.learning.train import train
from legato_drake.systems.episode_recorder import EpisodeRecorder
from legato_drake.systems.policy_controller import PolicyController
from tests.learning_helpers import synthetic_dataset, tiny_config

CHUNK, EXECUTE = 4, 3


@dataclass(frozen=True)
class ChunkState:
    calls: int


class ChunkPolicy(PolicyFamily):
    """A toy family: a linear map from the fingers to a chunk of CHUNK actions, whose last
    component says which call (and which step of the chunk) it came from."""

    loss_terms = ("mse", "total")
    execute_steps = EXECUTE

    def __init__(self, config, stats):
        super().__init__(config, stats)
        self.linear = torch.nn.Linear(len(stats["fingers"]["mean"]), 7)

    def losses(self, batch: Mapping) -> dict[str, torch.Tensor]:
        mse = ((self.linear(batch["obs"]["fingers"]) - batch["actions"]) ** 2).mean()
        return {"mse": mse, "total": 2 * mse}

    def initial_state(self, scene_seed: int = 0) -> ChunkState:
        return ChunkState(0)

    def act(self, obs, state: ChunkState):
        B = obs["fingers"].shape[0]
        chunk = torch.zeros(B, CHUNK, 7)
        chunk[..., 0] = state.calls
        chunk[..., 1] = torch.arange(CHUNK, dtype=torch.float32)
        return chunk, ChunkState(state.calls + 1)


@pytest.fixture
def chunk_family():
    registry.register_family("chunk_test", ChunkPolicy)
    yield "chunk_test"
    del registry.FAMILIES["chunk_test"]


def _stats():
    rng = np.random.default_rng(0)
    return {k: {"mean": rng.normal(0, 0.01, d).astype(np.float32),
                "std": np.full(d, 0.05, np.float32)}
            for k, d in observation_sizes(3).items()}


def test_the_registry_builds_both_recurrent_families_and_names_them_on_a_typo():
    assert set(registry.FAMILIES) >= {"legato", "bc_rnn"}
    for algo in ("legato", "bc_rnn"):
        assert isinstance(registry.build_policy(tiny_config(algo=algo), _stats()),
                          RecurrentGMMPolicy)
    with pytest.raises(ConfigError, match="unknown policy family 'nope'; registered: "
                                          "legato, bc_rnn"):
        registry.build_policy(tiny_config(algo="nope"), _stats())
    with pytest.raises(ValueError, match="already registered"):
        registry.register_family("legato", RecurrentGMMPolicy)


def test_train_with_an_unknown_algo_is_one_line_before_any_work(tmp_path, capsys):
    data = synthetic_dataset(tmp_path / "d.hdf5", images=False)
    config = tmp_path / "c.yaml"
    config.write_text("obs_mode: state\n")
    with pytest.raises(SystemExit) as exit_:
        main(["train", "--config", str(config), "--data", str(data), "--out",
              str(tmp_path / "run"), "--set", "algo=nope"])
    err = capsys.readouterr().err.strip().splitlines()
    assert exit_.value.code == 2 and len(err) == 1, err
    assert "unknown policy family 'nope'" in err[0] and "legato, bc_rnn" in err[0]
    assert not (tmp_path / "run").exists()


def test_a_family_trains_logs_its_own_terms_and_round_trips_a_checkpoint(
        tmp_path, chunk_family):
    data = synthetic_dataset(tmp_path / "d.hdf5", images=False)
    config = tiny_config(algo=chunk_family, state_keys=["fingers"], steps=6, valid_every=3,
                         checkpoint_every=3)
    ckpt = train(config, data, tmp_path / "run", progress=False)
    with open(tmp_path / "run" / "log.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == ["step", "mse", "total", "lr", "valid_mse", "valid_total"]
    assert [int(r["step"]) for r in rows] == list(range(1, 7))
    assert all(float(r["total"]) == pytest.approx(2 * float(r["mse"])) for r in rows)
    loaded = load_checkpoint(tmp_path / "run" / "last.pt")
    assert isinstance(loaded.policy, ChunkPolicy) and loaded.step == 6
    torch.testing.assert_close(loaded.policy.linear.weight, ckpt.policy.linear.weight)
    assert torch.load(tmp_path / "run" / "last.pt", weights_only=False)["algo"] == chunk_family
    del registry.FAMILIES[chunk_family]
    with pytest.raises(CheckpointError, match="unknown policy family 'chunk_test'"):
        load_checkpoint(tmp_path / "run" / "last.pt")
    registry.FAMILIES[chunk_family] = ChunkPolicy


def test_the_controller_executes_part_of_each_chunk_then_replans(
        tmp_path, chunk_family, abstract_plant):
    plant, _, robot, _ = abstract_plant
    config = tiny_config(algo=chunk_family, state_keys=["fingers"])
    stats = _stats()
    path = tmp_path / "chunk.pt"
    save_checkpoint(path, Checkpoint(config, stats, ChunkPolicy(config, stats)))
    features = EpisodeRecorder(plant, robot.tcp_frame, images=False,
                               object_bodies=object_bodies(plant, robot))
    controller = PolicyController(path, features)
    context = controller.CreateDefaultContext()
    controller.get_plant_state_input_port().FixValue(
        context, plant.GetPositionsAndVelocities(plant.CreateDefaultContext()))
    controller.get_commanded_pose_input_port().FixValue(context, [0, 0, 0.8, 1, 0, 0, 0])
    simulator = Simulator(controller, context)
    seen = []
    for k in range(7):
        simulator.AdvanceTo(conventions.HOMING_DURATION + k * conventions.POLICY_PERIOD
                            + 0.0015)
        action = controller.GetOutputPort("action").Eval(context)
        seen.append((int(action[0]), int(action[1])))
    # call 0 gives steps 0-2 of its chunk, call 1 steps 0-2 of its own, ...
    assert seen == [(k // EXECUTE, k % EXECUTE) for k in range(7)]
    state = controller.policy_state(context)
    assert state.step == 7 and state.policy == ChunkState(3) and len(state.plan) == 2
