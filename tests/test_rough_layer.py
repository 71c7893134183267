"""Rough Bragg layers (Bragg paper sec. 4.2): integrated transmissivity (eq 28), absorption
(eq 30), transmission probability and weights (eqs 31-33), numpy and GPU.

Filters are baked coarse here (1 degree, 128 azimuth samples, numpy) to keep the suite fast;
the App. C identity they obey is tested in test_transmission_filter.py.
"""

from __future__ import annotations

import gc
import math

import numpy as np
import pytest

from wgbragg import BraggMirror, RoughBraggLayer
from wgbragg.bsdf import rough_layer
from wgbragg.bsdf.microfacet import ggx_G1
from wgbragg.bsdf.transmission_filter import TransmissionFilter, ballistic_transmission_reference
from wgbragg.colour.colorimetry import xyz_weights
from wgbragg.optics import yeh_reflectance

IDENTITY_ATOL = 1e-3  # App. C: rows of the filter sum to G1 within this
THETA = np.radians([0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 85.0])
MIRROR = BraggMirror(1.0, 1.5, 110.0, 140.0, 8)
MATCHED = BraggMirror(1.3, 1.3, 110.0, 140.0, 8)  # index-matched: T = 1


@pytest.fixture(scope="module")
def filt():
    return TransmissionFilter.bake(0.2, resolution_deg=1.0, psi_samples=128, backend="numpy")


@pytest.fixture(scope="module")
def layer(filt):
    return RoughBraggLayer(MIRROR, 0.2, transmission_filter=filt)


def g1(theta, alpha=0.2):
    return ggx_G1(np.cos(theta), alpha)


def test_unit_transmittance_gives_g1(filt):
    """T = 1 (index-matched layers): f_t cos = G1, what the microfacets leave unshadowed."""
    matched = RoughBraggLayer(MATCHED, 0.2, transmission_filter=filt)
    for wavelength in (400.0, 700.0):
        np.testing.assert_allclose(matched.transmissivity(THETA, wavelength), g1(THETA),
                                   atol=IDENTITY_ATOL)
    np.testing.assert_allclose(matched.transmissivity_rgb(THETA), np.repeat(
        g1(THETA)[:, None], 3, axis=1), atol=2e-3)  # white point: G1 (1, 1, 1)


def test_matches_the_eq23_quadrature(layer):
    """Against a direct 2D quadrature of eq 23 with the same mirror (scipy)."""
    # Tabulated every 8e-6 rad (the quadrature moves by 4e-11): the nested quad calls it once
    # per scalar node, where Yeh's formula costs far more than np.interp (20 s -> 0.3 s).
    theta_d_grid = np.linspace(0.0, np.pi / 2, 200001)
    table = 1.0 - yeh_reflectance(1.0, 1.5, 110.0, 140.0, 8, 550.0, theta_d_grid)

    def transmittance(theta_d):
        return np.interp(theta_d, theta_d_grid, table)

    for degrees in (20.0, 70.0):
        theta = math.radians(degrees)
        expected = ballistic_transmission_reference(transmittance, theta, 0.2, epsabs=1e-6)
        assert layer.transmissivity(theta, 550.0) == pytest.approx(expected, abs=3e-3)


def test_bounded_by_g1_and_nonnegative(layer):
    wavelength = np.linspace(360.0, 830.0, 48)[:, None]
    value = layer.transmissivity(THETA, wavelength)
    assert np.all(value >= 0.0)
    assert np.all(value <= g1(THETA) + IDENTITY_ATOL)


def test_smooth_limit_is_the_mirror_transmittance():
    """alpha -> 0: the filter tends to G1 delta(theta_d - theta_i), G1 -> 1, so f_t cos tends
    to the smooth mirror's 1 - R(theta_i)."""
    # Whole degrees only: no interpolation between rows; 1000 azimuth samples resolve the
    # narrow lobe.
    filt = TransmissionFilter.bake(0.01, resolution_deg=1.0, psi_samples=1000, backend="numpy")
    thin = BraggMirror(1.0, 1.5, 110.0, 140.0, 3)  # T varies slowly with angle
    rough = RoughBraggLayer(thin, 0.01, transmission_filter=filt)
    theta = np.radians([0.0, 20.0, 40.0, 60.0])
    smooth = 1.0 - yeh_reflectance(1.0, 1.5, 110.0, 140.0, 3, 550.0, theta)
    np.testing.assert_allclose(rough.transmissivity(theta, 550.0), smooth, atol=5e-3)


@pytest.mark.gpu
def test_gpu_table_matches_numpy(layer):
    gpu = layer.transmissivity_table(backend="gpu")
    reference = layer.transmissivity_table(backend="numpy")
    assert gpu.shape == reference.shape == (layer.filter.theta_i.size, xyz_weights()[0].size)
    np.testing.assert_allclose(gpu, reference, atol=2e-5)
    np.testing.assert_allclose(layer.transmissivity(THETA, 450.0, backend="gpu"),
                               layer.transmissivity(THETA, 450.0), atol=2e-5)


@pytest.mark.gpu
@pytest.mark.parametrize("count", [1, 95, 96, 97, 1000])
def test_gpu_table_matches_numpy_on_any_grid(layer, count):
    """Wavelength counts that fill the product pass's blocks (96 per workgroup) or not; the
    filter's 91 rows are not a multiple of its 16 rows per workgroup either."""
    wavelength = np.linspace(380.0, 780.0, count)
    np.testing.assert_allclose(layer.transmissivity_table(wavelength, "gpu"),
                               layer.transmissivity_table(wavelength, "numpy"), atol=2e-5)


@pytest.mark.gpu
def test_gpu_table_pads_the_difference_angles():
    """alpha = 0.01 has 474 difference angles, not a whole number of vec4s."""
    filt = TransmissionFilter.bake(0.01, resolution_deg=1.0, psi_samples=64, backend="numpy")
    assert filt.theta_d.size % 4 != 0
    rough = RoughBraggLayer(MIRROR, 0.01, transmission_filter=filt)
    wavelength = np.linspace(380.0, 780.0, 41)
    np.testing.assert_allclose(rough.transmissivity_table(wavelength, "gpu"),
                               rough.transmissivity_table(wavelength, "numpy"), atol=2e-5)


@pytest.mark.gpu
def test_gpu_table_of_no_wavelengths_is_empty(layer):
    assert layer.transmissivity_table(np.zeros(0), "gpu").shape == (layer.filter.theta_i.size, 0)


@pytest.mark.gpu
def test_gpu_weights_are_uploaded_once_per_filter(filt):
    """Another mirror with the same filter reuses the filter's weights on the GPU."""
    wavelength = np.linspace(380.0, 780.0, 41)
    RoughBraggLayer(MIRROR, 0.2, transmission_filter=filt).transmissivity_table(wavelength)
    on_gpu = rough_layer._filters_on_gpu[id(filt)]
    other = RoughBraggLayer(BraggMirror(1.0, 1.7, 90.0, 130.0, 5), 0.2, transmission_filter=filt)
    np.testing.assert_allclose(other.transmissivity_table(wavelength, "gpu"),
                               other.transmissivity_table(wavelength, "numpy"), atol=2e-5)
    assert rough_layer._filters_on_gpu[id(filt)] is on_gpu


@pytest.mark.gpu
def test_gpu_weights_follow_the_filter():
    """Each filter's own weights, also when a new filter takes the memory (and so the id) of
    a dropped one; a dropped filter's GPU copy goes with it."""
    wavelength = np.linspace(380.0, 780.0, 41)
    keys = []
    for alpha, resolution, psi_samples in ((0.2, 3.0, 16), (0.5, 3.0, 16), (0.5, 3.0, 64),
                                           (0.5, 2.0, 16)):
        filt = TransmissionFilter.bake(alpha, resolution_deg=resolution, psi_samples=psi_samples,
                                       backend="numpy")
        rough = RoughBraggLayer(MIRROR, alpha, transmission_filter=filt)
        np.testing.assert_allclose(rough.transmissivity_table(wavelength, "gpu"),
                                   rough.transmissivity_table(wavelength, "numpy"), atol=2e-5)
        keys.append(id(filt))
        del rough, filt
        gc.collect()
        assert keys[-1] not in rough_layer._filters_on_gpu


@pytest.mark.gpu
def test_benchmark_table_times_both_passes(layer):
    seconds = layer.benchmark_table(np.linspace(380.0, 780.0, 41), repeats=2)
    assert len(seconds) == 2
    assert all(np.isfinite(s) and s > 0.0 for s in seconds)


@pytest.mark.gpu
@pytest.mark.parametrize("N", [1, 10**6])
def test_extreme_periods_stay_finite(filt, N):
    layer = RoughBraggLayer(BraggMirror(1.0, 1.5, 110.0, 140.0, N), 0.2, transmission_filter=filt)
    for backend in ("numpy", "gpu"):
        table = layer.transmissivity_table(np.linspace(380.0, 780.0, 41), backend)
        assert np.all(np.isfinite(table))
        assert np.all((table >= 0.0) & (table <= 1.0 + 1e-6))


def test_absorption_is_one_minus_g1(layer, filt):
    np.testing.assert_allclose(layer.absorption(THETA), 1.0 - g1(THETA))
    rows = filt.interpolate(THETA).sum(axis=-1)
    np.testing.assert_allclose(layer.absorption(THETA), 1.0 - rows, atol=IDENTITY_ATOL)


def test_probability_times_weight_is_the_transmissivity(layer):
    """Eq 31 x eq 32 per wavelength; eq 33 with the wavelength-averaged probability."""
    wavelength = np.array([420.0, 500.0, 560.0, 620.0, 680.0, 720.0, 800.0])
    transmitted = layer.transmissivity(THETA, wavelength)
    single = layer.transmission_probability(THETA, wavelength) * layer.transmission_weight(THETA)
    np.testing.assert_allclose(single, transmitted, rtol=1e-12)
    multiplexed = (layer.transmission_probability(THETA)
                   * layer.transmission_weight(THETA, wavelength))
    np.testing.assert_allclose(multiplexed, transmitted, rtol=1e-9, atol=1e-15)
    for probability in (layer.transmission_probability(THETA),
                        layer.transmission_probability(THETA, wavelength)):
        assert np.all((probability >= 0.0) & (probability <= 1.0))


def test_weight_of_a_single_wavelength_path(layer):
    np.testing.assert_allclose(layer.transmission_weight(THETA), 0.5 * (1.0 + g1(THETA)))


def test_n_dimensional_input(layer):
    theta = np.radians([[0.0, 30.0], [60.0, 89.0]])
    value = layer.transmissivity(theta, np.array([450.0, 650.0]))
    assert value.shape == (2, 2)
    assert value[1, 0] == pytest.approx(float(layer.transmissivity(theta[1, 0], 450.0)))
    assert layer.transmissivity_rgb(theta).shape == (2, 2, 3)
    assert layer.transmission_probability(theta).shape == (2, 2)


@pytest.mark.parametrize(("make", "name"), [
    (lambda f: RoughBraggLayer(MIRROR, 0.001), "alpha"),
    (lambda f: RoughBraggLayer(MIRROR, 1.5), "alpha"),
    (lambda f: RoughBraggLayer(MIRROR, 0.3, transmission_filter=f), "alpha"),
    (lambda f: RoughBraggLayer("mirror", 0.2), "mirror"),
    (lambda f: RoughBraggLayer(MIRROR, 0.2, transmission_filter=f).transmissivity(2.0, 500.0),
     "theta_i"),
    (lambda f: RoughBraggLayer(MIRROR, 0.2, transmission_filter=f).transmissivity(0.1, -5.0),
     "wavelength"),
    (lambda f: RoughBraggLayer(MIRROR, 0.2, transmission_filter=f).transmissivity_table(
        [[500.0]]), "wavelength_nm"),
    (lambda f: RoughBraggLayer(MIRROR, 0.2, transmission_filter=f).transmissivity_table(
        backend="cuda"), "backend"),
    # Returned 0.99999 before looking at the backend.
    (lambda f: RoughBraggLayer(MIRROR, 0.2, transmission_filter=f).transmission_weight(
        0.1, None, backend="x"), "backend"),
])
def test_bad_input(filt, make, name):
    with pytest.raises(ValueError, match=name):
        make(filt)


# ---------------------------------------------------------------- resonant mirrors (aliasing)

RESONANT = BraggMirror(1.0, 3.0, 100.0, 150.0, 1000)  # T oscillates far faster than the grid


def _dense_reference(layer, wavelength, samples=4000, seed=0):
    """``int T F dtheta_d`` with F interpolated per Gauss-Legendre panel through its 6 nodes
    (Lagrange) and T sampled at ``samples`` jittered points per panel: each node's share of
    the panel, ``int L_k T``, resolves the oscillations the nodes alias."""
    filt = layer.filter
    nodes = filt.theta_d
    panels = nodes.size // 6
    edges = np.linspace(0.0, np.pi / 2, panels + 1)
    x6 = np.polynomial.legendre.leggauss(6)[0]
    u = (np.arange(samples) + np.random.default_rng(seed).random(samples)) / samples * 2 - 1
    basis = np.ones((6, samples))
    for k in range(6):
        for j in range(6):
            if j != k:
                basis[k] *= (u - x6[j]) / (x6[k] - x6[j])
    shares = np.zeros((wavelength.size, nodes.size))
    m = layer.mirror
    for p in range(panels):
        theta = edges[p] + (u + 1) / 2 * (edges[p + 1] - edges[p])
        T = 1.0 - yeh_reflectance(m.n1, m.n2, m.d1, m.d2, m.N, wavelength[:, None], theta)
        shares[:, 6 * p:6 * p + 6] = T @ basis.T * (edges[p + 1] - edges[p]) / samples
    return shares @ filt.values.T  # (wavelengths, rows)


@pytest.fixture(scope="module")
def resonant(filt):
    return RoughBraggLayer(RESONANT, 0.2, transmission_filter=filt)


def test_resonant_mirror_matches_a_dense_reference(resonant):
    """Point values of T on the filter grid alias a resonant mirror (t off by 0.03 before the
    cell means); the table follows a dense sub-sampling of T."""
    wavelength = np.array([420.0, 530.0, 700.0])
    reference = _dense_reference(resonant, wavelength)
    table = resonant.transmissivity_table(wavelength, "numpy").T
    np.testing.assert_allclose(table, reference, atol=4e-3)


def test_well_resolved_mirror_keeps_its_point_values(layer):
    """N = 8: T is resolved by the nodes, the cell means leave its point values."""
    wavelength = np.array([420.0, 530.0, 700.0])
    np.testing.assert_allclose(layer.transmissivity_table(wavelength, "numpy").T,
                               _dense_reference(layer, wavelength), atol=5e-5)


@pytest.mark.gpu
def test_gpu_table_of_a_resonant_mirror_matches_numpy(resonant):
    wavelength = np.linspace(380.0, 780.0, 41)
    np.testing.assert_allclose(resonant.transmissivity_table(wavelength, "gpu"),
                               resonant.transmissivity_table(wavelength, "numpy"), atol=2e-4)


@pytest.mark.gpu
@pytest.mark.parametrize("n2, N, degrees, wavelengths", [
    (3.0, 1000, 60.0, [460.0, 530.0, 700.0]),
    (2.5, 30, 40.0, [530.0, 600.0]),
    (2.5, 100, 50.0, [460.0, 530.0]),
])
def test_resonant_layer_over_a_white_base_keeps_albedo_at_most_one(n2, N, degrees, wavelengths):
    """Lobe (exact R) + transmission must not create energy: before the cell means the
    aliased t took the albedo to 1.068 (N = 1000), 1.017 (N = 30), 1.040 (N = 100)."""
    from wgbragg import LayeredBragg

    structure = LayeredBragg([RoughBraggLayer(BraggMirror(1.0, n2, 100.0, 150.0, N), 0.03)],
                             base_albedo=1.0, base_interreflection=True)
    albedo = structure.albedo(np.radians(degrees), np.array(wavelengths), samples=65536)
    # Residual of the cell means at alpha = 0.03 (F varies across a cell): < 3e-3.
    assert np.all(np.asarray(albedo) <= 1.005)
