"""Structure and sanity of ``benchmarks.reflectance`` in its quick mode.

No speed is asserted here: timings on shared CI machines are noise. The tests check that a quick
run measures every method, that the markdown section parses, lands between its markers and
replaces (not duplicates) itself, and that what the tool times is the mirror it claims to time.
"""

from __future__ import annotations

import contextlib
import io
import math
import re

import numpy as np
import pytest
from conftest import bench_section, markdown_table

from benchmarks import end_to_end, report
from benchmarks import reflectance as bench

pytestmark = pytest.mark.gpu

LATER_SECTION = "## A later benchmark\n\n<!-- other:begin -->\nkeep me\n<!-- other:end -->\n"


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Two quick runs into one document that already holds an intro and a later section.

    Returns the document after each run and what the first run printed.
    """
    path = tmp_path_factory.mktemp("docs") / "benchmarks.md"
    path.write_text(f"# Benchmarks\n\nIntro text.\n\n{LATER_SECTION}", encoding="utf-8")
    texts, printed = [], []
    for _ in range(2):
        # capsys is function-scoped; these runs are shared by the module's tests.
        with contextlib.redirect_stdout(io.StringIO()) as capture:
            status = bench.main(["--quick", "--no-progress", "--output", str(path)])
        assert status == 0
        texts.append(path.read_text(encoding="utf-8"))
        printed.append(capture.getvalue())
    return texts, printed


def _table_after(section: str, heading: str) -> dict[str, list[str]]:
    """Rows (label -> cells) of the first markdown table after ``heading``."""
    return {row[0]: row[1:] for row in markdown_table(section, heading)}


def _is_placeholder(bench, cell: str) -> bool:
    return cell.rstrip("¹²") == bench.NOT_MEASURED or cell == bench.NOT_INSTALLED


# --------------------------------------------------------------------------- the quick run


def test_section_written_once_between_markers(runs):
    (first, second), _ = runs
    for text in (first, second):
        assert text.count(bench.BEGIN_MARKER) == 1
        assert text.count(bench.END_MARKER) == 1
        assert text.index(bench.BEGIN_MARKER) < text.index(bench.END_MARKER)
        # The rest of the document is left alone.
        assert text.startswith("# Benchmarks\n\nIntro text.\n")
        assert LATER_SECTION in text
        assert text.count("## Reflectance throughput") == 1


def test_rerun_replaces_section(runs):
    (first, second), _ = runs
    outside = [t.replace(bench_section(bench, t), "") for t in (first, second)]
    assert outside[0] == outside[1]


def test_section_printed(runs):
    (first, _), (printed, _) = runs
    assert bench_section(bench, first) in printed


def test_every_method_has_a_rate_row(runs):
    (text, _), _ = runs
    rows = _table_after(bench_section(bench, text), "### Evaluations per second")
    assert [row for row in rows if row != "method"] == [m.label for m in bench.METHODS]
    assert len(rows["method"]) == len(bench.N_VALUES) + 1
    for method in bench.METHODS:
        cells = rows[method.label][: len(bench.N_VALUES)]
        installed = cells[0] != bench.NOT_INSTALLED
        if method.package is None:
            assert installed, method.key
        for N, cell in zip(bench.N_VALUES, cells, strict=True):
            if installed and bench.applicable(method, N):
                rate = report.parse_rate(cell)
                assert math.isfinite(rate) and rate > 0, (method.key, N, cell)
            else:
                assert _is_placeholder(bench, cell), (method.key, N, cell)


def test_flatness_column_parses(runs):
    (text, _), _ = runs
    rows = _table_after(bench_section(bench, text), "### Evaluations per second")
    for method in bench.METHODS:
        cell = rows[method.label][-1]
        if method.linear or cell == bench.NOT_INSTALLED:
            assert _is_placeholder(bench, cell)
        else:
            assert re.fullmatch(r"\d+(\.\d+)?%", cell), cell


def test_ratio_rows_parse(runs):
    (text, _), _ = runs
    rows = _table_after(bench_section(bench, text), "### Speed-up")
    labels = [f"÷ {bench.METHOD_BY_KEY[k].label}" for k in bench.RATIO_KEYS]
    assert [row for row in rows if not row.startswith("GPU kernel (s)")] == labels
    for key, label in zip(bench.RATIO_KEYS, labels, strict=True):
        method = bench.METHOD_BY_KEY[key]
        for N, cell in zip(bench.N_VALUES, rows[label], strict=True):
            if _is_placeholder(bench, cell):
                assert cell == bench.NOT_INSTALLED or not bench.applicable(method, N)
                continue
            ratio = report.parse_ratio(cell)
            assert math.isfinite(ratio) and ratio > 0, (key, N, cell)


def test_header_facts(runs):
    (text, _), _ = runs
    section = bench_section(bench, text)
    from wgbragg import gpu

    assert gpu.adapter_info()["name"] in section
    assert "Command: `python -m benchmarks.reflectance --quick --no-progress --output" in section
    assert "Quick mode" in section
    assert "### Targets" in section
    assert re.search(r"WORKGROUP_SIZE = \d+", section)


def test_end_to_end_table_has_every_public_call(runs):
    (text, _), _ = runs
    rows = _table_after(bench_section(bench, text), "### Public calls end to end")
    labels = [call.label for call in end_to_end.CALLS]
    assert [row for row in rows if row != "call"] == labels
    for label in labels:
        points, kernel, whole, share, met = rows[label]
        assert int(points.replace(",", "")) > 0
        assert report.parse_rate(kernel) > 0 and report.parse_rate(whole) > 0
        assert re.fullmatch(r"\d+%", share), share
        assert met == "not checked (< 1M points)"  # quick sizes


def test_targets_hold_the_end_to_end_share(runs):
    (text, _), _ = runs
    rows = _table_after(bench_section(bench, text), "### Targets")
    (label,) = [row for row in rows if row.startswith("GPU end to end >= 50% of the GPU kernel")]
    assert "at N = 20, 16,384 points" in label  # quick: 128 x 128
    measured, met = rows[label]
    assert re.fullmatch(r"\d+%", measured) and met == "not checked (< 1M points)"


def test_end_to_end_share_and_verdicts():
    results = {"bragg_flat": end_to_end.Result(4_194_304, 0.08, 0.04),
               "film": end_to_end.Result(4_194_304, 0.1, 0.04),
               "sweep": end_to_end.Result(20_000, 0.01, 0.008)}
    assert results["bragg_flat"].share == pytest.approx(0.5)
    rows = {row.split(" | ")[0].lstrip("| "): row.split(" | ")
            for row in end_to_end.render_table(results)[2:]}
    labels = {call.key: call.label for call in end_to_end.CALLS}
    assert rows[labels["bragg_flat"]][-1].startswith("yes")
    assert rows[labels["film"]][-1].startswith("no")
    assert rows[labels["sweep"]][-1].startswith("not checked")
    assert len(rows) == 3


# --------------------------------------------------------------------------- what is timed


def test_evaluators_compute_the_mirror():
    """Every timed method returns Yeh's reflectance of the same mirror (so the rates compare
    like with like): float64 methods to 1e-9, the float32 kernel to a loose 1e-2."""
    from wgbragg import optics

    wavelength, theta = bench.grid(6)
    N = 5
    reference = optics.yeh_reflectance(bench.N1, bench.N2, bench.D1_NM, bench.D2_NM, N,
                                       wavelength.astype(np.float64),
                                       theta.astype(np.float64), "s")
    unpolarized = optics.yeh_reflectance(bench.N1, bench.N2, bench.D1_NM, bench.D2_NM, N,
                                         wavelength.astype(np.float64),
                                         theta.astype(np.float64), "unpolarized")
    for key, evaluate in bench.EVALUATORS.items():
        package = bench.METHOD_BY_KEY[key].package
        if package is not None and bench.optional_import(package)[0] is None:
            continue
        got = np.asarray(evaluate(N, wavelength, theta), np.float64)
        want = unpolarized if key == "gpu_unpolarized" else reference
        tolerance = 1e-2 if key.startswith("gpu") else 1e-9
        np.testing.assert_allclose(got, want, atol=tolerance, err_msg=key)


def test_tmm_fast_reported_when_missing(monkeypatch):
    """A package that cannot be imported becomes "not installed" cells, not a crash."""
    real = bench.optional_import

    def fake(name):
        return (None, "ModuleNotFoundError: no tmm_fast") if name == "tmm_fast" else real(name)

    monkeypatch.setattr(bench, "optional_import", fake)
    cfg = bench.dataclasses.replace(bench.QUICK, gpu_side=8, yeh_side=8, max_points_linear=16,
                                    max_calls_tmm=2, max_cells_tmm_fast=64, target_s=0.001,
                                    e2e_rounds=0)
    # Only the missing package matters here: keep the run to the cheapest cells.
    monkeypatch.setattr(bench, "N_VALUES", (1, 20))
    results = bench.run_benchmarks(cfg, progress=False)
    assert "tmm_fast" in results.missing
    assert not any(key == "tmm_fast" for key, _ in results.measurements)
    section = bench.render_section(results, "python -m benchmarks.reflectance")
    rows = _table_after(section, "### Evaluations per second")
    assert rows[bench.METHOD_BY_KEY["tmm_fast"].label][:2] == [bench.NOT_INSTALLED] * 2
    assert "not installed (ModuleNotFoundError" in section


# --------------------------------------------------------------------------- pure helpers


@pytest.mark.parametrize("rate", [0.5, 7.0, 999.7, 1234.0, 99_950.0, 3.2e6, 1.5e8, 2e9])
def test_rate_format_round_trip(rate):
    text = report.human_rate(rate)
    assert re.fullmatch(r"\d+(\.\d+)? [kMGT]?/s", text), text
    assert report.parse_rate(text) == pytest.approx(rate, rel=5e-3)


@pytest.mark.parametrize("ratio", [0.83, 1.0, 12.46, 431.0, 4312.0, 1_590_479.0])
def test_ratio_format_round_trip(ratio):
    assert report.parse_ratio(report.human_ratio(ratio)) == pytest.approx(ratio, rel=5e-3)


def test_update_document():
    section = f"{bench.BEGIN_MARKER}\nnew\n{bench.END_MARKER}"

    def update(text):
        return report.update_document(text, section, bench.BEGIN_MARKER, bench.END_MARKER)

    created = update(None)
    assert created.startswith(report.DOC_INTRO) and created.endswith(section + "\n")
    appended = update("# Benchmarks\n\nintro\n")
    assert appended == f"# Benchmarks\n\nintro\n\n{section}\n"
    old = f"head\n{bench.BEGIN_MARKER}\nold\n{bench.END_MARKER}\ntail\n"
    assert update(old) == f"head\n{section}\ntail\n"
    for broken in (f"{bench.BEGIN_MARKER}\nno end\n", f"{bench.END_MARKER}\n{bench.BEGIN_MARKER}",
                   f"{section}\n{section}\n"):
        with pytest.raises(ValueError, match="expected one"):
            update(broken)


def test_output_path(tmp_path):
    def where(*argv):
        return bench.output_path(bench.parse_args(list(argv)))

    assert where("--quick") is None
    assert where() == report.DEFAULT_OUTPUT
    assert where("--no-write") is None
    assert where("--quick", "--no-write") is None
    assert where("--quick", "--output", str(tmp_path / "b.md")) == tmp_path / "b.md"
    with pytest.raises(SystemExit):
        where("--output", "x.md", "--no-write")
