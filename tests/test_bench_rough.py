"""Structure and sanity of ``benchmarks.rough`` in its quick mode.

No speed is asserted (timings on shared CI machines are noise; the targets are what the full
run reports). The tests check that one quick run writes its section between its markers,
replacing a stale one and leaving the rest of the document alone, that every table parses
and holds positive, finite numbers for every cell of the quick grid, and that the targets of
the issue are listed.
"""

from __future__ import annotations

import contextlib
import io
import math

import pytest
from conftest import bench_section, markdown_rows

from benchmarks import report
from benchmarks import rough as bench

LATER_SECTION = "## A later benchmark\n\n<!-- other:begin -->\nkeep me\n<!-- other:end -->\n"


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """One quick run into a document holding an intro, a stale bench_rough section and a later
    section. Returns (path, document after the run, what the run printed)."""
    path = tmp_path_factory.mktemp("docs") / "benchmarks.md"
    stale = f"{bench.BEGIN_MARKER}\nstale numbers\n{bench.END_MARKER}"
    path.write_text(f"# Benchmarks\n\nIntro text.\n\n{stale}\n\n{LATER_SECTION}",
                    encoding="utf-8")
    with contextlib.redirect_stdout(io.StringIO()) as capture:
        status = bench.main(["--quick", "--no-progress", "--output", str(path)])
    assert status == 0
    return path, path.read_text(encoding="utf-8"), capture.getvalue()


def _table(section: str, heading: str) -> list[dict[str, str]]:
    """The first markdown table after the line starting with ``heading``, as one dict per
    row keyed by the header cells."""
    header, rule, *body = markdown_rows(section, heading)
    assert set("".join(rule)) == {"-"}
    assert all(len(row) == len(header) for row in body), heading
    return [dict(zip(header, row, strict=True)) for row in body]


def _positive_time(bench, text: str) -> float:
    seconds = report.parse_time(text)
    assert math.isfinite(seconds) and seconds > 0.0, text
    return seconds


# --------------------------------------------------------------------------- the document


@pytest.mark.gpu
def test_section_replaces_the_stale_one(run):
    path, text, _ = run
    assert text.count(bench.BEGIN_MARKER) == 1
    assert text.count(bench.END_MARKER) == 1
    assert "stale numbers" not in text
    assert text.startswith("# Benchmarks\n\nIntro text.\n\n" + bench.BEGIN_MARKER)
    assert text.rstrip().endswith(LATER_SECTION.rstrip())
    assert text.count("## Rough Bragg layers") == 1
    # Writing the same section again changes nothing: replaced, never appended.
    section = bench_section(bench, text)
    report.write_section(path, section, bench.BEGIN_MARKER, bench.END_MARKER)
    assert path.read_text(encoding="utf-8") == text
    assert [p.name for p in path.parent.iterdir()] == [path.name]  # no temporary files left


@pytest.mark.gpu
def test_section_printed_and_headed(run):
    _, text, printed = run
    section = bench_section(bench, text)
    assert section in printed
    from wgbragg import gpu

    assert gpu.adapter_info()["name"] in section
    assert "Quick mode" in section
    assert "- Command: `python -m benchmarks.rough --quick --no-progress --output" in section
    assert "- Other processes on the machine during the run: " in section
    assert "- CPU: " in section and "cores available" in section


# --------------------------------------------------------------------------- the tables


@pytest.mark.gpu
def test_bake_table(run):
    _, text, _ = run
    rows = _table(bench_section(bench, text), "### F_")
    cfg = bench.QUICK
    assert [float(row[bench.ALPHA]) for row in rows] == list(cfg.alphas)
    for row in rows:
        n_i, n_d = (int(v) for v in row[f"n_i {report.TIMES} n_d"].split(report.TIMES))
        assert n_i == round(90 / cfg.resolution_deg) + 1 and n_d > 0
        times = [_positive_time(bench, cell) for header, cell in row.items()
                 if "wall clock" in header]
        assert len(times) == 3  # GPU, numpy, LUT load
        assert report.parse_ratio(row["numpy / GPU"]) > 0


@pytest.mark.gpu
def test_transmissivity_table(run):
    _, text, _ = run
    rows = _table(bench_section(bench, text), "### Integrated transmissivity")
    cfg = bench.QUICK
    expected = [(layer.label, bench.grid_label(step)) for layer in bench.layers(cfg)
                for step in cfg.steps_nm]
    assert [(row["layer"], row["λ grid"]) for row in rows] == expected
    assert len(rows) == len(cfg.layer_alphas) * len(cfg.counts) * len(cfg.steps_nm)
    for row, step in zip(rows, [s for _ in bench.layers(cfg) for s in cfg.steps_nm],
                         strict=True):
        shape = row[f"n_i {report.TIMES} n_λ"].split(report.TIMES)
        assert int(shape[1]) == bench.wavelength_count(step)
        kernels = [_positive_time(bench, row[h]) for h in
                   ("GPU kernel: T = 1 - R pass", "GPU kernel: product pass")]
        assert _positive_time(bench, row["GPU kernel: sum"]) > 0
        assert max(kernels) <= _positive_time(bench, row["GPU kernel: sum"]) * (1 + 1e-2)
        _positive_time(bench, row["GPU f32, end-to-end wall"])
        _positive_time(bench, row["numpy f64, wall"])
        _positive_time(bench, row["numpy f64: product alone, wall"])
        difference = float(row["max abs(GPU - numpy)"])
        assert math.isfinite(difference) and difference >= 0.0
    assert {bench.wavelength_count(s) for s in cfg.steps_nm} == {471, 95}


@pytest.mark.gpu
def test_rgb_table(run):
    _, text, _ = run
    rows = _table(bench_section(bench, text), "### `transmissivity_rgb`")
    assert [row["layer"] for row in rows] == [layer.label for layer in bench.layers(bench.QUICK)]
    for row in rows:
        _positive_time(bench, row["GPU f32"])
        _positive_time(bench, row["numpy f64"])


@pytest.mark.gpu
def test_size_tables(run):
    _, text, _ = run
    section = bench_section(bench, text)
    rows = _table(section, "### Table sizes")
    for row in rows:
        n_i, n_cols = (int(v) for v in row["shape"].split(report.TIMES))
        # 3 significant digits of 4 bytes per float32 entry.
        assert report.parse_bytes(row["float32"]) == pytest.approx(4 * n_i * n_cols, rel=5e-3)
    papers = {row["paper (sec. 4.2.2)"] for row in rows}
    assert {report.parse_bytes(p) for p in papers} == {1.4e6, 620e3}
    files = _table(section, "### LUT files")
    assert [float(row[bench.ALPHA]) for row in files] == list(bench.QUICK.alphas)
    for row in files:
        assert report.parse_bytes(row["file"]) > 0


@pytest.mark.gpu
def test_targets_listed(run):
    _, text, _ = run
    rows = _table(bench_section(bench, text), "### Targets")
    targets = [row["target"] for row in rows]
    assert any(t.startswith(f"F_{bench.ALPHA} bake on the GPU <= 250 ms") for t in targets)
    for step in bench.QUICK.steps_nm:
        grid = bench.grid_label(step)
        for what in ("GPU kernel time", "GPU end-to-end"):
            assert any("<= 20.0 ms" in t and what in t and t.endswith(grid) for t in targets)
    for row in rows:
        assert row["met"] in ("yes", "no")
        _positive_time(bench, row["measured"].split("(")[0].removeprefix("worst").strip())


# --------------------------------------------------------------------------- helpers


@pytest.mark.parametrize("size", [3.0, 999.7, 10_900.0, 519_840.0, 1.4e6, 2_086_939.0])
def test_bytes_round_trip(size):
    assert report.parse_bytes(report.human_bytes(size)) == pytest.approx(size, rel=5e-3)


def test_bytes_format():
    assert report.human_bytes(519_840) == "520 KB"
    assert report.human_bytes(1.4e6) == "1.40 MB"
    assert report.human_bytes(999_700) == "1.00 MB"
    assert report.parse_bytes("≈ 620 KB") == 620e3


def test_wavelength_grids():
    assert bench.wavelengths(1.0) is None  # the library's default 1 nm grid
    grid = bench.wavelengths(5.0)
    assert grid.size == 95 and grid[0] == 360.0 and grid[-1] == 830.0
    assert bench.wavelength_count(1.0) == 471


def test_configs_match_the_issue():
    full, quick = bench.FULL, bench.QUICK
    assert full.alphas == (0.01, 0.05, 0.1, 0.4, 1.0)
    assert (full.resolution_deg, full.psi_samples) == (0.25, 1000)
    assert full.counts == (5, 100) and full.layer_alphas == (0.05, 0.4)
    assert quick.alphas == (0.3,) and quick.counts == (5,) and quick.passes == 2
    assert (quick.resolution_deg, quick.psi_samples) == (5.0, 32)


def test_output_path(tmp_path):
    def where(*argv):
        return bench.output_path(bench.parse_args(list(argv)))

    assert where("--quick") is None  # quick mode never writes docs/ by default
    assert where() == report.DEFAULT_OUTPUT
    assert report.DEFAULT_OUTPUT.parts[-2:] == ("docs", "benchmarks.md")
    assert where("--no-write") is None
    assert where("--quick", "--output", str(tmp_path / "b.md")) == tmp_path / "b.md"
    with pytest.raises(SystemExit):
        where("--output", "x.md", "--no-write")
