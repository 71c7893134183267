"""Prefiltered environments (wgbragg.lighting.environment_prefilter): the resampled input maps
(exact
area averages, the disc's energy), the prefiltered sums against closed forms and independent
quadratures, the float32 GPU bake against its float64 numpy twin, and the WGSL lookup
(wgsl/lighting/environment_prefilter_lookup.wgsl) against PrefilteredEnvironment.lookup.

Tolerances. The GPU bake sums float32 kernels per input row and then over rows, so its ratios
stay within ~1e-6 of float64 (``TWIN_RTOL`` leaves a margin for the float32 directions and
radiance); a constant environment prefilters to its constant within ``CONSTANT_RTOL`` on both
backends. Direction moments are compared absolutely (their components cross zero).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate

from wgbragg import gpu
from wgbragg.bsdf.microfacet import ggx_D, ggx_G1
from wgbragg.lighting.environment_map import EnvironmentMap
from wgbragg.lighting.environment_prefilter import (
    PrefilteredEnvironment,
    _Grid,
    _Plan,
    level_sizes,
    prefilter_environment,
    resample_environment,
    window_angle,
)
from wgbragg.lighting.procedural_environment import ProceduralEnvironment
from wgbragg.scene.model import Environment

KERNELS = Path(__file__).resolve().parent / "kernels"
"""The test suite's own WGSL kernels (not shipped in the wheel)."""

SMALL = ((64, 32), (32, 16))
CONSTANT_RTOL = 1e-5
TWIN_RTOL = 1e-4
TWIN_ATOL = 1e-4  # mean and second moments: |components| <= 1
LOOKUP_TOL = 1e-5
CONSTANT = np.array([0.7, 1.3, 2.1])


def centres(width, height):
    return _Grid(width, height).centres()


def structured_map(height=32, width=64, seed=0):
    """Random texels over a decade, a gradient in y and a bright blob: structure at every
    scale."""
    rng = np.random.default_rng(seed)
    d = centres(width, height)
    blob = np.exp(40.0 * (d @ np.array([0.6, 0.48, 0.64]) - 1.0))[..., None]
    radiance = (10.0 ** rng.uniform(-0.5, 0.5, (height, width, 3))
                + (1.0 + d[..., 1:2]) * np.array([0.2, 0.4, 0.9]) + 50.0 * blob)
    return EnvironmentMap(radiance, intensity=1.5)


def smooth_map():
    """A smooth environment, finely sampled: a broad lobe, a sky gradient and a floor."""
    d = centres(512, 256)
    s = np.array([0.3, 0.5, 0.8]) / np.linalg.norm([0.3, 0.5, 0.8])
    radiance = (0.2 + np.exp(3.0 * (d @ s - 1.0))[..., None] * np.array([1.0, 0.6, 0.3])
                + 0.1 * (1.0 + d[..., 1:2]) * np.array([0.2, 0.4, 1.0]))
    return EnvironmentMap(radiance)


def procedural(kind, **kwargs):
    return ProceduralEnvironment.from_scene(Environment(kind, **kwargs))


def matrices(second):
    """(..., 3, 3) symmetric matrices from (xx, yy, zz, xy, yz, zx)."""
    xx, yy, zz, xy, yz, zx = np.moveaxis(second, -1, 0)
    return np.stack([np.stack([xx, xy, zx], -1), np.stack([xy, yy, yz], -1),
                     np.stack([zx, yz, zz], -1)], -2)


# --------------------------------------------------------------------------- sizes, windows


def test_level_sizes_and_windows():
    assert level_sizes(1.0) == ((64, 32), (32, 16))
    assert level_sizes(0.5) == ((64, 32), (32, 16))
    assert level_sizes(0.1) == ((128, 64), (64, 32))
    assert level_sizes(0.05) == ((256, 128), (128, 64))
    assert level_sizes(0.02) == ((512, 256), (256, 128))
    assert level_sizes(0.01) == ((512, 256), (256, 128))
    assert level_sizes("cosine") == ((64, 32), (32, 16))
    assert window_angle("cosine") == window_angle(0.1) == pytest.approx(math.pi / 2)
    assert window_angle(0.05) == pytest.approx(2.0 * math.atan(0.5))
    # At the window's edge tan(r.h) = 10 alpha: D / D(n) = (1 + 100 alpha^2)^2 / 101^2, 1e-4
    # to first order.
    for alpha in (0.01, 0.03, 0.05):
        cos_h = math.cos(0.5 * window_angle(alpha))
        assert float(ggx_D(cos_h, alpha) / ggx_D(1.0, alpha)) == pytest.approx(
            (1.0 + 100.0 * alpha**2) ** 2 / 101.0**2, rel=1e-9)


def test_plan_visits_every_texel_in_the_window():
    """The rows and column spans the GPU loops over hold every texel centre that the window
    (tested as numpy does) admits, and the blocks keep the loop count in Mesa 22's budget."""
    for level, sizes in ((0.05, ((256, 128), (128, 64))), (0.3, ((96, 40), (20, 12))),
                         ("cosine", SMALL), (0.02, ((64, 32), (64, 32)))):
        plan = _Plan.make(level, sizes)
        (w_in, h_in), (w_out, h_out) = sizes
        l = centres(w_in, h_in)
        r = centres(w_out, h_out)
        for y in range(0, h_out, max(1, h_out // 8)):
            for x in range(0, w_out, max(1, w_out // 8)):
                q = 0.5 * np.sum((r[y, x] - l) ** 2, axis=-1)
                visited = np.zeros((h_in, w_in), bool)
                for row in range(plan.first[y], plan.end[y]):
                    n = plan.spans[y, row]
                    if n >= 0:
                        count = min(2 * n + 1, w_in)
                        visited[row, (plan.centre[x] - n + np.arange(count)) % w_in] = True
                assert not np.any((q <= plan.q_max) & ~visited), (level, y, x)
        cost = np.where(plan.spans >= 0, np.minimum(2 * plan.spans + 1, w_in) + 1, 0)
        for begin, end in plan.blocks():
            assert cost[:, begin:end].sum(axis=1).max() <= 60_000


# --------------------------------------------------------------------------- input maps


def test_resampled_map_is_its_area_average():
    environment = structured_map(24, 40, seed=3)
    omega = _Grid(40, 24).solid_angle[:, None, None]
    energy = np.sum(environment.radiance * omega, axis=(0, 1)) * environment.intensity
    for width, height in ((40, 24), (64, 32), (16, 8), (256, 128), (7, 5)):
        resampled = resample_environment(environment, width, height)
        total = np.sum(resampled * _Grid(width, height).solid_angle[:, None, None], axis=(0, 1))
        np.testing.assert_allclose(total, energy, rtol=1e-12)
    np.testing.assert_allclose(resample_environment(environment, 40, 24),
                               environment.radiance * environment.intensity, rtol=1e-13)
    # A finer grid nesting in the source's sees the source's texels unchanged (the texels
    # holding its centres: radiance_at blends texels bilinearly, the resampling boxes them).
    x, y = environment.direction_to_texel(centres(120, 72))
    np.testing.assert_allclose(resample_environment(environment, 120, 72),
                               environment.radiance[y, x] * environment.intensity, rtol=1e-12)


@pytest.mark.parametrize("kind", ["sky", "studio"])
def test_disc_energy_and_position(kind):
    """The rasterised disc carries its analytic energy (within 1 %, here to rounding) and sits
    where it should: its energy-weighted direction within a tenth of a texel of its centre."""
    environment = procedural(kind)
    dark = dataclasses.replace(environment, disc_radiance=np.zeros(3))
    analytic = environment.disc_radiance * environment.disc_solid_angle
    for width in (64, 128, 256, 512):
        grid = _Grid(width, width // 2)
        disc = resample_environment(environment, width, width // 2) - resample_environment(
            dark, width, width // 2)
        weight = disc[..., 1] * grid.solid_angle[:, None]
        np.testing.assert_allclose(np.sum(disc * grid.solid_angle[:, None, None], axis=(0, 1)),
                                   analytic, rtol=1e-2)
        centroid = np.einsum("yx,yxc->c", weight, grid.centres())
        off = math.acos(min(1.0, centroid @ environment.disc_direction / np.linalg.norm(centroid)))
        assert off < 0.1 * 2.0 * math.pi / width
    uniform = resample_environment(procedural("uniform", radiance=tuple(CONSTANT)), 32, 16)
    np.testing.assert_allclose(uniform, np.broadcast_to(CONSTANT, uniform.shape), rtol=1e-15)


# --------------------------------------------------------------------------- closed forms


@pytest.mark.gpu
@pytest.mark.parametrize("backend", ["gpu", "numpy"])
def test_constant_environment_prefilters_to_itself(backend):
    levels = (0.5, 0.1, "cosine")
    for source in (EnvironmentMap(np.broadcast_to(CONSTANT / 2.0, (16, 32, 3)), intensity=2.0),
                   procedural("uniform", radiance=tuple(CONSTANT))):
        pre = prefilter_environment(source, levels, backend, sizes=SMALL, progress=False)
        for radiance in pre.radiance:
            np.testing.assert_allclose(radiance, np.broadcast_to(CONSTANT, radiance.shape),
                                       rtol=CONSTANT_RTOL)


def mean_length(alpha):
    """|mean| of the GGX kernel in a uniform environment: a 1D quadrature over q = 1 - r.l."""
    q_max = 1.0 - math.cos(window_angle(alpha))

    def kernel(q):
        return float(ggx_D(math.sqrt(1.0 - 0.5 * q), alpha) * ggx_G1(1.0 - q, alpha))

    points = [min(q_max, k * alpha * alpha) for k in (1.0, 10.0, 100.0)]
    norm = integrate.quad(kernel, 0.0, q_max, points=points, limit=200, epsabs=0)[0]
    first = integrate.quad(lambda q: kernel(q) * (1.0 - q), 0.0, q_max, points=points,
                           limit=200, epsabs=0)[0]
    return first / norm


@pytest.fixture(scope="module")
def uniform_levels():
    levels = (0.05, 0.1, 0.25, 0.5, 1.0, "cosine")
    return prefilter_environment(procedural("uniform", radiance=tuple(CONSTANT)), levels,
                                 progress=False)


@pytest.mark.gpu
def test_uniform_environment_moments(uniform_levels):
    """Mean along r, shorter as the lobe widens (matching a 1D quadrature of the kernel within
    the texel sum's discretisation, measured <= 3e-4), covariance positive semidefinite; the
    cosine kernel's moments in closed form: mean 2/3 r, second (I + r r^T) / 4."""
    lengths = []
    for k, level in enumerate(uniform_levels.levels):
        radiance = uniform_levels.radiance[k]
        np.testing.assert_allclose(radiance, np.broadcast_to(CONSTANT, radiance.shape),
                                   rtol=CONSTANT_RTOL)
        height, width = radiance.shape[:2]
        r = centres(width, height)
        mean = uniform_levels.mean[k]
        length = np.linalg.norm(mean, axis=-1)
        assert np.max(np.linalg.norm(np.cross(mean, r), axis=-1) / length) < 2e-3
        assert np.all(np.sum(mean * r, axis=-1) > 0.0)
        second = matrices(uniform_levels.second[k])
        covariance = second - mean[..., :, None] * mean[..., None, :]
        assert np.all(np.trace(covariance, axis1=-2, axis2=-1) >= 0.0)
        assert np.linalg.eigvalsh(covariance).min() >= -1e-6
        np.testing.assert_allclose(np.trace(second, axis1=-2, axis2=-1), 1.0, atol=1e-5)
        if level == "cosine":
            np.testing.assert_allclose(length, 2.0 / 3.0, atol=1e-3)
            expected = 0.25 * (np.eye(3) + r[..., :, None] * r[..., None, :])
            np.testing.assert_allclose(second, expected, atol=1e-3)
        else:
            np.testing.assert_allclose(length, mean_length(level), atol=1e-3)
            lengths.append(np.median(length))
    assert np.all(np.diff(lengths) < 0.0)


def irradiance_over_pi(environment, n, nodes=256):
    """E(n) / pi by Gauss-Legendre in cos and the midpoint rule in azimuth about n; the disc,
    wholly above or below n's horizon, in closed form (a cap's mean direction is its axis
    times (1 + cos radius) / 2)."""
    t = np.cross(n, [0.3, 0.1, 0.9])
    t /= np.linalg.norm(t)
    b = np.cross(n, t)
    x, w = np.polynomial.legendre.leggauss(nodes)
    c, wc = 0.5 * (x + 1.0), 0.5 * w
    phi = 2.0 * np.pi * (np.arange(2 * nodes) + 0.5) / (2 * nodes)
    s = np.sqrt(1.0 - c * c)[:, None, None]
    d = c[:, None, None] * n + s * np.cos(phi)[:, None] * t + s * np.sin(phi)[:, None] * b
    radiance = environment.radiance(d, disc=False)
    irradiance = np.einsum("i,ijc->c", wc * c, radiance) * (np.pi / nodes)
    towards = n @ environment.disc_direction
    assert abs(towards) > math.sqrt(1.0 - environment.disc_cos**2)
    if towards > 0.0:
        irradiance += (environment.disc_radiance * environment.disc_solid_angle * towards
                       * 0.5 * (1.0 + environment.disc_cos))
    return irradiance / np.pi


@pytest.mark.gpu
@pytest.mark.parametrize("kind", ["sky", "studio"])
def test_cosine_level_is_irradiance_over_pi(kind):
    """Within 1 % (measured <= 0.31 %) at texels from the zenith to the nadir."""
    environment = procedural(kind)
    pre = prefilter_environment(environment, ["cosine"], progress=False)
    r = centres(32, 16)
    # Texels whose centres see the disc wholly above or below their horizon.
    for y, x in ((0, 31), (3, 26), (4, 10), (5, 11), (7, 15), (8, 15), (9, 28), (12, 1),
                 (15, 22)):
        np.testing.assert_allclose(pre.radiance[0][y, x],
                                   irradiance_over_pi(environment, r[y, x]), rtol=1e-2)


@pytest.mark.gpu
def test_narrow_lobes_approach_the_box_filtered_source():
    """Against the source averaged over each output texel, a smooth environment's GGX
    radiance at alpha = 0.05 is within 5 % (measured 3.6 %), at 0.02 within 1 % (0.68 %):
    the error shrinks about as alpha^2 until the texel's own footprint dominates."""
    environment = smooth_map()
    pre = prefilter_environment(environment, [0.05, 0.02], progress=False)
    errors = []
    for radiance, bound in zip(pre.radiance, (0.05, 0.01), strict=True):
        height, width = radiance.shape[:2]
        box = resample_environment(environment, width, height)
        errors.append(np.max(np.abs(radiance / box - 1.0)))
        assert errors[-1] < bound
    assert errors[1] < errors[0] / 3.0


# --------------------------------------------------------------------------- GPU twin


SOURCES = {
    "map": lambda: structured_map(),
    "sky": lambda: procedural("sky", intensity=0.5),
    # Softboxes (smooth, in the rasterized part) turned with rotate_deg.
    "softbox-studio": lambda: procedural("softbox-studio", rotate_deg=30.0),
}


@pytest.mark.gpu
@pytest.mark.parametrize("source", list(SOURCES))
def test_gpu_matches_numpy(source):
    environment = SOURCES[source]()
    levels = (0.5, 0.1, "cosine")
    twin = prefilter_environment(environment, levels, "numpy", sizes=SMALL, progress=False)
    pre = prefilter_environment(environment, levels, "gpu", sizes=SMALL, progress=False)
    for k in range(len(levels)):
        np.testing.assert_allclose(pre.radiance[k], twin.radiance[k], rtol=TWIN_RTOL)
        np.testing.assert_allclose(pre.mean[k], twin.mean[k], atol=TWIN_ATOL)
        np.testing.assert_allclose(pre.second[k], twin.second[k], atol=TWIN_ATOL)


@pytest.mark.gpu
def test_gpu_splits_long_loops():
    """Whole hemispheres of 512 x 256 texels: each texel needs ~65k loop turns, past Mesa 22's
    limit, so the bake runs in blocks of rows and still matches the twin."""
    environment = structured_map(64, 128, seed=5)
    sizes = ((512, 256), (8, 4))
    assert len(_Plan.make(0.5, sizes).blocks()) > 1
    twin = prefilter_environment(environment, [0.5], "numpy", sizes=sizes)
    pre = prefilter_environment(environment, [0.5], "gpu", sizes=sizes)
    np.testing.assert_allclose(pre.radiance[0], twin.radiance[0], rtol=TWIN_RTOL)
    np.testing.assert_allclose(pre.mean[0], twin.mean[0], atol=TWIN_ATOL)
    np.testing.assert_allclose(pre.second[0], twin.second[0], atol=TWIN_ATOL)


@pytest.mark.gpu
def test_gpu_loop_blocks_hold_for_outputs_narrower_than_a_simd_group():
    """Output rows of 2 texels: unpadded, one SIMD group of 8 lanes held all 4 output rows,
    whose loops (each within MAX_ITERATIONS per block) ran in lockstep past Mesa 22's budget
    and lost 5% of row 2's radiance."""
    environment = structured_map(64, 128, seed=5)
    sizes = ((1024, 512), (2, 4))
    twin = prefilter_environment(environment, [0.05], "numpy", sizes=sizes)
    pre = prefilter_environment(environment, [0.05], "gpu", sizes=sizes)
    np.testing.assert_allclose(pre.radiance[0], twin.radiance[0], rtol=TWIN_RTOL)
    np.testing.assert_allclose(pre.mean[0], twin.mean[0], atol=TWIN_ATOL)
    np.testing.assert_allclose(pre.second[0], twin.second[0], atol=TWIN_ATOL)


@pytest.mark.gpu
@pytest.mark.parametrize("backend", ["gpu", "numpy"])
def test_black_windows_fall_back_to_r(backend):
    """A black upper half: texels whose window (53 degrees at alpha = 0.05) sees only black
    have radiance 0, mean r and second r r^T; the others see the lower half."""
    radiance = np.ones((32, 64, 3))
    radiance[:16] = 0.0
    pre = prefilter_environment(EnvironmentMap(radiance), [0.05], backend, sizes=SMALL)
    r = centres(32, 16)
    theta = np.pi * (np.arange(16) + 0.5) / 16
    black = theta < np.pi / 2 - window_angle(0.05)
    assert black.sum() == 3
    np.testing.assert_array_equal(pre.radiance[0][black], 0.0)
    np.testing.assert_allclose(pre.mean[0][black], r[black], atol=1e-7)
    second = np.concatenate([r * r, r * np.roll(r, -1, axis=-1)], axis=-1)
    np.testing.assert_allclose(pre.second[0][black], second[black], atol=1e-7)
    white = theta > np.pi / 2 + window_angle(0.05)
    assert white.sum() == 3
    np.testing.assert_allclose(pre.radiance[0][white], 1.0, rtol=CONSTANT_RTOL)


# --------------------------------------------------------------------------- lookup, layout


def lookup_directions(n, seed):
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    special = np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [-0.0, 0.0, -1.0],
                        [1e-3, 0.0, -1.0], [-1e-3, 0.0, -1.0], [1e-30, 1.0, 1e-30],
                        [1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [3e-5, -1.0, 1e-4]])
    d[:len(special)] = special
    return (d / np.linalg.norm(d, axis=-1, keepdims=True)).astype(np.float32)


@pytest.fixture(scope="module")
def sky_levels():
    return prefilter_environment(procedural("sky"), [0.5, "cosine", 0.1, 0.5], progress=False)


@pytest.mark.gpu
def test_gpu_lookup_matches_numpy(sky_levels):
    records, texels = sky_levels.packed()
    n = 4000
    d = lookup_directions(n, seed=2)
    level = np.arange(n) % len(sky_levels.levels)
    queries = np.column_stack([d, level]).astype(np.float32)
    (out,) = gpu.compute_pipeline(str(KERNELS / "environment_prefilter_lookup_eval.wgsl")).run(
        [records, texels, queries], [((n, 4, 4), np.float32)])
    for k in range(len(sky_levels.levels)):
        mine = level == k
        radiance, mean, second = sky_levels.lookup(k, d[mine].astype(np.float64))
        np.testing.assert_allclose(out[mine, 0, :3], radiance, rtol=LOOKUP_TOL)
        np.testing.assert_allclose(out[mine, 1, :3], mean, atol=LOOKUP_TOL)
        np.testing.assert_allclose(out[mine, 2, :3], second[:, :3], atol=LOOKUP_TOL)
        np.testing.assert_allclose(out[mine, 3, :3], second[:, 3:], atol=LOOKUP_TOL)


@pytest.mark.gpu
def test_lookup_interpolates_texel_centres(sky_levels):
    """Texel centres return their texels; across the seam and beyond the first and last row
    centres the lookup wraps and clamps; midway it averages."""
    k = 2
    table = np.concatenate([sky_levels.radiance[k], sky_levels.mean[k], sky_levels.second[k]],
                           axis=-1)
    height, width = table.shape[:2]
    got = np.concatenate(sky_levels.lookup(k, centres(width, height)), axis=-1)
    np.testing.assert_allclose(got, table, rtol=1e-12, atol=1e-15)
    # The seam: phi = +-pi lies midway between the last and the first column.
    theta = np.pi * 10.5 / height
    seam = [math.sin(theta) * math.sin(math.pi), math.cos(theta), -math.sin(theta)]
    np.testing.assert_allclose(sky_levels.lookup(k, seam)[0],
                               0.5 * (table[10, 0, :3] + table[10, -1, :3]), rtol=1e-12)
    # Clamped in theta: +y (azimuth 0) reads the first row between its two middle columns.
    up = np.concatenate(sky_levels.lookup(k, [0.0, 1.0, 0.0]), axis=-1)
    column = width / 2 - 0.5
    low = math.floor(column)
    np.testing.assert_allclose(up, table[0, low] + (column - low) * (table[0, low + 1]
                                                                    - table[0, low]))


@pytest.mark.gpu
def test_levels_and_packed_layout(sky_levels):
    assert sky_levels.levels == (0.5, "cosine", 0.1, 0.5)
    np.testing.assert_array_equal(sky_levels.radiance[0], sky_levels.radiance[3])
    records, texels = sky_levels.packed()
    assert records.dtype == np.uint32 and texels.dtype == np.float32
    np.testing.assert_array_equal(records, [[32, 16, 0, 0], [32, 16, 512, 0],
                                            [64, 32, 1024, 0], [32, 16, 3072, 0]])
    assert texels.shape == (4 * 3584, 4)
    k, y, x = 2, 7, 13
    at = 4 * (1024 + y * 64 + x)
    np.testing.assert_array_equal(texels[at:at + 4, 3], 0.0)
    np.testing.assert_allclose(texels[at, :3], sky_levels.radiance[k][y, x], rtol=1e-7)
    np.testing.assert_allclose(texels[at + 1, :3], sky_levels.mean[k][y, x], rtol=1e-7)
    np.testing.assert_allclose(texels[at + 2, :3], sky_levels.second[k][y, x, :3], rtol=1e-7)
    np.testing.assert_allclose(texels[at + 3, :3], sky_levels.second[k][y, x, 3:], rtol=1e-7)
    with pytest.raises(ValueError, match="read-only"):
        sky_levels.radiance[0][0, 0, 0] = 1.0


# --------------------------------------------------------------------------- refusals


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: prefilter_environment(procedural("sky"), ["ggx"]), r"levels\[0\]"),
        (lambda: prefilter_environment(procedural("sky"), [0.5, 0.005]), r"levels\[1\].*0.01"),
        (lambda: prefilter_environment(procedural("sky"), [1.5]), r"levels\[0\].*\[0.01, 1\]"),
        (lambda: prefilter_environment(procedural("sky"), [True]), r"levels\[0\]"),
        (lambda: prefilter_environment(procedural("sky"), [math.nan]), r"levels\[0\]"),
        (lambda: prefilter_environment(procedural("sky"), "cosine"), "levels"),
        (lambda: prefilter_environment(procedural("sky"), []), "levels"),
        (lambda: prefilter_environment(procedural("sky"), [0.5], backend="cuda"), "backend"),
        (lambda: prefilter_environment(Environment("sky"), [0.5]), "source"),
        (lambda: prefilter_environment(np.ones((8, 16, 3)), [0.5]), "source"),
        (lambda: prefilter_environment(procedural("sky"), [0.5], sizes=(64, 32)), "sizes"),
        (lambda: prefilter_environment(procedural("sky"), [0.5], sizes=((64, 32), (1, 16))),
         "sizes"),
        (lambda: level_sizes(0.0), "level"),
        (lambda: resample_environment(procedural("sky"), 0, 8), "width"),
        (lambda: resample_environment(procedural("sky"), 8, 2.5), "height"),
        (lambda: PrefilteredEnvironment([0.5], [np.ones((4, 8, 3))], [], []), "mean"),
        (lambda: PrefilteredEnvironment([0.5], [np.ones((4, 8, 3))], [np.ones((4, 8, 3))],
                                        [np.ones((4, 8, 3))]), r"second\[0\]"),
    ],
)
def test_raises(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_lookup_raises():
    pre = PrefilteredEnvironment(["cosine"], [np.ones((4, 8, 3))], [np.ones((4, 8, 3))],
                                 [np.ones((4, 8, 6))])
    with pytest.raises(ValueError, match="level"):
        pre.lookup(1, [0.0, 1.0, 0.0])
    with pytest.raises(ValueError, match="directions"):
        pre.lookup(0, [0.0, 2.0, 0.0])
