"""``benchmarks.viewer`` in its quick mode: every budget is measured through the viewer,
its section is written once between its markers, and the tables hold what they say (no speed
is asserted)."""

from __future__ import annotations

import pytest
from conftest import markdown_rows, quick_run

from benchmarks import report
from benchmarks import viewer as bench

pytestmark = pytest.mark.gpu


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """The document after one quick run over a stale section."""
    return quick_run(bench, tmp_path_factory.mktemp("docs"))[0]


def _rows(text: str, heading: str) -> list[list[str]]:
    return markdown_rows(text, heading)[2:]


def _seconds(cell: str) -> float:
    return report.parse_time(cell)


def test_section_written_once(run):
    text = run
    assert text.count(bench.BEGIN_MARKER) == 1 and "stale" not in text
    assert "Quick mode" in text


def test_bragg_edits_rebake_tables_in_both_modes(run):
    text = run
    rows = _rows(text, "### Tables re-baked")
    assert [row[0] for row in rows] == list(bench.MODES)
    for _, edits, *times in rows:
        assert int(edits) == bench.QUICK.edits
        table_median, table_max, update_median, update_max = (_seconds(t) for t in times)
        assert 0.0 < table_median <= table_max
        assert table_median <= update_median <= update_max


def test_roughness_edit_bakes_then_finds_its_filter(run):
    text = run
    rows = _rows(text, "### Transmission filter")
    assert [row[:2] for row in rows] == [[f"{bench.FRESH_ALPHA:g}", "baked"],
                                         [f"{bench.FRESH_ALPHA:g}", "in memory"]]
    assert all(_seconds(row[2]) > 0 for row in rows)


def test_edits_that_change_the_kernel_are_timed(run):
    text = run
    rows = _rows(text, "### Edits that change the kernel")
    assert [row[0] for row in rows] == [
        "first frame of the session", "first frame of an interaction (rasterized)",
        "3 Bragg layers instead of 2", "spectral mode", "a thin film instead of the Bragg layers"]
    assert all(_seconds(row[1]) > 0 for row in rows)


def test_frame_rates_before_and_after_at_each_size(run):
    rows = markdown_rows(run, "### Frames per second")
    assert rows[0][1:] == [f"{side} x {side}" for side in bench.QUICK.fps_sizes]
    assert [row[0].split(":")[0] for row in rows[2:]] == [
        "interacting, before", "interacting, after", "at rest"]
    assert all(float(cell) > 0 for row in rows[2:] for cell in row[1:])


def test_preview_and_targets(run):
    text = run
    previews = _rows(text, "### Path-traced preview")
    assert [row[0] for row in previews] == ["teapot, spectral mode"]
    for _, *cells in previews:
        for fps, scale in (cells[:2], cells[2:]):
            assert float(fps) > 0 and int(scale) in (1, 2, 4, 8)
    assert previews[0][2] == "2"  # nothing measured before the first interaction
    targets = _rows(text, "### Targets")
    assert len(targets) == 5 and all(row[2] in ("yes", "no") for row in targets)
    # The rasterized targets are the issue's, at sizes the quick run does not measure.
    assert [row[0] for row in targets[2:4]] == [
        f"rasterized teapot at {side} x {side} >= {fps:g} frames/s"
        for side, fps in bench.RASTER_TARGETS.items()]
    assert all(row[1:] == ["not measured", "no"] for row in targets[2:4])
