"""float32 GPU twins of the landmark colour methods ("approx", "subdivided", "averaged").

The issue's target: numpy and GPU versions of each method agree within CIE dE2000 0.1, on the
grid n1 = 1, n2 = 1.5, Lambda in {244, 500, 988} nm, d1 / Lambda in {0.25, 0.5, 0.75},
N in {3, 5, 10, 20, 100}, theta = 0, 7, ..., 84 degrees; plus an Appendix D mirror (host != n1,
"averaged" only) and an evanescent-n2 mirror past its critical angle. Measured (lavapipe):
mean dE 4e-5 (approx, subdivided), max 3e-4; "averaged" uses the numpy twin's zones, Gauss
nodes and weights, and agrees within 3e-3 (0.013 on the 1-degree grid of benchmarks.rgb).

The numpy colours are computed once and shared between the tests.
"""

from __future__ import annotations

import itertools
import math
import re

import numpy as np
import pytest

from benchmarks import rgb as bench_rgb
from wgbragg import BraggMirror, gpu
from wgbragg.colour import landmark_methods as cm
from wgbragg.colour import landmark_methods_gpu as colour_landmarks_gpu
from wgbragg.colour.colorimetry import delta_e_2000, xyz_to_linear_srgb
from wgbragg.colour.methods import GPU_COLOUR_METHODS
from wgbragg.optics import landmarks_gpu
from wgbragg.optics.landmarks import find_landmarks

pytestmark = pytest.mark.gpu

ISSUE_DE = 0.1  # the issue: numpy and GPU versions of a method agree within dE2000 0.1
MEDIAN_DE = 0.01  # typical agreement; measured median 2e-5 .. 4e-5
LANDMARK_RTOL = 1e-5  # the issue asks 1e-4; measured 4.4e-7 relative in omega (and wavelength)
ZONES_ATOL = 1e-4  # XYZ, GPU vs numpy "averaged" at hard single colours

DEG = math.pi / 180.0
THETA = np.arange(0.0, 90.0, 7.0) * DEG
GRID = [
    BraggMirror(1.0, 1.5, fraction * period, (1.0 - fraction) * period, N)
    for period, fraction, N in itertools.product((244.0, 500.0, 988.0), (0.25, 0.5, 0.75),
                                                 (3, 5, 10, 20, 100))
]
HOST_MIRROR = BraggMirror(1.59, 1.67, 81.6, 78.4, 8, host=1.0)  # Appendix D (jewel beetle)
EVANESCENT = BraggMirror(1.5, 1.0, 100.0, 200.0, 20)  # n2 evanescent past 41.8 degrees
EVANESCENT_THETA = np.arange(42.0, 90.0, 3.0) * DEG
# A thick n2 barrier under a dense host: past 21.7 degrees, pass bands from 15 nm down to far
# below what float32 resolves.
TUNNELLING = BraggMirror(2.4, 1.0, 2700.0, 1000.0, 10, host=2.7)
TUNNELLING_THETA = np.arange(22.0, 62.0, 4.0) * DEG
METHODS = ("approx", "subdivided", "averaged")


def numpy_xyz(mirror, theta, method):
    if method == "averaged":
        return cm.averaged_xyz(mirror, theta)
    return cm.approx_xyz(mirror, theta, subdivisions=3 if method == "subdivided" else None)


def delta_e(xyz_a, xyz_b):
    return delta_e_2000(xyz_to_linear_srgb(xyz_a), xyz_to_linear_srgb(xyz_b))


@pytest.fixture(scope="module")
def numpy_colours():
    """{(mirror index or name, method): numpy XYZ}."""
    out = {}
    for method in METHODS:
        for index, mirror in enumerate(GRID):
            out[index, method] = numpy_xyz(mirror, THETA, method)
        out["evanescent", method] = numpy_xyz(EVANESCENT, EVANESCENT_THETA, method)
    out["host", "averaged"] = cm.averaged_xyz(HOST_MIRROR, THETA)
    return out


# --------------------------------------------------------------------------- numpy vs GPU


@pytest.mark.parametrize("method", METHODS)
def test_matches_numpy_on_the_issue_grid(numpy_colours, method):
    errors = np.array([
        delta_e(numpy_colours[index, method], colour_landmarks_gpu.landmark_xyz(mirror, THETA,
                                                                                method))
        for index, mirror in enumerate(GRID)
    ])
    assert errors.shape == (len(GRID), THETA.size)
    worst = np.unravel_index(errors.argmax(), errors.shape)
    assert errors.max() <= ISSUE_DE, (GRID[worst[0]], THETA[worst[1]] / DEG)
    assert np.median(errors) <= MEDIAN_DE


def test_averaged_matches_numpy_for_an_appendix_d_host(numpy_colours):
    gpu = colour_landmarks_gpu.landmark_xyz(HOST_MIRROR, THETA, "averaged")
    assert delta_e(numpy_colours["host", "averaged"], gpu).max() <= ISSUE_DE


@pytest.mark.parametrize("method", METHODS)
def test_matches_numpy_with_evanescent_n2(numpy_colours, method):
    gpu = colour_landmarks_gpu.landmark_xyz(EVANESCENT, EVANESCENT_THETA, method)
    errors = delta_e(numpy_colours["evanescent", method], gpu)
    assert errors.max() <= ISSUE_DE
    # The range holds pass bands (coloured) and total reflection (white): both are checked.
    assert np.ptp(gpu[:, 1]) > 0.3


def test_averaged_through_tunnelling_pass_bands():
    """Both twins find every pass band, however narrow, and agree; they are within 0.02
    dE2000 of a converged integral (0.0047 nm strata; the 1 nm reference is up to 0.4 off),
    and phase-average the bands whose oscillations are under 0.1 nm (measured: the float32
    kernel at 1.2x the reference's time per colour; integrated exactly, 6x)."""
    from wgbragg.colour.reference import MAX_SAMPLES, spectral_xyz_stratified

    theta = TUNNELLING_THETA.astype(np.float32).astype(np.float64)
    expected = cm.averaged_xyz(TUNNELLING, theta)
    assert delta_e(expected, colour_landmarks_gpu.averaged_xyz(TUNNELLING, theta)).max() <= 2e-3
    converged = spectral_xyz_stratified(TUNNELLING, theta[::3], samples=MAX_SAMPLES)
    assert delta_e(expected[::3], converged).max() <= 0.02


@pytest.mark.parametrize("method", ["approx", "subdivided"])
@pytest.mark.parametrize("backend", ["numpy", "gpu"])
def test_paper_methods_need_a_matched_host(method, backend):
    with pytest.raises(ValueError, match="host == n1"):
        HOST_MIRROR.xyz(0.3, method=method, backend=backend)


# --------------------------------------------------------------------------- landmarks


LANDMARK_MIRRORS = [
    BraggMirror(1.0, 1.5, 315.0, 315.0, 10),  # the paper's Fig. 3
    BraggMirror(1.0, 1.5, 61.0, 183.0, 20),
    BraggMirror(1.0, 1.5, 741.0, 247.0, 20),
    BraggMirror(1.33, 1.56, 900.0, 1100.0, 5),
    HOST_MIRROR,
    EVANESCENT,
]


@pytest.mark.parametrize(("mirror", "theta"), [
    *[(mirror, np.arange(0.0, 90.0, 3.0) * DEG) for mirror in LANDMARK_MIRRORS],
    (TUNNELLING, TUNNELLING_THETA),  # 5-19 pass bands per polarisation
], ids=lambda value: repr(value) if isinstance(value, BraggMirror) else f"{value.size}-angles")
@pytest.mark.parametrize("pol", ["s", "p"])
def test_landmarks_match_numpy(mirror, theta, pol):
    found = landmarks_gpu.find_landmarks_gpu(mirror, theta, pol)
    total = 0
    for angle, (omega, kind) in zip(theta, found, strict=True):
        # The kernel sees the float32 angle.
        expected = find_landmarks(mirror, float(np.float32(angle)), pol)
        assert list(kind) == list(expected.kind), angle / DEG
        np.testing.assert_allclose(omega, expected.omega, rtol=LANDMARK_RTOL, atol=0.0)
        total += omega.size
    assert total > 20  # the sweep did meet landmarks


# --------------------------------------------------------------------------- float32 zones


@pytest.mark.parametrize("mirror, theta", [
    (GRID[42], 0.3),   # Lambda 988, d1 = 0.75 Lambda, N = 20: many narrow zones
    (GRID[18], 1.1),   # Lambda 500, N = 100
    (GRID[6], 0.0),    # Lambda 244, N = 5: exact R, two panels per oscillation
    (BraggMirror(1.0, 1.5, 125.0, 375.0, 20), 1.5707),  # near grazing: zones of 1e-4 nm
    # N = 10 at 73 degrees: at two panels per oscillation a zone's 2 N share lay 0.003 above
    # 7, and the float32 kernel's phase at its band edge (off by 5e-4 rad) took 7 panels where
    # numpy took 8, dE 0.17, until both snapped edge phases (PHASE_SNAP; the snap itself is
    # tested in test_colour_methods.py).
    (BraggMirror(1.0, 1.5, 375.0, 125.0, 10), 1.2740904),
    # Short periods, N >= 16: zones of wide oscillations integrated through the exact R.
    (BraggMirror(1.0, 2.5, 30.0, 10.0, 20), 1.0471976),
    (BraggMirror(1.0, 1.5, 40.0, 40.0, 16), 0.0),
    (BraggMirror(1.0, 1.5, 60.0, 20.0, 50), 1.3089969),
    (BraggMirror(1.0, 2.5, 0.82 * 183.0, 0.18 * 183.0, 16), 1.4826),  # one exact, one averaged
    (BraggMirror(1.0, 1.5, 375.0, 125.0, 20), 0.9773844),  # exact from the range's start
    (BraggMirror(1.0, 1.02, 16.0, 3.0, 10**6), 1.2217305),  # unsnapped range ends: averaged
    (BraggMirror(1.0, 1.5, 30.0, 90.0, 20), 0.10471976),  # an edge just below 360 nm
])
def test_averaged_zones_match_numpy_in_xyz(mirror, theta):
    """The zones, panel counts and the edge-clustering map agree between the twins, so the
    float32 kernel keeps the numpy twin's nodes and weights, also where zones are narrow."""
    theta32 = float(np.float32(theta))
    expected = cm.averaged_xyz(mirror, theta32)
    gpu = colour_landmarks_gpu.landmark_xyz(mirror, theta32, "averaged")
    np.testing.assert_allclose(gpu, expected, rtol=0.0, atol=ZONES_ATOL)


# Below N = 16 with host == n1 <= n2 every zone is exact, and the pipeline compiles N into an
# unrolled recurrence for U_{N-1} (EXACT_PERIODS in wgsl/colour/landmark_methods.wgsl): one pipeline
# per N, with no branch between pass bands, band edges and gaps.
EXACT_LAYERS = {
    "n2=1.5": (1.5, 100.0, 150.0),
    "n2=4": (4.0, 80.0, 60.0),
    "n2=100": (100.0, 100.0, 5.0),  # |cos K Lambda| up to ~50: U_14 near float32's range
}


@pytest.mark.parametrize("periods", [1, 2, 7, 15, 16])
@pytest.mark.parametrize("layers", EXACT_LAYERS.values(), ids=EXACT_LAYERS.keys())
def test_averaged_exact_spectrum_pipelines_match_numpy(periods, layers):
    n2, d1, d2 = layers
    mirror = BraggMirror(1.0, n2, d1, d2, periods)
    theta = np.float32(np.arange(0.0, 90.0, 7.5) * DEG).astype(np.float64)
    expected = cm.averaged_xyz(mirror, theta)
    got = colour_landmarks_gpu.landmark_xyz(mirror, theta, "averaged")
    assert np.all(np.isfinite(got))
    assert delta_e(got, expected).max() <= ISSUE_DE


@pytest.mark.parametrize(("mirror", "specialised"), [
    (BraggMirror(1.0, 1.5, 100.0, 150.0, 15), 15),
    (BraggMirror(1.0, 1.5, 100.0, 150.0, 16), 0),  # averaged zones: N read at run time
    (BraggMirror(1.5, 1.0, 100.0, 150.0, 5), 0),  # n2 evanescent at some angles
    (BraggMirror(1.59, 1.67, 81.6, 78.4, 8, host=1.0), 0),  # Appendix D host
])
def test_exact_periods_specialise_only_pipelines_whose_zones_are_all_exact(mirror, specialised):
    kernel, _ = colour_landmarks_gpu._kernel_and_params(mirror, "averaged", 3)
    assert kernel.constants["EXACT_PERIODS"] == specialised


def test_exact_periods_are_for_averaged_only():
    kernel, _ = colour_landmarks_gpu._kernel_and_params(GRID[0], "subdivided", 3)
    assert GRID[0].N < cm.AVERAGING_MIN_PERIODS
    assert kernel.constants["EXACT_PERIODS"] == 0


def test_averaged_exact_spectrum_at_extreme_grazing_is_near_the_converged_integral():
    """At 89.99 degrees (|W| ~ 1e3) the exact spectrum has transmission dips narrower than
    float32 resolves in x = cos K Lambda; the numpy twin's nodes land on some of them. Its
    colour is then 0.78 dE2000 from a converged integral, the float32 kernel's 0.07, and the
    twins 0.7 apart: here the GPU is the better of the two."""
    mirror = BraggMirror(1.0, 1.50001, 100.0, 100.0, 12)
    theta = np.array([float(np.float32(89.99 * DEG))])
    converged = bench_rgb.fine_xyz(mirror, theta, 0.002)
    got = colour_landmarks_gpu.landmark_xyz(mirror, theta, "averaged")
    assert delta_e(got, converged).max() <= 0.2


# --------------------------------------------------------------------------- API and edges


@pytest.mark.parametrize("method", METHODS)
def test_backend_dispatch_and_theta_shapes(method):
    mirror = GRID[17]
    theta = np.linspace(0.0, 1.5, 6).reshape(2, 3)
    xyz = mirror.xyz(theta, method=method, backend="gpu")
    assert xyz.shape == (2, 3, 3)
    np.testing.assert_array_equal(xyz.reshape(-1, 3),
                                  colour_landmarks_gpu.landmark_xyz(mirror, theta.ravel(), method))
    assert mirror.xyz(0.25, method=method, backend="gpu").shape == (3,)
    assert mirror.xyz(np.zeros((0, 4)), method=method, backend="gpu").shape == (0, 4, 3)
    assert mirror.rgb([0.1], method=method, backend="gpu").shape == (1, 3)
    assert method in GPU_COLOUR_METHODS


def test_subdivided_options():
    mirror = GRID[22]
    # s = 1 subdivides nothing: the basic approximation.
    np.testing.assert_allclose(mirror.xyz(THETA, method="subdivided", backend="gpu", s=1),
                               mirror.xyz(THETA, method="approx", backend="gpu"), atol=1e-7)
    fine = mirror.xyz(THETA, method="subdivided", backend="gpu", s=6)
    assert not np.allclose(fine, mirror.xyz(THETA, method="subdivided", backend="gpu"))
    for bad in (0, -2, 2.5, True, "3", cm.MAX_SUBDIVISIONS + 1):
        with pytest.raises(ValueError, match=r"\bs\b"):
            mirror.xyz(0.2, method="subdivided", backend="gpu", s=bad)
    with pytest.raises(ValueError, match="method 'approx' takes no option 's'"):
        mirror.xyz(0.2, method="approx", backend="gpu", s=3)  # as numpy: no such option


# "averaged"'s speed options, each a pipeline constant: N = 5 and 12 below averaging_from
# (unrolled recurrence), 12 and 15 averaged sooner, an Appendix D host (geometry path), and
# the short-period zones that are exact at any N.
AVERAGED_OPTIONS = [
    (BraggMirror(1.0, 1.5, 250.0, 250.0, 5), {"panels_per_oscillation": 1}),
    (BraggMirror(1.0, 1.5, 247.0, 741.0, 12), {"averaging_from": 10}),
    (BraggMirror(1.0, 1.5, 247.0, 741.0, 12), {"averaging_from": 13,
                                               "panels_per_oscillation": 1}),
    (BraggMirror(1.0, 1.5, 247.0, 741.0, 15), {"averaging_from": 15}),
    (BraggMirror(1.59, 1.67, 81.6, 78.4, 8, host=1.0), {"averaging_from": 2}),
    (BraggMirror(1.0, 1.5, 25.0, 35.0, 50), {"panels_per_oscillation": 1}),
]


@pytest.mark.parametrize(("mirror", "options"), AVERAGED_OPTIONS)
def test_averaged_options_match_numpy(mirror, options):
    expected = mirror.xyz(THETA, "averaged", "numpy", **options)
    got = mirror.xyz(THETA, "averaged", "gpu", **options)
    assert delta_e(got, expected).max() <= ISSUE_DE
    # Each case changes the colours by 0.7 to 7 dE2000, so a kernel that ignored the option
    # would fail.
    assert delta_e(got, mirror.xyz(THETA, "averaged", "gpu")).max() > 3 * ISSUE_DE


def test_averaged_options_are_pipeline_constants():
    mirror = BraggMirror(1.0, 1.5, 100.0, 150.0, 12)
    kernel, _ = colour_landmarks_gpu._kernel_and_params(mirror, "averaged", 3, 12, 2)
    # N = 12 is averaged from 12 on: as from any averaging_from in [2, 12], one pipeline.
    assert kernel.constants["AVERAGING_MIN_PERIODS"] == 2
    assert kernel.constants["PANELS_PER_OSCILLATION"] == 2.0
    assert kernel.constants["EXACT_PERIODS"] == 0
    assert kernel is colour_landmarks_gpu._kernel_and_params(mirror, "averaged", 3, 5, 2)[0]
    kernel, _ = colour_landmarks_gpu._kernel_and_params(mirror, "averaged", 3, 13, 2)
    assert kernel.constants["EXACT_PERIODS"] == 12
    assert kernel.constants["AVERAGING_MIN_PERIODS"] == cm.AVERAGING_MIN_PERIODS
    # The paper's methods have no such options: their pipelines do not depend on them.
    kernel, _ = colour_landmarks_gpu._kernel_and_params(mirror, "approx", 3, 13, 2)
    assert "AVERAGING_MIN_PERIODS" not in kernel.constants


@pytest.mark.parametrize("backend", ["numpy", "gpu"])
def test_averaged_options_are_refused_outside_their_ranges(backend):
    mirror = GRID[22]
    for bad in (1, 0, cm.MAX_AVERAGING_FROM + 1, 10.0, True, "16", None):
        with pytest.raises(ValueError, match="averaging_from"):
            mirror.xyz(0.2, "averaged", backend, averaging_from=bad)
    for bad in (0, cm.MAX_PANELS_PER_OSCILLATION + 1, 1.5, 3.0, math.nan, True, "3"):
        with pytest.raises(ValueError, match="panels_per_oscillation"):
            mirror.xyz(0.2, "averaged", backend, panels_per_oscillation=bad)
    with pytest.raises(ValueError, match="takes no option 'averaging_from'"):
        mirror.xyz(0.2, "approx", backend, averaging_from=10)


def test_work_beyond_the_loop_budget_is_refused_not_cut_short():
    """s = 5000 sub-boxes per pass band take ~14 s iterations per landmark interval: beyond
    Mesa 22's loop budget, which would silently return a partial sum; refused there, and
    within 2e-4 of the numpy twin on a device without a budget (Mesa 25)."""
    mirror = BraggMirror(1.0, 1.5, 250.0, 250.0, 20)
    theta = np.linspace(0.0, 1.5, 16)
    within = mirror.xyz(theta, method="subdivided", backend="gpu", s=1000)
    np.testing.assert_allclose(within, mirror.xyz(theta, method="subdivided", s=1000), atol=2e-4)
    if gpu.loop_budget() is not None:
        with pytest.raises(gpu.LoopBudgetError, match=r"'subdivided'.*625 nm.*backend='numpy'"):
            mirror.xyz(theta, method="subdivided", backend="gpu", s=5000)
    else:
        np.testing.assert_allclose(mirror.xyz(theta, method="subdivided", backend="gpu", s=5000),
                                   mirror.xyz(theta, method="subdivided", s=5000), atol=2e-4)


EXTREME_MIRRORS = [
    BraggMirror(1.0, 1.5, 125.0, 375.0, 1),
    BraggMirror(1.0, 1.5, 125.0, 375.0, 2),
    BraggMirror(1.0, 1.5, 125.0, 375.0, 2**31 - 1),
    BraggMirror(1.0, 1.5, 0.0, 375.0, 20),  # d1 = 0: every gap closed
    BraggMirror(1.0, 1.5, 375.0, 0.0, 20),  # d2 = 0: bulk n1
    BraggMirror(1.3, 1.3, 100.0, 100.0, 20),  # n1 = n2
    BraggMirror(1.0, 1.5, 530.0 / 4, 530.0 / 6, 100),  # quarter wave: even gaps closed
    BraggMirror(1.0, 2.5, 1e-3, 1e-3, 20),
    BraggMirror(1.0, 1.5, 5000.0, 5000.0, 50),  # ~70 landmarks per polarisation
    BraggMirror(1.5, 1.0, 100.0, 200.0, 1),
]
EXTREME_HOSTS = [
    BraggMirror(1.3, 2.5, 300.0, 20.0, 20, host=2.0),  # dense host: total reflection
    BraggMirror(1.59, 1.67, 81.6, 78.4, 2**31 - 1, host=1.0),
]
EXTREME_THETA = np.array([0.0, 1e-6, math.atan(1.5), 0.7, 1.2, 1.5, 1.5707, 1.57079,
                          math.pi / 2])


@pytest.mark.parametrize("method", METHODS)
def test_finite_and_bounded_at_extremes(method):
    mirrors = EXTREME_MIRRORS + (EXTREME_HOSTS if method == "averaged" else [])
    white = cm._white()
    for mirror in mirrors:
        xyz = colour_landmarks_gpu.landmark_xyz(mirror, EXTREME_THETA, method)
        assert np.all(np.isfinite(xyz)), mirror
        assert np.all(xyz >= -1e-6) and np.all(xyz <= white * (1.0 + 1e-4)), mirror
        # Grazing incidence reflects everything, unless no n2 layer is there (host == n1:
        # nothing reflects at all).
        bulk = mirror.n1 == mirror.n2 or mirror.d2 == 0.0
        np.testing.assert_allclose(xyz[-1], 0.0 if bulk else white, rtol=1e-5, atol=1e-12)


BULK_MIRRORS = [
    BraggMirror(1.0, 1.5, 0.0, 0.0, 20),  # no period at all
    BraggMirror(1.3, 1.3, 100.0, 100.0, 20),
    BraggMirror(1.2, 1.5, 100.0, 0.0, 20, host=1.0),  # Appendix D host: Fresnel host | n1
    BraggMirror(1.5, 1.5, 100.0, 100.0, 5, host=2.0),  # total reflection beyond 48.6 deg
]


@pytest.mark.parametrize("mirror", BULK_MIRRORS, ids=str)
@pytest.mark.parametrize("backend", ["numpy", "gpu"])
def test_mirrors_without_an_n2_layer_have_their_exact_colour(mirror, backend):
    """No n2 layer: R is the host | n1 Fresnel reflectance at every wavelength, so every
    landmark method gives R times white (approx gave white, grazing gave white for any host)."""
    theta = np.concatenate([np.linspace(0.0, 1.5, 7), EXTREME_THETA[-3:]])
    want = mirror.reflectance(550.0, theta, "unpolarized")[:, None] * cm._white()
    methods = METHODS if mirror.host == mirror.n1 else ["averaged"]
    for method in methods:
        got = mirror.xyz(theta, method=method, backend=backend)
        np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-7, err_msg=method)


def _unpack_slopes(words: np.ndarray) -> np.ndarray:
    """Independent decoder of colour_landmarks_gpu.pack_density_slopes (two's complement)."""
    words = words.astype(np.int64)
    channels = []
    shift = 0
    for bits in colour_landmarks_gpu.DENSITY_SLOPE_BITS:
        value = (words >> shift) & ((1 << bits) - 1)
        channels.append(np.where(value >= 1 << (bits - 1), value - (1 << bits), value))
        shift += bits
    return np.stack(channels, axis=-1) * colour_landmarks_gpu.DENSITY_SLOPE_STEP


def test_packed_table_holds_the_densities_and_their_slopes_within_half_a_step():
    cmf = colour_landmarks_gpu.cmf_table()
    packed = colour_landmarks_gpu.packed_cmf_table()
    nodes = cmf.shape[0] // 2
    np.testing.assert_array_equal(packed[:, :3].view(np.float32), cmf[:, :3])
    slope = np.diff(cmf[:nodes, :3].astype(np.float64), axis=0)
    error = np.abs(_unpack_slopes(packed[: nodes - 1, 3]) - slope)
    assert np.all(error <= colour_landmarks_gpu.DENSITY_SLOPE_STEP / 2)
    # The steps are not needlessly coarse: the slopes span most of the range (85, 82, 73 %).
    limit = (2 ** (np.array(colour_landmarks_gpu.DENSITY_SLOPE_BITS) - 1) - 1
             ) * colour_landmarks_gpu.DENSITY_SLOPE_STEP
    assert np.all(np.abs(slope).max(axis=0) > 0.5 * limit)
    assert not np.any(packed[nodes - 1 :, 3])


def test_pack_density_slopes_refuses_slopes_that_do_not_fit():
    step = colour_landmarks_gpu.DENSITY_SLOPE_STEP
    edge = np.array([1023, -1023, -511]) * step
    np.testing.assert_allclose(_unpack_slopes(colour_landmarks_gpu.pack_density_slopes(edge)),
                               edge)
    for bad in (edge + np.array([0.0, 0.0, -step[2]]), np.array([np.nan, 0.0, 0.0]),
                np.array([1e30, 0.0, 0.0])):
        with pytest.raises(ValueError, match="slope"):
            colour_landmarks_gpu.pack_density_slopes(bad)


def test_the_kernel_unpacks_the_slopes_as_python_packs_them():
    """The WGSL decoder's steps and bit fields are colour_landmarks_gpu's (a step off by 2x
    would move the density by up to its slope, below what the colour twins resolve)."""
    source = (gpu.shader_dir() / "colour/landmark_methods.wgsl").read_text()
    steps = re.search(r"DENSITY_SLOPE_STEP: vec3<f32> = vec3<f32>\(([^)]*)\)", source)
    np.testing.assert_array_equal(np.array(steps.group(1).split(","), float),
                                  colour_landmarks_gpu.DENSITY_SLOPE_STEP)
    fields = re.findall(r"extractBits\(word, (\d+)u, (\d+)u\)", source)
    bits = colour_landmarks_gpu.DENSITY_SLOPE_BITS
    offsets = np.cumsum((0, *bits[:-1]))
    assert [(int(o), int(b)) for o, b in fields] == list(zip(offsets, bits, strict=True))
