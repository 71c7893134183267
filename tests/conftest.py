"""Project-wide test set-up: the GPU adapter check and numpy seeding.

GPU tests
---------
The adapter is requested once, when this file is imported. A test module that
needs the GPU declares it with one module-level line::

    pytestmark = pytest.mark.gpu

(a single test can carry ``@pytest.mark.gpu`` instead; any test that uses the
session fixture ``device`` gets the marker automatically). Then:

- no adapter, locally: every ``gpu`` test of the module is skipped with
  "no Vulkan adapter: apt-get install mesa-vulkan-drivers"; the decision is
  taken once per session, so a module skips as a whole;
- ``WGBRAGG_EXPECT_LAVAPIPE=1`` (CI): a missing adapter, or one whose name
  lacks "llvmpipe", makes every ``gpu`` test fail in set-up. They never skip,
  so a CI image without lavapipe cannot pass silently.

Tests without the marker (pure numpy) run everywhere.

Seeding
-------
``np.random.seed(0)`` runs before every test, so tests using the legacy global
generator are reproducible one by one and in any order.

Screenshots
-----------
``pytest --regenerate-screenshots`` rewrites the reference images in
``tests/screenshots/`` (the demo window's, ``test_viewer.py``) instead of comparing
frames with them.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import os
import sys
from pathlib import Path

import numpy as np
import pytest

from wgbragg import gpu

NO_ADAPTER = "no Vulkan adapter: apt-get install mesa-vulkan-drivers"
EXPECT_LAVAPIPE = os.environ.get("WGBRAGG_EXPECT_LAVAPIPE") == "1"

try:
    gpu.get_device()
    GPU_INFO: dict | None = gpu.adapter_info()
    GPU_ERROR: str | None = None
except Exception as exc:
    GPU_INFO = None
    GPU_ERROR = f"{type(exc).__name__}: {exc}"


def gpu_problem() -> tuple[str, str] | None:
    """What to do with ``gpu`` tests: None (run), ("skip", reason) or ("fail", reason)."""
    if EXPECT_LAVAPIPE:
        if GPU_INFO is None:
            return "fail", f"WGBRAGG_EXPECT_LAVAPIPE=1 but {NO_ADAPTER} ({GPU_ERROR})"
        if not GPU_INFO["is_lavapipe"]:
            return "fail", f"WGBRAGG_EXPECT_LAVAPIPE=1 but the adapter is {GPU_INFO['name']!r}"
        return None
    if GPU_INFO is None:
        return "skip", f"{NO_ADAPTER} ({GPU_ERROR})"
    return None


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--regenerate-screenshots", action="store_true",
                     help="rewrite the reference images of tests/screenshots/ from this run "
                          "instead of comparing with them")


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "gpu: needs a wgpu adapter (see tests/conftest.py)")


def adapter_line() -> str:
    """The adapter with its Mesa version and where its driver came from (or why none)."""
    if GPU_INFO is None:
        return f"wgbragg adapter: none ({GPU_ERROR})"
    return f"wgbragg adapter: {GPU_INFO['driver']} (driver: {GPU_INFO['driver_source']})"


def pytest_sessionstart(session: pytest.Session) -> None:
    # Written even under -q (which hides pytest's report header): every run says which
    # driver its GPU tests ran on, since results and times depend on it.
    terminal = session.config.pluginmanager.get_plugin("terminalreporter")
    if terminal is not None:
        terminal.write_line(adapter_line())


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    problem = gpu_problem()
    for item in items:
        if "device" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.gpu)
        if problem is not None and problem[0] == "skip" and item.get_closest_marker("gpu"):
            item.add_marker(pytest.mark.skip(reason=problem[1]))


def pytest_runtest_setup(item: pytest.Item) -> None:
    problem = gpu_problem()
    if problem is not None and problem[0] == "fail" and item.get_closest_marker("gpu"):
        pytest.fail(problem[1], pytrace=False)


@pytest.fixture(scope="session")
def device():
    """The process-wide wgpu device (``gpu.get_device()``); implies the ``gpu`` marker."""
    return gpu.get_device()


@pytest.fixture(autouse=True)
def _seed_numpy() -> None:
    np.random.seed(0)


TOOLS = Path(__file__).resolve().parents[1] / "tools"


@contextlib.contextmanager
def load_tool(name: str):
    """A script of ``tools/`` loaded as a module (``tools/`` is not a package)."""
    spec = importlib.util.spec_from_file_location(name, TOOLS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    # dataclasses look the module up in sys.modules while the class body runs.
    sys.modules[spec.name] = module
    try:
        spec.loader.exec_module(module)
        yield module
    finally:
        sys.modules.pop(spec.name, None)


def expected_direction_counts(density, cos_edges, phi_edges, n_samples, order=16):
    """Samples a direction sampler should put in each (cos theta, phi) cell, shape
    ``(len(cos_edges) - 1, len(phi_edges) - 1)``: ``density`` (a callable of unit directions,
    shape (..., 3), returning 1/sr) integrated over each cell by an ``order`` x ``order``
    Gauss-Legendre rule (Mitsuba's chi-square test)."""
    x, w = np.polynomial.legendre.leggauss(order)

    def nodes(edges):
        half = 0.5 * np.diff(edges)[:, None]
        return (0.5 * (edges[:-1] + edges[1:]))[:, None] + half * x, half * w

    c, wc = nodes(np.asarray(cos_edges))
    p, wp = nodes(np.asarray(phi_edges))
    c, p = c[:, None, :, None], p[None, :, None, :]
    sin = np.sqrt(1.0 - c * c)
    cells = np.stack(np.broadcast_arrays(sin * np.cos(p), sin * np.sin(p), c), axis=-1)
    return n_samples * np.einsum("ijab,ia,jb->ij", density(cells), wc, wp)


def sample_chi2_pvalue(material, wi, seed, random_dims, n_samples=100_000, n_cos=12,
                       n_phi=24) -> float:
    """p-value of a chi-square test of ``material.sample(wi, u, 550.0)`` against
    ``material.pdf`` on a (cos theta, phi) grid, ``u`` of ``random_dims`` uniform numbers per
    sample. The mass the density lacks (a Dirac reflection, directions lost below the horizon
    or to total internal reflection) is one more cell, matched by the samples whose pdf is 0."""
    rng = np.random.default_rng(seed)
    wo, _, pdf = material.sample(wi, rng.random((n_samples, random_dims)), 550.0)
    kept = pdf > 0.0
    cos_edges = np.linspace(0.0, 1.0, n_cos + 1) ** 0.5
    phi_edges = np.linspace(-np.pi, np.pi, n_phi + 1)
    observed, _, _ = np.histogram2d(wo[kept, 2], np.arctan2(wo[kept, 1], wo[kept, 0]),
                                    bins=[cos_edges, phi_edges])
    expected = expected_direction_counts(
        lambda cells: material.pdf(wi, cells.reshape(-1, 3)).reshape(cells.shape[:-1]),
        cos_edges, phi_edges, n_samples)
    observed = np.append(observed.ravel(), np.count_nonzero(~kept))
    expected = np.append(expected.ravel(), n_samples - expected.sum())
    assert expected[-1] > -1e-3 * n_samples  # the density never holds more than 1
    return pooled_chi2_pvalue(observed, expected)


def pooled_chi2_pvalue(observed, expected) -> float:
    """p-value of Pearson's chi-square with the cells expecting fewer than 5 samples pooled
    into one (so that the statistic's chi-square law holds)."""
    from scipy.stats import chi2

    observed, expected = np.ravel(observed), np.ravel(expected)
    low = expected < 5.0
    stat = np.sum((observed[~low] - expected[~low]) ** 2 / expected[~low])
    cells = np.count_nonzero(~low)
    if expected[low].sum() > 0:
        stat += (observed[low].sum() - expected[low].sum()) ** 2 / expected[low].sum()
        cells += 1
    return float(chi2.sf(stat, cells - 1))


# ------------------------------------------------------------ layered structures at fixed pairs


def unit_direction(theta_deg, phi_deg=0.0) -> np.ndarray:
    """Unit vectors (..., 3) at polar angle ``theta_deg`` and azimuth ``phi_deg`` (degrees)."""
    theta, phi = np.radians(theta_deg), np.radians(phi_deg)
    return np.stack(np.broadcast_arrays(np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi),
                                        np.cos(theta)), axis=-1)


# (theta_i, theta_o, phi_o) in degrees, phi_i = 0: near and off the mirror direction; the pairs
# at which the layered model and its simulation are compared.
LAYERED_PAIRS = np.array([(20.0, 25.0, 180.0), (45.0, 40.0, 170.0), (5.0, 30.0, 180.0),
                          (60.0, 60.0, 180.0), (30.0, 70.0, 90.0), (70.0, 20.0, 200.0)])


def paper_smape(a, b) -> float:
    """The Bragg paper's SMAPE: mean |a - b| / ((|a| + |b|) / 2)."""
    return float(np.mean(np.abs(a - b) / (0.5 * (np.abs(a) + np.abs(b)))))


def cosine_mean(g) -> float:
    """2 int_0^{pi/2} g(theta) cos sin dtheta: the mean of g over a cosine distribution."""
    import math

    from scipy.integrate import quad

    return quad(lambda t: 2.0 * g(t) * math.cos(t) * math.sin(t), 0.0, math.pi / 2,
                epsabs=1e-12, limit=200)[0]


def coating_internal_reflectance(theta: float, n: float) -> float:
    """A coating of index ``n`` seen from inside at ``theta``: Fresnel, 1 beyond its critical
    angle."""
    import math

    from wgbragg.bsdf.layered.model import coating_reflectance

    out = n * math.sin(theta)
    return 1.0 if out >= 1.0 else float(coating_reflectance(math.sqrt(1.0 - out * out), n))


# ------------------------------------------------------------ benchmark reports


def bench_section(bench, text: str) -> str:
    """The part of ``text`` a benchmark (a module of ``benchmarks/``) wrote, its markers
    included."""
    start, stop = text.index(bench.BEGIN_MARKER), text.index(bench.END_MARKER)
    return text[start:stop + len(bench.END_MARKER)]


def markdown_rows(text: str, heading: str) -> list[list[str]]:
    """Cells of every row of the first markdown table after ``heading``: header, rule, body."""
    rows: list[list[str]] = []
    for line in text[text.index(heading):].splitlines()[1:]:
        if line.startswith("|"):
            rows.append([c.strip() for c in line.strip().strip("|").split("|")])
        elif rows:
            break
    return rows


def markdown_table(text: str, heading: str) -> list[list[str]]:
    """:func:`markdown_rows` without the rule (rows whose first cell is only dashes)."""
    return [row for row in markdown_rows(text, heading) if not set(row[0]) <= set("-")]


def quick_run(bench, folder) -> tuple[str, str]:
    """Run benchmark module ``bench`` in quick mode over a document whose section is stale;
    return the document afterwards and what the run printed."""
    path = folder / "benchmarks.md"
    path.write_text(f"# Benchmarks\n\n{bench.BEGIN_MARKER}\nstale\n{bench.END_MARKER}\n",
                    encoding="utf-8")
    with contextlib.redirect_stdout(io.StringIO()) as capture:
        assert bench.main(["--quick", "--no-progress", "--output", str(path)]) == 0
    return path.read_text(encoding="utf-8"), capture.getvalue()
