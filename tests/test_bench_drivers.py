"""benchmarks.drivers: its quick mode runs every workload on each driver of the machine."""

from __future__ import annotations

import pytest

from benchmarks import drivers

pytestmark = pytest.mark.gpu


def test_quick_mode_measures_every_row_on_each_driver_present():
    found = drivers.drivers()
    results = drivers.run_benchmarks(drivers.QUICK, progress=False)
    assert results["errors"] == []
    present = [name for name, files in found.items() if files is not None]
    assert sorted(results["drivers"]) == sorted(present) and present
    for name in present:
        assert "Mesa" in results["drivers"][name] or "[" in results["drivers"][name]
        assert {key for key, *_ in drivers.ROWS} <= set(results["medians"][name])
        assert all(value > 0 for value in results["medians"][name].values())
    section = drivers.render_section(results, drivers.QUICK, "python -m benchmarks.drivers")
    assert section.startswith(drivers.BEGIN_MARKER) and section.endswith(drivers.END_MARKER)
    assert "**Driver: " in section and "| what | system driver | current driver |" in section
    assert section.count("\n| ") == 1 + len(drivers.ROWS)  # the header and one row each
