"""The docs name only flags that the command line has: every ``legato-drake VERB ... --flag``
in README.md and docs/ (code blocks and inline code) is checked against ``cli.build_parser``."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import pytest

from legato_drake.cli import build_parser

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md")),
        ROOT / "checkpoints" / "README.md"]
COMMAND = re.compile(r"legato-drake\s+([a-z][a-z-]*)(.*)")
FLAG = re.compile(r"(?<![\w-])(--[a-z][a-z0-9-]*)")


def commands(text: str) -> list[tuple[int, str, str]]:
    """(line, verb, the rest of the command) of every ``legato-drake VERB`` in code: fenced
    blocks line by line (``\\``-continued lines joined), inline code spans whole."""
    found = []
    fence = re.compile(r"^```[^\n]*\n(.*?)^```", re.S | re.M)
    for block in fence.finditer(text):
        start = text.count("\n", 0, block.start(1)) + 1
        lines = block.group(1).split("\n")
        i = 0
        while i < len(lines):
            line, first = lines[i], i
            while line.rstrip().endswith("\\") and i + 1 < len(lines):
                i += 1
                line = line.rstrip()[:-1] + " " + lines[i]
            for match in COMMAND.finditer(line):
                found.append((start + first, match.group(1), match.group(2)))
            i += 1
    prose = fence.sub(lambda m: "\n" * m.group(0).count("\n"), text)
    for span in re.finditer(r"`([^`]+)`", prose):
        for match in COMMAND.finditer(span.group(1).replace("\n", " ")):
            found.append((prose.count("\n", 0, span.start()) + 1, match.group(1),
                          match.group(2)))
    return found


def subcommands() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def test_the_finder_reads_blocks_continuations_and_inline_code():
    text = ("Run `legato-drake select --run R\n--task lid` then\n\n```bash\n"
            "legato-drake train --config c.yaml \\\n    --out runs/x   # --resume\n```\n")
    assert commands(text) == [(5, "train", " --config c.yaml      --out runs/x   # --resume"),
                              (1, "select", " --run R --task lid")]


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_documented_flags_exist(doc):
    verbs = subcommands()
    problems = []
    for line, verb, rest in commands(doc.read_text()):
        if verb not in verbs:
            problems.append(f"{doc.name}:{line}: no subcommand {verb!r}")
            continue
        known = verbs[verb]._option_string_actions
        problems += [f"{doc.name}:{line}: legato-drake {verb} has no {flag}"
                     for flag in FLAG.findall(rest) if flag not in known]
    assert not problems, "\n".join(problems)
