"""benchmarks.rasterizer: its quick mode measures two presets and both tables."""

from __future__ import annotations

import pytest

from benchmarks import rasterizer

pytestmark = pytest.mark.gpu


def test_quick_mode_measures_presets_and_the_frame_rates():
    results = rasterizer.run_benchmarks(rasterizer.QUICK, progress=False)
    assert set(results["accuracy"]) == set(rasterizer.QUICK.presets)
    assert set(rasterizer.FULL.presets) == set(rasterizer.PRESETS)
    for found in results["accuracy"].values():
        assert found["visible"] >= 0.99
        # The rasterizer shades as the filtered path trace does: closer to it than either
        # is to the Monte Carlo reference, give or take the quick mode's noise.
        assert 0.0 <= found["filtered"][0] < 0.2
        assert found["reference"][1] >= 0.0
    for rates in results["rates"].values():
        assert all(rate > 0 for rate in rates.values())
    section = rasterizer.render_section(results, rasterizer.QUICK, "python -m x --quick")
    assert section.startswith(rasterizer.BEGIN_MARKER)
    assert section.endswith(rasterizer.END_MARKER)
    assert "**Quick mode" in section and "| fig11 | " in section
