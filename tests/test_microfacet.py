"""GGX microfacet functions (wgbragg.bsdf.microfacet) and their float32 WGSL twins
(wgsl/bsdf/microfacet.wgsl).

Invariants (normalisation of D, of the visible-normal density), closed forms and limits of G1,
a chi-square test of the sampler against its density (Mitsuba style), and the GPU twins
against numpy on the float32-rounded inputs the kernel sees.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import expected_direction_counts, pooled_chi2_pvalue
from scipy.integrate import quad

from wgbragg import gpu
from wgbragg.bsdf.microfacet import (
    ggx_D,
    ggx_G1,
    ggx_lobe,
    ggx_sample_visible_normal,
    ggx_visible_normal_pdf,
)

KERNELS = Path(__file__).resolve().parent / "kernels"
"""The test suite's own WGSL kernels (not shipped in the wheel)."""

ALPHAS = [1e-4, 0.01, 0.1, 0.5, 1.0]
QUAD_ATOL = 1e-7  # nested scipy quad of the normalisation integrals
CHI2_P_MIN = 1e-3
F32_RTOL = 2e-5  # float32 kernel vs float64 twin on the same (rounded) inputs
SAMPLE_ATOL = 1e-5  # sampled normals beyond a 2-ulp change of u (built-in f32 sin/cos)


def direction(theta: float, phi: float = 0.0) -> np.ndarray:
    return np.array([math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi),
                     math.cos(theta)])


def hemisphere_integral(f, alpha: float, wi: np.ndarray | None = None) -> float:
    """int f(m) dw over the upper hemisphere; over the part with wi.m > 0 when wi is given.

    The polar integral is split at 10 alpha so that quad sees the GGX peak; the azimuthal one
    runs over the exact interval where wi.m > 0 (where f is smooth) with 64 Gauss nodes.
    """
    x, w = np.polynomial.legendre.leggauss(64)
    if wi is None:
        ci, si, phi_i = 1.0, 0.0, 0.0
    else:
        ci, si, phi_i = wi[2], math.hypot(wi[0], wi[1]), math.atan2(wi[1], wi[0])

    def ring(theta_m: float) -> float:
        cm, sm = math.cos(theta_m), math.sin(theta_m)
        half = math.acos(min(1.0, max(-1.0, -ci * cm / (si * sm)))) if si * sm > 0 else np.pi
        phi = phi_i + half * x
        m = np.stack([sm * np.cos(phi), sm * np.sin(phi), np.full_like(phi, cm)], axis=-1)
        return float(half * np.sum(w * f(m))) * sm

    split = min(10 * alpha, 1.0)
    return sum(quad(ring, lo, hi, epsabs=QUAD_ATOL / 10, limit=200)[0]
               for lo, hi in ((0.0, split), (split, np.pi / 2)))


# --------------------------------------------------------------------------- D and G1


@pytest.mark.parametrize("alpha", ALPHAS)
def test_D_projected_area_is_one(alpha):
    total = hemisphere_integral(lambda m: ggx_D(m[..., 2], alpha) * m[..., 2], alpha)
    assert total == pytest.approx(1.0, abs=QUAD_ATOL * 10)


def test_D_values_and_lower_hemisphere():
    alpha = 0.3
    theta = np.linspace(0.0, 1.5, 7)
    expected = alpha**2 / (np.pi * np.cos(theta) ** 4 * (alpha**2 + np.tan(theta) ** 2) ** 2)
    np.testing.assert_allclose(ggx_D(np.cos(theta), alpha), expected, rtol=1e-12)
    assert ggx_D(1.0, alpha) == pytest.approx(1.0 / (np.pi * alpha**2), rel=1e-15)
    np.testing.assert_array_equal(ggx_D([0.0, -0.5, -1.0], alpha), 0.0)


@pytest.mark.parametrize("alpha", ALPHAS)
def test_G1_closed_form_and_limits(alpha):
    theta = np.linspace(0.01, 1.55, 50)
    expected = 2.0 / (1.0 + np.sqrt(1.0 + alpha**2 * np.tan(theta) ** 2))
    np.testing.assert_allclose(ggx_G1(np.cos(theta), alpha), expected, rtol=1e-12)
    assert ggx_G1(1.0, alpha) == 1.0
    cos = np.array([1e-3, 1e-8, 1e-300, 0.0])
    grazing = ggx_G1(cos, alpha)
    # tan^2 overflows for the smallest cosines; G1 -> 2 cos / (cos + alpha) does not.
    np.testing.assert_allclose(
        grazing, 2 * cos / (cos + np.sqrt(cos**2 + alpha**2 * (1 - cos**2))), rtol=1e-12
    )
    assert grazing[-1] == 0.0
    np.testing.assert_array_equal(ggx_G1([-1e-9, -1.0], alpha), 0.0)


def test_G1_decreases_with_angle_and_roughness():
    cos = np.linspace(1.0, 0.0, 101)
    g = ggx_G1(cos[:, None], np.array(ALPHAS))
    assert np.all(np.diff(g, axis=0) <= 0.0)
    assert np.all(np.diff(g, axis=1) <= 0.0)


# --------------------------------------------------------------------------- visible normals


@pytest.mark.parametrize("alpha", [0.01, 0.2, 1.0])
@pytest.mark.parametrize("theta_i_deg", [0.0, 45.0, 85.0, 90.0])
def test_visible_normal_pdf_integrates_to_one(alpha, theta_i_deg):
    wi = direction(math.radians(theta_i_deg), 0.7)
    total = hemisphere_integral(lambda m: ggx_visible_normal_pdf(wi, m, alpha), alpha, wi)
    assert total == pytest.approx(1.0, abs=QUAD_ATOL * 10)


def test_visible_normal_pdf_is_D_cos_at_normal_incidence():
    m = np.stack([direction(t, p) for t, p in [(0.0, 0.0), (0.3, 1.0), (1.2, -2.0)]])
    np.testing.assert_allclose(ggx_visible_normal_pdf([0.0, 0.0, 1.0], m, 0.4),
                               ggx_D(m[:, 2], 0.4) * m[:, 2], rtol=1e-14)


def test_visible_normal_pdf_zero_for_hidden_and_lower_normals():
    wi = direction(math.radians(80.0))
    m = np.stack([direction(math.radians(60.0), np.pi), direction(2.0), -wi])
    np.testing.assert_array_equal(ggx_visible_normal_pdf(wi, m, 0.5), 0.0)


def chi2_pvalue(wi, alpha, seed, n_samples=200_000, n_cos=16, n_phi=32):
    """Mitsuba's chi-square test of the sampler against its pdf on a (cos theta, phi) grid.

    Expected counts integrate the pdf over each cell with a 24 x 24 Gauss rule; cells
    expecting fewer than 5 samples are pooled into one.
    """
    rng = np.random.default_rng(seed)
    m = ggx_sample_visible_normal(wi, rng.random((n_samples, 2)), alpha)
    # Cells equally likely under D cos in theta (GGX's CDF), so none is empty at small alpha.
    xi = np.linspace(0.0, 1.0, n_cos + 1)
    cos_edges = np.sqrt((1.0 - xi) / ((1.0 - xi) + alpha**2 * xi))[::-1]
    phi_edges = np.linspace(-np.pi, np.pi, n_phi + 1)
    observed, _, _ = np.histogram2d(m[:, 2], np.arctan2(m[:, 1], m[:, 0]),
                                    bins=[cos_edges, phi_edges])
    expected = expected_direction_counts(lambda cells: ggx_visible_normal_pdf(wi, cells, alpha),
                                         cos_edges, phi_edges, n_samples, order=24)
    assert expected.sum() == pytest.approx(n_samples, rel=1e-4)
    assert not np.any((expected == 0) & (observed > 0))
    return pooled_chi2_pvalue(observed, expected)


@pytest.mark.parametrize(
    ("alpha", "theta_i_deg", "seed"),
    [(0.05, 80.0, 1), (0.3, 60.0, 2), (0.8, 30.0, 3), (1.0, 0.0, 4), (0.5, 89.9, 5)],
)
def test_sampler_chi_square(alpha, theta_i_deg, seed):
    wi = direction(math.radians(theta_i_deg), 0.4)
    assert chi2_pvalue(wi, alpha, seed) > CHI2_P_MIN


def test_sampler_outputs_unit_upper_normals_seen_by_wi():
    rng = np.random.default_rng(7)
    wi = direction(math.radians(70.0), 1.0)
    m = ggx_sample_visible_normal(wi, rng.random((10_000, 2)), 0.6)
    np.testing.assert_allclose(np.linalg.norm(m, axis=-1), 1.0, atol=1e-14)
    assert np.all(m[:, 2] >= 0.0)
    assert np.all(m @ wi >= -1e-12)


def test_sampler_edge_inputs_finite():
    wi = np.stack([direction(0.0), direction(np.pi / 2, 0.3)])
    u = np.array([[0.0, 0.0], [1.0, 1.0], [0.5, 0.0], [1.0, 0.25]])
    for alpha in (1e-4, 1.0):
        m = ggx_sample_visible_normal(wi[:, None], u[None], alpha)
        assert m.shape == (2, 4, 3)
        assert np.all(np.isfinite(m))


# --------------------------------------------------------------------------- shapes, errors


def test_n_dimensional_broadcast():
    cos = np.linspace(-0.2, 1.0, 24).reshape(2, 3, 4)
    alpha = np.array([0.1, 0.2, 0.5, 1.0])
    assert ggx_D(cos, alpha).shape == (2, 3, 4)
    assert ggx_G1(cos, alpha).shape == (2, 3, 4)
    np.testing.assert_array_equal(ggx_G1(cos, alpha)[1, 2], ggx_G1(cos[1, 2], alpha))
    wi = np.stack([direction(t) for t in (0.1, 0.5, 1.0, 1.4, 1.5)])[:, None, :]
    u = np.random.default_rng(0).random((1, 7, 2))
    m = ggx_sample_visible_normal(wi, u, 0.3)
    assert m.shape == (5, 7, 3)
    assert ggx_visible_normal_pdf(wi, m, 0.3).shape == (5, 7)
    np.testing.assert_array_equal(m[3, 4], ggx_sample_visible_normal(wi[3, 0], u[0, 4], 0.3))
    assert ggx_D(0.5, 0.2).shape == ()


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: ggx_D(0.5, 0.0), r"alpha must be in \[0.0001, 1\]"),
        (lambda: ggx_D(0.5, 1.5), r"alpha must be in \[0.0001, 1\]"),
        (lambda: ggx_G1(0.5, [0.1, -0.1]), "alpha"),
        (lambda: ggx_G1(0.5, np.nan), "alpha contains NaN"),
        (lambda: ggx_D(1.5, 0.1), r"cos_theta_m must be in \[-1, 1\]"),
        (lambda: ggx_G1(np.nan, 0.1), "cos_theta contains NaN"),
        (lambda: ggx_G1("0.5", 0.1), "cos_theta must be a real number"),
        (lambda: ggx_sample_visible_normal([0, 0, 2.0], [0.5, 0.5], 0.1), "wi must hold unit"),
        (lambda: ggx_sample_visible_normal([0, 0, -1.0], [0.5, 0.5], 0.1), "upper hemisphere"),
        (lambda: ggx_sample_visible_normal([0, 1.0], [0.5, 0.5], 0.1), "trailing axis of length 3"),
        (lambda: ggx_sample_visible_normal([0, 0, 1.0], [0.5, 1.5], 0.1), r"u must be in \[0, 1\]"),
        (lambda: ggx_sample_visible_normal([0, 0, 1.0], [0.5], 0.1), "trailing axis of length 2"),
        (lambda: ggx_visible_normal_pdf([0, 0, 1.0], [0, 0, 0.5], 0.1), "m must hold unit"),
        (lambda: ggx_visible_normal_pdf(np.tile([0, 0, 1.0], (2, 1)),
                                        np.tile([0, 0, 1.0], (3, 1)), 0.1),
         r"wi \(2,\) and m \(3,\) and alpha \(\) do not broadcast"),
    ],
)
def test_raises(call, match):
    with pytest.raises(ValueError, match=match):
        call()


# --------------------------------------------------------------------------- GPU twins


def run_ggx_kernel(wi, m, u, alpha):
    params = np.zeros((), gpu.struct_dtype([("alpha", "f32")]))
    params["alpha"] = alpha
    pad = np.zeros((len(wi), 1), np.float32)
    values, sampled = gpu.compute_pipeline(str(KERNELS / "microfacet_eval.wgsl")).run(
        [np.hstack([wi, pad]), np.hstack([m, pad]), u],
        [((len(wi), 4), np.float32), ((len(wi), 4), np.float32)],
        params,
    )
    return values.astype(np.float64), sampled[:, :3].astype(np.float64)


def random_inputs(n, seed):
    """float32 directions (wi in the upper hemisphere, m anywhere) and u, with edge cases."""
    rng = np.random.default_rng(seed)
    theta_i = np.concatenate([[0.0, np.pi / 2, 1.5], np.arccos(rng.random(n - 3))])
    wi = np.stack([direction(t, p) for t, p in zip(theta_i, rng.uniform(-np.pi, np.pi, n),
                                                    strict=True)])
    m = rng.normal(size=(n, 3))
    m /= np.linalg.norm(m, axis=-1, keepdims=True)
    m[:2] = [0.0, 0.0, 1.0]
    u = rng.random((n, 2))
    u[:2] = [[0.0, 0.0], [1.0, 1.0]]
    # The kernel sees float32 values; compare with numpy on exactly those.
    return tuple(a.astype(np.float32) for a in (wi, m, u))


@pytest.mark.gpu
@pytest.mark.parametrize("alpha", [2**-13, 0.01, 0.3, 1.0])
def test_gpu_matches_numpy(alpha):
    wi, m, u = random_inputs(4096, seed=11)
    alpha = float(np.float32(alpha))
    values, sampled = run_ggx_kernel(wi, m, u, alpha)
    wi64, m64, u64 = (a.astype(np.float64) for a in (wi, m, u))
    np.testing.assert_allclose(values[:, 0], ggx_D(m64[:, 2], alpha), rtol=F32_RTOL, atol=0)
    np.testing.assert_allclose(values[:, 1], ggx_G1(wi64[:, 2], alpha), rtol=F32_RTOL,
                               atol=1e-7)
    pdf = ggx_visible_normal_pdf(wi64, m64, alpha)
    # float32 wi.m has an absolute error ~1e-7, which dominates near the visibility edge
    # wi.m = 0: allow that much of d pdf / d(wi.m) = (G1 / cos) D.
    c = wi64[:, 2]
    slope = 2.0 / (c + np.sqrt(c * c + alpha**2 * (1 - c * c))) * ggx_D(m64[:, 2], alpha)
    np.testing.assert_array_less(np.abs(values[:, 2] - pdf), F32_RTOL * pdf + 2e-7 * slope + 1e-30)
    # Near the rim of the sampled disk the map u -> m is ill-conditioned (sqrt(1 - t1^2 - t2^2)
    # cancels, and small alpha magnifies the tilt), so float32 rounding moves m as much as a
    # 2-ulp change of u does: that spread is the tolerance, as in test_optics_gpu.
    expected = ggx_sample_visible_normal(wi64, u64, alpha)
    spread = np.zeros(len(u64))
    for step in itertools.product((-2, 0, 2), repeat=2):
        nudged = np.clip(u64 + np.array(step) * np.spacing(u).astype(np.float64), 0.0, 1.0)
        moved = ggx_sample_visible_normal(wi64, nudged, alpha) - expected
        spread = np.maximum(spread, np.abs(moved).max(axis=-1))
    np.testing.assert_array_less(np.abs(sampled - expected).max(axis=-1), SAMPLE_ATOL + spread)
    assert np.all(np.isfinite(values)) and np.all(np.isfinite(sampled))


def test_lobe_is_the_specular_microfacet_factor():
    """ggx_lobe = D(h) G1(i) G1(o) / (4 cos_i cos_o) from the checked functions, any shape."""
    rng = np.random.default_rng(11)
    cos_h, cos_i, cos_o = (rng.uniform(0.05, 1.0, (4, 5)) for _ in range(3))
    alpha = rng.uniform(0.05, 1.0, (4, 5))
    expected = (ggx_D(cos_h, alpha) * ggx_G1(cos_i, alpha) * ggx_G1(cos_o, alpha)
                / (4.0 * cos_i * cos_o))
    np.testing.assert_allclose(ggx_lobe(cos_h, cos_i, cos_o, alpha), expected, rtol=1e-12)
    assert np.all(np.isfinite(ggx_lobe(np.zeros(3), np.zeros(3), np.zeros(3), 0.3)))
