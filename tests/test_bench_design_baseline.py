"""Structure and sanity of ``benchmarks.design_baseline`` in its quick mode: the table parses,
both fits recover the film, both saw spectra, and the section replaces itself between its
markers. No speed is asserted."""

from __future__ import annotations

import pytest
from conftest import bench_section, markdown_table, quick_run

from benchmarks import design_baseline as bench
from benchmarks import report

pytestmark = pytest.mark.gpu


def test_quick_run_fits_with_both_and_reports_the_ratio(tmp_path):
    text = quick_run(bench, tmp_path)[0]
    assert text.count(bench.BEGIN_MARKER) == 1 and "stale" not in text
    section = bench_section(bench, text)
    rows = markdown_table(section, "- Success:")
    assert rows[0] == ["case", "wgbragg recovered", "wgbragg time", "spectra",
                       "tmm + scipy recovered", "tmm + scipy time", "spectra", "time ratio"]
    (row,) = rows[1:]
    assert row[0] == "17 (film on glass)"
    assert row[1] == row[4] == "yes"  # a noisy film, recovered by both searches
    assert report.parse_time(row[2]) > 0 and report.parse_time(row[5]) > 0
    assert int(row[3].replace(",", "")) > 0 and int(row[6].replace(",", "")) > 0
    assert "Recovered: wgbragg 1/1, tmm + scipy 1/1" in section
    assert "Quick mode" in section
