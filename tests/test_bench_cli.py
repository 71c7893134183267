"""``benchmarks.cli`` in its quick mode: every command line is timed, its section is written
once between its markers, and no ``--help`` imports a heavy package (no speed is asserted)."""

from __future__ import annotations

import pytest
from conftest import markdown_rows, quick_run

from benchmarks import cli as bench
from benchmarks import report


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """The document after one quick run over a stale section."""
    return quick_run(bench, tmp_path_factory.mktemp("docs"))[0]


def test_section_written_once(run):
    assert run.count(bench.BEGIN_MARKER) == 1 and "stale" not in run
    assert "Quick mode" in run


def test_every_help_is_timed_and_imports_nothing_heavy(run):
    rows = markdown_rows(run, "### Start-up")[2:]
    labels = [row[0].strip("`") for row in rows]
    assert labels[:2] == ["python -c pass (the interpreter)", "python -c 'import wgbragg'"]
    helps = labels[2:]
    assert helps[0].endswith(" --help") and len(helps) == 1 + len(bench.COMMANDS)
    for command, label in zip(bench.COMMANDS, helps[1:], strict=True):
        assert label.endswith(f" {command} --help")
    for _, median, top, heavy, _ in rows:
        assert 0.0 < report.parse_time(median) <= report.parse_time(top)
        assert heavy == "none"
    # The target applies to the help lines, not to the two for scale.
    assert [row[4] for row in rows[:2]] == [report.NOT_MEASURED] * 2
    assert all(row[4] in ("yes", "no") for row in rows[2:])
