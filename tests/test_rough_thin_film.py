"""The rough thin-film BRDF (:class:`wgbragg.bsdf.rough_thin_film.RoughThinFilm`, BB17 eq 1) and the
deterministic lobe quadrature it shares with :mod:`wgbragg.lighting.ibl`.

Checked against invariants (reciprocity, energy), the sampler against its own density
(chi-square) and weights, the quadrature against the sampler, the colour of the spectral BRDF,
and the smooth-film limit.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import sample_chi2_pvalue

from wgbragg import ThinFilm
from wgbragg.bsdf.microfacet import ggx_D, ggx_G1
from wgbragg.bsdf.rough_thin_film import RoughThinFilm, reflection_quadrature
from wgbragg.colour.colorimetry import linear_srgb_to_xyz, xyz_to_linear_srgb, xyz_weights

FILMS = {
    "fig7": ThinFilm(1.33, 550.0, n_base=2.0, k_base=0.5),
    "dielectric": ThinFilm(1.3, 650.0, n_base=2.0),
    "gold": ThinFilm(1.45, 300.0, base="Au"),
    "low-index film": ThinFilm(1.2, 400.0, n_base=1.5, host=1.33),
}
MAX_THETA = math.radians(85.0)
# Albedo at alpha = 0.01 against the smooth film's colour: measured max |difference| 2e-4 at
# normal incidence, 7.4e-4 up to 60 deg, 3.9e-3 at 80 deg (the colour changes fastest there
# across the lobe's width; the lobe's masking loss is ~1e-4).
SMOOTH_LIMIT_ATOL = 6e-3


def direction(theta, phi=0.0):
    return np.stack(np.broadcast_arrays(np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi),
                                        np.cos(theta)), axis=-1)


def random_directions(n, seed, max_theta=MAX_THETA):
    rng = np.random.default_rng(seed)
    return direction(np.arccos(rng.uniform(np.cos(max_theta), 1.0, n)),
                     rng.uniform(-np.pi, np.pi, n))


@pytest.mark.parametrize("name", list(FILMS))
@pytest.mark.parametrize("alpha", [0.01, 0.3, 1.0])
def test_reciprocity(name, alpha):
    s = RoughThinFilm(FILMS[name], alpha)
    wi, wo = random_directions(300, 1), random_directions(300, 2)
    np.testing.assert_allclose(s.brdf(wi, wo), s.brdf(wo, wi), rtol=1e-10, atol=0.0)
    wavelength = np.array([420.0, 555.0, 700.0])
    np.testing.assert_allclose(s.brdf(wi, wo, wavelength), s.brdf(wo, wi, wavelength),
                               rtol=1e-10, atol=0.0)


def test_brdf_is_the_microfacet_lobe_times_the_film_reflectance():
    film = FILMS["fig7"]
    s = RoughThinFilm(film, 0.2)
    wi, wo = random_directions(50, 3), random_directions(50, 4)
    h = (wi + wo) / np.linalg.norm(wi + wo, axis=-1, keepdims=True)
    cos_d = np.sum(wi * h, axis=-1)
    lobe = (ggx_D(h[:, 2], 0.2) * ggx_G1(wi[:, 2], 0.2) * ggx_G1(wo[:, 2], 0.2)
            / (4.0 * wi[:, 2] * wo[:, 2]))
    expected = lobe[:, None] * film.reflectance(np.array([480.0, 610.0]),
                                                np.arccos(cos_d)[:, None])
    np.testing.assert_allclose(s.brdf(wi, wo, [480.0, 610.0]), expected, rtol=1e-10)
    np.testing.assert_allclose(s.brdf(wi, wo, method="fourier-gaussian", order=2),
                               lobe[:, None] * film.rgb(np.arccos(cos_d), "fourier-gaussian",
                                                        order=2), rtol=1e-10, atol=1e-15)


def test_reference_rgb_is_the_colour_of_the_spectral_brdf():
    """The BRDF's only spectral factor is R: its colour is the lobe times R's colour."""
    s = RoughThinFilm(FILMS["gold"], 0.15)
    wi, wo = random_directions(20, 5), random_directions(20, 6)
    grid, weights = xyz_weights()
    integrated = xyz_to_linear_srgb(s.brdf(wi, wo, grid) @ weights)
    np.testing.assert_allclose(s.brdf(wi, wo, method="reference"), integrated, rtol=1e-9,
                               atol=1e-12)


def test_lower_hemisphere_and_shapes():
    s = RoughThinFilm(FILMS["fig7"], 0.3)
    up, down = direction(0.4), direction(0.4) * np.array([1.0, 1.0, -1.0])
    assert np.all(s.brdf(up, down) == 0.0) and np.all(s.brdf(down, up, 500.0) == 0.0)
    assert s.pdf(up, down) == 0.0 and s.pdf(down, up) == 0.0
    wi = random_directions(4, 7).reshape(2, 2, 3)
    wo = random_directions(3, 8)[:, None, None, :]
    assert s.brdf(wi, wo).shape == (3, 2, 2, 3)
    assert s.brdf(wi, wo, 550.0).shape == (3, 2, 2, 1)
    assert s.brdf(wi, wo, [450.0, 550.0]).shape == (3, 2, 2, 2)
    assert s.pdf(wi, wo).shape == (3, 2, 2)
    assert s.albedo(np.zeros((2, 3)), nodes=8).shape == (2, 3, 3)
    grazing = direction(np.array([0.0, 1e-6, np.pi / 2 - 1e-7, np.pi / 2]))
    for value in (s.brdf(grazing, grazing[::-1]), s.pdf(grazing, grazing[::-1]),
                  s.albedo(np.array([0.0, np.pi / 2]), nodes=8)):
        assert np.all(np.isfinite(value))


# ---------------------------------------------------------------------- energy


@pytest.mark.parametrize("name", list(FILMS))
@pytest.mark.parametrize("alpha", [0.01, 0.25, 1.0])
def test_furnace_albedo_at_most_one(name, alpha):
    """Spectral albedo <= 1 (it is the film's R <= 1 under a lobe of albedo E <= 1), and so is
    the luminance of the RGB albedo (its channels may exceed 1 out of gamut: gold's red)."""
    s = RoughThinFilm(FILMS[name], alpha)
    theta = np.radians([0.0, 30.0, 60.0, 80.0, 89.0])
    albedo = s.albedo(theta, np.linspace(380.0, 780.0, 9), nodes=24)
    assert np.all(albedo >= 0.0) and np.all(albedo <= 1.0)
    assert np.all(linear_srgb_to_xyz(s.albedo(theta, nodes=24))[..., 1] <= 1.0 + 1e-9)


def test_perfect_reflector_albedo_is_the_microfacet_albedo():
    """A base that reflects everything (a film over a perfect conductor-like base of the
    largest k accepted, R = 1 - 6e-8) has R = 1: its albedo is the lobe's, sum of the
    quadrature weights."""
    s = RoughThinFilm(ThinFilm(1.5, 300.0, n_base=1.0, k_base=1e4), 0.4)
    theta = np.radians([0.0, 45.0, 80.0])
    _, _, weight = reflection_quadrature(np.cos(theta), 0.4, 32)
    np.testing.assert_allclose(s.albedo(theta, 550.0, nodes=32)[..., 0], weight.sum(-1),
                               rtol=1e-6)


@pytest.mark.parametrize("degrees", [0.0, 35.0, 75.0])
def test_albedo_quadrature_matches_the_sampler(degrees):
    """The deterministic albedo against the mean sample weight (1e5 samples, 4 sigma)."""
    s = RoughThinFilm(FILMS["fig7"], 0.35)
    wi = direction(math.radians(degrees))
    wavelength = np.array([450.0, 600.0])
    _, weight, _ = s.sample(wi, np.random.default_rng(9).random((100_000, 2)), wavelength)
    mean, error = weight.mean(0), weight.std(0) / math.sqrt(weight.shape[0])
    albedo = s.albedo(math.radians(degrees), wavelength)
    assert np.all(np.abs(albedo - mean) < 4.0 * error + 1e-6), (albedo, mean, error)


@pytest.mark.parametrize("degrees", [0.0, 30.0, 60.0, 80.0])
def test_smooth_limit_is_the_film_colour(degrees):
    """alpha -> 0: the lobe becomes a mirror and the albedo the smooth film's colour."""
    film = FILMS["fig7"]
    theta = math.radians(degrees)
    albedo = RoughThinFilm(film, 0.01).albedo(theta, method="reference", nodes=32)
    np.testing.assert_allclose(albedo, film.rgb(theta, "reference"), atol=SMOOTH_LIMIT_ATOL)


def test_quadrature_nodes_leave_the_surface_and_weights_are_positive():
    l, cos_d, weight = reflection_quadrature(np.array([0.0, 0.2, 0.9, 1.0]), 0.5, 16, mirror=True)
    assert l.shape == (4, 2 * 2 * 16 * 16, 3) and cos_d.shape == weight.shape == l.shape[:-1]
    # cos 2 theta_m at theta_m = pi / 4 is 0 only up to the rounding of cos and sin.
    assert np.all(l[..., 2] >= -4 * np.finfo(float).eps) and np.all(weight >= 0.0)
    np.testing.assert_allclose(np.linalg.norm(l, axis=-1), 1.0, atol=1e-12)
    # The mirrored half cancels every odd moment in y.
    np.testing.assert_allclose(np.einsum("ek,ek->e", weight, l[..., 1]), 0.0, atol=1e-15)


# ---------------------------------------------------------------------- sampling


@pytest.mark.parametrize("alpha,degrees", [(0.3, 10.0), (0.3, 60.0), (0.8, 30.0),
                                           (0.8, 80.0)])
def test_sample_chi_square(alpha, degrees):
    s = RoughThinFilm(FILMS["fig7"], alpha)
    assert sample_chi2_pvalue(s, direction(math.radians(degrees)), 3, 2) > 0.01


@pytest.mark.parametrize("wavelength", [None, [450.0, 650.0]])
def test_sample_weight_is_f_cos_over_pdf(wavelength):
    s = RoughThinFilm(FILMS["gold"], 0.4)
    wi = direction(math.radians(50.0))
    wo, weight, pdf = s.sample(wi, np.random.default_rng(3).random((400, 2)), wavelength)
    above = wo[:, 2] > 0.0
    assert (~above).any() and above.any()
    assert np.all(weight[~above] == 0.0) and np.all(pdf[~above] == 0.0)
    f = s.brdf(wi, wo[above], wavelength)
    np.testing.assert_allclose(weight[above], f * (wo[above, 2] / pdf[above])[:, None],
                               rtol=1e-9, atol=1e-14)


# ---------------------------------------------------------------------- errors


@pytest.mark.parametrize("make,match", [
    (lambda: RoughThinFilm(FILMS["fig7"], 0.005), r"alpha must be a real number in \[0.01, 1\]"),
    (lambda: RoughThinFilm(FILMS["fig7"], 1.5), "alpha"),
    (lambda: RoughThinFilm(FILMS["fig7"], True), "alpha"),
    (lambda: RoughThinFilm(FILMS["fig7"], "0.3"), "alpha"),
    (lambda: RoughThinFilm("film", 0.3), "ThinFilm"),
])
def test_bad_materials_raise(make, match):
    with pytest.raises(ValueError, match=match):
        make()


UP = [0.0, 0.0, 1.0]


@pytest.mark.parametrize("call,match", [
    (lambda s: s.brdf([0.0, 0.0, 2.0], UP), "unit"),
    (lambda s: s.brdf([0.0, 1.0], UP), "length 3"),
    (lambda s: s.brdf(UP, [0.0, 0.0, np.nan]), "NaN"),
    (lambda s: s.brdf(UP, UP, -5.0), "wavelength_nm"),
    (lambda s: s.brdf(UP, UP, [[500.0]]), "1-D"),
    (lambda s: s.brdf(UP, UP, method="exact"), "method"),
    (lambda s: s.brdf(UP, UP, order=17), "order"),
    (lambda s: s.sample(UP, [0.5]), "length 2"),
    (lambda s: s.sample(UP, [0.5, 1.5]), r"\[0, 1\]"),
    (lambda s: s.sample([1.0, 0.0, 0.0], [0.5, 0.5]), "above the horizon"),
    (lambda s: s.albedo(2.0), "theta_i"),
    (lambda s: s.albedo(0.1, nodes=1), "nodes"),
    (lambda s: s.pdf(UP, [1.0, 1.0, 1.0]), "unit"),
])
def test_bad_arguments_raise(call, match):
    with pytest.raises(ValueError, match=match):
        call(RoughThinFilm(FILMS["fig7"], 0.3))


def test_bad_quadrature_arguments_raise():
    with pytest.raises(ValueError, match=r"cos_v must be in \[0, 1\]"):
        reflection_quadrature(-0.1, 0.3)
    with pytest.raises(ValueError, match="alpha"):
        reflection_quadrature(0.5, 0.0)
    with pytest.raises(ValueError, match="nodes"):
        reflection_quadrature(0.5, 0.3, nodes=True)
