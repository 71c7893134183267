"""The "spectral" colour method is self-normalised (issue 40, item 5): a perfect reflector is
exactly white for every K and seed, on both backends, and the estimator still converges to
"reference" as K grows.

Before, the stratified sum was used as is: K = 16 gave XYZ (0.962, 1.0065, 1.096) for a
perfect reflector, ``seed=3`` Z = 1.32 and ``samples=1`` (4.2, 2.77, 0.004).
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from wgbragg import BraggMirror, ThinFilm
from wgbragg.colour.colorimetry import delta_e_2000, xyz_to_linear_srgb, xyz_weights
from wgbragg.colour.reference import (
    WHITE_XYZ,
    reference_xyz,
    self_normalised_weights,
    spectral_xyz_stratified,
    stratified_nodes,
)

D65_WHITE = np.array([0.95047, 1.0, 1.08883])  # CIE 1931 2 degree, Y = 1
SAMPLES = (1, 2, 16, 100)
SEEDS = (None, 0, 3, 7, 12345)
THETA = np.radians([0.0, 30.0, 60.0, 89.0])
# Total internal reflection: R = 1 at every wavelength on both backends (exactly, measured).
TIR_THETA = 1.3
TIR_MATERIALS = [BraggMirror(1.2, 1.4, 100.0, 100.0, 10, host=1.6),
                 ThinFilm(n_film=1.2, d=300.0, n_base=1.0, host=1.5)]


class PerfectReflector:
    """R = 1 at every wavelength and angle (any object with ``reflectance`` is a material
    for the numpy backend)."""

    def reflectance(self, wavelength_nm, theta, polarization="unpolarized", backend="numpy"):
        return np.ones(np.broadcast_shapes(np.shape(wavelength_nm), np.shape(theta)))


def delta_e(xyz_a, xyz_b):
    return delta_e_2000(xyz_to_linear_srgb(xyz_a), xyz_to_linear_srgb(xyz_b))


def test_the_white_is_d65s():
    np.testing.assert_allclose(WHITE_XYZ, D65_WHITE, atol=5e-6)
    np.testing.assert_array_equal(WHITE_XYZ, xyz_weights()[1].sum(axis=0))


@pytest.mark.parametrize(("samples", "seed"), list(itertools.product(SAMPLES, SEEDS)))
def test_a_perfect_reflector_is_exactly_white(samples, seed):
    xyz = spectral_xyz_stratified(PerfectReflector(), THETA, samples, seed=seed)
    np.testing.assert_allclose(xyz, np.broadcast_to(WHITE_XYZ, (len(THETA), 3)),
                               rtol=1e-14, atol=0.0)


@pytest.mark.parametrize("material", TIR_MATERIALS, ids=["mirror", "film"])
def test_the_issues_reproducers_are_white(material):
    # K = 16 (the default), seed=3 and samples=1 through the public API.
    for options in ({}, {"seed": 3}, {"samples": 1}, {"samples": 1, "seed": 3}):
        xyz = material.xyz(TIR_THETA, method="spectral", **options)
        np.testing.assert_allclose(xyz, WHITE_XYZ, rtol=1e-14, atol=0.0)


def test_channels_no_node_sees_fall_back_to_the_mean():
    # K = 1 with its node beyond 650 nm: zbar is 0 there, so Z takes the unweighted mean of R.
    seed = next(s for s in range(1000) if stratified_nodes(1, s)[1][0, 2] == 0.0)
    wavelength, weights = stratified_nodes(1, seed)
    assert wavelength[0] > 650.0 and weights[0, 0] > 0.0
    np.testing.assert_allclose(self_normalised_weights(weights), [WHITE_XYZ], rtol=1e-15)
    np.testing.assert_allclose(
        spectral_xyz_stratified(PerfectReflector(), 0.2, 1, seed=seed), WHITE_XYZ, rtol=1e-15)
    mirror = BraggMirror(1.0, 1.5, 125.0, 375.0, 20)
    r = mirror.reflectance(wavelength[0], 0.2)
    np.testing.assert_allclose(spectral_xyz_stratified(mirror, 0.2, 1, seed=seed),
                               r * WHITE_XYZ, rtol=1e-12)


@pytest.mark.parametrize("seed", [None, 3, 7])
def test_spectral_converges_to_the_reference(seed):
    mirror = BraggMirror(1.0, 1.5, 125.0, 375.0, 20)
    theta = np.radians(np.arange(0.0, 90.0, 5.0))
    reference = reference_xyz(mirror, theta)
    error = {k: delta_e(spectral_xyz_stratified(mirror, theta, k, seed=seed), reference).mean()
             for k in (16, 128, 1024)}
    # Measured mean dE2000 5.2-6.8, 0.85-1.3, 0.09-0.13.
    assert error[1024] < error[128] < error[16]
    assert error[1024] < 0.25
    xyz = spectral_xyz_stratified(mirror, theta, 1024, seed=seed)
    assert np.abs(xyz - reference).max() < 0.01  # measured 3.5e-3 - 4.5e-3


def test_471_centred_strata_still_reproduce_the_reference():
    mirror = BraggMirror(1.0, 1.5, 247.0, 741.0, 100)
    np.testing.assert_allclose(spectral_xyz_stratified(mirror, THETA, 471),
                               reference_xyz(mirror, THETA), rtol=0.0, atol=1e-12)


@pytest.mark.gpu
@pytest.mark.parametrize("material", TIR_MATERIALS, ids=["mirror", "film"])
def test_gpu_perfect_reflector_is_white_and_equals_numpy(material):
    theta = np.array([TIR_THETA, 1.4, 1.5])
    for samples, seed in itertools.product(SAMPLES, SEEDS):
        gpu_xyz = spectral_xyz_stratified(material, theta, samples, backend="gpu", seed=seed)
        numpy_xyz = spectral_xyz_stratified(material, theta, samples, seed=seed)
        np.testing.assert_allclose(numpy_xyz, np.broadcast_to(WHITE_XYZ, (3, 3)), rtol=1e-14)
        # float32 weights and sums.
        np.testing.assert_allclose(gpu_xyz, numpy_xyz, rtol=1e-6, atol=0.0)


@pytest.mark.gpu
def test_gpu_spectral_of_a_mirror_equals_numpy():
    mirror = BraggMirror(1.0, 1.5, 125.0, 375.0, 20)
    for samples, seed in ((1, 3), (16, None), (100, 7)):
        gpu_xyz = spectral_xyz_stratified(mirror, THETA, samples, backend="gpu", seed=seed)
        numpy_xyz = spectral_xyz_stratified(mirror, THETA, samples, seed=seed)
        assert delta_e(gpu_xyz, numpy_xyz).max() < 0.1
