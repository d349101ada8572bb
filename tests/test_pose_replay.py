"""Pose streams: loading with clear errors, resampling, re-anchoring; PoseStreamReplay alone;
the scenario field; a replayed scripted recording reproduces the episode's success."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.systems.analysis import Simulator

from legato_drake import conventions
from legato_drake.data import pose_stream as pose_stream_module
from legato_drake.data.pose_stream import (
    COLUMNS,
    PoseStreamError,
    load_pose_stream,
    make_pose_stream,
    script_to_stream,
    stream_to_actions,
    write_pose_stream,
)
from legato_drake.diagram import build_diagram
from legato_drake.errors import ConfigError, LegatoError
from legato_drake.pipelines.pose_streams import scripted_pose_stream
from legato_drake.poses import apply_delta, pose_error, pose_to_vector, vector_to_pose
from legato_drake.scenario import Scenario, scenario_from_yaml_text
from legato_drake.systems.pose_replay import PoseStreamReplay

X_TRACKER = RigidTransform(RollPitchYaw(0.3, -0.2, 1.0), [1.0, 2.0, 3.0])
"""Pose of a tracker's world frame: replay must not depend on it."""


def _script(n: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """A small script: a move forward and down while pitching, then a grasp."""
    X0 = conventions.START_POSE
    poses = [X0 @ RigidTransform(RollPitchYaw(0.0, 0.04 * (k + 1), 0.01 * k),
                                 [0.01 * (k + 1), 0.002 * k, -0.005 * (k + 1)])
             for k in range(n)]
    grasps = np.array([0.0] * (n // 2) + [1.0] * (n - n // 2))
    return np.array([pose_to_vector(X) for X in poses]), grasps


def _rows(path, rows: list[str]) -> str:
    path.write_text("\n".join([",".join(COLUMNS), *rows]) + "\n")
    return str(path)


def test_stream_actions_reach_the_script_from_any_tracker_frame():
    poses, grasps = _script()
    for rate, X_WT in ((None, None), (200.0, X_TRACKER)):
        stream = script_to_stream(poses, grasps, rate=rate, X_WT=X_WT)
        actions, commanded = stream_to_actions(stream)
        assert actions.shape == (12, 7) and commanded.shape == (13, 7)
        np.testing.assert_allclose(commanded[0], pose_to_vector(conventions.START_POSE),
                                   atol=1e-12)
        X = conventions.START_POSE
        for k in range(12):
            X = apply_delta(X, actions[k, :6])
            dp, dr = pose_error(X, vector_to_pose(poses[k]))
            assert dp < 1e-9 and dr < 1e-9
        np.testing.assert_array_equal(actions[:, 6], grasps)


def test_csv_and_npz_round_trip(tmp_path):
    poses, grasps = _script()
    stream = script_to_stream(poses, grasps, rate=100.0, X_WT=X_TRACKER, seed=7, task="lid")
    for name in ("s.csv", "s.npz"):
        loaded = load_pose_stream(write_pose_stream(tmp_path / name, stream))
        assert loaded.seed == 7 and loaded.task == "lid" and len(loaded) == len(stream)
        np.testing.assert_allclose(loaded.positions, stream.positions, atol=1e-8)
        np.testing.assert_allclose(stream_to_actions(loaded)[0], stream_to_actions(stream)[0],
                                   atol=1e-8)


def test_quaternion_sign_flips_and_slow_streams_resample():
    t = np.array([0.0, 0.25, 0.5])
    q = RollPitchYaw(0.0, 0.0, 0.5).ToQuaternion().wxyz()
    poses = np.array([[0, 0, 0, 1, 0, 0, 0], [0.1, 0, 0, *(-q)], [0.2, 0, 0, *q]])
    stream = make_pose_stream(t, poses, [0.0, 0.2, 0.9])
    actions, commanded = stream_to_actions(stream)
    assert actions.shape == (5, 7)  # samples at 0, 0.1, .., 0.5
    np.testing.assert_allclose(actions[:, 0].sum(), 0.2 * np.cos(0.0), atol=0.05)
    assert np.abs(actions[:, 5]).max() < 0.3  # took the short way round
    np.testing.assert_array_equal(actions[:, 6], [0, 0, 0, 1, 1])  # nearest sample >= 0.5


GOOD_ROW = "0,0,0,0,1,0,0,0,0"


@pytest.mark.parametrize("header, row, column, words", [
    ("t,x,y,z,qw,qx,qy,qz", "0.1,0,0,0,1,0,0,0", "grasp", "missing column"),
    (None, "0,0,0,0,1,0,0,0,0", "t", "not strictly increasing"),
    (None, "0.1,nan,0,0,1,0,0,0,0", "x", "non-finite"),
    (None, "0.1,0,0,0,0.5,0,0,0,0", "qw", "not a unit quaternion"),
    (None, "0.1,0,0,0,1,0,0,0,2", "grasp", "must be in [0, 1]"),
    (None, "0.1,0,zero,0,1,0,0,0,0", "y", "not a number"),
    (None, None, None, "at least 2 samples"),
])
def test_bad_streams_name_the_file_and_the_column(tmp_path, header, row, column, words):
    path = tmp_path / "bad.csv"
    rows = [GOOD_ROW[:-2] if header else GOOD_ROW] + ([row] if row else [])
    path.write_text("\n".join([header or ",".join(COLUMNS), *rows]) + "\n")
    with pytest.raises(PoseStreamError) as info:
        load_pose_stream(path)
    message = str(info.value)
    assert str(path) in message and words in message
    if column is not None:
        assert f"'{column}'" in message


def test_missing_or_foreign_files(tmp_path):
    with pytest.raises(PoseStreamError, match="not found"):
        load_pose_stream(tmp_path / "none.csv")
    (tmp_path / "p.txt").write_text("t\n")
    with pytest.raises(PoseStreamError, match="unknown format"):
        load_pose_stream(tmp_path / "p.txt")
    np.savez(tmp_path / "p.npz", t=np.arange(3.0))
    with pytest.raises(PoseStreamError, match="missing field 'x'"):
        load_pose_stream(tmp_path / "p.npz")


def test_scenario_field(tmp_path, monkeypatch):
    with pytest.raises(ConfigError, match="pose_stream.*when controller is 'replay'"):
        Scenario(controller="replay").validate()
    with pytest.raises(ConfigError, match="pose_stream in s.yaml: pose stream file not found"):
        scenario_from_yaml_text(f"controller: replay\npose_stream: {tmp_path / 'x.csv'}\n",
                                "s.yaml")
    (tmp_path / "p.txt").write_text("t\n")
    with pytest.raises(ConfigError, match="pose_stream: .*p.txt: unknown format"):
        Scenario(controller="replay", pose_stream=str(tmp_path / "p.txt")).validate()
    # Validation only checks that the file is there; it is read where the diagram is built.
    bad = _rows(tmp_path / "bad.csv", ["0,0,0,0,1,0,0,0,0", "0,0,0,0,1,0,0,0,0"])
    scenario = Scenario(embodiment="abstract", controller="replay", pose_stream=bad)
    scenario.camera.enabled = False
    with pytest.raises(ConfigError, match="bad.csv: column 't'"):
        build_diagram(scenario.validate())
    good = write_pose_stream(tmp_path / "good.csv", script_to_stream(*_script()))
    reads = []
    read_csv = pose_stream_module._read_csv
    monkeypatch.setattr(pose_stream_module, "_read_csv",
                        lambda path: reads.append(path) or read_csv(path))
    scenario = scenario.replace(pose_stream=str(good)).replace(seed=1)
    built = build_diagram(scenario)
    assert built.controller.stream.source == str(good) and reads == [good]  # read once


def test_replay_system_alone():
    poses, grasps = _script()
    stream = script_to_stream(poses, grasps, rate=200.0, X_WT=X_TRACKER)
    system = PoseStreamReplay(stream, t_start=1.0)
    assert system.num_input_ports() == 0
    context = system.CreateDefaultContext()
    action, done = system.GetOutputPort("action"), system.GetOutputPort("done")
    simulator = Simulator(system, context)
    simulator.AdvanceTo(0.99)
    assert not action.Eval(context).any() and done.Eval(context)[0] == 0.0
    outputs = []
    for k in range(14):
        simulator.AdvanceTo(1.0 + conventions.CONTROLLER_OFFSET + 0.1 * k + 0.01)
        outputs.append((action.Eval(context).copy(), done.Eval(context)[0]))
    np.testing.assert_allclose([a for a, _ in outputs[:12]], system.actions, atol=1e-12)
    assert [d for _, d in outputs] == [0.0] * 12 + [1.0, 1.0]
    np.testing.assert_array_equal(outputs[12][0], [0, 0, 0, 0, 0, 0, 1.0])
    assert system.commanded_poses.shape == (13, 7)


def test_replaying_a_scripted_recording_reproduces_the_success(tmp_path):
    """A scripted demonstration written as a 200 Hz stream in a tracker frame, replayed by
    ``collect --source``, succeeds as the scripted episode does; a bad stream before it is
    refused before anything is written, so the corrected command then runs."""
    from legato_drake.data.layout import check_file, open_dataset
    from legato_drake.pipelines.collect import collect, parts_dir

    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "typo.csv").write_text("a,b\n0,1\n")
    with pytest.raises(LegatoError, match="missing column 't'"):
        collect("lid", "abstract", 5, tmp_path / "replayed.hdf5", source=tmp_path / "bad",
                camera=False)
    assert not parts_dir(tmp_path / "replayed.hdf5").exists()
    stream = scripted_pose_stream("lid", seed=1, rate=200.0, X_WT=X_TRACKER)
    write_pose_stream(tmp_path / "streams" / "seed1.csv", stream)
    report = collect("lid", "abstract", 5, tmp_path / "replayed.hdf5",
                     source=tmp_path / "streams", camera=False)
    assert [o["success"] for o in report.outcomes] == [True], report.outcomes
    check_file(tmp_path / "replayed.hdf5")
    with open_dataset(tmp_path / "replayed.hdf5") as f:
        demo = f["data/demo_0"]
        assert demo.attrs["controller"] == "replay" and demo.attrs["seed"] == 1
        assert demo.attrs["source"] == "seed1.csv"
        actions = demo["actions"][()]
    expected, _ = stream_to_actions(stream)
    np.testing.assert_allclose(actions[:len(expected)], expected[:len(actions)], atol=1e-8)
