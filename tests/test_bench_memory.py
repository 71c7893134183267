"""``benchmarks.memory`` in its quick mode: it measures a 1e6-point reflectance call on each
backend in a subprocess, writes its section between its markers once, and every row holds a
peak RSS of at least the call's output (no bound on memory or speed is asserted: the full run
reports them)."""

from __future__ import annotations

import pytest
from conftest import markdown_table, quick_run

from benchmarks import memory as bench
from benchmarks import report

pytestmark = pytest.mark.gpu


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """The document after one quick run over a stale section."""
    return quick_run(bench, tmp_path_factory.mktemp("docs"))[0]


def test_section_written_once(run):
    assert run.count(bench.BEGIN_MARKER) == 1 and run.count(bench.END_MARKER) == 1
    assert "stale" not in run and "Quick mode" in run


def test_each_backend_measured_at_a_million_points(run):
    rows = markdown_table(run, "### Peak RSS")
    assert rows[0][:4] == ["backend", "points", "grid", "ended"]
    body = rows[1:]
    assert [row[0] for row in body] == ["numpy", "gpu"]
    for _, points, grid, ended, seconds, peak, before, growth, output, per_point in body:
        assert (points, grid, ended) == ("1e6", "1000 x 1000", "ok")
        assert report.parse_time(seconds) > 0.0
        assert report.parse_bytes(output) == 8e6
        # The child held at least its inputs before the call, and the output after it.
        assert report.parse_bytes(peak) >= report.parse_bytes(before) > 0
        assert report.parse_bytes(growth) >= 0.99 * 4e6  # float32 readback or float64 output
        assert float(per_point.split()[0]) == pytest.approx(
            report.parse_bytes(growth) / 1e6, rel=0.01)


def test_a_call_past_its_cap_is_killed_and_still_reports_its_peak():
    measured = bench.measure_call("numpy", 1000, 1000, cap_seconds=0.3)
    assert measured.status.startswith("timed out")
    assert measured.peak > 0
