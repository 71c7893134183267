"""The transmission filter F_alpha (wgbragg.bsdf.transmission_filter) on both backends.

Checks: the App. C identity (rows of weights sum to G1), the filtered transmissivity against a
direct 2D quadrature of eq 23, the psi integral against its closed form, the small-roughness
limit, GPU against numpy, and the table's shape and validation.
"""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest
from scipy.integrate import IntegrationWarning

from wgbragg import gpu
from wgbragg.bsdf import transmission_filter
from wgbragg.bsdf.microfacet import ggx_G1
from wgbragg.bsdf.transmission_filter import (
    F_alpha,
    TransmissionFilter,
    ballistic_transmission_reference,
    difference_angle_grid,
)
from wgbragg.optics import yeh_reflectance

ALPHAS = [0.01, 0.1, 0.4, 1.0]
IDENTITY_ATOL = 3e-4  # |sum_d weights - G1(theta_i)|, theta_i <= 89 deg; measured <= 1.8e-4
REFERENCE_ATOL = 2e-4  # filtered T against the eq-23 quadrature
GPU_RTOL = 5e-5  # float32 bake vs float64, relative to the row's peak
DEG = math.pi / 180.0


def bragg_transmissivity():
    """1 - R of a 10-period Bragg mirror at 550 nm, tabulated finely: a T with sub-degree
    resonances near grazing, and cheap to call from scipy's quad."""
    grid = np.linspace(0.0, np.pi / 2, 100_001)
    table = 1.0 - yeh_reflectance(1.0, 1.5, 100.0, 150.0, 10, 550.0, grid)
    return lambda theta_d: np.interp(theta_d, grid, table)


TRANSMISSIVITIES = {
    "cos2": lambda theta_d: np.cos(theta_d) ** 2,
    "bragg": bragg_transmissivity(),
}
# (alpha, theta_i in degrees, T): the Bragg cases cost ~0.5 s of quadrature each.
REFERENCE_CASES = [
    *[(alpha, deg, "cos2") for alpha in ALPHAS for deg in (30.0, 85.0)],
    (0.01, 60.0, "bragg"),
    (0.1, 85.0, "bragg"),
    (1.0, 30.0, "bragg"),
]


@pytest.fixture(scope="module")
def references():
    with warnings.catch_warnings():
        # quad reports roundoff on the piecewise-linear Bragg table, well below the tolerance.
        warnings.simplefilter("ignore", IntegrationWarning)
        return {
            case: ballistic_transmission_reference(TRANSMISSIVITIES[case[2]], case[1] * DEG,
                                                   case[0])
            for case in REFERENCE_CASES
        }


@pytest.fixture(scope="module")
def numpy_filters():
    return {alpha: TransmissionFilter.bake(alpha, 1.0, backend="numpy") for alpha in ALPHAS}


@pytest.fixture(scope="module")
def gpu_filters(device):
    return {alpha: TransmissionFilter.bake(alpha) for alpha in ALPHAS}


def identity_error(filt):
    below = filt.theta_i <= 89.0 * DEG + 1e-12
    total = filt.integrate(np.ones(filt.theta_d.size))
    return np.abs(total - ggx_G1(np.cos(filt.theta_i), filt.alpha))[below].max()


def psi_integral_closed_form(theta_i, theta_d, alpha):
    """int_0^{psi_max} D~ dpsi in closed form, an oracle for the midpoint rule.

    D~ = alpha^2 / (pi (1 - k^2 c^2)^2) with k = sqrt(1 - alpha^2), c = cos theta_m, splits into
    partial fractions 1/4 [1/(1-kc)^2 + 1/(1+kc)^2 + 1/(1-kc) + 1/(1+kc)]. With t = tan(psi/2)
    each 1 -+ kc is (a + b t^2) / (1 + t^2) with a, b > 0, whose integrals are arctangents.
    """
    si, sd = np.sin(theta_i), np.sin(theta_d)
    cos_delta, cos_sigma = np.cos(theta_i - theta_d), np.cos(theta_i + theta_d)
    k = math.sqrt(1.0 - alpha**2)
    t_max = math.sqrt(cos_delta / -cos_sigma) if cos_sigma < 0 else math.inf
    minus = alpha**2 / (1.0 + k) + 2.0 * k * math.sin((theta_i - theta_d) / 2) ** 2
    plus = 1.0 + k * cos_delta
    q = 2.0 * k * si * sd

    def first(a, b):  # int_0^t_max 2 dt / (a + b t^2)
        return 2.0 * math.atan(t_max * math.sqrt(b / a)) / math.sqrt(a * b)

    def second(a, b):  # int_0^t_max 2 (1 + t^2) dt / (a + b t^2)^2
        j1 = first(a, b) / 2.0
        edge = 0.0 if math.isinf(t_max) else t_max / (a + b * t_max**2)
        return 2.0 * (j1 / b + (1.0 - a / b) * (edge + j1) / (2.0 * a))

    pieces = (second(minus, minus + q) + second(plus, plus - q) + first(minus, minus + q)
              + first(plus, plus - q))
    return alpha**2 / (4.0 * np.pi) * pieces


# --------------------------------------------------------------------------- accuracy


@pytest.mark.parametrize("alpha", ALPHAS)
def test_identity_numpy(numpy_filters, alpha):
    assert identity_error(numpy_filters[alpha]) < IDENTITY_ATOL


@pytest.mark.gpu
@pytest.mark.parametrize("alpha", ALPHAS)
def test_identity_gpu(gpu_filters, alpha):
    assert identity_error(gpu_filters[alpha]) < IDENTITY_ATOL


@pytest.mark.parametrize("alpha", [0.01, 0.2, 1.0])
def test_psi_quadrature_matches_closed_form(alpha):
    theta_i = np.array([0.0, 0.3, 0.8, 1.2, 1.5, np.pi / 2])
    theta_d = np.array([1e-3, 0.29, 0.31, 0.79, 1.0, 1.56])
    ti, td = np.meshgrid(theta_i, theta_d, indexing="ij")
    got = F_alpha(ti, td, alpha)
    g1 = ggx_G1(np.cos(ti), alpha)
    expected = np.vectorize(psi_integral_closed_form)(ti, td, alpha)
    expected = 2.0 * g1**2 / np.maximum(np.cos(ti), 1e-300) * np.cos(td) * np.sin(td) * expected
    np.testing.assert_allclose(got[:-1], expected[:-1], rtol=1e-8)
    np.testing.assert_array_equal(got[-1], 0.0)


@pytest.mark.parametrize("case", REFERENCE_CASES, ids=lambda c: f"{c[0]}-{c[1]:.0f}deg-{c[2]}")
def test_filter_matches_eq23_numpy(references, case):
    alpha, deg, name = case
    theta_d, quadrature = difference_angle_grid(alpha)
    T = TRANSMISSIVITIES[name](theta_d)
    filtered = np.sum(F_alpha(deg * DEG, theta_d, alpha) * quadrature * T)
    assert filtered == pytest.approx(references[case], abs=REFERENCE_ATOL)


@pytest.mark.gpu
@pytest.mark.parametrize("case", REFERENCE_CASES, ids=lambda c: f"{c[0]}-{c[1]:.0f}deg-{c[2]}")
def test_filter_matches_eq23_gpu(gpu_filters, references, case):
    alpha, deg, name = case
    filt = gpu_filters[alpha]
    row = round(deg / filt.resolution_deg)
    assert filt.theta_i[row] == pytest.approx(deg * DEG, abs=1e-12)
    filtered = filt.integrate(TRANSMISSIVITIES[name](filt.theta_d))[row]
    assert filtered == pytest.approx(references[case], abs=REFERENCE_ATOL)


def test_small_roughness_concentrates_at_theta_i(numpy_filters):
    """int T F -> G1 T(theta_i) -> T(theta_i) as alpha -> 0, with an error of order
    alpha^2 log(1/alpha) (GGX's slope variance) away from grazing incidence."""
    errors = []
    for alpha in (0.01, 0.1, 0.4):
        filt = numpy_filters[alpha]
        below = filt.theta_i <= 80.0 * DEG + 1e-12
        filtered = filt.integrate(np.cos(filt.theta_d) ** 2)
        errors.append(np.abs(filtered - np.cos(filt.theta_i) ** 2)[below].max())
    assert errors[0] < 2e-3
    assert errors[0] < errors[1] / 10 < errors[2] / 10


# --------------------------------------------------------------------------- GPU twin


@pytest.mark.gpu
@pytest.mark.parametrize("alpha", ALPHAS)
def test_gpu_matches_numpy(numpy_filters, alpha):
    cpu = numpy_filters[alpha]
    gpu_filter = TransmissionFilter.bake(alpha, 1.0, backend="gpu")
    np.testing.assert_array_equal(gpu_filter.theta_d, cpu.theta_d)
    peak = cpu.values.max(axis=1, keepdims=True)
    assert np.all(np.abs(gpu_filter.values - cpu.values) <= GPU_RTOL * peak)
    np.testing.assert_allclose(gpu_filter.weights.sum(1), cpu.weights.sum(1), atol=GPU_RTOL)


def assert_gpu_bake_matches(gpu_filter, cpu):
    peak = cpu.values.max(axis=1, keepdims=True)
    assert np.all(np.abs(gpu_filter.values - cpu.values) <= GPU_RTOL * peak)


@pytest.mark.gpu
def test_gpu_bake_sums_every_psi_sample_past_the_loop_budget():
    # Mesa 22's llvmpipe ends a SIMD group's loops after 65536 iterations (gpu.loop_budget()):
    # in one dispatch the psi loop stopped at sample 65535 of 100000, every entry 34% low.
    psi_samples = 100_000
    assert psi_samples > (gpu.loop_budget() or 65536)
    gpu_filter = TransmissionFilter.bake(0.3, 10.0, psi_samples, backend="gpu")
    # The midpoint rule has converged long before (see F_alpha): 1000 samples are the reference.
    assert_gpu_bake_matches(gpu_filter, TransmissionFilter.bake(0.3, 10.0, 1000, backend="numpy"))


@pytest.mark.gpu
def test_gpu_bake_parts_partition_the_psi_samples(monkeypatch):
    monkeypatch.setattr(transmission_filter, "PSI_SAMPLES_PER_DISPATCH", 7)  # 8 parts, 1 partial
    gpu_filter = TransmissionFilter.bake(0.3, 10.0, 50, backend="gpu")
    assert_gpu_bake_matches(gpu_filter, TransmissionFilter.bake(0.3, 10.0, 50, backend="numpy"))


# --------------------------------------------------------------------------- table


@pytest.mark.parametrize("backend", ["numpy", pytest.param("gpu", marks=pytest.mark.gpu)])
def test_table_layout(backend):
    filt = TransmissionFilter.bake(0.2, 2.0, 200, backend=backend)
    assert (filt.alpha, filt.resolution_deg, filt.psi_samples) == (0.2, 2.0, 200)
    np.testing.assert_allclose(np.diff(filt.theta_i), 2.0 * DEG, rtol=1e-12)
    assert filt.theta_i[0] == 0.0 and filt.theta_i[-1] == np.pi / 2
    assert np.all(np.diff(filt.theta_d) > 0)
    assert 0.0 < filt.theta_d[0] and filt.theta_d[-1] < np.pi / 2
    assert filt.values.shape == filt.weights.shape == (46, filt.theta_d.size)
    assert filt.values.dtype == filt.weights.dtype == np.float64
    assert np.all(np.isfinite(filt.values)) and np.all(filt.values >= 0.0)
    # 90 degrees: G1 = 0, so the row is exactly zero, not 0/0.
    np.testing.assert_array_equal(filt.values[-1], 0.0)
    _, quadrature = difference_angle_grid(0.2, 2.0)
    np.testing.assert_allclose(filt.weights, filt.values * quadrature, rtol=1e-15)


def test_resolution_not_dividing_90_uses_the_next_finer_step():
    filt = TransmissionFilter.bake(0.5, 7.0, 50, backend="numpy")
    np.testing.assert_allclose(np.diff(filt.theta_i), 90.0 / 13 * DEG)
    assert TransmissionFilter.bake(0.5, 0.1, 1, backend="numpy").theta_i.size == 901


def test_theta_d_grid_adapts_to_alpha_and_resolution():
    sizes = {alpha: difference_angle_grid(alpha, 1.0)[0].size for alpha in ALPHAS}
    assert sizes[0.01] > 3 * sizes[0.1]
    assert sizes[0.4] == sizes[1.0] == 144
    assert difference_angle_grid(1.0, 0.25)[0].size == 360
    _, weights = difference_angle_grid(0.05)
    assert weights.sum() == pytest.approx(np.pi / 2, rel=1e-14)
    assert np.all(weights > 0)


def test_integrate_and_interpolate(numpy_filters):
    filt = numpy_filters[0.4]
    T = np.stack([np.ones(filt.theta_d.size), np.cos(filt.theta_d)])[:, None, :] * [[1.0], [2.0]]
    out = filt.integrate(T)
    assert out.shape == (2, 2, filt.theta_i.size)
    np.testing.assert_allclose(out[0, 1], 2.0 * filt.weights.sum(1), rtol=1e-14)
    np.testing.assert_allclose(filt.interpolate(filt.theta_i), filt.weights, rtol=1e-12)
    middle = 0.5 * (filt.theta_i[3] + filt.theta_i[4])
    np.testing.assert_allclose(filt.interpolate(middle),
                               0.5 * (filt.weights[3] + filt.weights[4]), rtol=1e-12)
    assert filt.interpolate(np.full((2, 3), 0.5)).shape == (2, 3, filt.theta_d.size)
    np.testing.assert_array_equal(filt.interpolate(np.pi / 2), 0.0)


def test_from_arrays_round_trip_and_frozen(numpy_filters):
    filt = numpy_filters[0.1]
    fields = {f.name: getattr(filt, f.name) for f in dataclasses.fields(filt)}
    assert set(fields) == {"alpha", "resolution_deg", "psi_samples", "theta_i", "theta_d",
                           "values", "weights"}
    copy = TransmissionFilter.from_arrays(**{k: np.array(v) for k, v in fields.items()})
    for name, value in fields.items():
        np.testing.assert_array_equal(getattr(copy, name), value)
    with pytest.raises(dataclasses.FrozenInstanceError):
        copy.alpha = 0.2
    with pytest.raises(ValueError, match="read-only"):
        copy.values[0, 0] = 1.0
    with pytest.raises(ValueError, match=r"weights must have shape"):
        TransmissionFilter.from_arrays(**{**fields, "weights": filt.weights[:, :-1]})


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"alpha": 0.005}, r"alpha must be in \[0.01, 1\]"),
        ({"alpha": 0.0}, r"alpha must be in \[0.01, 1\]"),
        ({"alpha": 1.5}, r"alpha must be in \[0.01, 1\]"),
        ({"alpha": True}, "alpha must be a real number"),
        ({"alpha": "0.1"}, "alpha must be a real number"),
        ({"alpha": 0.1, "resolution_deg": 0.0}, r"resolution_deg must be .* in \[0.05, 90\]"),
        ({"alpha": 0.1, "resolution_deg": 0.01}, r"resolution_deg must be .* in \[0.05, 90\]"),
        ({"alpha": 0.1, "resolution_deg": 91.0}, "resolution_deg"),
        ({"alpha": 0.1, "resolution_deg": float("nan")}, "resolution_deg"),
        ({"alpha": 0.1, "psi_samples": 0}, "psi_samples must be an integer"),
        ({"alpha": 0.1, "psi_samples": 2.5}, "psi_samples must be an integer"),
        ({"alpha": 0.1, "backend": "cuda"}, "backend must be one of"),
    ],
)
def test_bake_raises(kwargs, match):
    with pytest.raises(ValueError, match=match):
        TransmissionFilter.bake(**kwargs)


def test_other_raises(numpy_filters):
    filt = numpy_filters[0.1]
    with pytest.raises(ValueError, match="T must have a last axis"):
        filt.integrate(np.ones(3))
    with pytest.raises(ValueError, match=r"theta_i must be in \[0, pi/2\]"):
        filt.interpolate(2.0)
    with pytest.raises(ValueError, match="theta_d"):
        F_alpha(0.1, -0.1, 0.1)
    with pytest.raises(ValueError, match="alpha"):
        ballistic_transmission_reference(np.cos, 0.1, 0.0)


def test_F_alpha_names_angles_that_do_not_broadcast():
    with pytest.raises(ValueError, match=r"theta_i.*theta_d"):
        transmission_filter.F_alpha([0.1, 0.2], [0.1, 0.2, 0.3], 0.1)
