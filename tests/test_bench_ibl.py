"""Structure and sanity of ``benchmarks.ibl`` in its quick mode (numpy only, a few seconds).

A quick run must report every material, roughness and mode with finite errors, replace (never
duplicate) its section between its markers, draw its three figures, and show Kneiphof's filter
beating the split sum on the films at alpha >= 0.25 (true on the quick grid and on the full one:
docs/benchmarks.md).
"""

from __future__ import annotations

import contextlib
import io
import math

import pytest
from conftest import bench_section, markdown_table
from PIL import Image

from benchmarks import ibl as bench
from benchmarks import report

LATER_SECTION = "## A later benchmark\n\n<!-- other:begin -->\nkeep me\n<!-- other:end -->\n"


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """One quick run into a document with an intro, a stale section and a later section."""
    folder = tmp_path_factory.mktemp("bench_ibl")
    path = folder / "benchmarks.md"
    stale = f"{bench.BEGIN_MARKER}\nstale numbers\n{bench.END_MARKER}"
    path.write_text(f"# Benchmarks\n\nIntro text.\n\n{stale}\n\n{LATER_SECTION}",
                    encoding="utf-8")
    with contextlib.redirect_stdout(io.StringIO()) as capture:
        assert bench.main(["--quick", "--no-progress", "--output", str(path),
                           "--figures", str(folder / "figures")]) == 0
    return path.read_text(encoding="utf-8"), capture.getvalue(), folder / "figures"


def _errors(bench, text):
    """(material, alpha, mode) -> (mean dE, max dE, SMAPE) parsed from the section."""
    rows = markdown_table(bench_section(bench, text), "### CIE dE2000")
    out = {}
    for row in rows[1:]:
        material, alpha = row[0], float(row[1])
        for k, mode in enumerate(bench.MODES):
            mean, top = bench.parse_cell(row[2 + 2 * k])
            out[material, alpha, mode] = (mean, top, float(row[3 + 2 * k]))
    return out


def test_section_replaced_and_headed(run):
    text, printed, _ = run
    assert text.count(bench.BEGIN_MARKER) == text.count(bench.END_MARKER) == 1
    assert "stale numbers" not in text
    assert text.startswith("# Benchmarks\n\nIntro text.\n")
    # Kept whole; the rendered comparison's own section, new to this document, follows it.
    assert LATER_SECTION.rstrip() in text
    section = bench_section(bench, text)
    assert section in printed
    assert f"## {bench.HEADING}" in section
    assert "IBL modes under uniform light (Kneiphof Fig. 7 analog)" in section
    assert "Quick mode" in section


def test_every_case_is_reported_with_finite_errors(run):
    errors = _errors(bench, run[0])
    materials = [*bench.QUICK.bases, bench.BRAGG]
    assert set(errors) == {(m, a, mode) for m in materials for a in bench.QUICK.alphas
                           for mode in bench.MODES}
    for key, (mean, top, smape) in errors.items():
        assert all(math.isfinite(v) for v in (mean, top, smape)), key
        assert 0.0 <= mean <= top and 0.0 <= smape <= 1.0, key


def test_kneiphof_beats_the_split_sum_on_films_when_rough(run):
    """Issue 9's target, on the films: lower mean dE2000 and lower SMAPE at alpha >= 0.25."""
    errors = _errors(bench, run[0])
    for base in bench.QUICK.bases:
        for alpha in (a for a in bench.QUICK.alphas if a >= 0.25):
            split, filtered = errors[base, alpha, "split-sum"], errors[base, alpha, "kneiphof"]
            assert filtered[0] < split[0] and filtered[2] < split[2], (base, alpha)
    verdicts = markdown_table(bench_section(bench, run[0]), "### Does kneiphof beat")[1:]
    assert all(row[2] in ("yes", "no") for row in verdicts)
    assert all(row[2] == "yes" for row in verdicts if row[0] in bench.QUICK.bases)


def test_floor_and_table_error_are_reported(run):
    section = bench_section(bench, run[0])
    rows = markdown_table(section, "### Floor")[1:]
    assert [row[0] for row in rows] == [*bench.QUICK.bases, bench.BRAGG]
    assert all(bench.parse_cell(row[1])[0] >= 0.0 for row in rows)
    assert "max dE2000 = " in section


def test_figures_are_written(run):
    folder = run[2]
    names = sorted(p.name for p in folder.glob("*.png"))
    assert names == ["ibl_bragg_alpha.png", "ibl_film_alpha.png", "ibl_film_thickness.png"]
    for name in names:
        with Image.open(folder / name) as image:
            assert image.size[0] > 100 and image.size[1] > 100


def test_colour_table_and_lobe():
    """The spline table reproduces its nodes; a grey material reflects E times its grey."""
    import numpy as np

    from wgbragg import ThinFilm
    from wgbragg.lighting.ibl import microfacet_albedo

    material = ThinFilm(1.33, 400.0, n_base=2.0)
    table = bench.ColourTable(material, 64)
    nodes = np.linspace(0.0, 0.5 * np.pi, 64)
    np.testing.assert_allclose(table(nodes), material.rgb(nodes, "reference"), atol=1e-12)
    assert table.max_error < 2e-2 and table.max_delta_e < 2.0
    theta = np.radians([0.0, 45.0, 85.0])
    lobe = bench.Lobe.at(theta, 0.3, 16)
    grey = lobe.reference(lambda t: np.full((*t.shape, 3), 0.5))
    np.testing.assert_allclose(grey[:, 0], 0.5 * microfacet_albedo(np.cos(theta), 0.3, 16),
                               rtol=1e-12)


def test_default_outputs():
    quick = bench.parse_args(["--quick"])
    assert report.section_output(quick) is None
    assert bench.figures_folder(quick) is None
    full = bench.parse_args([])
    assert report.section_output(full) == report.DEFAULT_OUTPUT
    assert bench.figures_folder(full) == bench.DEFAULT_FIGURES


def test_rendered_spheres_section(run):
    """The renderer's modes against its path tracer: every case with finite errors and frame
    times, under its own markers."""
    text, printed, _ = run
    assert text.count(bench.RENDER_BEGIN) == text.count(bench.RENDER_END) == 1
    start = text.index(bench.RENDER_BEGIN)
    section = text[start:text.index(bench.RENDER_END) + len(bench.RENDER_END)]
    assert section in printed
    cases = [(e, m, a) for e in bench.RENDER_QUICK.environments
             for m in bench.RENDER_QUICK.materials for a in bench.RENDER_QUICK.alphas]
    errors = markdown_table(section, "### SMAPE and mean dE2000")[1:]
    assert [(row[0], row[1], float(row[2])) for row in errors] == cases
    for row in errors:
        values = [float(cell) for cell in row[3:7]]
        assert all(math.isfinite(v) and v >= 0.0 for v in values), row
        assert row[7] in ("yes", "no")
    times = markdown_table(section, "### Time per 1-spp frame")[1:]
    assert len(times) == len(cases)
    for row in times:
        assert all(report.parse_time(cell) > 0 for cell in (*row[3:6], *row[7:9])), row
    assert markdown_table(section, "### Target")[1][1] in ("yes", "no")
