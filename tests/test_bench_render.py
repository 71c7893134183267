"""``benchmarks.render`` in its quick mode: it runs every part, writes its section between its
markers and every table holds positive numbers (no speed is asserted)."""

from __future__ import annotations

import pytest
from conftest import markdown_rows, quick_run

from benchmarks import render as bench

pytestmark = pytest.mark.gpu


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """The document after one quick run over a stale section."""
    return quick_run(bench, tmp_path_factory.mktemp("docs"))[0]


def _rows(text: str, heading: str) -> list[list[str]]:
    return markdown_rows(text, heading)[2:]


def test_section_written_once(run):
    text = run
    assert text.count(bench.BEGIN_MARKER) == 1 and "stale" not in text
    assert "Quick mode" in text


def test_every_preset_and_configuration_measured(run):
    from wgbragg.scene.model import PRESETS

    text = run
    presets = _rows(text, "### Presets")
    assert [row[0] for row in presets] == list(PRESETS)
    for row in presets:
        # Triangles / spheres / planes: every preset has some.
        assert sum(int(n.replace(",", "")) for n in row[1].split(" / ")) > 0
        assert all(float(cell.split()[0]) > 0 for cell in row[2:6])
    convergence = _rows(text, "### Time to SMAPE")
    assert [row[0] for row in convergence] == ["rgb", "spectral"]
    for _, seconds, spp, error in convergence:
        assert int(spp) >= 1 and 0.0 <= float(error) <= 1.0
        # Reached or not, the time is there.
        assert seconds.split()[-2].replace(".", "").isdigit()
    configurations = _rows(text, "### A sphere")
    assert len(configurations) == 3 and configurations[0][2] == "1.00"
    targets = _rows(text, "### Targets")
    assert len(targets) == 2 and all(row[2] in ("yes", "no") for row in targets)
    assert "ready to render in" in text and "the first took" in text


def test_large_mesh_times_apart_first_pass():
    """The first pass (the kernel's compilation, unless Mesa's cache holds it) is timed apart
    from the later ones: benchmarks.drivers reads these keys."""
    times = bench.large_mesh_times(1, 8)
    assert times["mesh_triangles"] == 80 and times["mesh_gpu_bytes"] > 0
    for key in ("bvh_s", "mesh_setup_s", "mesh_first_pass_s", "mesh_pass_s"):
        assert times[key] > 0
