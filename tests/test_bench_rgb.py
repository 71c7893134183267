"""Structure and sanity of ``benchmarks.rgb`` in its quick mode.

No speed or accuracy is asserted (timings on shared CI machines are noise, and the accuracy
targets are what the full run reports). The tests check that a quick run covers every colour
method and every GPU kernel the library declares at run time, that the tables parse, that the
section replaces (never duplicates) itself between its markers, and that the plot is a PNG.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import math

import numpy as np
import pytest
from conftest import bench_section, markdown_table
from PIL import Image

from benchmarks import report
from benchmarks import rgb as bench

pytestmark = pytest.mark.gpu

LATER_SECTION = "## A later benchmark\n\n<!-- other:begin -->\nkeep me\n<!-- other:end -->\n"


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Two quick runs into a document that holds an intro, a stale bench_rgb section and a
    later section. Returns (documents after each run, first run's stdout, plot path)."""
    folder = tmp_path_factory.mktemp("docs")
    path = folder / "benchmarks.md"
    stale = f"{bench.BEGIN_MARKER}\nstale numbers\n{bench.END_MARKER}"
    path.write_text(f"# Benchmarks\n\nIntro text.\n\n{stale}\n\n{LATER_SECTION}",
                    encoding="utf-8")
    plot = folder / "plots" / "tradeoff.png"
    texts, printed = [], []
    for _ in range(2):
        with contextlib.redirect_stdout(io.StringIO()) as capture:
            status = bench.main(["--quick", "--no-progress", "--output", str(path),
                                 "--plot", str(plot)])
        assert status == 0
        texts.append(path.read_text(encoding="utf-8"))
        printed.append(capture.getvalue())
    return texts, printed[0], plot


def _methods():
    from wgbragg.colour.methods import COLOUR_METHODS, GPU_COLOUR_METHODS

    return list(COLOUR_METHODS), tuple(GPU_COLOUR_METHODS)


# --------------------------------------------------------------------------- the document


def test_section_replaced_not_duplicated(runs):
    (first, second), _, _ = runs
    for text in (first, second):
        assert text.count(bench.BEGIN_MARKER) == 1
        assert text.count(bench.END_MARKER) == 1
        assert "stale numbers" not in text
        assert text.startswith("# Benchmarks\n\nIntro text.\n")
        assert text.rstrip().endswith(LATER_SECTION.rstrip())
        assert text.count("## Colour methods: speed and accuracy") == 1
    outside = [t.replace(bench_section(bench, t), "") for t in (first, second)]
    assert outside[0] == outside[1]


def test_section_printed(runs):
    (first, _), printed, _ = runs
    assert bench_section(bench, first) in printed


def test_header_facts(runs):
    (text, _), _, _ = runs
    section = bench_section(bench, text)
    from wgbragg import gpu

    assert gpu.adapter_info()["name"] in section
    assert "Quick mode" in section
    assert "Command: `python -m benchmarks.rgb --quick --no-progress --output" in section
    _, gpu_methods = _methods()
    assert f"run time): {', '.join(gpu_methods)}." in section


# --------------------------------------------------------------------------- the tables


def _assert_stats_rows(bench, body, methods):
    """One row per method, in order, each cell a consistent mean / p95 / max."""
    assert [row[0] for row in body] == [bench.method_label(m) for m in methods]
    for row in body:
        for cell in row[1:]:
            mean, p95, top = report.parse_stats(cell)
            assert 0.0 <= mean <= top and 0.0 <= p95 <= top, row


def test_time_table_has_every_method(runs):
    (text, _), _, _ = runs
    rows = markdown_table(bench_section(bench, text), "### Time per colour")
    header, body = rows[0], rows[1:]
    assert header[-1] == "all" and len(header) == 2 + len(bench.QUICK.periods_nm) + 1
    methods, gpu_methods = _methods()
    labels = {(row[0], row[1]) for row in body}
    for method in methods:
        assert (bench.method_label(method), bench.TIMING_LABELS[bench.NUMPY]) in labels, method
    for method in gpu_methods:
        assert (bench.method_label(method), bench.TIMING_LABELS[bench.GPU_WALL]) in labels
    for row in body:
        for cell in row[2:]:
            seconds = report.parse_time(cell)
            assert math.isfinite(seconds) and seconds > 0, row


def test_speedup_table_parses(runs):
    (text, _), _, _ = runs
    rows = markdown_table(bench_section(bench, text), "### Speed-up over")
    body = rows[1:]
    measured = [row for row in body if not row[0].startswith("paper")]
    for row in measured:
        ratios = [report.parse_ratio(cell) for cell in row[2:]]
        assert all(math.isfinite(r) and r > 0 for r in ratios), row
        if row[0] == "reference":
            assert ratios == [1.0] * len(ratios)
    papers = [row for row in body if row[0].startswith("paper")]
    assert len(papers) == len(bench.PAPER_TABLE1)


def test_delta_e_table_has_every_method(runs):
    (text, _), _, _ = runs
    rows = markdown_table(bench_section(bench, text), "### dE2000 against")
    header, body = rows[0], rows[1:]
    assert header[1:] == [f"N = {n}" for n in bench.QUICK.counts] + ["N ≥ 10", "all N"]
    methods, _ = _methods()
    _assert_stats_rows(bench, body, methods)
    reference = body[methods.index("reference")]
    assert report.parse_stats(reference[-1]) == (0.0, 0.0, 0.0)


def test_gpu_agreement_table(runs):
    (text, _), _, _ = runs
    body = markdown_table(bench_section(bench, text), "### numpy against GPU")[1:]
    methods, gpu_methods = _methods()
    assert [row[0] for row in body] == [bench.method_label(m) for m in methods]
    for method, row in zip(methods, body, strict=True):
        assert len(row) == len(bench.QUICK.counts) + 4
        if method in gpu_methods:
            assert all(float(cell) >= 0.0 for cell in row[1:-1]) and row[-1] in ("yes", "no")
        else:
            assert row[1] == "no GPU kernel yet" and row[-1] == "not checked"


def test_converged_table(runs):
    """The check of the reference itself: every method, reference included, against the
    converged integral."""
    (text, _), _, _ = runs
    section = bench_section(bench, text)
    body = markdown_table(section, "### dE2000 against the converged integral")[1:]
    methods, _ = _methods()
    _assert_stats_rows(bench, body, methods)


def test_short_period_table(runs):
    """Every method against the converged integral on the short-period grid; "averaged" is
    within its bound of it (phase-averaged zones were 14 dE2000 off here)."""
    (text, _), _, _ = runs
    rows = markdown_table(bench_section(bench, text), "### Short periods")
    header, body = rows[0], rows[1:]
    assert header[1:] == [f"N = {n}" for n in bench.QUICK.short_counts] + ["all N"]
    methods, _ = _methods()
    _assert_stats_rows(bench, body, methods)
    averaged = body[methods.index("averaged")]
    assert report.parse_stats(averaged[-1])[2] <= 0.5


def test_dense_host_table(runs):
    """Past n2's critical angle: a row per mirror and method that takes it, each timed on
    the GPU where the method has a kernel, its dE2000 consistent, and "averaged" within its
    bound of the converged integral."""
    (text, _), _, _ = runs
    rows = markdown_table(bench_section(bench, text), "### Past n2's critical angle")
    header, body = rows[0], rows[1:]
    assert header == ["mirror", "θ", "method", "GPU kernel", "speed-up",
                      "dE2000 mean / p95 / max"]
    methods, gpu_methods = _methods()
    taken = [m for m in methods if m != "spectral"]  # the quick mirror has host == n1
    assert [row[2] for row in body] == [bench.method_label(m) for m in taken]
    for method, row in zip(taken, body, strict=True):
        mean, p95, top = report.parse_stats(row[5])
        assert 0.0 <= mean <= top and p95 <= top
        if method in gpu_methods:
            assert report.parse_time(row[3]) > 0.0 and report.parse_ratio(row[4]) > 0.0
    assert report.parse_stats(body[taken.index("averaged")][5])[2] <= 0.5


def test_dense_host_range_is_past_the_critical_angle():
    from wgbragg import BraggMirror

    first, last = bench.dense_host_range(BraggMirror(1.5, 1.0, 100.0, 200.0, 20))
    assert first == pytest.approx(math.degrees(math.asin(1.0 / 1.5)) + 0.5) and last == 89.0
    first, last = bench.dense_host_range(BraggMirror(2.4, 1.0, 2700.0, 1000.0, 10, host=2.7))
    assert last == pytest.approx(math.degrees(math.asin(2.4 / 2.7)) - 0.5)


def test_fine_integral():
    """On the 1 nm grid the trapezoid integral is the reference's sum (the density vanishes
    at the ends); the adaptive step resolves N-fold oscillations."""
    from wgbragg.colour.reference import reference_xyz

    case = bench.Case(500.0, 0.5, 20)
    theta = np.radians([0.0, 40.0])
    np.testing.assert_allclose(bench.fine_xyz(case.mirror, theta, 1.0),
                               reference_xyz(case.mirror, theta), atol=1e-6)
    assert bench.fine_step_nm(bench.Case(988.0, 0.5, 100)) < 0.02
    assert bench.fine_step_nm(bench.Case(244.0, 0.5, 3)) == bench.FINE_MAX_STEP_NM


def test_spectral_sweep_rows(runs):
    (text, _), _, _ = runs
    body = markdown_table(bench_section(bench, text), '### "spectral"')[1:]
    assert [int(row[0]) for row in body] == list(bench.QUICK.samples)
    for row in body:
        for cell in row[1:4]:
            assert report.parse_time(cell) > 0
        for cell in row[4:6]:
            assert report.parse_ratio(cell) > 0
        assert all(float(cell) >= 0.0 for cell in row[6:])


def test_averaged_settings_rows(runs):
    """One row per setting: the default row repeats the `averaged` method's dE2000, the others
    are timed and checked against numpy like the methods."""
    (text, _), _, _ = runs
    section = bench_section(bench, text)
    body = markdown_table(section, '### "averaged" settings')[1:]
    settings = [(int(row[1]), int(row[2]), row[0],
                 int(row[3]) if row[0] == "grid" else bench.NOT_MEASURED) for row in body]
    assert settings == [(a, p, q, n if q == "grid" else bench.NOT_MEASURED)
                        for a, p, q, n in bench.QUICK.averaged_settings]
    for row in body:
        assert report.parse_time(row[4]) > 0 and report.parse_ratio(row[5]) > 0
        for cell in row[6:10]:
            mean, p95, worst = report.parse_stats(cell)
            assert 0.0 <= mean <= p95 <= worst
        assert float(row[10]) <= bench.TARGET_GPU_AGREEMENT
    from wgbragg.colour.landmark_methods import AVERAGING_MIN_PERIODS, PANELS_PER_OSCILLATION

    default = next(row for row in body if row[0] == "landmarks" and (int(row[1]), int(row[2]))
                   == (AVERAGING_MIN_PERIODS, PANELS_PER_OSCILLATION))
    methods = markdown_table(section, '### dE2000 against "reference"')[1:]
    averaged = next(row for row in methods if row[0] == "averaged")
    assert default[7] == averaged[-1]  # all N
    # The grid is another quadrature: its colours and its time differ from the landmarks'.
    grid = next(row for row in body if row[0] == "grid")
    assert report.parse_stats(grid[9]) != report.parse_stats(default[9])
    assert report.parse_time(grid[4]) != report.parse_time(default[4])


def test_targets_listed(runs):
    (text, _), _, _ = runs
    body = markdown_table(bench_section(bench, text), "### Targets")[1:]
    targets = " ".join(row[0] for row in body)
    for needle in ("`averaged`: mean dE2000 <= 0.5", "over all N", "the speed of `reference`",
                   '`quadrature="grid"` (96 nodes): mean dE2000 <= 0.5',
                   "`approx`: the paper's Table 1", "`approx`: dE2000 reported",
                   "numpy and GPU versions"):
        assert needle in targets, needle
    assert all(row[2] in ("yes", "no", "not checked", "reported") for row in body)


# --------------------------------------------------------------------------- the plot


def test_plot_is_a_png(runs):
    _, _, plot = runs
    with Image.open(plot) as image:
        image.verify()
    with Image.open(plot) as image:
        pixels = np.asarray(image.convert("RGB"), dtype=np.float64)
    assert pixels.shape[0] >= 200 and pixels.shape[1] >= 200
    assert pixels.std() > 10.0
    assert [p.name for p in plot.parent.iterdir()] == [plot.name]  # no temporary files left


# --------------------------------------------------------------------------- behaviour


def test_gpu_methods_read_at_run_time(monkeypatch):
    """The GPU rows follow ``GPU_COLOUR_METHODS`` as it is when the run starts."""
    from wgbragg.colour import methods as colour_methods

    monkeypatch.setattr(colour_methods, "GPU_COLOUR_METHODS", ("reference",))
    tiny = dataclasses.replace(bench.QUICK, counts=(10,), angles_deg=(20.0,), samples=(4,),
                               timing_angles=16)
    results = bench.run_benchmarks(tiny, progress=False)
    assert results.gpu_methods == ("reference",)
    assert set(results.gpu_delta_e) == {"reference"}
    assert ("spectral", *bench.GPU_WALL) not in results.seconds
    assert ("reference", *bench.GPU_WALL) in results.seconds
    assert not results.sweep_gpu_delta_e
    section = bench.render_section(results, "python -m benchmarks.rgb")
    rows = markdown_table(section, "### numpy against GPU")[1:]
    spectral = next(row for row in rows if row[0].startswith("spectral"))
    assert spectral[1] == "no GPU kernel yet"


@pytest.mark.parametrize("seconds", [3.2e-9, 4.56e-7, 9.9996e-4, 1.2e-3, 0.5, 12.0])
def test_time_format_round_trip(seconds):
    assert report.parse_time(report.human_time(seconds)) == pytest.approx(seconds, rel=5e-3)


@pytest.mark.parametrize("ratio", [0.0123, 0.83, 1.0, 12.46, 431.0, 4312.0])
def test_ratio_format_round_trip(ratio):
    assert report.parse_ratio(report.human_ratio(ratio)) == pytest.approx(ratio, rel=5e-3)


def test_output_and_plot_paths(tmp_path):
    def where(*argv):
        args = bench.parse_args(list(argv))
        return bench.output_path(args), bench.plot_path(args)

    assert where("--quick") == (None, None)
    assert where() == (report.DEFAULT_OUTPUT, bench.DEFAULT_PLOT)
    assert where("--no-write") == (None, bench.DEFAULT_PLOT)
    assert where("--quick", "--output", str(tmp_path / "b.md"), "--plot",
                 str(tmp_path / "p.png")) == (tmp_path / "b.md", tmp_path / "p.png")
    # Generated output stays out of the tracked tree.
    assert bench.DEFAULT_PLOT.parts[-2] == "out"
    with pytest.raises(SystemExit):
        where("--output", "x.md", "--no-write")
