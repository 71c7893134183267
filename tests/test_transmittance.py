"""Transmittance and absorptance of Bragg mirrors and thin films (issue 40, item 2).

``transmittance`` is the normal Poynting flux the exit medium carries away over the incident
one, as ``tmm.coh_tmm``'s ``T`` (a mirror's ``n1`` substrate, a film's lossless base);
``absorptance`` what an absorbing base absorbs (tmm's ``T`` there, all of which the base
absorbs). Every layer is lossless, so ``R + T + A = 1`` everywhere: ``R + T = 1`` for lossless
stacks, ``R + A = 1`` over metals. Both backends; the float32 kernel is held to the criterion
of ``test_float32_domain.py``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import tmm
from test_float32_domain import check_float32

from wgbragg import BraggMirror, ThinFilm
from wgbragg.optics import base_flux, thin_film_absorptance, yeh_transmittance

TMM_ATOL = 1e-10  # float64 closed forms against tmm's transfer matrices
BALANCE_ATOL = 1e-12  # R + T + A = 1 in float64
GPU_BALANCE_ATOL = 1e-6  # ... in float32 (each term within a few float32 ulps)
HALF_PI = math.pi / 2
POLARIZATIONS = ("s", "p")

WAVELENGTHS = np.linspace(380.0, 800.0, 15)
# Off every critical angle of the materials below by more than 1e-3 rad: tmm divides by a
# vanishing normal component at a critical angle itself.
ANGLES = np.array([0.0, 0.2, 0.45, 0.7, 0.8, 0.95, 1.1, 1.3, 1.45, 1.55])

MIRRORS = [
    BraggMirror(1.0, 1.5, 125.0, 375.0, 5),
    BraggMirror(1.5, 1.0, 100.0, 200.0, 3),  # evanescent n2 beyond 41.8 degrees
    BraggMirror(1.59, 1.67, 81.6, 78.4, 8, host=1.0),  # Appendix D, jewel beetle
    BraggMirror(1.5, 1.0, 100.0, 200.0, 4, host=1.2),  # evanescent n2 under another host
    BraggMirror(1.3, 2.5, 300.0, 20.0, 4, host=2.0),  # total reflection beyond 40.5 degrees
    BraggMirror(1.0, 1.5, 125.0, 375.0, 40),  # deep gaps: T down to 1e-20
]
FILMS = [  # (film, the base's index for tmm)
    (ThinFilm(1.3, 290.0, 1.5, 0.0, 1.0), 1.5),
    (ThinFilm(1.3, 200.0, 1.0, 0.0, 1.5), 1.0),  # total reflection in the base past 41.8 deg
    (ThinFilm(1.3, 200.0, 1.5, 0.0, 2.0), 1.5),  # ... and in the film past 40.5 deg
    (ThinFilm(1.8, 450.0, 0.2, 3.5, 1.0), 0.2 + 3.5j),  # over a metal
    (ThinFilm(1.4, 120.0, 1.1, 10.0, 1.33), 1.1 + 10.0j),
    (ThinFilm(1.5, 0.0, 0.5, 2.0, 1.0), 0.5 + 2.0j),  # the bare metal
]


def mirror_stack(mirror):
    indices = [mirror.host] + [mirror.n1, mirror.n2] * mirror.N + [mirror.n1]
    return indices, [np.inf] + [mirror.d1, mirror.d2] * mirror.N + [np.inf]


def tmm_values(indices, thicknesses, polarization):
    """tmm's (R, T) over the WAVELENGTHS x ANGLES grid."""
    out = np.empty((2, WAVELENGTHS.size, ANGLES.size))
    for i, wavelength in enumerate(WAVELENGTHS):
        for j, theta in enumerate(ANGLES):
            result = tmm.coh_tmm(polarization, indices, thicknesses, theta, wavelength)
            out[:, i, j] = result["R"], result["T"]
    return out


@pytest.mark.parametrize("mirror", MIRRORS, ids=str)
def test_mirror_transmittance_matches_tmm(mirror):
    grid = (WAVELENGTHS[:, None], ANGLES[None, :])
    for pol in POLARIZATIONS:
        R_tmm, T_tmm = tmm_values(*mirror_stack(mirror), pol)
        R, T = mirror.reflectance(*grid, pol), mirror.transmittance(*grid, pol)
        np.testing.assert_allclose(T, T_tmm, rtol=0, atol=TMM_ATOL, err_msg=pol)
        np.testing.assert_allclose(R, R_tmm, rtol=0, atol=TMM_ATOL, err_msg=pol)
        np.testing.assert_allclose(R + T, 1.0, rtol=0, atol=BALANCE_ATOL, err_msg=pol)
        np.testing.assert_array_equal(mirror.absorptance(*grid, pol), 0.0)
        # Formed directly, T keeps its relative accuracy where it is tiny (deep gaps); beyond
        # the critical angle of n1 it is 0, where tmm leaves rounding (1e-20 and below).
        enters = np.broadcast_to(mirror.host * np.sin(ANGLES) < mirror.n1, T.shape)
        small = (T_tmm < 1e-6) & enters
        np.testing.assert_allclose(T[small], T_tmm[small], rtol=1e-6, err_msg=pol)
        np.testing.assert_array_equal(T[~enters], 0.0)


def test_deep_gaps_have_relative_accuracy():
    mirror = MIRRORS[-1]
    T = mirror.transmittance(WAVELENGTHS[:, None], ANGLES[None, :], "s")
    assert T.min() < 1e-15  # the grid really reaches deep into the gap


@pytest.mark.parametrize("film, base", FILMS, ids=[str(f) for f, _ in FILMS])
def test_film_transmittance_and_absorptance_match_tmm(film, base):
    grid = (WAVELENGTHS[:, None], ANGLES[None, :])
    absorbing = np.imag(base) > 0
    for pol in POLARIZATIONS:
        R_tmm, T_tmm = tmm_values([film.host, film.n_film, base], [np.inf, film.d, np.inf], pol)
        R = film.reflectance(*grid, pol)
        T, A = film.transmittance(*grid, pol), film.absorptance(*grid, pol)
        np.testing.assert_allclose(R, R_tmm, rtol=0, atol=TMM_ATOL, err_msg=pol)
        # tmm's T is the flux entering the base; an absorbing base absorbs all of it.
        np.testing.assert_allclose(A if absorbing else T, T_tmm, rtol=0, atol=TMM_ATOL,
                                   err_msg=pol)
        np.testing.assert_array_equal(T if absorbing else A, 0.0)
        np.testing.assert_allclose(R + T + A, 1.0, rtol=0, atol=BALANCE_ATOL, err_msg=pol)


@pytest.mark.parametrize("case", [
    (BraggMirror(1.3, 2.5, 300.0, 20.0, 4, host=2.0), math.asin(1.3 / 2.0)),
    (ThinFilm(1.3, 200.0, 1.0, 0.0, 1.5), math.asin(1.0 / 1.5)),
], ids=["mirror", "film"])
def test_total_internal_reflection_transmits_nothing(case):
    thing, critical = case
    theta = np.linspace(critical + 1e-6, HALF_PI, 30)[None, :]
    for backend in ("numpy", "gpu"):
        for pol in ("s", "p", "unpolarized"):
            T = thing.transmittance(WAVELENGTHS[:, None], theta, pol, backend)
            np.testing.assert_array_equal(T, 0.0, err_msg=f"{backend} {pol}")
            R = thing.reflectance(WAVELENGTHS[:, None], theta, pol, backend)
            np.testing.assert_allclose(R, 1.0, rtol=0, atol=GPU_BALANCE_ATOL)


@pytest.mark.parametrize("metal", ["Ag", "Al", "Au", "Cu"])
def test_film_over_a_tabulated_metal(metal):
    film = ThinFilm(1.45, 250.0, host=1.0, base=metal)
    wavelength = np.linspace(360.0, 830.0, 48)[:, None]
    theta = ANGLES[None, :]
    index = film.base_index(wavelength)
    for pol in POLARIZATIONS:
        A = film.absorptance(wavelength, theta, pol)
        np.testing.assert_array_equal(film.transmittance(wavelength, theta, pol), 0.0)
        np.testing.assert_allclose(film.reflectance(wavelength, theta, pol) + A, 1.0, rtol=0,
                                   atol=BALANCE_ATOL)
        np.testing.assert_allclose(
            A, thin_film_absorptance(1.0, 1.45, 250.0, index, wavelength, theta, pol), rtol=0,
            atol=0)
        for i in (0, 20, 47):
            for j in (0, 5, 9):
                want = tmm.coh_tmm(pol, [1.0, 1.45, complex(index[i, 0])],
                                   [np.inf, 250.0, np.inf], ANGLES[j], wavelength[i, 0])["T"]
                assert A[i, j] == pytest.approx(want, abs=TMM_ATOL)


# --------------------------------------------------------------------------- the GPU backend


@pytest.mark.gpu
@pytest.mark.parametrize("thing", [m for m in MIRRORS] + [f for f, _ in FILMS], ids=str)
def test_gpu_matches_float64(thing):
    wavelength = np.linspace(360.0, 830.0, 95)[:, None]
    theta = np.linspace(0.0, HALF_PI, 24)[None, :]
    absorbing = isinstance(thing, ThinFilm) and thing.k_base > 0
    for pol in ("s", "p", "unpolarized"):
        quantity = "absorptance" if absorbing else "transmittance"
        check_float32(thing, quantity, wavelength, theta, pol)
        R = thing.reflectance(wavelength, theta, pol, "gpu")
        T = thing.transmittance(wavelength, theta, pol, "gpu")
        A = thing.absorptance(wavelength, theta, pol, "gpu")
        np.testing.assert_allclose(R + T + A, 1.0, rtol=0, atol=GPU_BALANCE_ATOL,
                                   err_msg=f"{thing} {pol}")


@pytest.mark.gpu
def test_gpu_transmittance_of_deep_gaps_keeps_its_relative_accuracy():
    """T inside a gap is formed directly on the GPU too: 1e-20 of it is not 1 - R."""
    mirror = BraggMirror(1.0, 1.5, 125.0, 375.0, 40)
    wavelength = np.linspace(600.0, 780.0, 181)
    T64 = mirror.transmittance(wavelength, 0.0, "s")
    T32 = mirror.transmittance(wavelength, 0.0, "s", "gpu")
    deep = (T64 < 1e-10) & (T64 > 1e-30)
    assert deep.sum() > 20
    np.testing.assert_allclose(T32[deep], T64[deep], rtol=1e-3)
    appendix_d = BraggMirror(1.0, 1.5, 125.0, 375.0, 40, host=1.33)
    T64 = appendix_d.transmittance(wavelength, 0.0, "s")
    T32 = appendix_d.transmittance(wavelength, 0.0, "s", "gpu")
    deep = (T64 < 1e-10) & (T64 > 1e-30)
    assert deep.sum() > 20
    np.testing.assert_allclose(T32[deep], T64[deep], rtol=1e-3)


def test_transmittance_validates_like_reflectance():
    for thing in (MIRRORS[0], FILMS[0][0]):
        for method in ("transmittance", "absorptance"):
            with pytest.raises(ValueError, match="polarization"):
                getattr(thing, method)(550.0, 0.1, "q")
            with pytest.raises(ValueError, match="wavelength"):
                getattr(thing, method)(-1.0, 0.1)
            with pytest.raises(ValueError, match="theta"):
                getattr(thing, method)(550.0, 2.0)
            with pytest.raises(ValueError, match="backend"):
                getattr(thing, method)(550.0, 0.1, "s", "cuda")


def test_module_functions_agree_with_the_classes():
    mirror = MIRRORS[2]
    np.testing.assert_array_equal(
        yeh_transmittance(1.59, 1.67, 81.6, 78.4, 8, WAVELENGTHS, 0.3, "p", host=1.0),
        mirror.transmittance(WAVELENGTHS, 0.3, "p"))
    film = FILMS[3][0]
    np.testing.assert_array_equal(
        base_flux(1.0, 1.8, 450.0, 0.2 + 3.5j, WAVELENGTHS, 0.3, "s"),
        film.absorptance(WAVELENGTHS, 0.3, "s"))
