"""The command line: the demo writes replays and a table; bad input gives clear errors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from legato_drake.cli import main


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "legato_drake.cli", *args],
                          capture_output=True, text=True, timeout=600)


def test_unknown_embodiment_lists_the_valid_ones():
    result = _cli("demo", "--embodiment", "r2d2")
    assert result.returncode == 2
    assert "unknown embodiment 'r2d2'" in result.stderr and "panda" in result.stderr
    assert "Traceback" not in result.stderr


def test_malformed_scenario_file(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("embodiment: panda\ncamera: {fps: 3}\n")
    result = _cli("demo", "--scenario", str(bad))
    assert result.returncode == 2
    assert str(bad) in result.stderr and "fps" in result.stderr
    assert "Traceback" not in result.stderr


def test_bad_seeds():
    with pytest.raises(SystemExit) as exit_info:
        main(["demo", "--seeds", "9-3"])
    assert exit_info.value.code == 2


@pytest.mark.slow
def test_demo_writes_a_replay_and_a_table(tmp_path):
    result = _cli("demo", "--embodiment", "abstract", "--out", str(tmp_path / "replays"),
                  "--json", str(tmp_path / "r.json"))
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()  # the shipped LEGATO policy by default
    assert lines[0].split()[:5] == ["embodiment", "task", "controller", "seed", "success"]
    assert lines[2].split()[:5] == ["abstract", "lid", "policy:legato_state_lid.pt", "0",
                                    "yes"]
    html = (tmp_path / "replays" / "abstract-lid-seed0.html").read_text()
    assert html.lstrip().lower().startswith("<!doctype html") or "<html" in html[:200].lower()
    assert "http://" not in html.split("<script", 1)[0]  # no remote assets in the head
    assert len(html) > 1_000_000  # the viewer and the recording are inlined
    (record,) = json.loads((tmp_path / "r.json").read_text())
    assert record["success"] and record["tracking"]["rms_mm"] < 5.0


# ------------------------------------------------------------------ bad input (issue 12)


def _main(capsys, *args: str) -> tuple[int, str, str]:
    """Runs ``legato-drake ARGS`` in this process: (exit code, stdout, stderr)."""
    try:
        code = main(list(args))
    except SystemExit as e:
        code = e.code
    out, err = capsys.readouterr()
    return code, out, err


def _one_error_line(err: str, *words: str) -> str:
    """The single error line of ``err``, which must name each of ``words``."""
    assert "Traceback" not in err
    (line,) = [line for line in err.splitlines() if "error:" in line]
    for word in words:
        assert word in line, (word, line)
    return line


@pytest.mark.parametrize("args, words", [
    (["evaluate", "--checkpoint", "x.pt", "--duration", "nan"], ["--duration", "nan"]),
    (["evaluate", "--checkpoint", "x.pt", "--duration", "-3"], ["--duration"]),
    (["evaluate", "--checkpoint", "x.pt", "--seed0", "-100"], ["--seed0", "-100"]),
    (["evaluate", "--checkpoint", "x.pt", "--trials", "0"], ["--trials"]),
    (["evaluate", "--checkpoint", "x.pt", "--trials", "many"], ["--trials", "many"]),
    (["evaluate", "--checkpoint", "x.pt", "--replays", "-1"], ["--replays"]),
    (["train", "--config", "c.yaml", "--data", "d.hdf5", "--out", "r", "--steps", "0"],
     ["--steps"]),
    (["collect", "--out", "d.hdf5", "--episodes", "0"], ["--episodes"]),
    (["collect", "--out", "d.hdf5", "--duration", "inf"], ["--duration"]),
    (["collect", "--out", "d.hdf5", "--seed0", "-1"], ["--seed0"]),
    (["collect", "--out", "d.hdf5", "--workers", "0"], ["--workers"]),
    (["collect", "--out", "d.hdf5", "--camera-model", "orthographic"],
     ["--camera-model", "pinhole", "fisheye", "orthographic"]),
    (["demo", "--workers", "0"], ["--workers"]),
    (["demo", "--seeds", "-3"], ["--seeds"]),
    (["retarget-benchmark", "--seeds", "4-1"], ["--seeds"]),
    (["inspect", "d.hdf5", "--episode", "-1"], ["--episode"]),
    (["demo", "--bogus"], ["--bogus"]),
])
def test_bad_flags_are_one_line_errors(capsys, args, words):
    code, out, err = _main(capsys, *args)
    assert code == 2 and out == ""
    _one_error_line(err, *words)


@pytest.mark.parametrize("verb", [
    ["demo", "--embodiment", "abstract"],
    ["retarget-benchmark"],
    ["evaluate", "--checkpoint", "x.pt"],
    ["inspect", "d.hdf5"],
])
def test_out_at_a_file_or_under_a_file_is_refused_before_any_work(tmp_path, capsys, verb):
    a_file = tmp_path / "a_file"
    a_file.write_text("mine")
    for out in (a_file, a_file / "sub"):
        code, _, err = _main(capsys, *verb, "--out", str(out))
        assert code == 2
        _one_error_line(err, "--out", str(a_file))
    assert a_file.read_text() == "mine"


def test_json_and_collect_outputs_under_a_file_are_refused(tmp_path, capsys):
    a_file = tmp_path / "a_file"
    a_file.write_text("mine")
    code, _, err = _main(capsys, "demo", "--embodiment", "abstract", "--no-replay", "--json",
                         str(a_file / "r.json"))
    assert code == 2
    _one_error_line(err, "--json")
    code, _, err = _main(capsys, "collect", "--out", str(a_file / "d.hdf5"))
    assert code == 2
    _one_error_line(err, "--out")
    code, _, err = _main(capsys, "collect", "--out", str(tmp_path))  # a folder
    assert code == 2
    _one_error_line(err, "--out", "folder")


@pytest.mark.parametrize("text, words", [
    ("embodiment: [abstract\n", ["not valid YAML", "line 2"]),
    ("embodiment: abstract\nseed: twelve\n", ["seed", "integer"]),
    ("embodiment: abstract\nduration: .nan\n", ["duration"]),
    ("embodiment: abstract\nspeed: 3\n", ["unknown field", "speed"]),
    ("embodiment: abstract\nrecording: {fps: .inf}\n", ["recording.fps"]),
])
def test_malformed_scenario_files_are_one_line_errors(tmp_path, capsys, text, words):
    path = tmp_path / "s.yaml"
    path.write_text(text)
    code, _, err = _main(capsys, "demo", "--scenario", str(path))
    assert code == 2
    _one_error_line(err, str(path), *words)


def test_a_binary_scenario_file_is_a_clear_error(tmp_path, capsys):
    path = tmp_path / "s.yaml"
    path.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00")
    code, _, err = _main(capsys, "demo", "--scenario", str(path))
    assert code == 2
    _one_error_line(err, str(path), "text")


def _fake_demo() -> tuple:
    """A stand-in for run_episodes in cmd_demo: records the scenarios, succeeds at once."""
    seen = []

    def fake(jobs_in, workers=1, desc="", executor=None):
        scenarios = [job.scenario for job in jobs_in]
        seen.extend(scenarios)
        return [{"embodiment": s.embodiment, "task": s.task, "controller": s.controller,
                 "seed": s.seed, "success": True,
                 "reason": "", "tracking": {"rms_mm": 0.1, "rms_deg": 0.1, "max_mm": 0.2},
                 "sim_time": 1.0, "wall_time": 1.0, "real_time_factor": 1.0, "html": None}
                for s in scenarios]

    return fake, seen


@pytest.mark.parametrize("flags, expected", [
    ([], [("abstract", "cup", 7)]),                                  # the file's own fields
    (["--embodiment", "panda"], [("panda", "cup", 7)]),               # a flag overrides
    (["--embodiments", "panda,abstract", "--tasks", "lid", "--seeds", "1"],
     [("panda", "lid", 1), ("abstract", "lid", 1)]),
])
def test_demo_respects_the_scenario_file_unless_flags_say_otherwise(tmp_path, capsys,
                                                                    monkeypatch, flags,
                                                                    expected):
    path = tmp_path / "s.yaml"
    path.write_text("embodiment: abstract\ntask: cup\nseed: 7\nduration: 3.0\n")
    fake, seen = _fake_demo()
    monkeypatch.setattr("legato_drake.pipelines.episodes.run_episodes", fake)
    code, out, _ = _main(capsys, "demo", "--scenario", str(path), "--no-replay", *flags)
    assert code == 0
    assert [(s.embodiment, s.task, s.seed) for s in seen] == expected
    assert all(s.duration == 3.0 for s in seen)  # fields no flag names stay the file's
    assert out.splitlines()[0].split()[:4] == ["embodiment", "task", "controller", "seed"]
    assert {s.controller for s in seen} == {"scripted"}  # the file's (default) controller


def test_demo_without_a_scenario_runs_every_embodiment(capsys, monkeypatch):
    fake, seen = _fake_demo()
    monkeypatch.setattr("legato_drake.pipelines.episodes.run_episodes", fake)
    assert _main(capsys, "demo", "--no-replay")[0] == 0
    assert [s.embodiment for s in seen] == ["abstract", "panda", "spot", "google", "gr1"]
    assert {s.task for s in seen} == {"lid"}
    assert {(s.controller, Path(s.checkpoint).name) for s in seen} == {
        ("policy", "legato_state_lid.pt")}  # the shipped policy by default


def test_demo_controller_flags(capsys, monkeypatch, tmp_path):
    fake, seen = _fake_demo()
    monkeypatch.setattr("legato_drake.pipelines.episodes.run_episodes", fake)
    assert _main(capsys, "demo", "--no-replay", "--controller", "scripted",
                 "--embodiment", "panda")[0] == 0
    assert [(s.controller, s.checkpoint) for s in seen] == [("scripted", "")]
    code, _, err = _main(capsys, "demo", "--no-replay", "--task", "lid", "--checkpoint",
                         str(tmp_path / "nope.pt"))
    assert code == 2
    _one_error_line(err, "--checkpoint", "nope.pt")
    monkeypatch.setattr("legato_drake.models.CHECKPOINTS_DIR", tmp_path)
    code, _, err = _main(capsys, "demo", "--no-replay")
    assert code == 2
    _one_error_line(err, "no shipped policy", "--controller scripted")


def test_demo_embodiment_file_and_embodiment_together_are_refused(tmp_path, capsys):
    code, _, err = _main(capsys, "demo", "--embodiment", "panda", "--embodiment-file",
                         str(tmp_path / "x.yaml"))
    assert code == 2
    _one_error_line(err, "--embodiment-file", "--embodiment")


def test_spellings_version_and_verbose_after_the_verb(capsys):
    from legato_drake import __version__
    from legato_drake.cli import build_parser

    parser = build_parser()
    for verb in ("demo", "evaluate", "retarget-benchmark"):
        plural = parser.parse_args([verb, "--embodiments", "panda", "--tasks", "lid"])
        single = parser.parse_args([verb, "--embodiment", "panda", "--task", "lid"])
        assert vars(plural) == vars(single)
    assert parser.parse_args(["demo", "-v"]).verbose is True
    assert parser.parse_args(["-v", "demo"]).verbose is True
    assert parser.parse_args(["demo"]).verbose is False
    code, out, _ = _main(capsys, "--version")
    assert code == 0 and __version__ in out


def _run_folder(tmp_path):
    """A learning config, a small dataset and a run folder that already holds a run."""
    from legato_drake.learning.config import save_config
    from tests.learning_helpers import synthetic_dataset, tiny_config

    config = tmp_path / "tiny.yaml"
    save_config(tiny_config(steps=2, valid_every=1, checkpoint_every=1), config)
    data = synthetic_dataset(tmp_path / "d.hdf5", demos=3, length=10, images=False)
    run = tmp_path / "run"
    run.mkdir()
    (run / "last.pt").write_bytes(b"the old run")
    (run / "log.csv").write_text("step\n1\n")
    (run / "step_000001.pt").write_bytes(b"an old snapshot")
    (run / "machine.json").write_text('[{"step": 0, "cpu": "the old machine"}]')
    (run / "notes.txt").write_text("the user's own notes")
    return config, data, run


def test_train_into_an_existing_run_is_refused_unless_resume_or_overwrite(tmp_path, capsys):
    config, data, run = _run_folder(tmp_path)
    args = ["train", "--config", str(config), "--data", str(data), "--out", str(run)]
    code, _, err = _main(capsys, *args)
    assert code == 2
    _one_error_line(err, str(run), "--resume", "--overwrite")
    assert (run / "last.pt").read_bytes() == b"the old run"  # nothing touched
    code, _, err = _main(capsys, *args, "--resume", "--overwrite")
    assert code == 2
    _one_error_line(err, "--resume", "--overwrite")
    assert _main(capsys, *args, "--overwrite")[0] == 0
    assert (run / "last.pt").read_bytes() != b"the old run"
    assert not (run / "step_000001.pt").exists()          # the old run's files are gone
    machines = json.loads((run / "machine.json").read_text())
    assert len(machines) == 1 and machines[0]["cpu"] != "the old machine"  # not appended
    assert (run / "notes.txt").read_text() == "the user's own notes"  # the rest stays
    assert (run / "best.pt").is_file() and not (run / ".overwritten").exists()


def test_a_failed_train_overwrite_puts_the_old_run_back(tmp_path, capsys, monkeypatch):
    config, data, run = _run_folder(tmp_path)

    def failing_train(config, data, out, **kwargs):
        (out / "log.csv").write_text("step\n")
        (out / "step_000009.pt").write_bytes(b"new")
        raise KeyboardInterrupt

    monkeypatch.setattr("legato_drake.learning.train.train", failing_train)
    code, _, err = _main(capsys, "train", "--config", str(config), "--data", str(data),
                         "--out", str(run), "--overwrite")
    assert code == 130 and "interrupted" in err
    assert (run / "last.pt").read_bytes() == b"the old run"
    assert (run / "log.csv").read_text() == "step\n1\n"
    assert "the old machine" in (run / "machine.json").read_text()
    assert sorted(p.name for p in run.iterdir()) == ["last.pt", "log.csv", "machine.json",
                                                     "notes.txt", "step_000001.pt"]


def test_train_checks_its_files_and_device_first(tmp_path, capsys):
    config, data, _ = _run_folder(tmp_path)
    new = str(tmp_path / "new")
    for args, words in (
            (["--config", str(config), "--data", str(tmp_path / "no.hdf5")], ["--data"]),
            (["--config", str(config), "--data", str(tmp_path)], ["--data", "is a folder"]),
            (["--config", str(tmp_path / "no.yaml"), "--data", str(data)], ["no.yaml"]),
            (["--config", str(config), "--data", str(data), "--device", "gpu"],
             ["--device", "gpu"])):
        code, _, err = _main(capsys, "train", *args, "--out", new)
        assert code == 2
        _one_error_line(err, *words)
    assert not (tmp_path / "new").exists()


def test_a_checkpoint_that_is_not_one_is_refused_before_any_episode(tmp_path, capsys,
                                                                    monkeypatch):
    """``demo`` and ``evaluate`` read the checkpoint first: a folder or a file torch did not
    write is one line naming it, and no episode starts."""
    from legato_drake.pipelines import episodes

    monkeypatch.setattr(episodes, "run_episodes", lambda *a, **k: pytest.fail("ran"))
    empty = tmp_path / "empty.pt"
    empty.write_bytes(b"")
    for verb, path, words in (("demo", empty, ["cannot read checkpoint", "torch.save"]),
                              ("demo", tmp_path, ["--checkpoint", "is a folder"]),
                              ("evaluate", tmp_path, ["checkpoint", "is a folder"]),
                              ("evaluate", empty, ["cannot read checkpoint"])):
        extra = ["--no-replay", "--no-camera"] if verb == "demo" else [
            "--out", str(tmp_path / "eval")]
        code, _, err = _main(capsys, verb, "--embodiment", "abstract", "--task", "lid",
                             "--checkpoint", str(path), *extra)
        assert code == 2
        _one_error_line(err, str(path), *words)
    assert not (tmp_path / "eval").exists()


def test_collect_never_shrinks_a_dataset(tmp_path, capsys, monkeypatch):
    import hashlib

    from tests.learning_helpers import synthetic_dataset

    data = synthetic_dataset(tmp_path / "d.hdf5", demos=3, length=6, images=False)
    before = hashlib.sha256(data.read_bytes()).hexdigest()
    code, _, err = _main(capsys, "collect", "--out", str(data), "--episodes", "2",
                         "--no-camera")
    assert code == 2
    _one_error_line(err, str(data), "3 episodes", "--overwrite")
    assert hashlib.sha256(data.read_bytes()).hexdigest() == before

    calls = []

    def fake_collect(**kwargs):
        from legato_drake.pipelines.collect import CollectReport

        calls.append(kwargs)
        assert not data.exists() and not (tmp_path / "d.hdf5.parts").exists()
        return CollectReport(data, kwargs["episodes"], [{}] * kwargs["episodes"], [], 0.0)

    (tmp_path / "d.hdf5.parts").mkdir()
    monkeypatch.setattr("legato_drake.pipelines.collect.collect", fake_collect)
    args = ["collect", "--out", str(data), "--episodes", "2", "--no-camera", "--overwrite"]
    code, _, _ = _main(capsys, *args)
    assert code == 0 and calls[0]["episodes"] == 2
    assert not data.exists() and not (tmp_path / ".d.hdf5.overwritten").exists()

    # An --overwrite whose collection fails puts the old dataset back.
    data = synthetic_dataset(tmp_path / "d.hdf5", demos=3, length=6, images=False)
    before = hashlib.sha256(data.read_bytes()).hexdigest()

    def failing_collect(**kwargs):
        from legato_drake.data.layout import DatasetError

        (tmp_path / "d.hdf5.parts").mkdir()
        raise DatasetError("no episode kept")

    monkeypatch.setattr("legato_drake.pipelines.collect.collect", failing_collect)
    code, _, err = _main(capsys, *args)
    assert code == 2
    _one_error_line(err, "no episode kept")
    assert hashlib.sha256(data.read_bytes()).hexdigest() == before
    assert not (tmp_path / "d.hdf5.parts").exists()
    assert sorted(p.name for p in tmp_path.iterdir() if "d.hdf5" in p.name) == ["d.hdf5"]


def test_evaluate_exit_codes_follow_the_documented_rule(tmp_path, capsys, monkeypatch):
    """0 when every trial ran (failed trials are results), 1 when a trial raised."""
    from legato_drake.learning.train import train
    from legato_drake.pipelines import evaluate as evaluation
    from tests.learning_helpers import synthetic_dataset, tiny_config

    data = synthetic_dataset(tmp_path / "d.hdf5", demos=3, length=10, images=False)
    train(tiny_config(steps=2), data, tmp_path / "run", progress=False)
    args = ["evaluate", "--checkpoint", str(tmp_path / "run" / "best.pt"), "--embodiments",
            "abstract", "--trials", "2"]

    def failing(job):
        s = job.scenario
        return {"method": job.method, "embodiment": s.embodiment, "task": s.task,
                "trial": job.trial, "seed": s.seed, "success": False,
                "reason": "lid tilted 40 deg", "success_time": None, "episode_time": 1.0,
                "wall_time": 0.1, "html": None}

    monkeypatch.setattr(evaluation, "run_trial", failing)
    assert _main(capsys, *args, "--out", str(tmp_path / "a"))[0] == 0

    def boom(scenario, html=None):
        raise RuntimeError("the solver diverged")

    monkeypatch.undo()
    monkeypatch.setattr(evaluation, "run_episode", boom)
    code, out, _ = _main(capsys, *args, "--out", str(tmp_path / "b"))
    assert code == 1 and "error" in out


def test_bad_input_in_a_fresh_process_prints_no_traceback(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text("embodiment: {abstract\n")
    result = _cli("demo", "--scenario", str(path))
    assert result.returncode == 2 and result.stdout == ""
    assert "Traceback" not in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and str(path) in result.stderr


def test_evaluate_accepts_demos_seed_spelling(capsys):
    from legato_drake.cli import _trial_seeds, build_parser

    parser = build_parser()
    assert _trial_seeds(parser.parse_args(["evaluate"])) == (10000, 50)
    assert _trial_seeds(parser.parse_args(["evaluate", "--seeds", "20000-20009"])) == \
        (20000, 10)
    assert _trial_seeds(parser.parse_args(["evaluate", "--seed0", "5", "--trials", "2"])) == \
        (5, 2)
    for args in (["--seeds", "1,5"], ["--seeds", "1-4", "--trials", "2"]):
        code, _, err = _main(capsys, "evaluate", "--checkpoint", "x.pt", *args)
        assert code == 2
        _one_error_line(err, "--seeds")
