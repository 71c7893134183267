"""Fourier colour methods of ThinFilm (numpy): the Airy series, the transforms, each method
against "reference" within its documented bound, the white point, prefiltering, dispersive
bases against ``tmm``, n-dimensional input and bad input."""

import itertools
import math
import warnings

import numpy as np
import pytest
import tmm

from wgbragg import ThinFilm
from wgbragg.colour.colorimetry import delta_e_2000, xyz_to_linear_srgb, xyz_weights
from wgbragg.colour.thin_film import (
    DEFAULT_ORDER,
    E_TO_D65_BRADFORD,
    FOURIER_METHODS,
    MAX_ORDER,
    PREFILTER_RANGE_NM,
    TABLE_RANGE_NM,
    airy_series,
    fourier_windows,
    fourier_xyz,
)
from wgbragg.optics import thin_film_reflectance
from wgbragg.optics.metals import METALS, SpectralIndex

SERIES_ATOL = 1e-12  # the series summed far enough against the Airy closed form
TMM_ATOL = 1e-10  # float64 Airy against tmm
WHITE_ATOL = 2e-3  # perfect reflector in linear sRGB (the reference's own offset is 2e-4)
TRANSFORM_ATOL = 2e-4  # interpolated table against the direct 1 nm sum (F(0) ~ 1)
PREFILTERED_ATOL = 5e-3  # the same along the prefiltering axis (linear in s, 10 nm steps)

# Documented bounds (docs/benchmarks.md), dE2000 on GRID at the default order.
TABLE_MEAN = 1.0  # the issue's target; measured 0.26
GAUSSIAN_MEAN = 4.0  # measured 3.2 (Cu 9.5: one Fresnel value per lobe)
CONSTANT_INDEX_MAX = 0.1  # table, dielectric base 1.5: exact up to truncation; measured 0.05
EVANESCENT_MEAN = 0.5  # table where the film is evanescent; measured 0.001-0.3
PREFILTER_MEAN = 0.05  # table at MAX_ORDER against a brute-force thickness average

DEG = math.pi / 180.0
THETA = np.arange(0.0, 90.0, 5.0) * DEG
BASES = {"1.0": {"n_base": 1.0}, "1.5": {"n_base": 1.5}, "Au": {"base": "Au"},
         "Cu": {"base": "Cu"}, "Al": {"base": "Al"}}
GRID = [ThinFilm(n, d, **kw) for kw in BASES.values() for n in (1.3, 1.5, 2.0)
        for d in np.arange(0.0, 1001.0, 100.0)]


def delta_e(xyz_a, xyz_b):
    return delta_e_2000(xyz_to_linear_srgb(xyz_a), xyz_to_linear_srgb(xyz_b))


def names(parameter):
    return rf"\b{parameter}\b"


@pytest.fixture(scope="module")
def errors():
    """{method: dE array over GRID x THETA} against "reference" at the default order."""
    out = {}
    for film in GRID:
        reference = film.xyz(THETA)
        for method in FOURIER_METHODS:
            out.setdefault(method, []).append(delta_e(film.xyz(THETA, method), reference))
    return {method: np.array(values) for method, values in out.items()}


# --------------------------------------------------------------------------- the series


@pytest.mark.parametrize("n_base", [1.0, 1.5, 0.2 + 3.0j, 1.5 + 0.5j, 0.5, complex(0.13, 4.1)])
@pytest.mark.parametrize("polarization", ["s", "p"])
def test_series_sums_to_the_airy_reflectance(n_base, polarization):
    """Summed to high order, the Fourier series is the exact Airy reflectance (dielectric,
    conducting and totally reflecting bases)."""
    wavelength = np.linspace(360.0, 830.0, 40)[:, None]
    theta = np.radians([0.0, 20.0, 45.0, 70.0])
    for n_film, d in ((1.3, 290.0), (2.0, 1000.0), (1.5, 0.0)):
        t_star, w, opd_per_nm = airy_series(1.0, n_film, n_base, theta, polarization)
        phase = np.exp(2j * np.pi * opd_per_nm * d / wavelength)
        series = sum(np.real((-w * phase) ** m) for m in range(1, 400))
        R = 1.0 - t_star * (1.0 + 2.0 * series)
        exact = thin_film_reflectance(1.0, n_film, d, n_base, wavelength, theta, polarization)
        np.testing.assert_allclose(R, exact, rtol=0, atol=SERIES_ATOL)


def test_series_coefficients_are_physical():
    theta = np.linspace(0.0, np.pi / 2, 91)
    for n_base in (1.0, 1.5, 0.2 + 3.0j, 0.7):
        for pol in ("s", "p"):
            t_star, w, _ = airy_series(1.0, 1.4, n_base, theta, pol)
            assert np.all((t_star >= 0.0) & (t_star <= 1.0))
            assert np.all(np.abs(w) <= 1.0 + 1e-15)
            assert t_star[-1] == 0.0  # grazing: everything is reflected


# --------------------------------------------------------------------------- the transforms


def direct_transform(windows, window, x, s=0.0):
    """F(x, s) of a table window by its definition: the 1 nm sum."""
    wavelength, weights = xyz_weights()
    from wgbragg.colour.thin_film import DISPERSION_NODES, _spline_nodes

    hats = (_spline_nodes(DISPERSION_NODES)[1] if windows.count > 1
            else np.ones((1, wavelength.size)))
    nu = 1.0 / wavelength
    kernel = np.exp(2j * np.pi * np.multiply.outer(x, nu) - 2.0 * np.pi**2 * s**2 * nu**2)
    return kernel @ (hats[window][:, None] * weights)


@pytest.mark.parametrize("dispersive", [False, True])
def test_table_matches_its_definition(dispersive):
    windows = fourier_windows("fourier-table", dispersive)
    x = np.random.default_rng(3).uniform(0.0, TABLE_RANGE_NM - 10.0, 200)
    for window in range(windows.count):
        got = windows.transform(window, x)
        np.testing.assert_allclose(got, direct_transform(windows, window, x), rtol=0,
                                   atol=TRANSFORM_ATOL)
    np.testing.assert_allclose(windows.white.sum(0), xyz_weights()[1].sum(0), rtol=1e-13)
    assert np.all(windows.transform(0, np.array([TABLE_RANGE_NM, 1e6])) == 0.0)


def test_prefiltered_table_matches_its_definition():
    windows = fourier_windows("fourier-table", False, True)
    rng = np.random.default_rng(4)
    x = rng.uniform(0.0, 20000.0, 100)
    s = rng.uniform(0.0, PREFILTER_RANGE_NM - 10.0, 100)
    got = windows.transform(0, x, s)
    want = np.array([direct_transform(windows, 0, xi, si) for xi, si in zip(x, s, strict=True)])
    np.testing.assert_allclose(got, want, rtol=0, atol=PREFILTERED_ATOL)
    np.testing.assert_array_equal(windows.transform(0, x, np.zeros_like(x)),
                                  fourier_windows("fourier-table", False).transform(0, x))


def test_gaussian_prefilter_is_a_convolution_of_its_transform():
    """The closed form equals F convolved with a Gaussian of std s in OPD (numerically)."""
    windows = fourier_windows("fourier-gaussian", False)
    grid = np.linspace(-4000.0, 8000.0, 24001)
    for window in range(windows.count):
        F = windows.transform(window, grid)
        for x, s in ((0.0, 50.0), (700.0, 120.0), (2500.0, 30.0)):
            kernel = np.exp(-0.5 * ((grid - x) / s) ** 2)
            want = (F * kernel[:, None]).sum(0) / kernel.sum()
            np.testing.assert_allclose(windows.transform(window, x, s), want, rtol=0,
                                       atol=1e-9)


def test_gaussian_lobes_are_the_papers_fit():
    """One lobe per Gaussian of the supplemental code, each channel 1 at zero OPD; the
    paper's single normaliser 1.0685e-7 leaves the channels within 0.2 % of that."""
    windows = fourier_windows("fourier-gaussian", False)
    np.testing.assert_allclose(windows.white.sum(0), 1.0, rtol=1e-14)
    np.testing.assert_allclose(1.0 / windows.lobes[:, 1], [594.9, 446.5, 557.0, 452.8],
                               atol=0.1)


# --------------------------------------------------------------------------- white point


@pytest.mark.parametrize("method", ["reference", "spectral", *FOURIER_METHODS])
@pytest.mark.parametrize("film", [ThinFilm(1.5, 300.0), ThinFilm(1.3, 0.0, base="Au"),
                                  ThinFilm(2.0, 800.0, n_base=0.2, k_base=3.0)])
def test_perfect_reflector_is_white(method, film):
    """At grazing incidence every film reflects everything: sRGB (1, 1, 1)."""
    options = {"samples": 471} if method == "spectral" else {}
    rgb = film.rgb(np.pi / 2, method, **options)
    np.testing.assert_allclose(rgb, 1.0, rtol=0, atol=WHITE_ATOL)
    np.testing.assert_allclose(film.xyz(np.pi / 2, method, **options),
                               xyz_weights()[1].sum(0), rtol=1e-12)


def test_uncorrected_gaussian_white_is_tinted():
    """Without the adaptation the fit's E white reads (1.205, 0.948, 0.909) in D65 sRGB
    (``docs/physics.md``, "Thin-film colour in Fourier space"): the correction is what makes it
    white."""
    xyz = ThinFilm(1.5, 300.0).xyz(np.pi / 2, "fourier-gaussian")
    raw = xyz @ np.linalg.inv(E_TO_D65_BRADFORD).T
    np.testing.assert_allclose(raw, 1.0, rtol=1e-12)
    np.testing.assert_allclose(xyz_to_linear_srgb(raw), [1.2048, 0.9484, 0.9087], atol=1e-4)


# --------------------------------------------------------------------------- accuracy


def test_table_meets_the_issue_target(errors):
    assert errors["fourier-table"].mean() <= TABLE_MEAN


def test_gaussian_within_its_measured_bound(errors):
    assert errors["fourier-gaussian"].mean() <= GAUSSIAN_MEAN
    assert errors["fourier-gaussian"].mean() > errors["fourier-table"].mean()


def test_table_is_exact_for_a_constant_index_base(errors):
    constant = np.array([film.base is None and film.n_base == 1.5 for film in GRID])
    assert errors["fourier-table"][constant].max() <= CONSTANT_INDEX_MAX
    film = ThinFilm(1.5, 700.0, n_base=2.2)
    theta = np.radians(np.arange(0.0, 61.0, 5.0))
    high = delta_e(film.xyz(theta, "fourier-table", order=MAX_ORDER), film.xyz(theta))
    assert high.max() <= 1e-3


@pytest.mark.parametrize("method", FOURIER_METHODS)
def test_higher_orders_converge(method):
    films = [ThinFilm(n, d, **kw) for kw in BASES.values() for n in (1.3, 2.0)
             for d in (150.0, 600.0)]
    means = []
    for order in (0, 1, 3, 8):
        means.append(np.mean([delta_e(f.xyz(THETA, method, order=order), f.xyz(THETA)).mean()
                              for f in films]))
    assert all(a > b for a, b in itertools.pairwise(means)), means


def test_evanescent_film_uses_exact_nodes():
    """host > n_film beyond the critical angle: no oscillation, exact Airy at the nodes."""
    theta = np.radians(np.arange(0.0, 90.0, 2.0))
    for film in (ThinFilm(1.3, 300.0, n_base=1.5, host=1.6),
                 ThinFilm(1.45, 50.0, base="Au", host=1.6)):
        de = delta_e(film.xyz(theta, "fourier-table", order=8), film.xyz(theta))
        evanescent = film.host * np.sin(theta) >= film.n_film
        assert evanescent.any() and de[evanescent].mean() <= EVANESCENT_MEAN


CRITICAL_FILMS = [ThinFilm(1.0, 20.0, n_base=1.5, host=1.5),
                  ThinFilm(1.33, 100.0, n_base=1.5, host=1.5),
                  ThinFilm(1.33, 500.0, n_base=1.5, host=1.5)]


@pytest.mark.parametrize("film", CRITICAL_FILMS, ids=str)
def test_films_just_below_their_critical_angle_keep_their_colour(film):
    """Just below the critical angle of a film under a denser host, both interfaces reflect
    almost totally and the truncated series went white (dE2000 up to 87 within 0.01 rad),
    while the exact spectrum, of a small OPD there, is smooth: integrated exactly now."""
    critical = math.asin(film.n_film / film.host)
    theta = critical - np.array([0.1, 1e-2, 1e-3, 1e-4, 1e-6, 0.0])
    for method, bound in (("fourier-table", 0.1), ("fourier-gaussian", 2.5)):
        de = delta_e(film.xyz(theta, method), film.xyz(theta))
        assert de.max() <= bound, (method, de)


def test_constant_spectral_index_matches_the_constant_base():
    """The dispersive machinery with a flat table is the constant-index method (up to the
    table's interpolation, which differs between the split and the whole sensitivity)."""
    flat = SpectralIndex("flat", [300.0, 900.0], [0.3, 0.3], [2.5, 2.5])
    theta = np.radians(np.arange(0.0, 90.0, 7.0))
    for method in FOURIER_METHODS:
        for order in (0, 3):
            a = ThinFilm(1.4, 420.0, base=flat).xyz(theta, method, order=order)
            b = ThinFilm(1.4, 420.0, n_base=0.3, k_base=2.5).xyz(theta, method, order=order)
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-5)


# --------------------------------------------------------------------------- prefiltering


def brute_force(film, theta, sigma, nodes=32):
    """Reference colour averaged over thicknesses N(d, sigma^2) (nodes reach 10 sigma)."""
    x, w = np.polynomial.hermite_e.hermegauss(nodes)
    w = w / w.sum()
    return sum(wi * ThinFilm(film.n_film, film.d + sigma * xi, film.n_base, film.k_base,
                             film.host, film.base).xyz(theta) for xi, wi in zip(x, w, strict=True))


@pytest.mark.parametrize("film", [ThinFilm(1.5, 600.0, n_base=1.0),
                                  ThinFilm(1.3, 600.0, n_base=1.5),
                                  ThinFilm(2.0, 600.0, n_base=0.2, k_base=3.0)])
@pytest.mark.parametrize("sigma", [5.0, 20.0, 50.0])
def test_prefiltering_matches_a_brute_force_thickness_average(film, sigma):
    theta = np.radians(np.arange(0.0, 71.0, 10.0))
    got = film.xyz(theta, "fourier-table", order=MAX_ORDER, thickness_std_nm=sigma)
    assert delta_e(got, brute_force(film, theta, sigma)).mean() <= PREFILTER_MEAN


@pytest.mark.parametrize("method", FOURIER_METHODS)
def test_prefiltering_limits(method):
    film = ThinFilm(1.5, 600.0, base="Cu")
    np.testing.assert_array_equal(film.xyz(THETA, method),
                                  film.xyz(THETA, method, thickness_std_nm=0.0))
    # Wide distributions average the interference out: the order-0 (phase-averaged) colour.
    np.testing.assert_allclose(film.xyz(THETA, method, thickness_std_nm=2000.0),
                               film.xyz(THETA, method, order=0), rtol=0, atol=1e-9)


def test_wide_prefilter_is_the_mean_reflectance_colour():
    """The phase-averaged colour is the reference colour averaged over many thicknesses."""
    film = ThinFilm(1.5, 1200.0, n_base=1.0)
    theta = np.radians([0.0, 30.0, 60.0])
    sigma = 150.0
    d = film.d + np.linspace(-5.0, 5.0, 501) * sigma
    weight = np.exp(-0.5 * ((d - film.d) / sigma) ** 2)
    weight /= weight.sum()
    average = sum(w * ThinFilm(1.5, di).xyz(theta) for di, w in zip(d, weight, strict=True))
    got = film.xyz(theta, "fourier-table", thickness_std_nm=sigma)
    assert delta_e(got, average).max() <= 0.05


# --------------------------------------------------------------------------- dispersive bases


@pytest.mark.parametrize("name", sorted(METALS))
def test_film_over_metal_matches_tmm(name):
    rng = np.random.default_rng(sorted(METALS).index(name))
    for _ in range(40):
        n_film, d = rng.uniform(1.0, 2.5), rng.uniform(0.0, 1000.0)
        host = [1.0, 1.33][int(rng.integers(2))]
        wavelength, theta = rng.uniform(360.0, 830.0), rng.uniform(0.0, 89.0 * DEG)
        film = ThinFilm(n_film, d, host=host, base=name)
        index = complex(METALS[name](wavelength))
        for pol in ("s", "p"):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                want = tmm.coh_tmm(pol, [host, n_film, index], [np.inf, d, np.inf], theta,
                                   wavelength)["R"]
            assert abs(float(film.reflectance(wavelength, theta, pol)) - want) <= TMM_ATOL


def test_bare_metal_colours_are_plausible():
    """d = 0 is the bare metal: gold and copper warm (R > G > B), silver and aluminium
    near-neutral and bright."""
    for name in ("Au", "Cu"):
        r, g, b = ThinFilm(1.5, 0.0, base=name).rgb(0.0)
        assert r > g > b
    for name in ("Ag", "Al"):
        rgb = ThinFilm(1.5, 0.0, base=name).rgb(0.0)
        assert rgb.min() > 0.8 and rgb.max() - rgb.min() < 0.1


# --------------------------------------------------------------------------- input


@pytest.mark.parametrize("method", FOURIER_METHODS)
def test_n_dimensional_theta(method):
    film = ThinFilm(1.4, 350.0, base="Au")
    theta = np.radians(np.arange(24.0).reshape(2, 3, 4) * 3.5)
    xyz = film.xyz(theta, method, order=2)
    assert xyz.shape == (2, 3, 4, 3)
    np.testing.assert_array_equal(xyz.reshape(-1, 3), film.xyz(theta.ravel(), method, order=2))
    assert film.xyz(0.3, method).shape == (3,)
    assert film.rgb([[0.1]], method).shape == (1, 1, 3)


@pytest.mark.parametrize("method", FOURIER_METHODS)
@pytest.mark.parametrize("order", [-1, MAX_ORDER + 1, 2.5, True, "3", None])
def test_bad_order(method, order):
    with pytest.raises(ValueError, match=names("order")):
        ThinFilm(1.5, 300.0).xyz(0.2, method, order=order)


@pytest.mark.parametrize("value", [-1.0, 1.0000001e6, 1e300, math.nan, math.inf, "5", True])
def test_bad_thickness_std(value):
    with pytest.raises(ValueError, match=names("thickness_std_nm")):
        ThinFilm(1.5, 300.0).xyz(0.2, "fourier-table", thickness_std_nm=value)


def test_bad_method_and_angle():
    film = ThinFilm(1.5, 300.0)
    with pytest.raises(ValueError, match=names("method")):
        film.xyz(0.2, "fourier")
    with pytest.raises(ValueError, match=names("method")):
        fourier_xyz(film, 0.2, "approx")
    for theta in (-0.1, 2.0, math.nan):
        with pytest.raises(ValueError, match=names("theta")):
            film.xyz(theta, "fourier-table")


def test_default_order_is_documented():
    assert DEFAULT_ORDER == 3
    film = ThinFilm(1.5, 300.0)
    np.testing.assert_array_equal(film.xyz(THETA, "fourier-table"),
                                  film.xyz(THETA, "fourier-table", order=3))
