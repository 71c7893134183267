"""``benchmarks.denoise`` in its quick mode: it runs every part, writes its section between its
markers, and every table holds a row per preset (and spp) with numbers in range (no speed or
quality is asserted: the quick reference is too noisy for that)."""

from __future__ import annotations

import pytest
from conftest import markdown_rows, quick_run

from benchmarks import denoise as bench
from benchmarks.report import parse_ratio, parse_time

pytestmark = pytest.mark.gpu


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """The document after one quick run over a stale section."""
    return quick_run(bench, tmp_path_factory.mktemp("docs"))[0]


def _rows(text: str, heading: str) -> list[list[str]]:
    return markdown_rows(text, heading)[2:]


def test_section_written_once(run):
    assert run.count(bench.BEGIN_MARKER) == 1 and "stale" not in run
    assert "Quick mode" in run


def test_every_preset_and_spp_measured(run):
    errors = _rows(run, "### Error against the reference")
    spps = [str(spp) for spp in bench.QUICK.spps]
    assert [(row[0], row[2]) for row in errors] == [
        (name, spp) for name in bench.PRESETS for spp in spps]
    for _, mode, _, raw, denoised, ratio in errors:
        assert mode in ("rgb", "spectral")
        assert 0.0 < float(raw) < 1.0 and 0.0 < float(denoised) < 1.0
        assert parse_ratio(ratio) > 0.0
    matches = _rows(run, "### Effective speed-up")
    assert [row[0] for row in matches] == list(bench.PRESETS)
    for row in matches:
        assert 0.0 < float(row[1]) < 1.0
        assert row[2].split()[0].lstrip(">").strip()  # a number of spp, or "> N"
    hues = _rows(run, "### Hue")
    assert [(row[0], row[1]) for row in hues] == [
        (name, spp) for name in bench.PRESETS for spp in spps]
    for row in hues:
        assert float(row[2]) >= 0.0 and float(row[3]) >= 0.0
        assert 0.0 <= float(row[4].removesuffix(" %")) <= 100.0
        assert row[5].strip("()") in ("yes", "no")
    timings = _rows(run, "### Denoise time per frame")
    assert len(timings) == 1 + 2 * len(bench.QUICK.timing_sizes)
    assert all(parse_time(row[2]) > 0.0 for row in timings)


def testmatching_spp_interpolates_between_the_bracketing_samples():
    errors = {4: 0.4, 8: 0.2, 16: 0.1, 32: 0.05}  # error ~ 1 / spp
    spp, low, high = bench.matching_spp(errors, 0.15)
    assert (low, high) == (8, 16) and spp == pytest.approx(8 * 0.2 / 0.15)
    assert bench.matching_spp(errors, 0.5) == (4.0, 4, 4)
    assert bench.matching_spp(errors, 0.01) == (None, 32, 32)
