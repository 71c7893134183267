"""Structure and sanity of ``benchmarks.film`` in its quick mode.

No speed or accuracy is asserted (the full run reports the targets): a quick run must cover
every Fourier method and order of its grid, the tables must parse, and the section must
replace (never duplicate) itself between its markers.
"""

from __future__ import annotations

import contextlib
import io

import numpy as np
import pytest
from conftest import bench_section, markdown_table

from benchmarks import film as bench
from benchmarks import report

pytestmark = pytest.mark.gpu

LATER_SECTION = "## A later benchmark\n\n<!-- other:begin -->\nkeep me\n<!-- other:end -->\n"


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Two quick runs into a document with an intro, a stale section and a later section."""
    path = tmp_path_factory.mktemp("docs") / "benchmarks.md"
    stale = f"{bench.BEGIN_MARKER}\nstale numbers\n{bench.END_MARKER}"
    path.write_text(f"# Benchmarks\n\nIntro text.\n\n{stale}\n\n{LATER_SECTION}",
                    encoding="utf-8")
    texts, printed = [], []
    for _ in range(2):
        with contextlib.redirect_stdout(io.StringIO()) as capture:
            assert bench.main(["--quick", "--no-progress", "--output", str(path)]) == 0
        texts.append(path.read_text(encoding="utf-8"))
        printed.append(capture.getvalue())
    return texts, printed[0]


def test_section_replaced_not_duplicated(runs):
    (first, second), printed = runs
    for text in (first, second):
        assert text.count(bench.BEGIN_MARKER) == text.count(bench.END_MARKER) == 1
        assert "stale numbers" not in text
        assert text.startswith("# Benchmarks\n\nIntro text.\n")
        assert text.rstrip().endswith(LATER_SECTION.rstrip())
    assert bench_section(bench, first) in printed
    assert "Quick mode" in bench_section(bench, first)


def test_delta_e_table_has_every_method_and_order(runs):
    (text, _), _ = runs
    rows = markdown_table(bench_section(bench, text), '### dE2000 against "reference"')
    header, body = rows[0], rows[1:]
    assert header == ["method", *[f"base {b}" for b in bench.QUICK.bases], "all"]
    assert [row[0] for row in body] == [bench.label(*key) for key in bench.rows(bench.QUICK)]
    for row in body:
        for cell in row[1:]:
            mean, p95, top = report.parse_stats(cell)
            assert 0.0 <= mean <= top and 0.0 <= p95 <= top, row


def test_white_point_table(runs):
    (text, _), _ = runs
    body = markdown_table(bench_section(bench, text), "### Perfect reflector")[1:]
    verdict = {row[0]: row[2] for row in body}
    assert verdict == {"reference": "yes", "fourier-table": "yes", "fourier-gaussian": "yes",
                       bench.UNCORRECTED: "no"}


def test_gpu_and_timing_tables(runs):
    (text, _), _ = runs
    section = bench_section(bench, text)
    body = markdown_table(section, "### numpy against GPU")[1:]
    assert len(body) == 1 + 2 * len(bench.QUICK.orders)
    assert all(row[-1] == "yes" for row in body)
    body = markdown_table(section, "### Time per colour")[1:]
    assert len(body) == 2 * (1 + 2 * len(bench.QUICK.orders))
    for row in body:
        assert all(report.parse_time(cell) > 0 for cell in row[2:]), row


def test_prefilter_and_targets(runs):
    (text, _), _ = runs
    section = bench_section(bench, text)
    body = markdown_table(section, "### Thickness prefiltering")[1:]
    assert len(body) == 2 * len(bench.QUICK.bases) * len(bench.QUICK.prefilter_std_nm)
    assert all(0.0 <= float(row[3]) <= float(row[4]) for row in body)
    targets = markdown_table(section, "### Targets")[1:]
    assert "mean dE2000 <= 1" in targets[0][0]
    assert all(row[2] in ("yes", "no", "not checked") for row in targets)


def test_brute_force_average_of_a_uniform_film():
    """With no thickness spread the average is the film's own colour."""
    from wgbragg import ThinFilm

    film = ThinFilm(1.5, 400.0)
    theta = np.radians([0.0, 40.0])
    np.testing.assert_allclose(bench.brute_force_xyz(film, theta, 0.0, 8), film.xyz(theta),
                               rtol=1e-12)


def test_default_output(tmp_path):
    args = bench.parse_args(["--quick"])
    assert report.section_output(args) is None
    assert report.section_output(bench.parse_args([])) == report.DEFAULT_OUTPUT
