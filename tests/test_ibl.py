"""Filtered image-based lighting (:mod:`wgbragg.lighting.ibl`): the microfacet albedo, the moment
statistics, the split-sum and Kneiphof reflectance terms of a thin film, our Gauss-Hermite
analogue for Bragg layers, and their limit under uniform light as the roughness vanishes.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from wgbragg import BraggMirror, ThinFilm
from wgbragg.bsdf.microfacet import ggx_G1, ggx_sample_visible_normal
from wgbragg.colour.colorimetry import delta_e_2000
from wgbragg.colour.thin_film import PREFILTER_RANGE_NM
from wgbragg.lighting.ibl import (
    ALBEDO_TABLE_NODES,
    IBL_MODES,
    bragg_filtered_reflectance,
    film_kneiphof_reflectance,
    film_split_sum_reflectance,
    kneiphof_parameters,
    microfacet_albedo,
    microfacet_albedo_table,
    moment_statistics,
    reflected_light_statistics,
    uniform_light_moments,
    uniform_light_statistics,
    uniform_reflected_radiance,
)

FIG7 = ThinFilm(1.33, 550.0, n_base=2.0, k_base=0.5)
GOLD = ThinFilm(1.45, 300.0, base="Au")
# A film of lower index than its host: evanescent at the mean incidence for mu_x < -0.63.
LOW_INDEX = ThinFilm(1.2, 450.0, n_base=1.6, host=1.33)
BRAGG = BraggMirror(1.0, 1.5, 125.0, 125.0, 10)

# alpha = 0.01 under uniform light, theta_v = 0, 20, ..., 80 deg (16 quadrature nodes), against
# the exact reflected radiance: measured max |difference| 5.1e-3 (films), 8.4e-3 (Bragg,
# filtered) and max dE2000 0.23 (films), 0.33 (Bragg), at 80 deg; the films' floor includes
# the Fourier truncation (M = 3). At alpha = 0.05 the same errors are 2.5 to 14 times larger.
SMOOTH_LIMIT_ATOL = 1.2e-2
SMOOTH_LIMIT_DELTA_E = 0.6


def view(cos_v):
    cos_v = np.asarray(cos_v, np.float64)
    return np.stack([np.sqrt(1.0 - cos_v**2), np.zeros_like(cos_v), cos_v], axis=-1)


def test_modes():
    assert IBL_MODES == ("monte-carlo", "split-sum", "kneiphof")


# ---------------------------------------------------------------------- E(cos_v)


@pytest.mark.parametrize("alpha", [0.05, 0.3, 1.0])
@pytest.mark.parametrize("cos_v", [0.02, 0.4, 0.95])
def test_microfacet_albedo_against_monte_carlo(alpha, cos_v):
    """E = E_{m ~ VNDF}[G1(l)], l = reflect(v, m): 1e6 samples, within 4 standard errors."""
    v = view(cos_v)
    m = ggx_sample_visible_normal(v, np.random.default_rng(11).random((1_000_000, 2)), alpha)
    l_z = 2.0 * (m @ v) * m[:, 2] - cos_v
    g = ggx_G1(np.clip(l_z, -1.0, 1.0), alpha)
    error = g.std() / 1000.0
    assert abs(float(microfacet_albedo(cos_v, alpha)) - g.mean()) < 4.0 * error


def test_microfacet_albedo_limits_and_closed_form():
    cos_v = np.linspace(0.0, 1.0, 41)
    for alpha in (1e-3, 0.01, 0.2, 0.6, 1.0):
        E = microfacet_albedo(cos_v, alpha, nodes=32)
        assert np.all(E > 0.0) and np.all(E <= 1.0)
    # Nearly smooth, away from grazing: 1 - E ~ alpha^2 (1 + tan^2 theta_v / 2) (measured within
    # 0.7% at alpha = 1e-3 and 9% at 0.01 for cos_v >= 0.2): E -> 1 as alpha -> 0.
    cos_v = cos_v[cos_v >= 0.2]
    tan2 = (1.0 - cos_v**2) / cos_v**2
    for alpha, rtol in ((1e-3, 0.01), (0.01, 0.1)):
        loss = 1.0 - microfacet_albedo(cos_v, alpha, nodes=32)
        np.testing.assert_allclose(loss, alpha**2 * (1.0 + 0.5 * tan2), rtol=rtol)
    # alpha = 1 at normal incidence: D = 1/pi, E = 2 int_0^{pi/4} tan (cos 2t) dt = 1 - ln 2.
    assert float(microfacet_albedo(1.0, 1.0)) == pytest.approx(1.0 - math.log(2.0), abs=1e-12)


@pytest.mark.parametrize("alpha", [0.01, 0.02, 0.05, 0.3, 1.0])
def test_microfacet_albedo_quadrature_converges(alpha):
    """The default 64 nodes against 384: within 1e-5 on the renderer's table nodes nearest
    grazing (the hardest) and elsewhere; measured <= 2e-6 against 1536 nodes on all 64."""
    cos_v = np.concatenate([(np.arange(4) + 0.5) / ALBEDO_TABLE_NODES, [0.3, 0.7, 0.99, 1.0]])
    coarse = microfacet_albedo(cos_v, alpha)
    fine = microfacet_albedo(cos_v, alpha, nodes=384)
    np.testing.assert_allclose(coarse, fine, atol=1e-5, rtol=0.0)


def test_albedo_table():
    table = microfacet_albedo_table(0.3)
    assert table.shape == (ALBEDO_TABLE_NODES,) and table.dtype == np.float64
    cos_v = (np.arange(ALBEDO_TABLE_NODES) + 0.5) / ALBEDO_TABLE_NODES
    np.testing.assert_allclose(table, microfacet_albedo(cos_v, 0.3), rtol=1e-14)
    table[:] = 0.0  # a copy: the cache stays intact
    assert microfacet_albedo_table(0.3)[0] > 0.0
    assert microfacet_albedo_table(0.3, nodes=8).shape == (8,)


def test_vectorised_shapes():
    cos_v = np.full((2, 3), 0.6)
    assert microfacet_albedo(cos_v, 0.2, nodes=8).shape == (2, 3)
    assert microfacet_albedo(0.6, np.array([0.1, 0.2]), nodes=8).shape == (2,)
    mu, sigma = uniform_light_statistics(cos_v, 0.2, nodes=8)
    assert mu.shape == sigma.shape == (2, 3)
    assert film_kneiphof_reflectance(FIG7, mu, sigma).shape == (2, 3, 3)
    assert film_split_sum_reflectance(FIG7, cos_v).shape == (2, 3, 3)
    assert bragg_filtered_reflectance(BRAGG.rgb, mu, sigma).shape == (2, 3, 3)
    assert uniform_reflected_radiance(BRAGG.rgb, cos_v[0, :1], 0.2, nodes=4).shape == (1, 3)


# ---------------------------------------------------------------------- moments


def test_moment_statistics_packed_and_matrix_forms():
    rng = np.random.default_rng(1)
    l = rng.normal(size=(5, 200, 3))
    l /= np.linalg.norm(l, axis=-1, keepdims=True)
    m1 = l.mean(1)
    m2 = np.einsum("eki,ekj->eij", l, l) / l.shape[1]
    packed = np.concatenate([np.diagonal(m2, axis1=-2, axis2=-1),
                             np.stack([m2[:, 0, 1], m2[:, 1, 2], m2[:, 2, 0]], axis=-1)], axis=-1)
    v = view(np.linspace(0.1, 1.0, 5))
    x = np.einsum("eki,ei->ek", l, v)
    for second in (m2, packed):
        mu, sigma = moment_statistics(v, m1, second)
        np.testing.assert_allclose(mu, x.mean(1), atol=1e-14)
        np.testing.assert_allclose(sigma, x.std(1), rtol=1e-12)
    # One direction: no spread.
    mu, sigma = moment_statistics(v[0], v[1], np.outer(v[1], v[1]))
    assert mu == pytest.approx(v[0] @ v[1], abs=1e-15) and sigma == pytest.approx(0.0, abs=1e-7)


@pytest.mark.parametrize("alpha", [0.1, 0.5])
def test_uniform_light_moments_against_monte_carlo(alpha):
    """The kernel D(h) G1(l) at v = n = r is the VNDF's reflection weighted by G1(l)."""
    v = np.array([0.0, 0.0, 1.0])
    m = ggx_sample_visible_normal(v, np.random.default_rng(5).random((1_000_000, 2)), alpha)
    l = 2.0 * m[:, 2:] * m - v
    w = ggx_G1(np.clip(l[:, 2], -1.0, 1.0), alpha)
    mean_cos, second = uniform_light_moments(alpha)
    assert mean_cos == pytest.approx(np.sum(w * l[:, 2]) / w.sum(), abs=2e-3)
    assert second[2, 2] == pytest.approx(np.sum(w * l[:, 2] ** 2) / w.sum(), abs=2e-3)
    np.testing.assert_allclose(second, np.diag(np.diagonal(second)), atol=1e-15)
    assert second[0, 0] == pytest.approx(second[1, 1], rel=1e-12)
    assert np.trace(second) == pytest.approx(1.0, abs=1e-12)


def test_uniform_light_statistics_at_normal_view_and_the_exact_lobe():
    alpha = 0.4
    mean_cos, second = uniform_light_moments(alpha)
    mu, sigma = uniform_light_statistics(1.0, alpha)
    assert mu == pytest.approx(mean_cos, rel=1e-12)
    assert sigma == pytest.approx(math.sqrt(second[2, 2] - mean_cos**2), rel=1e-10)
    # At normal view the lobe is the kernel itself: the exact statistics agree.
    exact = reflected_light_statistics(1.0, alpha)
    np.testing.assert_allclose(exact, (mu, sigma), rtol=1e-10)
    # Off normal they differ (the n = v = r assumption): the exact mean is closer to 1.
    mu_u, _ = uniform_light_statistics(0.3, alpha)
    mu_e, _ = reflected_light_statistics(0.3, alpha)
    assert mu_e > mu_u


def test_reflected_light_statistics_against_monte_carlo():
    alpha, cos_v = 0.35, 0.45
    v = view(cos_v)
    m = ggx_sample_visible_normal(v, np.random.default_rng(8).random((1_000_000, 2)), alpha)
    l = 2.0 * (m @ v)[:, None] * m - v
    w = ggx_G1(np.clip(l[:, 2], -1.0, 1.0), alpha)
    x = l @ v
    mean = np.sum(w * x) / w.sum()
    std = math.sqrt(np.sum(w * x * x) / w.sum() - mean**2)
    mu, sigma = reflected_light_statistics(cos_v, alpha)
    assert mu == pytest.approx(mean, abs=2e-3) and sigma == pytest.approx(std, abs=2e-3)


# ---------------------------------------------------------------------- films


@pytest.mark.parametrize("film", [FIG7, GOLD, LOW_INDEX], ids=["fig7", "gold", "low-index"])
def test_kneiphof_without_spread_is_the_split_sum(film):
    cos_v = np.linspace(0.0, 1.0, 11)
    mu = 2.0 * cos_v**2 - 1.0
    np.testing.assert_allclose(film_kneiphof_reflectance(film, mu, 0.0),
                               film_split_sum_reflectance(film, cos_v), rtol=1e-10, atol=1e-14)
    theta1, s = kneiphof_parameters(film, mu, 0.0)
    np.testing.assert_allclose(np.cos(theta1), cos_v, atol=1e-12)
    assert np.all(s == 0.0)


@pytest.mark.parametrize("film,method", [(FIG7, "fourier-table"), (GOLD, "fourier-table"),
                                         (FIG7, "fourier-gaussian"), (LOW_INDEX, "fourier-table")],
                         ids=["fig7", "gold", "gaussian", "low-index"])
def test_kneiphof_is_the_prefiltered_film_colour_at_the_mean(film, method):
    """Elementwise film.rgb(theta1, thickness_std_nm=s), including evanescent means."""
    mu = np.array([0.95, 0.6, 0.1, -0.4, -0.8, -1.0])
    sigma = np.array([0.05, 0.2, 0.35, 0.3, 0.15, 0.0])
    theta1, s = kneiphof_parameters(film, mu, sigma)
    expected = np.stack([film.rgb(t, method, order=2, thickness_std_nm=float(x))
                         for t, x in zip(theta1, s, strict=True)])
    np.testing.assert_allclose(film_kneiphof_reflectance(film, mu, sigma, order=2, method=method),
                               expected, rtol=1e-10, atol=1e-13)


def test_kneiphof_parameters_follow_eqs_25_to_28():
    film = FIG7
    mu, sigma = np.array([0.8, 0.0, -0.5]), np.array([0.1, 0.3, 0.2])
    theta1, s = kneiphof_parameters(film, mu, sigma)
    k = 1.0 / film.n_film**2
    mean_c2 = np.sqrt(1.0 + 0.5 * k * (mu - 1.0))
    sigma_D = 2.0 * film.n_film * film.d * (0.25 * k / mean_c2 * sigma)
    # thin_film_colour spreads the first term by (2 n2 cos theta2) s at theta1.
    cos_theta2 = np.sqrt(1.0 - k * np.sin(theta1) ** 2)
    np.testing.assert_allclose(cos_theta2, mean_c2, rtol=1e-12)
    np.testing.assert_allclose(2.0 * film.n_film * cos_theta2 * s, sigma_D, rtol=1e-12)
    np.testing.assert_allclose(np.cos(theta1), np.sqrt(0.5 * (1.0 + mu)), rtol=1e-12)
    # Evanescent at the mean: no spread; a huge spread stays finite (the table reads 0).
    _, s = kneiphof_parameters(LOW_INDEX, -0.9, 0.3)
    assert s == 0.0
    _, s = kneiphof_parameters(LOW_INDEX, -0.62, 1e300)
    assert np.isfinite(s) and s > 0.0
    theta1, _ = kneiphof_parameters(LOW_INDEX, -0.62, 1e300)
    opd = 2.0 * LOW_INDEX.n_film * np.sqrt(1.0 - (1.33 / 1.2) ** 2 * np.sin(theta1) ** 2)
    assert opd * s == pytest.approx(PREFILTER_RANGE_NM, rel=1e-9)


def test_spread_desaturates_the_film():
    """A wider OPD distribution mixes more colours: less chroma, towards the mean colour."""
    colours = film_kneiphof_reflectance(FIG7, 0.2, np.array([0.0, 0.1, 0.3, 0.6]))
    chroma = colours.max(-1) - colours.min(-1)
    assert np.all(np.diff(chroma) < 0.0)


# ---------------------------------------------------------------------- Bragg analogue


def test_bragg_filter_without_spread_is_the_colour_at_theta1():
    mu = np.array([1.0, 0.5, 0.0, -0.7])
    theta1 = np.arccos(np.sqrt(0.5 * (1.0 + mu)))
    np.testing.assert_allclose(bragg_filtered_reflectance(BRAGG.rgb, mu, 0.0),
                               BRAGG.rgb(theta1), rtol=1e-12, atol=1e-15)


def test_bragg_filter_averages_over_the_normal_distribution():
    """Five Gauss-Hermite nodes are exact for polynomials of degree <= 9 in x: cos^2 theta1
    = (1 + x) / 2 and its square average exactly (no node clamped here)."""
    def colour(theta):
        c2 = np.cos(theta) ** 2
        return np.stack([c2, c2 * c2, np.ones_like(c2)], axis=-1)

    mu, sigma = np.array([0.2, -0.1]), np.array([0.1, 0.25])
    out = bragg_filtered_reflectance(colour, mu, sigma)
    np.testing.assert_allclose(out[:, 0], 0.5 * (1.0 + mu), rtol=1e-12)
    np.testing.assert_allclose(out[:, 1], ((1.0 + mu) ** 2 + sigma**2) / 4.0, rtol=1e-12)
    np.testing.assert_allclose(out[:, 2], 1.0, rtol=1e-12)
    # Nodes beyond [-1, 1] are clamped: the mirror direction at most.
    np.testing.assert_allclose(bragg_filtered_reflectance(colour, 1.0, 5.0)[0], 0.5 * (
        1.0 + np.clip(5.0 * np.polynomial.hermite_e.hermegauss(5)[0] + 1.0, -1.0, 1.0)) @ (
        np.polynomial.hermite_e.hermegauss(5)[1] / math.sqrt(2.0 * math.pi)), rtol=1e-12)


# ---------------------------------------------------------------------- uniform light


@pytest.fixture(scope="module")
def smooth_limit():
    """Every mode's radiance under uniform light at alpha = 0.01 and 0.05, and the exact one."""
    theta = np.radians(np.arange(0.0, 81.0, 20.0))
    cos_v = np.cos(theta)
    out = {}
    for alpha in (0.01, 0.05):
        E = microfacet_albedo(cos_v, alpha)[..., None]
        mu, sigma = uniform_light_statistics(cos_v, alpha)
        for name, material in (("fig7", FIG7), ("gold", GOLD)):
            exact = uniform_reflected_radiance(lambda t, f=material: f.rgb(t, "reference"),
                                               cos_v, alpha, nodes=16)
            out[name, alpha] = (exact, {
                "split-sum": E * film_split_sum_reflectance(material, cos_v),
                "kneiphof": E * film_kneiphof_reflectance(material, mu, sigma)})
        exact = uniform_reflected_radiance(lambda t: BRAGG.rgb(t, "reference"), cos_v, alpha,
                                           nodes=16)
        out["bragg", alpha] = (exact, {
            "split-sum": E * BRAGG.rgb(theta, "reference"),
            "kneiphof": E * bragg_filtered_reflectance(lambda t: BRAGG.rgb(t, "reference"),
                                                       mu, sigma)})
    return out


@pytest.mark.parametrize("material", ["fig7", "gold", "bragg"])
@pytest.mark.parametrize("mode", ["split-sum", "kneiphof"])
def test_modes_converge_to_the_exact_radiance_as_alpha_vanishes(smooth_limit, material, mode):
    exact, modes = smooth_limit[material, 0.01]
    np.testing.assert_allclose(modes[mode], exact, atol=SMOOTH_LIMIT_ATOL)
    assert delta_e_2000(modes[mode], exact).max() < SMOOTH_LIMIT_DELTA_E
    rough_exact, rough_modes = smooth_limit[material, 0.05]
    assert (np.abs(modes[mode] - exact).max()
            < np.abs(rough_modes[mode] - rough_exact).max())


def test_exact_radiance_of_a_grey_material_is_its_albedo():
    cos_v = np.array([0.1, 0.5, 1.0])
    grey = uniform_reflected_radiance(lambda t: np.full((*np.shape(t), 3), 0.25), cos_v, 0.3)
    np.testing.assert_allclose(grey, 0.25 * microfacet_albedo(cos_v, 0.3)[:, None] * np.ones(3),
                               rtol=1e-12)


# ---------------------------------------------------------------------- errors


@pytest.mark.parametrize("call,match", [
    (lambda: microfacet_albedo(1.5, 0.3), r"cos_v must be in \[0, 1\]"),
    (lambda: microfacet_albedo(0.5, 0.0), "alpha"),
    (lambda: microfacet_albedo(0.5, 0.3, nodes=1), "nodes"),
    (lambda: microfacet_albedo_table(2.0), "alpha"),
    (lambda: microfacet_albedo_table("0.3"), "alpha"),
    (lambda: microfacet_albedo_table(0.3, nodes=1), "nodes"),
    (lambda: moment_statistics([0.0, 0.0, 5.0], [0.0, 0.0, 1.0], np.eye(3)), "v must hold unit"),
    (lambda: moment_statistics([0.0, 0.0, 1.0], [0.0, 1.0], np.eye(3)), "m1"),
    (lambda: moment_statistics([0.0, 0.0, 1.0], [0.0, 0.0, 1.0], np.zeros(5)), "m2"),
    (lambda: film_kneiphof_reflectance(FIG7, 1.2, 0.1), r"mu_x must be in \[-1, 1\]"),
    (lambda: film_kneiphof_reflectance(FIG7, 0.2, -0.1), "sigma_x"),
    (lambda: film_kneiphof_reflectance(FIG7, np.nan, 0.1), "NaN"),
    (lambda: film_kneiphof_reflectance(FIG7, 0.2, np.inf), "sigma_x"),
    (lambda: film_kneiphof_reflectance(FIG7, 0.2, 0.1, method="reference"), "method"),
    (lambda: film_kneiphof_reflectance(FIG7, 0.2, 0.1, order=17), "order"),
    (lambda: film_kneiphof_reflectance(BRAGG, 0.2, 0.1), "ThinFilm"),
    (lambda: film_kneiphof_reflectance(FIG7, [0.1, 0.2], [0.1, 0.2, 0.3]), "broadcast"),
    (lambda: film_split_sum_reflectance(FIG7, -0.1), "cos_v"),
    (lambda: bragg_filtered_reflectance(BRAGG.rgb, 0.2, 0.1, nodes=0), "nodes"),
    (lambda: bragg_filtered_reflectance(lambda t: np.zeros(3), 0.2, 0.1), "colour_of_theta"),
    (lambda: uniform_reflected_radiance(lambda t: np.zeros(3), 0.5, 0.3, 4), "colour_of_theta"),
    (lambda: uniform_light_moments(-0.2), "alpha"),
    (lambda: uniform_light_statistics(0.5, 1.5), "alpha"),
])
def test_bad_arguments_raise(call, match):
    with pytest.raises(ValueError, match=match):
        call()
