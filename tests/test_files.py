"""Reading user files and checking output locations: one-line errors naming the flag."""

from __future__ import annotations

import pytest
import yaml

from legato_drake.errors import ConfigError, LegatoError, one_line, yaml_problem
from legato_drake.files import (
    check_output_dir,
    check_output_file,
    read_text_file,
    require_file,
)


def test_read_text_file(tmp_path):
    good = tmp_path / "a.yaml"
    good.write_text("seed: 1\n")
    assert read_text_file(good, "scenario file") == "seed: 1\n"
    (tmp_path / "b.bin").write_bytes(b"\xff\xfe\x00")
    (tmp_path / "nul.txt").write_bytes(b"ab\x00cd")
    for path, words in ((tmp_path / "none.yaml", "not found"), (tmp_path, "not a file"),
                        (tmp_path / "b.bin", "UTF-8"), (tmp_path / "nul.txt", "NUL")):
        with pytest.raises(ConfigError, match=words) as error:
            read_text_file(path, "scenario file")
        assert str(path) in str(error.value) and "scenario file" in str(error.value)


def test_require_file_names_a_missing_file_and_a_folder(tmp_path):
    class ThingError(LegatoError):
        pass

    (tmp_path / "a.pt").write_bytes(b"x")
    assert require_file(tmp_path / "a.pt", "--checkpoint") == tmp_path / "a.pt"
    with pytest.raises(ConfigError, match=r"^--data dataset file not found: .*none\.h5$"):
        require_file(tmp_path / "none.h5", "--data dataset file")
    with pytest.raises(ThingError, match=r"^checkpoint .* is a folder, not a file$"):
        require_file(tmp_path, "checkpoint", ThingError)


def test_output_locations(tmp_path):
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    assert check_output_dir(tmp_path / "new" / "deeper", "--out") == tmp_path / "new" / "deeper"
    assert not (tmp_path / "new").exists()  # nothing is created
    check_output_dir(tmp_path, "--out")
    check_output_file(a_file, "--json")  # an existing file may be replaced (atomically)
    check_output_file(tmp_path / "new" / "r.json", "--json")
    for check, path, words in ((check_output_dir, a_file, "is an existing file"),
                               (check_output_dir, a_file / "sub", "is a file"),
                               (check_output_file, tmp_path, "is a folder"),
                               (check_output_file, a_file / "x" / "r.json", "is a file")):
        with pytest.raises(ConfigError, match=words) as error:
            check(path, "--out")
        assert str(error.value).startswith("--out ")


def test_messages_are_one_line():
    assert one_line("while parsing\n  in 'x', line 2\n    a: [\n       ^\n") == \
        "while parsing; in 'x', line 2; a: ["
    with pytest.raises(yaml.YAMLError) as error:
        yaml.safe_load("a: [1,\nb: 2\n")
    message = yaml_problem(error.value)
    assert message.startswith("not valid YAML: line ") and "\n" not in message
    assert yaml_problem(RuntimeError("two\nlines")) == "two; lines"
