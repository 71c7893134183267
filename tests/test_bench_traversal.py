"""``benchmarks.traversal`` in its quick mode: both sides the working tree, in two processes;
the section is written once, with a row per scene and measure, and the two sides' camera
rays hit the same faces (no speed is asserted)."""

from __future__ import annotations

import pytest
from conftest import markdown_table, quick_run

from benchmarks import report
from benchmarks import traversal as bench

pytestmark = pytest.mark.gpu


def test_quick_section(tmp_path):
    text, _ = quick_run(bench, tmp_path)
    assert text.count(bench.BEGIN_MARKER) == 1 and "stale" not in text
    assert "Quick mode" in text
    rows = markdown_table(text, "### Time per sample")[1:]
    assert [row[:2] for row in rows] == [
        [scene, what] for scene in bench.SCENES
        for what in ("CPU time / sample", "wall time / sample")]
    for row in rows:
        assert report.parse_time(row[2]) > 0 and report.parse_time(row[3]) > 0
    assert [row[5] for row in rows[1::2]] == ["0 / 0 of 256"] * len(bench.SCENES)
