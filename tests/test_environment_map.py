"""EnvironmentMap: the convention (Mitsuba 3's equirectangular orientation; the marked
panorama of tests/test_environment_panorama.py checks it end to end), the bilinear lookups, the
sampling density (from the mean of the bilinear luminance over each texel, checked by
quadrature; normalised; matched by the sampler in a chi-square test; free of the fireflies a
density of the texels' own luminance leaves around a small sun), n-dimensional input and
refusals; then the float32 WGSL twin (wgsl/lighting/environment_map.wgsl) against it on the
GPU.

GPU tolerances. The kernel sees the same float32 u and directions as numpy; it differs in its
float32 arithmetic and CDFs, rounded by up to 2**-25 each, which moves u within its CDF step by
up to ``CDF_ERROR``. So a sampled direction may differ from numpy's as much as numpy's moves
when u moves by ``CDF_ERROR`` (into the neighbouring texel, at a CDF step), plus
``DIRECTION_ATOL`` of float32 trigonometry. Densities agree to ``PDF_RTOL``, except for
directions within ``EDGE_MARGIN`` texels of a texel edge, which may lie in the neighbour and
are only checked to be finite. Radiance is continuous (bilinear): it agrees within
``RADIANCE_RTOL`` of the largest of the four texels blended (float32 image coordinates,
~1e-6 of a texel, times the step between neighbours, plus float32 rounding).
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import expected_direction_counts, pooled_chi2_pvalue

from wgbragg import EnvironmentMap, gpu

KERNELS = Path(__file__).resolve().parent / "kernels"
"""The test suite's own WGSL kernels (not shipped in the wheel)."""

CHI2_P_MIN = 1e-3
PDF_RTOL = 1e-4
EDGE_MARGIN = 1e-5
CDF_ERROR = 4 * 2.0**-24
DIRECTION_ATOL = 1e-6
RADIANCE_RTOL = 1e-4


def sky(height, width, seed, sun=1e4):
    """Random radiance over two decades with one texel ``sun`` times brighter."""
    rng = np.random.default_rng(seed)
    radiance = 10.0 ** rng.uniform(-1.0, 1.0, (height, width, 3))
    radiance[rng.integers(height), rng.integers(width)] *= sun
    return radiance


def sun_sky(height, width, radius, sun=1e4, seed=0):
    """A dim sky (brighter towards the zenith, dimmer below the horizon, with texel noise) and
    a disc of ``radius`` texels of radiance ``sun`` above the horizon, off the texel grid."""
    rng = np.random.default_rng(seed)
    v = (np.arange(height) + 0.5) / height
    brightness = 0.3 + 0.7 * np.clip(np.cos(np.pi * v), 0.0, 1.0)
    radiance = brightness[:, None, None] * [0.6, 0.8, 1.0] * rng.uniform(0.8, 1.2,
                                                                       (height, width, 1))
    y, x = np.mgrid[0:height, 0:width] + 0.5
    radiance[np.hypot(y - 0.3 * height - 0.23, x - 0.37 * width - 0.41) < radius] = sun
    return radiance


MAPS = {
    "sky": lambda: EnvironmentMap(sky(8, 16, seed=1), intensity=2.5),
    "sun": lambda: EnvironmentMap(sun_sky(16, 32, radius=1.5), intensity=0.5),
    "odd": lambda: EnvironmentMap(sky(5, 7, seed=2)),
    "one-row": lambda: EnvironmentMap(sky(1, 4, seed=3)),
    "wide": lambda: EnvironmentMap(sky(64, 128, seed=4, sun=1e6)),
    "black": lambda: EnvironmentMap(np.zeros((4, 8, 3))),
    "dim-half": lambda: EnvironmentMap(np.concatenate([np.zeros((3, 6, 3)), sky(3, 6, 5)])),
}


@pytest.fixture(params=list(MAPS))
def environment(request):
    return MAPS[request.param]()


def direction(theta, phi):
    """The convention's direction of polar angle ``theta = pi v`` (from +y) and azimuth
    ``phi = 2 pi u`` (Mitsuba 3's ``uv_to_direction``)."""
    theta, phi = np.broadcast_arrays(theta, phi)
    return np.stack(
        [np.sin(theta) * np.sin(phi), np.cos(theta), -np.sin(theta) * np.cos(phi)], axis=-1
    )


def texel_centres(environment):
    h, w = environment.height, environment.width
    theta = np.pi * (np.arange(h) + 0.5) / h
    phi = 2.0 * np.pi * (np.arange(w) + 0.5) / w
    return direction(theta[:, None], phi[None, :])


def texel_probabilities(environment):
    """Probability of each texel: density at its centre times its solid angle."""
    h, w = environment.height, environment.width
    cos_edges = np.cos(np.pi * np.arange(h + 1) / h)
    solid_angle = (2.0 * np.pi / w) * -np.diff(cos_edges)
    return environment.pdf(texel_centres(environment)) * solid_angle[:, None]


def random_directions(n, seed):
    v = np.random.default_rng(seed).normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


# --------------------------------------------------------------------------- convention


def test_texel_centres_see_their_texels(environment):
    centres = texel_centres(environment)
    x, y = environment.direction_to_texel(centres)
    h, w = environment.height, environment.width
    np.testing.assert_array_equal(y, np.broadcast_to(np.arange(h)[:, None], (h, w)))
    np.testing.assert_array_equal(x, np.broadcast_to(np.arange(w)[None, :], (h, w)))
    # Bilinear weights of 0 and 1 at the centres, up to the rounding of the angles.
    np.testing.assert_allclose(
        environment.radiance_at(centres), environment.radiance * environment.intensity,
        rtol=1e-9, atol=1e-9 * environment.radiance.max() * environment.intensity,
    )


def test_mitsuba_uv_mapping():
    """u = atan2(d_x, -d_z) / (2 pi) wrapped to [0, 1) and v = acos(d_y) / pi pick the texel,
    as Mitsuba 3's envmap maps directions to its image."""
    environment = EnvironmentMap(sky(12, 20, seed=11))
    d = random_directions(5000, seed=12)
    u = np.mod(np.arctan2(d[:, 0], -d[:, 2]) / (2.0 * np.pi), 1.0)
    v = np.arccos(d[:, 1]) / np.pi
    x, y = environment.direction_to_texel(d)
    np.testing.assert_array_equal(x, np.floor(u * 20).astype(int))
    np.testing.assert_array_equal(y, np.floor(v * 12).astype(int))
    # Named directions: -z at the left edge (the seam), +x a quarter across, +z at the centre,
    # -x three quarters across.
    x, _ = environment.direction_to_texel([[1e-9, 0, -1], [1, 0, 0], [0, 0, 1], [-1, 0, 0]])
    np.testing.assert_array_equal(x, [0, 5, 10, 15])


def test_bilinear_between_texel_centres():
    radiance = np.zeros((4, 8, 3))
    radiance[1, 2] = [8.0, 4.0, 2.0]
    environment = EnvironmentMap(radiance, intensity=0.5)
    centre = radiance[1, 2] * 0.5
    # A quarter of a texel right of the centre (u + 1/4 texel) and a quarter above it.
    u, v = (2.5 + 0.25) / 8, (1.5 - 0.25) / 4
    d = direction(np.pi * v, 2.0 * np.pi * u)
    np.testing.assert_allclose(environment.radiance_at(d), 0.75 * 0.75 * centre, rtol=1e-12)
    # Halfway to the next centre in u, on the row's centre line.
    d = direction(np.pi * 1.5 / 4, 2.0 * np.pi * 3.0 / 8)
    np.testing.assert_allclose(environment.radiance_at(d), 0.5 * centre, rtol=1e-12)
    # The density stays the texel's: the same anywhere inside it.
    inside = direction(np.pi * np.array([1.05, 1.5, 1.95]) / 4,
                       2.0 * np.pi * np.array([2.05, 2.5, 2.95]) / 8)
    assert np.ptp(environment.pdf(inside)) == 0.0


def test_bilinear_wraps_in_u_and_clamps_in_v():
    radiance = np.zeros((3, 6, 3))
    radiance[:, 0] = 1.0  # the first column: u in [0, 1/6]
    radiance[0] += [0.0, 2.0, 0.0]  # the top row
    environment = EnvironmentMap(radiance)
    theta = np.pi * 1.5 / 3
    # On the seam (-z), midway between the last column's centre and the first's.
    for x in (0.0, -0.0, 1e-12, -1e-12):
        seam = [x, math.cos(theta), -math.sin(theta)]
        np.testing.assert_allclose(environment.radiance_at(seam), [0.5, 0.5, 0.5], rtol=1e-9)
    # Above the first row's centres only u is interpolated: row 0 alone, up to +y.
    for theta in (1e-9, np.pi / 6 * 0.999):
        d = direction(theta, 2.0 * np.pi * 0.5 / 6)  # column 0's centre line
        np.testing.assert_allclose(environment.radiance_at(d), [1.0, 3.0, 1.0], rtol=1e-9)
    # Below the last row's centres, to -y: row 2 alone.
    d = direction(np.pi * 0.999, 2.0 * np.pi * 0.5 / 6)
    np.testing.assert_allclose(environment.radiance_at(d), [1.0, 1.0, 1.0], rtol=1e-9)
    # The poles themselves are at u = 1/2, between columns 2 and 3.
    np.testing.assert_array_equal(environment.radiance_at([0.0, 1.0, 0.0]), [0.0, 2.0, 0.0])
    np.testing.assert_array_equal(environment.radiance_at([0.0, -1.0, -0.0]), 0.0)


def test_one_row_map_interpolates_only_in_u():
    radiance = np.zeros((1, 4, 3))
    radiance[0, 1] = 4.0
    environment = EnvironmentMap(radiance)
    for theta in (1e-9, 0.3, np.pi / 2, 3.0, np.pi - 1e-9):
        d = direction(theta, 2.0 * np.pi * 1.25 / 4)
        np.testing.assert_allclose(environment.radiance_at(d), 3.0, rtol=1e-9)


def test_image_centre_looks_along_plus_z_and_row_0_up():
    radiance = np.zeros((9, 17, 3))
    radiance[4, 8] = [100.0, 200.0, 300.0]
    radiance[0, :] = [5.0, 0.0, 0.0]
    environment = EnvironmentMap(radiance)
    np.testing.assert_array_equal(environment.radiance_at([0.0, 0.0, 1.0]), radiance[4, 8])
    np.testing.assert_array_equal(environment.radiance_at([0.0, 1.0, 0.0]), radiance[0, 0])
    d = environment.sample(np.random.default_rng(0).random((20_000, 2)))
    x, y = environment.direction_to_texel(d)
    # The bilinear lookup spreads the centre texel over its 3 x 3 neighbourhood, row 0 into
    # the top half of row 1; so does the density.
    in_centre = (np.abs(x - 8) <= 1) & (np.abs(y - 4) <= 1)
    in_top = y <= 1
    assert in_centre.mean() > 0.97
    assert np.mean((x == 8) & (y == 4)) > 0.5
    assert in_top.mean() > 0.01
    # What the luminance floor leaves for the black texels: ~1e-3 of the samples.
    assert np.mean(~in_centre & ~in_top) < 3e-3
    mean = d[in_centre].mean(axis=0)
    np.testing.assert_allclose(mean / np.linalg.norm(mean), [0.0, 0.0, 1.0], atol=1e-2)


def test_sun_direction_convention():
    # A sun at azimuth az from +z towards +x (the scenes' procedural suns) lies at
    # u = 1/2 - az / 360 degrees.
    environment = EnvironmentMap(np.ones((18, 36, 3)))
    azimuth, elevation = np.radians(125.0), np.radians(32.0)
    sun = [
        math.cos(elevation) * math.sin(azimuth),
        math.sin(elevation),
        math.cos(elevation) * math.cos(azimuth),
    ]
    x, y = environment.direction_to_texel(sun)
    assert (int(x), int(y)) == (5, 5)  # 180 - 125 degrees of 360 by 10; 90 - 32 by 10


def test_seam_and_poles():
    environment = EnvironmentMap(sky(4, 8, seed=0))
    x, y = environment.direction_to_texel(
        [
            [0.0, 0.0, -1.0],
            [-0.0, 0.0, -1.0],
            [1e-9, 0.0, -1.0],
            [-1e-9, 0.0, -1.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
        ]
    )
    # The seam: -z itself and u just above 0 (+x side) in column 0, just below 1 in column 7;
    # the poles at u = 1/2.
    np.testing.assert_array_equal(x, [0, 0, 0, 7, 4, 4])
    np.testing.assert_array_equal(y, [2, 2, 2, 2, 0, 3])


# --------------------------------------------------------------------------- density


def test_pdf_integrates_to_one(environment):
    # Midpoint rule in (theta, phi) with sin theta: cells nest in texels, so the only error
    # is the rule's for sin theta, ~(pi / n_theta)^2 / 24.
    h, w = environment.height, environment.width
    n_theta, n_phi = h * -(-512 // h), 8 * w
    theta = np.pi * (np.arange(n_theta) + 0.5) / n_theta
    phi = 2.0 * np.pi * (np.arange(n_phi) + 0.5) / n_phi
    pdf = environment.pdf(direction(theta[:, None], phi[None, :]))
    integral = np.sum(pdf * np.sin(theta)[:, None]) * (np.pi / n_theta) * (2.0 * np.pi / n_phi)
    assert integral == pytest.approx(1.0, rel=1e-5)


def test_pdf_is_sampling_luminance_plus_floor(environment):
    # pdf = (S + f) / sum((S + f) Omega), S the sampling luminance, f = 1e-3 of its mean
    # (1 for a black map).
    luminance = environment.sampling_luminance
    cos_edges = np.cos(np.pi * np.arange(environment.height + 1) / environment.height)
    solid_angle = (2.0 * np.pi / environment.width) * -np.diff(cos_edges)[:, None]
    mean = np.sum(luminance * solid_angle) / (4.0 * np.pi)
    weight = luminance + (1e-3 * mean if mean > 0.0 else 1.0)
    np.testing.assert_allclose(
        environment.pdf(texel_centres(environment)),
        weight / np.sum(weight * solid_angle),
        rtol=1e-12,
    )


def bilinear_cell_means(environment, order=6):
    """Mean of the luminance of ``radiance_at`` (without the intensity) over each texel's solid
    angle, by quadrature: each texel split into quarters at its centre lines (where the
    bilinear lookup has its kinks), an ``order`` x ``order`` Gauss-Legendre rule in (theta,
    phi) with sin theta on each quarter, exact to rounding for these smooth integrands."""
    h, w = environment.height, environment.width
    x, weights = np.polynomial.legendre.leggauss(order)
    x, weights = 0.5 * (x + 1.0), 0.5 * weights  # on [0, 1]
    theta_edges = np.pi * np.arange(2 * h + 1) / (2 * h)  # quarter edges: texel edges, centres
    phi_edges = 2.0 * np.pi * np.arange(2 * w + 1) / (2 * w)
    theta = theta_edges[:-1, None] + np.diff(theta_edges)[:, None] * x  # (2h, order)
    phi = phi_edges[:-1, None] + np.diff(phi_edges)[:, None] * x  # (2w, order)
    d = direction(theta[:, :, None, None], phi[None, None])  # (2h, order, 2w, order, 3)
    luminance = environment.radiance_at(d) @ [0.2126, 0.7152, 0.0722]
    if environment.intensity > 0.0:
        luminance = luminance / environment.intensity
    measure = (np.sin(theta) * weights)[:, :, None, None] * weights  # (2h, order, 1, order)
    integral = np.einsum("aibj,aibj->ab", luminance, np.broadcast_to(measure, luminance.shape))
    # Sum the quarters, and divide by each quarter's measure (sum of sin theta weights).
    area = np.einsum("ai,i->a", np.sin(theta), weights)[:, None] * np.ones(2 * w)
    integral = integral.reshape(h, 2, w, 2).sum(axis=(1, 3))
    return integral / area.reshape(h, 2, w, 2).sum(axis=(1, 3))


@pytest.mark.parametrize("shape", [(5, 7), (1, 4), (2, 2), (2, 5), (9, 3)])
def test_sampling_luminance_is_the_mean_of_the_bilinear_luminance_over_each_texel(shape):
    """Every row, the first and last included (where the lookup is constant in v beyond the
    row centres), and every column, the seam's included (where it wraps)."""
    environment = EnvironmentMap(sky(*shape, seed=sum(shape)), intensity=3.0)
    np.testing.assert_allclose(environment.sampling_luminance,
                               bilinear_cell_means(environment), rtol=1e-10)
    assert not environment.sampling_luminance.flags.writeable


def test_sampling_luminance_filters_columns_by_eighths_and_rows_by_solid_angle():
    """A single lit texel at the seam spreads 1/8, 3/4, 1/8 across columns (wrapping); across
    rows by solid-angle weights, near 1/8, 3/4, 1/8 away from the poles: in the northern
    hemisphere more into the row above, whose lower half (towards the equator) holds more of
    its solid angle, than into the row below, whose upper half holds less."""
    radiance = np.zeros((64, 16, 3))
    radiance[20, 0] = 1.0
    environment = EnvironmentMap(radiance)
    spread = environment.sampling_luminance
    np.testing.assert_array_equal(np.flatnonzero(spread.sum(axis=0)), [0, 1, 15])
    np.testing.assert_allclose(spread[:, [15, 0, 1]],
                               np.outer(spread[:, 0] / 0.75, [1 / 8, 3 / 4, 1 / 8]), rtol=1e-12)
    np.testing.assert_array_equal(np.flatnonzero(spread.sum(axis=1)), [19, 20, 21])
    above, centre, below = spread[19:22, 0] / 0.75
    np.testing.assert_allclose([above, centre, below], [1 / 8, 3 / 4, 1 / 8], atol=5e-3)
    assert above > 1 / 8 > below
    # A single row is filtered across columns only.
    one_row = sky(1, 6, seed=4) @ [0.2126, 0.7152, 0.0722]
    np.testing.assert_allclose(
        EnvironmentMap(sky(1, 6, seed=4)).sampling_luminance[0],
        0.75 * one_row[0] + 0.125 * (np.roll(one_row[0], 1) + np.roll(one_row[0], -1)),
        rtol=1e-12)


def irradiance_figures(environment, density, split=8):
    """For estimating the irradiance at a horizontal point by sampling ``density`` (per texel,
    (H, W), 1/sr) with the estimator L(d) cos / p(d) (L the luminance of radiance_at): its
    relative variance per sample, Var / E^2, and the firefly ratio max(L / p) over the sphere
    relative to the map's power (1 for a density proportional to L). Both by the midpoint rule
    over cells of equal solid angle, ``split`` x ``split`` per texel."""
    cos_edges, phi_edges = aligned_edges(environment, split)
    cos_theta = 0.5 * (cos_edges[:-1] + cos_edges[1:])
    phi = 0.5 * (phi_edges[:-1] + phi_edges[1:])
    sin_theta = np.sqrt(1.0 - cos_theta**2)[:, None]
    d = np.stack(np.broadcast_arrays(sin_theta * np.sin(phi), cos_theta[:, None],
                                     sin_theta * np.cos(phi)), axis=-1)
    omega = np.diff(cos_edges)[:, None] * np.diff(phi_edges)
    luminance = environment.radiance_at(d) @ [0.2126, 0.7152, 0.0722]
    x, y = environment.direction_to_texel(d)
    p = density[y, x]
    assert np.sum(p * omega) == pytest.approx(1.0, rel=1e-9)
    g = luminance * np.maximum(d[..., 1], 0.0)
    mean = np.sum(g * omega)
    variance = np.sum(g**2 / p * omega) - mean**2
    return variance / mean**2, float(np.max(luminance / p) / np.sum(luminance * omega))


def test_a_small_sun_leaves_no_fireflies():
    """A sun of a few texels on a dim sky: texels beside it show the sun blended in (10-100x
    their own value) but held only their own luminance's density, so that directions there
    were seldom drawn and their estimates huge (the fireflies Mitsuba 3, whose density follows
    the bilinear lookup, does not have). The density from the bilinear luminance holds the
    firefly ratio max(L / p) to a small constant and the irradiance estimator's variance far
    below the texels' own luminance's."""
    environment = EnvironmentMap(sun_sky(32, 64, radius=1.5), intensity=2.0)
    h, w = environment.height, environment.width
    cos_edges = np.cos(np.pi * np.arange(h + 1) / h)
    solid_angle = (2.0 * np.pi / w) * -np.diff(cos_edges)[:, None]
    own = environment.radiance @ [0.2126, 0.7152, 0.0722]
    own = own + 1e-3 * np.sum(own * solid_angle) / (4.0 * np.pi)
    old = own / np.sum(own * solid_angle)
    new = environment.pdf(texel_centres(environment))
    old_variance, old_fireflies = irradiance_figures(environment, old)
    new_variance, new_fireflies = irradiance_figures(environment, new)
    print(f"relative variance per sample: old {old_variance:.4g}, new {new_variance:.4g}; "
          f"firefly ratio: old {old_fireflies:.4g}, new {new_fireflies:.4g}")
    # Bilinear over a texel peaks at most 4 x its mean per axis (a lit neighbour at a corner).
    assert new_fireflies < 16.0
    assert old_fireflies > 1000.0
    assert new_variance < 0.5
    assert new_variance * 3.0 < old_variance
    # The samples themselves: the estimator's mean and variance agree with the quadrature's.
    d = environment.sample(np.random.default_rng(5).random((200_000, 2)))
    estimates = (environment.radiance_at(d) @ [0.2126, 0.7152, 0.0722]
                 * np.maximum(d[:, 1], 0.0) / environment.pdf(d))
    relative = estimates.var() / estimates.mean() ** 2
    assert relative == pytest.approx(new_variance, rel=0.1)


def test_uniform_and_black_maps_are_uniform():
    directions = random_directions(1000, seed=1)
    for radiance in (np.full((6, 10, 3), 3.0), np.zeros((6, 10, 3))):
        environment = EnvironmentMap(radiance)
        np.testing.assert_allclose(environment.pdf(directions), 1.0 / (4.0 * np.pi), rtol=1e-12)
    black = EnvironmentMap(np.zeros((6, 10, 3)), intensity=4.0)
    d = black.sample(np.random.default_rng(2).random((1000, 2)))
    assert np.all(np.isfinite(d))
    np.testing.assert_array_equal(black.radiance_at(d), 0.0)


@pytest.mark.parametrize("scale", [2.0**-1000, 2.0**1000])
def test_density_does_not_depend_on_the_radiance_scale(environment, scale):
    scaled = EnvironmentMap(environment.radiance * scale)
    directions = random_directions(1000, seed=3)
    np.testing.assert_allclose(scaled.pdf(directions), environment.pdf(directions), rtol=1e-12)
    u = np.random.default_rng(4).random((1000, 2))
    np.testing.assert_allclose(scaled.sample(u), environment.sample(u), atol=1e-9)


def test_a_map_at_the_float64_limit_samples():
    # Its integral overflowed float64, and the map was refused.
    huge = EnvironmentMap(np.full((2, 4, 3), np.finfo(np.float64).max))
    directions = random_directions(100, seed=7)
    np.testing.assert_allclose(huge.pdf(directions), 1.0 / (4.0 * np.pi), rtol=1e-12)
    assert np.all(np.isfinite(huge.sample(np.random.default_rng(8).random((100, 2)))))


def test_the_largest_scaled_radiance_is_finite():
    # intensity * radiance overflowed to inf in radiance_at; the limit itself is accepted.
    top = np.finfo(np.float64).max
    environment = EnvironmentMap(np.full((2, 4, 3), 1e300), intensity=top / 1e300)
    assert np.all(np.isfinite(environment.radiance_at(random_directions(100, seed=9))))
    black = EnvironmentMap(np.zeros((2, 4, 3)), intensity=top)
    assert black.radiance_at([0.0, 1.0, 0.0]).max() == 0.0


def test_a_single_subnormal_texel_is_a_lamp():
    # Its floor (1e-3 of the mean) underflowed to 0: 0 / 0 CDFs and NaN directions.
    lamp = np.zeros((4, 8, 3))
    lamp[1, 2] = 5e-324
    unit = lamp / 5e-324
    directions = random_directions(1000, seed=5)
    np.testing.assert_allclose(EnvironmentMap(lamp).pdf(directions),
                               EnvironmentMap(unit).pdf(directions), rtol=1e-12)
    u = np.random.default_rng(6).random((1000, 2))
    np.testing.assert_allclose(EnvironmentMap(lamp).sample(u), EnvironmentMap(unit).sample(u),
                               atol=1e-12)


def aligned_edges(environment, split):
    """Cells of a (cos theta, phi) grid, each texel split into ``split`` x ``split``, uniform
    in cos theta and phi, so that the density is constant in every cell."""
    h, w = environment.height, environment.width
    cos_rows = np.cos(np.pi * np.arange(h, -1, -1) / h)  # ascending
    steps = np.arange(split) / split
    cos_edges = np.append(cos_rows[:-1, None] + np.diff(cos_rows)[:, None] * steps, 1.0)
    phi_edges = np.linspace(-np.pi, np.pi, split * w + 1)
    return cos_edges, phi_edges


def chi2_pvalue(environment, directions, split=2):
    cos_edges, phi_edges = aligned_edges(environment, split)
    observed, _, _ = np.histogram2d(
        directions[:, 1],
        np.arctan2(directions[:, 0], directions[:, 2]),
        bins=[cos_edges, phi_edges],
    )
    # conftest's cells have z as the polar axis and phi from +x towards +y; ours are y and
    # atan2(x, z) = pi - 2 pi u, whose uniform bins are the texels' columns, split.
    expected = expected_direction_counts(
        lambda cells: environment.pdf(cells[..., [1, 2, 0]]),
        cos_edges,
        phi_edges,
        len(directions),
        order=2,
    )
    assert expected.sum() == pytest.approx(len(directions), rel=1e-6)
    return pooled_chi2_pvalue(observed, expected)


def test_sampler_matches_pdf_chi_square(environment):
    u = np.random.default_rng(3).random((200_000, 2))
    assert chi2_pvalue(environment, environment.sample(u)) > CHI2_P_MIN


def test_samples_fall_in_texels_with_their_probabilities(environment):
    n = 200_000
    x, y = environment.direction_to_texel(
        environment.sample(np.random.default_rng(4).random((n, 2)))
    )
    observed = np.zeros((environment.height, environment.width))
    np.add.at(observed, (y, x), 1.0)
    assert pooled_chi2_pvalue(observed, n * texel_probabilities(environment)) > CHI2_P_MIN


def test_sample_edges_of_u(environment):
    below_one = np.nextafter(1.0, 0.0)
    u = np.array(
        [
            [0.0, 0.0],
            [0.0, below_one],
            [below_one, 0.0],
            [below_one, below_one],
            [1.0, 1.0],
            [0.5, 1.0],
            [1e-300, 1e-300],
        ]
    )
    d = environment.sample(u)
    np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0, atol=1e-15)
    np.testing.assert_allclose(d[0], [0.0, 1.0, 0.0], atol=1e-15)  # the top of row 0: +y
    assert np.all(d[2:5, 1] < -0.99)  # the last row, around -y
    assert np.all(environment.pdf(d) > 0.0)


# --------------------------------------------------------------------------- shapes, layout


def test_n_dimensional_inputs():
    environment = EnvironmentMap(sky(4, 6, seed=7))
    u = np.random.default_rng(8).random((2, 3, 4, 2))
    d = environment.sample(u)
    assert d.shape == (2, 3, 4, 3)
    assert environment.pdf(d).shape == (2, 3, 4)
    assert environment.radiance_at(d).shape == (2, 3, 4, 3)
    x, y = environment.direction_to_texel(d)
    assert x.shape == y.shape == (2, 3, 4)
    np.testing.assert_array_equal(environment.pdf(d)[1, 2], environment.pdf(d[1, 2]))
    assert environment.sample([0.3, 0.6]).shape == (3,)
    assert environment.pdf([0.0, 0.0, 1.0]).shape == ()
    np.testing.assert_array_equal(environment.sample(u.reshape(-1, 2)), d.reshape(-1, 3))


def test_packed_layout():
    radiance = sky(3, 5, seed=9)
    environment = EnvironmentMap(radiance, intensity=0.5)
    packed = environment.packed()
    assert packed.dtype == np.float32
    assert packed.shape == (1 + 3 + 15 + 4, 4)
    np.testing.assert_array_equal(packed[0], [5.0, 3.0, 0.5, 0.0])
    marginal, conditional = packed[1:4, 0], packed[4:19, 3].reshape(3, 5)
    assert marginal[-1] == 1.0 and np.all(conditional[:, -1] == 1.0)
    assert np.all(np.diff(marginal) > 0) and np.all(np.diff(conditional, axis=1) > 0)
    np.testing.assert_array_equal(packed[4:19, :3], radiance.reshape(-1, 3).astype(np.float32))
    theta = np.pi * np.arange(4) / 3
    np.testing.assert_allclose(packed[1:4, 1], np.sin(theta[:-1] / 2) ** 2, rtol=1e-7)
    np.testing.assert_allclose(
        packed[1:4, 2], (np.cos(theta[:-1]) - np.cos(theta[1:])) / 2, rtol=1e-7
    )
    np.testing.assert_allclose(packed[1:4, 3], np.cos(theta[1:] / 2) ** 2, rtol=1e-7, atol=1e-30)
    probabilities = texel_probabilities(environment)
    np.testing.assert_allclose(marginal, np.cumsum(probabilities.sum(axis=1)), rtol=1e-6)
    # The densities, 4 a row, row-major, the last row padded with zeros.
    densities = packed[19:].reshape(-1)
    np.testing.assert_allclose(densities[:15], environment.pdf(texel_centres(environment)).ravel(),
                               rtol=1e-6)
    np.testing.assert_array_equal(densities[15:], 0.0)


def test_radiance_is_a_read_only_copy():
    radiance = np.ones((2, 4, 3))
    environment = EnvironmentMap(radiance)
    radiance[:] = 5.0
    np.testing.assert_array_equal(environment.radiance, 1.0)
    with pytest.raises(ValueError, match="read-only"):
        environment.radiance[0, 0, 0] = 2.0


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: EnvironmentMap(np.ones((4, 8))), r"radiance must have shape \(H, W, 3\)"),
        (lambda: EnvironmentMap(np.ones((4, 8, 4))), r"radiance must have shape \(H, W, 3\)"),
        (lambda: EnvironmentMap(np.ones((4, 1, 3))), "radiance needs H >= 1 rows and W >= 2"),
        (lambda: EnvironmentMap(np.ones((0, 8, 3))), "radiance needs H >= 1 rows and W >= 2"),
        (lambda: EnvironmentMap(np.full((2, 2, 3), np.nan)), "radiance contains NaN"),
        (lambda: EnvironmentMap(np.full((2, 2, 3), np.inf)), "radiance must be finite"),
        (lambda: EnvironmentMap(-np.ones((2, 2, 3))), "radiance must be finite and >= 0"),
        (lambda: EnvironmentMap(np.full((2, 2, 3), "1")), "radiance must be a real number"),
        (lambda: EnvironmentMap(np.ones((2, 2, 3)), intensity=-1.0), "intensity must be"),
        (lambda: EnvironmentMap(np.ones((2, 2, 3)), intensity=np.inf), "intensity must be"),
        (lambda: EnvironmentMap(np.ones((2, 2, 3)), intensity=np.nan), "intensity is NaN"),
        (lambda: EnvironmentMap(np.full((4, 8, 3), 1e308), intensity=1e308),
         r"intensity .* must not overflow float64"),
        (lambda: EnvironmentMap(np.full((2, 2, 3), np.finfo(np.float64).max), intensity=2.0),
         r"intensity .* must not overflow float64"),
        (lambda: EnvironmentMap(np.full((2, 2, 3), True)), "radiance must be a real number"),
        (lambda: EnvironmentMap(np.full((2, 2, 3), 1e39)).packed(), "float32 range"),
        (
            lambda: EnvironmentMap(np.ones((2, 2, 3))).pdf([0.0, 0.0, 2.0]),
            "directions must hold unit vectors",
        ),
        (
            lambda: EnvironmentMap(np.ones((2, 2, 3))).radiance_at([0.0, 1.0]),
            "directions must have a trailing axis of length 3",
        ),
        (
            lambda: EnvironmentMap(np.ones((2, 2, 3))).direction_to_texel([np.nan, 0.0, 1.0]),
            "directions contains NaN",
        ),
        (lambda: EnvironmentMap(np.ones((2, 2, 3))).sample([0.5, 1.5]), r"u must be in \[0, 1\]"),
        (lambda: EnvironmentMap(np.ones((2, 2, 3))).sample([-0.1, 0.5]), r"u must be in \[0, 1\]"),
        (
            lambda: EnvironmentMap(np.ones((2, 2, 3))).sample([0.5, 0.5, 0.5]),
            "u must have a trailing axis of length 2",
        ),
    ],
)
def test_raises(call, match):
    with pytest.raises(ValueError, match=match):
        call()


# --------------------------------------------------------------------------- GPU twin


def run_kernel(environment, u, directions):
    """(sampled directions, their pdf, radiance at directions, pdf at directions) in float32."""
    n = len(u)
    pad = np.zeros((n, 1), np.float32)
    kernel = gpu.compute_pipeline(str(KERNELS / "environment_map_eval.wgsl"), "evaluate")
    sampled, looked_up = kernel.run(
        [environment.packed(), u, np.hstack([directions, pad])],
        [((n, 4), np.float32), ((n, 4), np.float32)],
    )
    return sampled[:, :3], sampled[:, 3], looked_up[:, :3], looked_up[:, 3]


def gpu_inputs(n, seed):
    """float32 u and unit directions, random and at the edges: u at 0 and just under 1, the
    poles, the seam (both signs of zero) and directions beside them."""
    rng = np.random.default_rng(seed)
    below_one = np.nextafter(np.float32(1.0), np.float32(0.0))
    u = rng.random((n, 2))
    u[:6] = [
        [0.0, 0.0],
        [0.0, below_one],
        [below_one, 0.0],
        [below_one, below_one],
        [1.0, 1.0],
        [0.5, 0.0],
    ]
    special = np.array(
        [
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, -1.0],
            [-0.0, 0.0, -1.0],
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [1e-3, 0.0, -1.0],
            [-1e-3, 0.0, -1.0],
            [1e-4, 1.0, 2e-5],
            [3e-5, -1.0, 1e-4],
            [1e-30, 1.0, 1e-30],
            [0.0, -1.0, -1e-30],
        ]
    )
    directions = random_directions(n, seed)
    directions[: len(special)] = special / np.linalg.norm(special, axis=-1, keepdims=True)
    return u.astype(np.float32), directions.astype(np.float32), len(special)


def near_edge(environment, d):
    """Whether a direction lies within EDGE_MARGIN texels of a texel edge (the seam counted)."""
    azimuth = (0.5 - np.arctan2(d[:, 0], d[:, 2]) / (2 * np.pi)) * environment.width
    polar = np.arctan2(np.hypot(d[:, 0], d[:, 2]), d[:, 1]) / np.pi * environment.height
    interior = (polar > 0.5) & (polar < environment.height - 0.5)
    return (np.abs(azimuth - np.round(azimuth)) < EDGE_MARGIN) | (
        interior & (np.abs(polar - np.round(polar)) < EDGE_MARGIN)
    )


def radiance_scale(environment, d):
    """The largest channel of the (up to 9) texels around each direction's texel, times the
    intensity: a bound on the radiance its bilinear lookup blends."""
    x, y = environment.direction_to_texel(d)
    h, w = environment.height, environment.width
    largest = environment.radiance.max(axis=-1)
    scale = np.zeros(len(d))
    for dy, dx in itertools.product((-1, 0, 1), repeat=2):
        scale = np.maximum(scale, largest[np.clip(y + dy, 0, h - 1), (x + dx) % w])
    return scale * environment.intensity


def sample_spread(environment, u):
    """numpy's samples, how far they move when u moves by CDF_ERROR, and whether they stay in
    their texels meanwhile."""
    expected = environment.sample(u)
    x, y = environment.direction_to_texel(expected)
    spread = np.zeros(len(u))
    stays = np.ones(len(u), dtype=bool)
    for step in itertools.product((-CDF_ERROR, CDF_ERROR), repeat=2):
        moved = environment.sample(np.clip(u + step, 0.0, 1.0))
        spread = np.maximum(spread, np.linalg.norm(moved - expected, axis=-1))
        moved_x, moved_y = environment.direction_to_texel(moved)
        stays &= (moved_x == x) & (moved_y == y)
    return expected, spread, stays


@pytest.mark.gpu
def test_gpu_matches_numpy(environment):
    u, directions, n_special = gpu_inputs(8192, seed=21)
    sampled, sampled_pdf, radiance, pdf = run_kernel(environment, u, directions)
    for value in (sampled, sampled_pdf, radiance, pdf):
        assert np.all(np.isfinite(value))
    np.testing.assert_allclose(np.linalg.norm(sampled, axis=-1), 1.0, atol=1e-6)
    u64, d64 = u.astype(np.float64), directions.astype(np.float64)

    # Lookups: bilinear radiance within RADIANCE_RTOL of the texels it blends (all of them,
    # the seam and the poles included), the density to float32 accuracy.
    expected_radiance = environment.radiance_at(d64)
    scale = radiance_scale(environment, d64)
    error = np.abs(radiance - expected_radiance).max(axis=-1)
    print(f"radiance: max |gpu - numpy| / largest texel blended "
          f"{(error / np.maximum(scale, 1e-300)).max():.2e}")
    np.testing.assert_array_less(error, RADIANCE_RTOL * scale + 1e-30)
    compare = ~near_edge(environment, d64)
    compare[:n_special] = True
    assert compare.mean() > 0.99
    np.testing.assert_allclose(pdf[compare], environment.pdf(d64[compare]), rtol=PDF_RTOL)

    # Samples: within what the float32 CDFs allow (the neighbour's, at a step).
    expected, spread, stays = sample_spread(environment, u64)
    error = np.linalg.norm(sampled.astype(np.float64) - expected, axis=-1)
    np.testing.assert_array_less(error, DIRECTION_ATOL + spread)
    compare = stays & ~near_edge(environment, expected)
    assert compare.mean() > 0.99
    np.testing.assert_allclose(
        sampled_pdf[compare], environment.pdf(expected[compare]), rtol=PDF_RTOL
    )


@pytest.mark.gpu
def test_gpu_sampler_matches_pdf_chi_square():
    environment = MAPS["sky"]()
    u = np.random.default_rng(22).random((200_000, 2)).astype(np.float32)
    sampled, _, _, _ = run_kernel(environment, u, np.zeros((len(u), 3), np.float32))
    sampled = sampled.astype(np.float64)
    sampled /= np.linalg.norm(sampled, axis=-1, keepdims=True)
    assert chi2_pvalue(environment, sampled) > CHI2_P_MIN
