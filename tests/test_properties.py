"""Property tests over the whole valid input domain, on both backends: every reflectance is
finite and in [0, 1], never NaN. The GPU case dispatches ~256 (wavelength, theta) pairs per
example, so 60 examples stay fast on lavapipe."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from wgbragg import BraggMirror, ThinFilm

MAX_INT32 = 2**31 - 1
BACKENDS = [pytest.param("numpy"), pytest.param("gpu", marks=pytest.mark.gpu)]

PROPERTY_SETTINGS = settings(max_examples=60, deadline=None, derandomize=True, database=None,
                             suppress_health_check=[HealthCheck.too_slow])
indices = st.floats(0.05, 20.0)
thicknesses = st.one_of(st.just(0.0), st.floats(0.0, 1e5))
counts = st.one_of(st.sampled_from([1, 2, MAX_INT32]), st.integers(1, MAX_INT32))
polarizations = st.sampled_from(["s", "p", "unpolarized"])
seeds = st.integers(0, 2**32 - 1)


def property_inputs(seed, size=256):
    """~256 (wavelength, theta) pairs over the whole domain, endpoints included."""
    rng = np.random.default_rng(seed)
    wavelength = np.exp(rng.uniform(0.0, math.log(1e5), size))
    theta = rng.uniform(0.0, math.pi / 2, size)
    wavelength[:4] = [1.0, 1e5, 1.0, 1e5]
    theta[:6] = [0.0, 0.0, math.pi / 2, math.pi / 2, 0.0, math.pi / 2]
    return wavelength, theta


def assert_valid(R, *context):
    bad = ~(np.isfinite(R) & (R >= 0.0) & (R <= 1.0))
    assert not bad.any(), (*context, np.flatnonzero(bad)[:5], R[bad][:5])


@pytest.mark.parametrize("backend", BACKENDS)
@PROPERTY_SETTINGS
@given(n1=indices, n2=indices, d1=thicknesses, d2=thicknesses, N=counts,
       host_kind=st.sampled_from(["n1", "free", "n2"]), host_value=indices, pol=polarizations,
       seed=seeds)
def test_mirror_is_always_a_reflectance(backend, n1, n2, d1, d2, N, host_kind, host_value, pol,
                                        seed):
    host = {"n1": None, "free": host_value, "n2": n2}[host_kind]  # n2 == host: q2 = 0 at grazing
    mirror = BraggMirror(n1, n2, d1, d2, N, host=host)
    wavelength, theta = property_inputs(seed)
    assert_valid(mirror.reflectance(wavelength, theta, pol, backend=backend), mirror, pol, seed)


@pytest.mark.parametrize("backend", BACKENDS)
@PROPERTY_SETTINGS
@given(n_film=indices, d=thicknesses, n_base=indices, k_base=st.floats(0.0, 50.0),
       host=indices, pol=polarizations, seed=seeds)
def test_thin_film_is_always_a_reflectance(backend, n_film, d, n_base, k_base, host, pol, seed):
    film = ThinFilm(n_film, d, n_base, k_base, host)
    wavelength, theta = property_inputs(seed)
    assert_valid(film.reflectance(wavelength, theta, pol, backend=backend), film, pol, seed)
