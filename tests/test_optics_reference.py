"""The float64 reference optics (numpy backend) against the ``tmm`` package and analytic limits.

Stack convention: ``host | (n1 d1, n2 d2) x N | n1``; the ``tmm`` oracle of a Bragg mirror is
``coh_tmm(pol, [host] + [n1, n2] * N + [n1], [inf] + [d1, d2] * N + [inf], theta, lambda)``.
``tmm`` overflows for a host denser than n1 beyond the critical angle and is wrong at exactly
grazing incidence: those cases are tested by their analytic limits instead.
"""

from __future__ import annotations

import itertools
import math
import warnings

import numpy as np
import pytest
import tmm
from scipy.optimize import brentq

import wgbragg
from wgbragg import BraggMirror, ThinFilm
from wgbragg.optics import (
    bloch_dispersion,
    thin_film_reflectance,
    transfer_matrix_reflectance,
    yeh_reflectance,
)

# Absolute tolerances, one per kind of comparison.
TMM_ATOL = 1e-10  # float64 closed forms and transfer matrices vs the tmm package
EDGE_ATOL = 1e-9  # at and next to exact band edges, vs tmm
EXACT_ATOL = 1e-12  # analytic limits (R = 0, R = 1, Fresnel, quarter-wave closed form)
CONTINUITY_ATOL = 1e-6  # R at an exact critical angle vs R one float64 ulp of theta away
SELF_ATOL = 1e-13  # identities between our own numbers (broadcasting, s/p averaging)

POLARIZATIONS = ("s", "p")
MAX_INT32 = 2**31 - 1
DEG = math.pi / 180.0


# --------------------------------------------------------------------------- helpers


def tmm_R(pol, indices, thicknesses, theta, wavelength, key="R"):
    """One tmm evaluation; ``thicknesses`` are the inner layers only."""
    d_list = [np.inf, *thicknesses, np.inf]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return float(tmm.coh_tmm(pol, list(indices), d_list, float(theta), float(wavelength))[key])


def bragg_stack(n1, n2, d1, d2, N, host=None):
    host = n1 if host is None else host
    return [host] + [n1, n2] * N + [n1], [d1, d2] * N


def tmm_bragg(pol, n1, n2, d1, d2, N, wavelength, theta, host=None, key="R"):
    indices, thicknesses = bragg_stack(n1, n2, d1, d2, N, host)
    return tmm_R(pol, indices, thicknesses, theta, wavelength, key)


def fresnel_R(n_i, n_j, theta, pol):
    """|r|^2 at one interface between real media, written out independently of wgbragg.

    Equal media are no interface (R = 0), also at grazing incidence where the formula is 0/0.
    """
    if n_i == n_j:
        return np.zeros_like(np.asarray(theta, dtype=float))
    cos_i = np.cos(theta) + 0j
    sin_j = n_i * np.sin(theta) / n_j
    cos_j = np.sqrt(1.0 - sin_j**2 + 0j)
    if pol == "s":
        r = (n_i * cos_i - n_j * cos_j) / (n_i * cos_i + n_j * cos_j)
    else:
        r = (n_j * cos_i - n_i * cos_j) / (n_j * cos_i + n_i * cos_j)
    return np.abs(r) ** 2


def random_stack(rng, evanescent=False):
    """A random Bragg mirror of the tested domain plus one (wavelength, theta) with s < n1."""
    if evanescent:
        # n2 < n1 and beyond n2's critical angle, still below n1's (tmm stays valid).
        n1 = rng.uniform(1.3, 1.7)
        n2 = rng.uniform(1.0, n1 - 0.1)
        host = [n1, rng.uniform(n2 + 0.05, 2.5)][rng.integers(2)]
        s = rng.uniform(n2 + 1e-3, min(n1, host) - 1e-3)
        theta = math.asin(s / host)
    else:
        n1, n2 = rng.uniform(1.0, 1.7), rng.uniform(1.0, 2.5)
        host = [n1, 1.0, rng.uniform(1.0, 2.5)][rng.integers(3)]
        theta_max = 89.5 * DEG
        if host > n1:
            theta_max = min(theta_max, math.asin(n1 / host) - 1e-3)
        theta = rng.uniform(0.0, theta_max)
    d1, d2 = rng.uniform(0.0, 600.0, 2)
    N = int(rng.integers(1, 41))
    wavelength = rng.uniform(300.0, 1000.0)
    return (n1, n2, d1, d2, N, host), wavelength, theta


def band_edges(n1, n2, d1, d2, theta, pol, host=None, lo=360.0, hi=830.0, samples=4000):
    """Wavelengths where |cos K Lambda| = 1, by brentq on sin^2(K Lambda) = 1 - x^2."""

    def sin2(wavelength):
        return float(bloch_dispersion(n1, n2, d1, d2, wavelength, theta, pol, host=host)[1])

    grid = np.linspace(lo, hi, samples)
    values = bloch_dispersion(n1, n2, d1, d2, grid, theta, pol, host=host)[1]
    change = np.flatnonzero(np.sign(values[:-1]) != np.sign(values[1:]))
    return [brentq(sin2, grid[i], grid[i + 1], xtol=1e-13) for i in change]


# --------------------------------------------------------------------------- tmm oracle


def test_yeh_matches_tmm_on_random_stacks():
    rng = np.random.default_rng(20240601)
    cases = [random_stack(rng) for _ in range(200)]
    cases += [random_stack(rng, evanescent=True) for _ in range(60)]
    evanescent = 0
    for (n1, n2, d1, d2, N, host), wavelength, theta in cases:
        evanescent += host * math.sin(theta) > n2
        mirror = BraggMirror(n1, n2, d1, d2, N, host=host)
        for pol in POLARIZATIONS:
            got = float(mirror.reflectance(wavelength, theta, pol))
            want = tmm_bragg(pol, n1, n2, d1, d2, N, wavelength, theta, host)
            assert abs(got - want) <= TMM_ATOL, (mirror, wavelength, theta, pol, got, want)
    assert evanescent >= 60


def random_layers(rng):
    count = int(rng.integers(1, 13))
    real = rng.uniform(1.0, 3.0, count + 1)
    k = np.where(rng.random(count + 1) < 0.5, 0.0, rng.uniform(0.0, 5.0, count + 1))
    host = rng.uniform(1.0, 2.5)
    indices = [host, *(real + 1j * k)]
    thicknesses = list(rng.uniform(0.0, 600.0, count))
    return indices, thicknesses


def test_transfer_matrix_matches_tmm_on_random_stacks():
    rng = np.random.default_rng(7)
    for _ in range(200):
        indices, thicknesses = random_layers(rng)
        wavelength = rng.uniform(300.0, 1000.0)
        theta = rng.uniform(0.0, 89.5 * DEG)
        for pol in POLARIZATIONS:
            got = float(transfer_matrix_reflectance(indices, thicknesses, wavelength, theta, pol))
            want = tmm_R(pol, indices, thicknesses, theta, wavelength)
            assert abs(got - want) <= TMM_ATOL, (indices, thicknesses, wavelength, theta, pol)


def test_transfer_matrix_accepts_tmm_style_thicknesses():
    rng = np.random.default_rng(8)
    for _ in range(20):
        indices, thicknesses = random_layers(rng)
        wavelength = rng.uniform(300.0, 1000.0, 16)
        theta = rng.uniform(0.0, math.pi / 2, 16)
        inner = transfer_matrix_reflectance(indices, thicknesses, wavelength, theta, "s")
        tmm_style = [np.inf, *thicknesses, np.inf]
        outer = transfer_matrix_reflectance(indices, tmm_style, wavelength, theta, "s")
        np.testing.assert_array_equal(inner, outer)


def test_yeh_matches_transfer_matrix():
    """Includes what tmm cannot do: host > n1 beyond the critical angle and large N."""
    rng = np.random.default_rng(11)
    for i in range(120):
        (n1, n2, d1, d2, N, host), _, _ = random_stack(rng, evanescent=i % 4 == 0)
        N = int(rng.choice([N, rng.integers(41, 300)]))
        wavelength = rng.uniform(300.0, 1000.0, 8)
        theta = rng.uniform(0.0, math.pi / 2, 8)
        mirror = BraggMirror(n1, n2, d1, d2, N, host=host)
        indices, thicknesses = bragg_stack(n1, n2, d1, d2, N, host)
        for pol in POLARIZATIONS:
            got = mirror.reflectance(wavelength, theta, pol)
            want = transfer_matrix_reflectance(indices, thicknesses, wavelength, theta, pol)
            np.testing.assert_allclose(got, want, rtol=0, atol=TMM_ATOL, err_msg=f"{mirror} {pol}")


@pytest.mark.parametrize("N", [1, 2, 5, 40])
@pytest.mark.parametrize("host", [None, 1.0, 2.0])
def test_transfer_matrix_at_grazing_incidence_reflects_everything(N, host):
    """theta = pi/2 in the host: no energy enters, whatever the stack (tmm is wrong here)."""
    indices, thicknesses = bragg_stack(1.0, 1.5, 100.0, 100.0, N, host)
    wavelength = np.linspace(360.0, 830.0, 11)
    for pol in (*POLARIZATIONS, "unpolarized"):
        R = transfer_matrix_reflectance(indices, thicknesses, wavelength, math.pi / 2, pol)
        np.testing.assert_array_equal(R, 1.0, err_msg=f"{indices} {pol}")


def test_single_period_is_a_thin_film():
    rng = np.random.default_rng(12)
    wavelength = np.linspace(300.0, 1000.0, 57)[:, None]
    theta = np.linspace(0.0, math.pi / 2, 19)[None, :]
    for _ in range(30):
        (n1, n2, d1, d2, _, host), _, _ = random_stack(rng)
        for pol in (*POLARIZATIONS, "unpolarized"):
            matched = BraggMirror(n1, n2, d1, d2, 1).reflectance(wavelength, theta, pol)
            film = ThinFilm(n_film=n2, d=d2, n_base=n1, host=n1).reflectance(
                wavelength, theta, pol)
            np.testing.assert_allclose(matched, film, rtol=0, atol=TMM_ATOL)
            hosted = BraggMirror(n1, n2, d1, d2, 1, host=host).reflectance(wavelength, theta, pol)
            stack = transfer_matrix_reflectance([host, n1, n2, n1], [d1, d2], wavelength, theta,
                                                pol)
            np.testing.assert_allclose(hosted, stack, rtol=0, atol=TMM_ATOL)


def test_thin_film_matches_tmm_including_conductors():
    rng = np.random.default_rng(13)
    for i in range(200):
        n_film = rng.uniform(1.0, 2.5)
        d = [0.0, rng.uniform(0.0, 1000.0)][i % 5 != 0]
        n_base = rng.uniform(0.05, 3.0)
        k_base = [0.0, rng.uniform(0.0, 10.0)][i % 2]
        host = [1.0, rng.uniform(1.0, 2.5)][i % 3 == 0]
        wavelength = rng.uniform(300.0, 1000.0)
        theta = rng.uniform(0.0, 89.5 * DEG)
        film = ThinFilm(n_film, d, n_base, k_base, host)
        indices = [host, n_film, complex(n_base, k_base)]
        for pol in POLARIZATIONS:
            got = float(film.reflectance(wavelength, theta, pol))
            want = tmm_R(pol, indices, [d], theta, wavelength)
            assert abs(got - want) <= TMM_ATOL, (film, wavelength, theta, pol, got, want)


# --------------------------------------------------------------------------- invariants


def test_reflectance_is_in_unit_interval():
    rng = np.random.default_rng(14)
    wavelength = rng.uniform(200.0, 2000.0, 300)
    theta = rng.uniform(0.0, math.pi / 2, 300)
    theta[:10] = 0.0
    theta[10:20] = math.pi / 2
    for i in range(100):
        (n1, n2, d1, d2, N, host), _, _ = random_stack(rng, evanescent=i % 3 == 0)
        N = int(rng.choice([N, 10**6, MAX_INT32]))
        for pol in (*POLARIZATIONS, "unpolarized"):
            R = BraggMirror(n1, n2, d1, d2, N, host=host).reflectance(wavelength, theta, pol)
            assert np.all(np.isfinite(R) & (R >= 0.0) & (R <= 1.0)), (n1, n2, d1, d2, N, host)


def test_equal_indices_do_not_reflect():
    wavelength = np.linspace(360.0, 830.0, 95)[:, None]
    theta = np.linspace(0.0, math.pi / 2, 31)[None, :]
    for n, N in itertools.product((1.0, 1.33, 2.4), (1, 20, MAX_INT32)):
        mirror = BraggMirror(n, n, 137.0, 211.0, N)
        for pol in (*POLARIZATIONS, "unpolarized"):
            np.testing.assert_allclose(mirror.reflectance(wavelength, theta, pol), 0.0,
                                       rtol=0, atol=EXACT_ATOL)


@pytest.mark.parametrize("host", [None, 1.0, 1.9])
def test_no_second_layer_is_the_bare_interface(host):
    wavelength = np.linspace(360.0, 830.0, 48)[:, None]
    theta = np.linspace(0.0, math.pi / 2, 46)[None, :]
    n1 = 1.45
    for N in (1, 7, MAX_INT32):
        for n2, d2 in ((1.45, 300.0), (2.1, 0.0)):  # n1 == n2, or d2 == 0
            mirror = BraggMirror(n1, n2, 180.0, d2, N, host=host)
            for pol in POLARIZATIONS:
                want = fresnel_R(n1 if host is None else host, n1, theta, pol)
                want = np.broadcast_to(want, (48, 46))
                np.testing.assert_allclose(mirror.reflectance(wavelength, theta, pol), want,
                                           rtol=0, atol=EXACT_ATOL)


def test_no_first_layer_is_one_slab():
    rng = np.random.default_rng(15)
    wavelength = np.linspace(300.0, 1000.0, 71)[:, None]
    theta = np.linspace(0.0, 89.5 * DEG, 23)[None, :]
    for _ in range(30):
        (n1, n2, _, d2, N, host), _, _ = random_stack(rng)
        mirror = BraggMirror(n1, n2, 0.0, d2, N, host=host)
        slab = ThinFilm(n_film=n2, d=N * d2, n_base=n1, host=host)
        for pol in POLARIZATIONS:
            got = mirror.reflectance(wavelength, theta, pol)
            want = slab.reflectance(wavelength, theta, pol)
            np.testing.assert_allclose(got, want, rtol=0, atol=TMM_ATOL, err_msg=f"{mirror} {pol}")


@pytest.mark.parametrize("n1, n2", [(1.0, 1.5), (1.5, 1.0), (1.33, 1.56), (1.3, 2.5)])
def test_brewster_angle_p_reflectance_vanishes(n1, n2):
    theta_b = math.atan(n2 / n1)
    wavelength = np.linspace(360.0, 830.0, 471)
    for N in (1, 2, 7, 100, 10**6, MAX_INT32):
        R = BraggMirror(n1, n2, 125.0, 375.0, N).reflectance(wavelength, theta_b, "p")
        np.testing.assert_allclose(R, 0.0, rtol=0, atol=EXACT_ATOL, err_msg=f"N={N}")


def test_grazing_incidence_reflects_everything():
    rng = np.random.default_rng(16)
    wavelength = np.linspace(360.0, 830.0, 95)
    for _ in range(40):
        (n1, n2, d1, d2, N, host), _, _ = random_stack(rng)
        N = int(rng.choice([N, 10**6, MAX_INT32]))
        for mirror_host in (None, host):
            mirror = BraggMirror(n1, n2, d1, d2, N, host=mirror_host)
            for pol in (*POLARIZATIONS, "unpolarized"):
                R = mirror.reflectance(wavelength, math.pi / 2, pol)
                np.testing.assert_allclose(R, 1.0, rtol=0, atol=EXACT_ATOL,
                                           err_msg=f"{mirror} {pol}")


@pytest.mark.parametrize("n1, n2, host", [(1.5, 1.0, 1.0), (2.0, 1.0, 1.0), (1.59, 1.33, 1.33)])
def test_grazing_incidence_with_n2_matching_the_host(n1, n2, host):
    """n2 == host: at grazing incidence n2 is exactly at its critical angle (q2 = 0)."""
    wavelength = np.linspace(360.0, 830.0, 48)
    for N in (1, 2, 5, 1000):
        mirror = BraggMirror(n1, n2, 100.0, 100.0, N, host=host)
        for pol in (*POLARIZATIONS, "unpolarized"):
            R = mirror.reflectance(wavelength, math.pi / 2, pol)
            np.testing.assert_allclose(R, 1.0, rtol=0, atol=EXACT_ATOL,
                                       err_msg=f"{mirror} {pol}")


def exact_critical_angle(host, n):
    """A float64 theta with host * sin(theta) == n exactly (q = 0 in the medium n)."""
    theta = math.asin(n / host)
    for direction in (4.0, -1.0):
        candidate = theta
        for _ in range(64):
            if host * math.sin(candidate) == n:
                return candidate
            candidate = float(np.nextafter(candidate, direction))
    raise AssertionError(f"no float64 angle with {host} sin(theta) == {n}")


CRITICAL_CASES = [(1.5, 1.0, None), (1.5, 1.0, 1.2), (1.6, 1.2, None), (1.59, 1.2, 1.4)]


@pytest.mark.parametrize("n1, n2, host", CRITICAL_CASES)
def test_mirror_is_continuous_at_the_critical_angle_of_n2(n1, n2, host):
    """q2 = 0 exactly: the formulas are 0/0 there, but R(theta) is continuous."""
    theta = exact_critical_angle(n1 if host is None else host, n2)
    around = np.array([np.nextafter(theta, -1.0), np.nextafter(theta, 4.0)])
    wavelength = np.array([400.0, 550.0, 700.0])
    for N, pol in itertools.product((1, 5, 40), POLARIZATIONS):
        mirror = BraggMirror(n1, n2, 100.0, 200.0, N, host=host)
        at = mirror.reflectance(wavelength, theta, pol)
        for neighbour in around:
            np.testing.assert_allclose(at, mirror.reflectance(wavelength, neighbour, pol),
                                       rtol=0, atol=CONTINUITY_ATOL,
                                       err_msg=f"{mirror} {pol} theta={theta!r}")


@pytest.mark.parametrize("n1, n2, host", CRITICAL_CASES)
def test_transfer_matrix_is_continuous_at_a_critical_angle(n1, n2, host):
    h = n1 if host is None else host
    theta = exact_critical_angle(h, n2)
    around = np.array([np.nextafter(theta, -1.0), np.nextafter(theta, 4.0)])
    wavelength = np.array([400.0, 550.0, 700.0])
    indices, thicknesses = bragg_stack(n1, n2, 100.0, 200.0, 3, host)
    for pol in POLARIZATIONS:
        at = transfer_matrix_reflectance(indices, thicknesses, wavelength, theta, pol)
        for neighbour in around:
            np.testing.assert_allclose(
                at, transfer_matrix_reflectance(indices, thicknesses, wavelength, neighbour, pol),
                rtol=0, atol=CONTINUITY_ATOL, err_msg=f"{indices} {pol} theta={theta!r}")


@pytest.mark.parametrize("n_film, n_base, k_base, host", [(1.0, 1.5, 0.0, 1.2),
                                                          (1.3, 0.2, 3.5, 2.0),
                                                          (1.2, 1.0, 0.0, 1.6)])
def test_thin_film_is_continuous_at_its_critical_angle(n_film, n_base, k_base, host):
    theta = exact_critical_angle(host, n_film)
    around = np.array([np.nextafter(theta, -1.0), np.nextafter(theta, 4.0)])
    wavelength = np.array([400.0, 550.0, 700.0])
    film = ThinFilm(n_film, 100.0, n_base, k_base, host)
    for pol in POLARIZATIONS:
        at = film.reflectance(wavelength, theta, pol)
        for neighbour in around:
            np.testing.assert_allclose(at, film.reflectance(wavelength, neighbour, pol),
                                       rtol=0, atol=CONTINUITY_ATOL,
                                       err_msg=f"{film} {pol} theta={theta!r}")


def test_total_internal_reflection_in_a_dense_host():
    wavelength = np.linspace(360.0, 830.0, 95)[:, None]
    for n1, n2, host in ((1.3, 2.5, 2.0), (1.0, 1.5, 1.33), (1.5, 1.0, 1.6), (1.59, 1.67, 2.4)):
        # 1e-9 rad past the critical angle: host sin(theta) >= n1 by thousands of ulps, whatever
        # the last bit of a CPU's sin (1 - R grows as the square root of a shortfall, so no
        # tolerance of a few ulps would cover one).
        critical = math.asin(n1 / host) + 1e-9
        theta = np.linspace(critical, math.pi / 2, 25)
        for N in (1, 2, 20, MAX_INT32):
            mirror = BraggMirror(n1, n2, 300.0, 20.0, N, host=host)
            for pol in (*POLARIZATIONS, "unpolarized"):
                np.testing.assert_array_equal(mirror.reflectance(wavelength, theta[None], pol), 1.0)


@pytest.mark.parametrize("n1, n2, host", [(1.0, 1.5, None), (1.5, 1.0, None), (1.38, 2.3, None),
                                          (1.59, 1.67, 1.0), (1.3, 2.5, 2.0)])
def test_quarter_wave_stack_closed_form(n1, n2, host):
    """At its design wavelength and normal incidence a quarter-wave stack has admittance
    Y = n1 (n1/n2)^(2N): each (n1, n2) pair of quarter-wave layers has the characteristic
    matrix diag(-n2/n1, -n1/n2), and the substrate is n1. So R = ((h - Y)/(h + Y))^2, which is
    tanh^2(N ln(n2/n1)) for h = n1."""
    design = 550.0
    d1, d2 = design / (4 * n1), design / (4 * n2)
    h = n1 if host is None else host
    for N in (1, 2, 5, 20, 60):
        Y = n1 * (n1 / n2) ** (2 * N)
        closed = ((h - Y) / (h + Y)) ** 2
        if host is None:
            assert closed == pytest.approx(math.tanh(N * math.log(n2 / n1)) ** 2, abs=1e-15)
        assert tmm_bragg("s", n1, n2, d1, d2, N, design, 0.0, h) == pytest.approx(
            closed, abs=EXACT_ATOL)
        for pol in (*POLARIZATIONS, "unpolarized"):
            got = float(BraggMirror(n1, n2, d1, d2, N, host=host).reflectance(design, 0.0, pol))
            assert got == pytest.approx(closed, abs=EXACT_ATOL), (N, pol)


def test_normal_incidence_does_not_depend_on_polarization():
    rng = np.random.default_rng(17)
    wavelength = np.linspace(300.0, 1000.0, 301)
    for _ in range(30):
        (n1, n2, d1, d2, N, host), _, _ = random_stack(rng)
        mirror = BraggMirror(n1, n2, d1, d2, N, host=host)
        np.testing.assert_allclose(mirror.reflectance(wavelength, 0.0, "s"),
                                   mirror.reflectance(wavelength, 0.0, "p"),
                                   rtol=0, atol=SELF_ATOL)


def test_lossless_stack_reflects_the_same_from_both_sides():
    """Reciprocity with energy conservation: R is the same seen from the n1 substrate side,
    through the reversed stack, at the same Snell invariant (when light gets through at all)."""
    rng = np.random.default_rng(18)
    for i in range(60):
        (n1, n2, d1, d2, N, host), wavelength, theta = random_stack(rng, evanescent=i % 4 == 0)
        s = host * math.sin(theta)
        if s >= min(n1, host):
            continue
        indices, thicknesses = bragg_stack(n1, n2, d1, d2, N, host)
        theta_back = math.asin(s / n1)
        for pol in POLARIZATIONS:
            front = float(BraggMirror(n1, n2, d1, d2, N, host=host).reflectance(
                wavelength, theta, pol))
            back = float(transfer_matrix_reflectance(indices[::-1], thicknesses[::-1],
                                                     wavelength, theta_back, pol))
            assert front == pytest.approx(back, abs=TMM_ATOL), (n1, n2, d1, d2, N, host, pol)


def test_unpolarized_is_the_mean_of_s_and_p():
    rng = np.random.default_rng(19)
    wavelength = rng.uniform(300.0, 1000.0, 200)
    theta = rng.uniform(0.0, math.pi / 2, 200)
    for i in range(20):
        (n1, n2, d1, d2, N, host), _, _ = random_stack(rng, evanescent=i % 2 == 0)
        for thing in (BraggMirror(n1, n2, d1, d2, N, host=host),
                      ThinFilm(n2, d2, n1, float(rng.uniform(0, 5)), host)):
            mean = 0.5 * (thing.reflectance(wavelength, theta, "s")
                          + thing.reflectance(wavelength, theta, "p"))
            np.testing.assert_allclose(thing.reflectance(wavelength, theta, "unpolarized"), mean,
                                       rtol=0, atol=SELF_ATOL)
            np.testing.assert_allclose(thing.reflectance(wavelength, theta), mean,
                                       rtol=0, atol=SELF_ATOL)
        indices, thicknesses = bragg_stack(n1, n2, d1, d2, min(N, 5), host)
        mean = 0.5 * (transfer_matrix_reflectance(indices, thicknesses, wavelength, theta, "s")
                      + transfer_matrix_reflectance(indices, thicknesses, wavelength, theta, "p"))
        np.testing.assert_allclose(
            transfer_matrix_reflectance(indices, thicknesses, wavelength, theta, "unpolarized"),
            mean, rtol=0, atol=SELF_ATOL)


def test_lossless_reflectance_plus_tmm_transmittance_is_one():
    rng = np.random.default_rng(21)
    for i in range(80):
        (n1, n2, d1, d2, N, host), wavelength, theta = random_stack(rng, evanescent=i % 4 == 0)
        for pol in POLARIZATIONS:
            R = float(BraggMirror(n1, n2, d1, d2, N, host=host).reflectance(wavelength, theta, pol))
            T = tmm_bragg(pol, n1, n2, d1, d2, N, wavelength, theta, host, key="T")
            assert R + T == pytest.approx(1.0, abs=TMM_ATOL), (n1, n2, d1, d2, N, host, pol)


# --------------------------------------------------------------------------- extreme N


EXTREME_MIRRORS = [
    (1.0, 1.5, 125.0, 375.0, None),
    (1.59, 1.67, 81.6, 78.4, 1.0),
    (1.5, 1.0, 100.0, 200.0, None),
    (1.5, 1.0, 100.0, 200.0, 1.2),
    (1.3, 2.5, 300.0, 20.0, 2.0),
]


@pytest.mark.parametrize("N", [1, 2, 1000, 10**6, MAX_INT32])
def test_extreme_period_counts_stay_finite(N):
    wavelength = np.linspace(360.0, 830.0, 4701)[:, None]
    theta = np.array([0.0, 89.9 * DEG, math.pi / 2])[None, :]
    for n1, n2, d1, d2, host in EXTREME_MIRRORS:
        mirror = BraggMirror(n1, n2, d1, d2, N, host=host)
        for pol in (*POLARIZATIONS, "unpolarized"):
            R = mirror.reflectance(wavelength, theta, pol)
            assert R.shape == (4701, 3)
            assert np.all(np.isfinite(R) & (R >= 0.0) & (R <= 1.0)), (mirror, pol)
        if host is None:
            np.testing.assert_array_equal(mirror.reflectance(wavelength, math.pi / 2), 1.0)


def test_million_periods_reflect_everything_inside_a_gap():
    n1, n2, d1, d2 = 1.0, 1.5, 125.0, 375.0
    wavelength = np.linspace(360.0, 830.0, 47001)
    checked = 0
    for theta in (0.0, 30 * DEG, 60 * DEG):
        for pol in POLARIZATIONS:
            _, sin2 = bloch_dispersion(n1, n2, d1, d2, wavelength, theta, pol)
            mu = np.arcsinh(np.sqrt(np.maximum(-sin2, 0.0)))
            deep = mu * 10**6 > 40  # 1 - R ~ e^(-2 N mu) / |C|^2: far below 1e-12
            R = BraggMirror(n1, n2, d1, d2, 10**6).reflectance(wavelength[deep], theta, pol)
            np.testing.assert_allclose(R, 1.0, rtol=0, atol=EXACT_ATOL)
            checked += deep.sum()
    assert checked > 10000


EDGE_MIRRORS = [
    (1.0, 1.5, 125.0, 375.0, None, (0.0, 40 * DEG)),
    (1.59, 1.67, 81.6, 78.4, 1.0, (0.0, 50 * DEG)),
    (1.5, 1.0, 100.0, 200.0, None, (30 * DEG,)),
]


@pytest.mark.parametrize("n1, n2, d1, d2, host, angles", EDGE_MIRRORS)
def test_exact_band_edges_match_tmm(n1, n2, d1, d2, host, angles):
    count = 0
    for theta, pol in itertools.product(angles, POLARIZATIONS):
        edges = band_edges(n1, n2, d1, d2, theta, pol, host)
        for edge in edges[:4]:
            _, sin2 = bloch_dispersion(n1, n2, d1, d2, edge, theta, pol, host=host)
            assert abs(float(sin2)) < 1e-12
            for N in (1, 2, 20, 1000):
                mirror = BraggMirror(n1, n2, d1, d2, N, host=host)
                for wavelength in (edge, edge * (1 - 1e-7), edge * (1 + 1e-7)):
                    got = float(mirror.reflectance(wavelength, theta, pol))
                    want = tmm_bragg(pol, n1, n2, d1, d2, N, wavelength, theta, host)
                    assert abs(got - want) <= EDGE_ATOL, (N, wavelength, theta, pol, got, want)
                    count += 1
    assert count > 20


@pytest.mark.parametrize("wavelength", [360.0, 830.0])
def test_ten_micron_layers(wavelength):
    for N, theta, host in itertools.product((1, 3, 10), (0.0, 0.7, 1.3), (None, 1.0)):
        mirror = BraggMirror(1.33, 1.56, 10000.0, 10000.0, N, host=host)
        for pol in POLARIZATIONS:
            got = float(mirror.reflectance(wavelength, theta, pol))
            want = tmm_bragg(pol, 1.33, 1.56, 1e4, 1e4, N, wavelength, theta, host)
            assert abs(got - want) <= TMM_ATOL, (N, theta, host, pol, got, want)


def test_thick_evanescent_barrier_under_a_different_host():
    """n2 evanescent over micrometres: the n1 | n2 interface reflects everything (R -> 1)."""
    wavelength = np.linspace(360.0, 830.0, 48)
    theta = 1.4  # host sin(theta) = 1.18 > n2 = 1.0, < n1 = 1.5
    for d2 in (200.0, 5e3, 1e5):
        for host in (1.2, 1.5):
            mirror = BraggMirror(1.5, 1.0, 100.0, d2, 2, host=host)
            indices, thicknesses = bragg_stack(1.5, 1.0, 100.0, d2, 2, host)
            for pol in POLARIZATIONS:
                got = mirror.reflectance(wavelength, theta, pol)
                want = transfer_matrix_reflectance(indices, thicknesses, wavelength, theta, pol)
                np.testing.assert_allclose(got, want, rtol=0, atol=TMM_ATOL,
                                           err_msg=f"d2={d2} host={host} {pol}")


# --------------------------------------------------------------------------- broadcasting


def test_n_dimensional_inputs_broadcast_like_a_loop():
    rng = np.random.default_rng(22)
    wavelength = rng.uniform(360.0, 830.0, (3, 1, 4))
    theta = rng.uniform(0.0, math.pi / 2, (5, 1))
    things = [BraggMirror(1.0, 1.5, 125.0, 375.0, 20), BraggMirror(1.59, 1.67, 81.6, 78.4, 8, 1.0),
              ThinFilm(1.3, 290.0, 0.2, 3.5, 1.0)]
    for thing, pol in itertools.product(things, (*POLARIZATIONS, "unpolarized")):
        R = thing.reflectance(wavelength, theta, pol)
        assert R.shape == (3, 5, 4)
        for i, j, k in itertools.product(range(3), range(5), range(4)):
            want = float(thing.reflectance(wavelength[i, 0, k], theta[j, 0], pol))
            assert R[i, j, k] == pytest.approx(want, abs=SELF_ATOL)
    indices, thicknesses = [1.0, 1.5, 1.2 + 0.3j, 1.0], [120.0, 80.0]
    R = transfer_matrix_reflectance(indices, thicknesses, wavelength, theta, "p")
    assert R.shape == (3, 5, 4)
    for i, j, k in itertools.product(range(3), range(5), range(4)):
        want = float(transfer_matrix_reflectance(indices, thicknesses, wavelength[i, 0, k],
                                                 theta[j, 0], "p"))
        assert R[i, j, k] == pytest.approx(want, abs=SELF_ATOL)


def test_scalar_inputs_give_zero_dimensional_arrays():
    R = BraggMirror(1.0, 1.5, 125.0, 375.0, 20).reflectance(687.5, 0.0)  # 2nd-order gap centre
    assert np.shape(R) == ()
    assert float(R) > 0.99
    assert wgbragg.ThinFilm(1.3, 290.0).reflectance([500.0, 600.0], 0.1).shape == (2,)


# --------------------------------------------------------------------------- phase average


@pytest.mark.parametrize("host", [None, 1.0, 1.3])
@pytest.mark.parametrize("pol", POLARIZATIONS)
def test_phase_average_is_the_mean_over_many_periods(host, pol):
    """method="phase-averaged" equals the brute-force mean of R over N (which sweeps the phase
    N K Lambda uniformly), with host = n1 and for Appendix D hosts."""
    n1, n2 = (1.59, 1.67) if host else (1.0, 1.5)
    wavelength = np.array([480.0, 560.0, 610.0, 700.0])
    counts = np.arange(2000, 6000, 3)
    brute = np.mean([yeh_reflectance(n1, n2, 81.6, 78.4, int(N), wavelength, 0.4, pol,
                                     host=host) for N in counts], axis=0)
    averaged = yeh_reflectance(n1, n2, 81.6, 78.4, 10**6, wavelength, 0.4, pol, host=host,
                               method="phase-averaged")
    np.testing.assert_allclose(averaged, brute, rtol=0, atol=3e-4)


def test_phase_average_is_exact_inside_band_gaps():
    wavelength = np.linspace(400.0, 800.0, 801)
    _, sin2 = bloch_dispersion(1.0, 1.5, 125.0, 375.0, wavelength, 0.2, "s")
    gap = sin2 < 0
    assert gap.any() and (~gap).any()
    for N in (3, 40):
        exact = yeh_reflectance(1.0, 1.5, 125.0, 375.0, N, wavelength, 0.2, "s")
        averaged = yeh_reflectance(1.0, 1.5, 125.0, 375.0, N, wavelength, 0.2, "s",
                                   method="phase-averaged")
        np.testing.assert_array_equal(averaged[gap], exact[gap])


def test_phase_average_at_a_band_edge_under_brewster_is_exact():
    """p at Brewster's angle: C = 0, and where sin^2 K Lambda is 0 too the mean was 0 / 0.

    The inputs land on sin^2 = 0 exactly only with this CPU's last bit of sin; one ulp away
    sin^2 ~ 1e-29 and |C| ~ 1e-17, where the exact R is below 1e-20 and the phase average, ill
    conditioned at this 0 / 0 point, a few 1e-6. What must hold is a finite, vanishing R."""
    n1, n2, d1, d2 = 1.0144732001868666, 1.0, 561.4886022923857, 1986.001046149856
    brewster, wavelength = math.atan(n2 / n1), 514.24326811702133
    assert abs(bloch_dispersion(n1, n2, d1, d2, wavelength, brewster, "p")[1]) <= 1e-27
    for N in (5, 10**4):
        averaged = yeh_reflectance(n1, n2, d1, d2, N, wavelength, brewster, "p",
                                   method="phase-averaged")
        assert np.isfinite(averaged) and 0.0 <= averaged <= 1e-5
        assert 0.0 <= yeh_reflectance(n1, n2, d1, d2, N, wavelength, brewster, "p") <= 1e-20


def test_unknown_yeh_method_is_refused():
    with pytest.raises(ValueError, match="method"):
        yeh_reflectance(1.0, 1.5, 125.0, 375.0, 5, 500.0, 0.1, "s", method="fast")


# --------------------------------------------------------------------------- input validation

# Each bad call must raise ValueError naming the parameter and the accepted range.
FILM = {"n_host": 1.0, "n_film": 1.3, "d_film_nm": 290.0, "n_base": 1.5,
        "wavelength_nm": 500.0, "theta": 0.3}
CELL = {"n1": 1.0, "n2": 1.5, "d1_nm": 125.0, "d2_nm": 375.0, "wavelength_nm": 500.0,
        "theta": 0.3, "polarization": "s"}


@pytest.mark.parametrize("name, value, accepted", [
    ("n_base", math.nan, r"\[0.01, 100\]"),
    ("n_base", math.inf, r"\[0.01, 100\]"),
    ("n_base", -math.inf, r"\[0.01, 100\]"),
    ("n_base", 1.5 - 0.1j, r"k in \[0, 10000\]"),
    ("n_base", 1.5 + 2e4j, r"k in \[0, 10000\]"),
    ("d_film_nm", -300.0, r"\[0, 1e\+06\] nm"),
    ("n_film", 0.0, r"\[0.01, 100\]"),
    ("n_host", 1.5 + 0.0j, "must be a real number"),
    ("n_host", math.nan, "is NaN"),
    ("theta", 2.0, r"\[0, pi/2\]"),
    ("polarization", "x", r"one of"),
])
def test_thin_film_reflectance_rejects_bad_input(name, value, accepted):
    with pytest.raises(ValueError, match=rf"\b{name}\b.*{accepted}"):
        thin_film_reflectance(**{**FILM, name: value})


@pytest.mark.parametrize("changes, name, accepted", [
    ({"n1": 0.0}, "n1", r"\[0.01, 100\]"),
    ({"wavelength_nm": 0.0}, "wavelength_nm", r"\[1, 1e\+06\] nm"),
    ({"host": 3.0, "theta": 1.5}, "theta", r"host sin\(theta\) below n1"),
    ({"theta": math.pi / 2}, "theta", r"host sin\(theta\) below n1"),  # grazing in n1
    ({"polarization": "x"}, "polarization", r"\('s', 'p'\)"),
    ({"polarization": "unpolarized"}, "polarization", r"\('s', 'p'\)"),
    ({"theta": 2.0}, "theta", r"\[0, pi/2\]"),
    ({"d2_nm": -1.0}, "d2_nm", r"\[0, 1e\+06\] nm"),
])
def test_bloch_dispersion_rejects_bad_input(changes, name, accepted):
    with pytest.raises(ValueError, match=rf"\b{name}\b.*{accepted}"):
        bloch_dispersion(**{**CELL, **changes})


@pytest.mark.parametrize("indices, thicknesses, polarization, name, accepted", [
    ([1.0, math.inf, 1.5], [100.0], "s", "indices", r"n in \[0.01, 100\]"),
    ([1.0, 1e-300, 1.5], [100.0], "p", "indices", r"n in \[0.01, 100\]"),
    ([1.0, 100.5, 1.5], [100.0], "s", "indices", r"n in \[0.01, 100\]"),
    ([1.0, 1.5 + 2e4j, 1.5], [100.0], "s", "indices", r"k in \[0, 10000\]"),
    ([1.0, "1.5", 1.5], [100.0], "s", "indices", r"n \+ i k"),
    ([1.0, 1.5, 1.5], [2e6], "s", "thicknesses_nm", r"\[0, 1e\+06\] nm"),
])
def test_transfer_matrix_rejects_bad_input(indices, thicknesses, polarization, name, accepted):
    with pytest.raises(ValueError, match=rf"\b{name}\b.*{accepted}"):
        transfer_matrix_reflectance(indices, thicknesses, 500.0, 0.3, polarization)


def test_valid_extremes_stay_finite():
    wavelength = np.array([1.0, 500.0, 1e6])[:, None]
    theta = np.array([0.0, 0.5, 1.2, math.pi / 2])[None, :]
    # A host denser than the film and base: total reflection beyond the critical angle.
    for pol in (*POLARIZATIONS, "unpolarized"):
        R = [thin_film_reflectance(2.4, 1.3, 290.0, 1.5, wavelength, theta, pol),
             thin_film_reflectance(1.0, 1.3, 0.0, 1.0 + 1e4j, wavelength, theta, pol),
             thin_film_reflectance(0.01, 100.0, 1e6, 100.0 + 1e4j, wavelength, theta, pol),
             transfer_matrix_reflectance([2.4, 1.3, 1.0 + 1e4j], [0.0], wavelength, theta, pol),
             transfer_matrix_reflectance([1.0, 0.01, 100.0], [1e6], wavelength, theta, pol),
             yeh_reflectance(1.0, 1.5, 0.0, 1e6, 5, wavelength, theta, pol, host=2.4)]
        for value in R:
            assert np.all(np.isfinite(value) & (value >= 0.0) & (value <= 1.0)), pol
    # 2.4 sin 1.2 > 1.5: |r| = 1 exactly in exact arithmetic; |r|^2 of a quotient of complex
    # numbers of equal modulus carries a few ulps of rounding (numpy's SIMD sin/cos differ in
    # the last bit between CPUs).
    np.testing.assert_allclose(
        thin_film_reflectance(2.4, 1.3, 290.0, 1.5, 500.0, 1.2), 1.0, rtol=0, atol=8e-16)
    np.testing.assert_allclose(  # k = 1e4: a near-perfect conductor
        thin_film_reflectance(1.0, 1.3, 0.0, 1.0 + 1e4j, 500.0, 0.0), 1.0, rtol=0, atol=1e-7)
    for pol in POLARIZATIONS:  # host above n1, below its critical angle; edge of the range
        for x, sin2 in (bloch_dispersion(1.5, 1.0, 0.0, 1e6, wavelength, 0.6, pol, host=2.4),
                        bloch_dispersion(0.01, 100.0, 1e6, 1e6, wavelength, 0.0, pol)):
            assert np.all(np.isfinite(x) & np.isfinite(sin2)), pol
