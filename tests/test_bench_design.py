"""Structure and sanity of ``benchmarks.design`` in its quick mode: every table is there and
parses, rates are fractions of the fits run, the tmm generator agrees with the numpy twin, and
the section replaces (never duplicates) itself between its markers. No speed is asserted."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import bench_section, markdown_table, quick_run

from benchmarks import design as bench
from benchmarks import report

pytestmark = pytest.mark.gpu


@pytest.fixture(scope="module")
def section(tmp_path_factory):
    text = quick_run(bench, tmp_path_factory.mktemp("docs"))[0]
    assert text.count(bench.BEGIN_MARKER) == 1 and "stale" not in text
    return bench_section(bench, text)


def test_recovery_table(section):
    rows = markdown_table(section, "### Parameter recovery")
    assert rows[0] == ["search", "structures", "success", "median time",
                       "median spectra evaluated"]
    searches = {row[0] for row in rows[1:]}
    assert searches == {"DE, GPU global stage", "DE, numpy global stage",
                        "CMA-ES, GPU global stage"}
    for row in rows[1:]:
        done, total = (int(v) for v in row[2].split("/"))
        assert 0 <= done <= total
        assert report.parse_time(row[3]) > 0


def test_baseline_and_colour_tables(section):
    rows = markdown_table(section, "### Against the float64 numpy search")[1:]
    assert len(rows) == 3 and rows[0][2] == "1"
    assert all(report.parse_time(row[1]) > 0 for row in rows)
    colour = markdown_table(section, "### Colour design")[1:]
    assert [row[1] for row in colour] == ['"averaged"', '"grid"']
    assert all(row[2].endswith("%") for row in colour)
    methods = markdown_table(section, "### Search colour methods")
    assert [row[0] for row in methods[1:]] == [
        "averaged, GPU population kernel", "grid (2 nm), GPU population kernel",
        "averaged, float64 numpy twin"]
    for row in methods[1:]:
        assert report.parse_time(row[1]) > 0
        mean, p95, worst = (float(v) for v in row[3:])
        assert 0 <= mean <= p95 <= worst < 2.0  # dE2000 to the reference colour
    # The float32 population kernel and its float64 twin colour alike.
    assert abs(float(methods[1][3]) - float(methods[3][3])) < 0.01
    robust = markdown_table(section, "### Robust design")[1:]
    assert [row[1] for row in robust] == ["plain", "robust"]
    assert all(float(row[3]) > 0 and report.parse_time(row[4]) > 0 for row in robust)
    assert "Quick mode" in section
    agreement = float(section.split("max |ΔR| = ")[1].split(".\n")[0].rstrip("."))
    assert agreement < 1e-10


def test_tmm_generator_matches_the_public_reflectance():
    from wgbragg import BraggMirror, ThinFilm

    theta = np.radians([0.0, 50.0])
    wavelength = np.array([420.0, 555.0, 700.0])
    for structure in (BraggMirror(1.59, 1.67, 81.6, 78.4, 8, host=1.0),
                      ThinFilm(1.4, 333.0, base="Au")):
        np.testing.assert_allclose(bench.tmm_spectrum(structure, wavelength, theta),
                                   structure.reflectance(wavelength[:, None], theta),
                                   atol=1e-10)
