"""``benchmarks.sweep`` in its quick mode: it runs every part, writes its section once between
its markers, every table has its rows with numbers in range (no speed is asserted), and the
100-worker model follows its formula."""

from __future__ import annotations

import pytest
from conftest import markdown_table, quick_run

from benchmarks import report
from benchmarks import sweep as bench

pytestmark = pytest.mark.gpu


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """The document after one quick run over a stale section."""
    return quick_run(bench, tmp_path_factory.mktemp("docs"))[0]


def test_section_written_once(run):
    assert run.count(bench.BEGIN_MARKER) == 1 and "stale" not in run
    assert "Quick mode" in run


def test_every_run_is_measured(run):
    rows = markdown_table(run, "### Throughput")[1:]
    assert [row[0] for row in rows] == ["in-process, no Dask, no Zarr", "1 worker", "2 workers"]
    for row in rows:
        assert bench.parse_colours(row[1]) > 0.0
    overhead = markdown_table(run, "### Per-chunk overhead")[1:]
    assert [int(row[0]) for row in overhead] == list(bench.QUICK.chunk_sizes)
    for row in overhead:
        assert report.parse_time(row[4]) > 0.0 and 0 <= int(row[6].removesuffix(" %")) <= 100
    model = {row[0]: row[1:] for row in markdown_table(run, "### A model of 100 workers")[1:]}
    assert all(cell.endswith("chunks/s") for cell in model["scheduler-bound chunk rate"])


def test_the_model_puts_the_crossover_where_the_workers_outpace_the_scheduler():
    # a = 10 ms, b = 5 ms a structure, 1 ms a task: 100 workers saturate the scheduler until a
    # chunk takes 100 ms, at (100 - 10) / 5 = 18 structures; 10 % busy at 1 s, 198 structures.
    overhead = [{"chunk": c, "cluster": 0.010 + 0.005 * c} for c in (1, 4, 16)]
    model = bench.model_workers(overhead, 0.001, angles=10)
    assert model["a"] == pytest.approx(0.010) and model["b"] == pytest.approx(0.005)
    assert model["crossover"] == pytest.approx(18.0)
    assert model["choose"] == 198
    assert model["rate"] == pytest.approx(100 / (0.010 + 0.005 * 198) * 198 * 10, rel=1e-3)
