"""The README's examples run as written: its Python blocks in order (later blocks use the names
of earlier ones, as the README says), and its `wgbragg ...` command lines parse with the CLI's
own parser. Only image sizes and sample counts of the viewer example are made smaller."""

from __future__ import annotations

import re
import shlex
import warnings
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def _fenced_blocks(text: str) -> list[tuple[str, str]]:
    """(language, body) of every fenced block."""
    blocks, language, body = [], None, []
    for line in text.splitlines():
        fence = re.match(r"^```(\w*)\s*$", line)
        if fence is None:
            if language is not None:
                body.append(line)
        elif language is None:
            language, body = fence.group(1), []
        else:
            blocks.append((language, "\n".join(body) + "\n"))
            language = None
    return blocks


BLOCKS = _fenced_blocks(README.read_text(encoding="utf-8"))
PYTHON_BLOCKS = [body for language, body in BLOCKS if language == "python"]
SHELL_BLOCKS = [body for language, body in BLOCKS if language in ("", "sh")]
# The viewer example's 256 x 256 image and 64 samples cost most of a minute on lavapipe; the
# calls are what this test checks.
SHRINK = {"size=(256, 256)": "size=(16, 16)", "v.refine(64)": "v.refine(2)"}


def _commands() -> list[list[str]]:
    """Every complete `wgbragg ...` line of the shell blocks (usage lines with [options] and
    comments left out)."""
    commands = []
    for block in SHELL_BLOCKS:
        for line in block.splitlines():
            line = line.split("#", 1)[0].strip()
            if line.startswith("wgbragg ") and "[" not in line:
                commands.append(shlex.split(line)[1:])
    return commands


def test_the_readme_has_examples():
    assert len(PYTHON_BLOCKS) >= 6 and len(_commands()) >= 8


@pytest.mark.gpu
def test_python_examples_run_in_order(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("WGBRAGG_CACHE", str(tmp_path / "cache"))
    namespace: dict = {"__name__": "readme"}
    for index, block in enumerate(PYTHON_BLOCKS):
        for old, new in SHRINK.items():
            block = block.replace(old, new)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            try:
                exec(compile(block, f"README.md python block {index + 1}", "exec"), namespace)
            except Exception as exc:  # name the block in the failure
                pytest.fail(f"README python block {index + 1} raised {exc!r}:\n{block}")


@pytest.mark.parametrize("argv", _commands(), ids=" ".join)
def test_command_lines_parse(argv):
    from wgbragg.app.cli import build_parser

    build_parser().parse_args(argv)
