"""wgbragg.colour.colorimetry: XYZ weights, density, cumulative integral, sRGB and dE2000.

Everything is checked against colour-science computing the same quantity its own way
(``colour.sd_to_XYZ``, ``colour.delta_E``) or against published values (Sharma et al. 2005),
and against invariants (perfect reflector, monotone cumulative integral, exact box integrals).
"""

from __future__ import annotations

import math
import warnings

import colour
import numpy as np
import pytest

from wgbragg.colour import colorimetry
from wgbragg.colour.colorimetry import (
    WAVELENGTH_RANGE_NM,
    XYZ_TO_LINEAR_SRGB,
    cumulative_table,
    cumulative_xyz,
    delta_e_2000,
    linear_srgb_to_xyz,
    spectral_xyz,
    xyz_density,
    xyz_to_linear_srgb,
    xyz_weights,
)

EXACT_ATOL = 1e-12  # float64 identities
COLOUR_RTOL = 1e-3  # agreement with colour-science computing the same integral
WHITE_ATOL = 2e-3  # perfect reflector in linear sRGB; measured 1.7e-4 (B = 0.99983)
QUADRATURE_ATOL = 1e-5  # trapezoid rule versus 1 nm Riemann sum; measured 2e-6

CMFS = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
D65 = colour.SDS_ILLUMINANTS["D65"]
SHAPE = colour.SpectralShape(*WAVELENGTH_RANGE_NM, 1.0)
BAD_REALS = [math.nan, math.inf, -math.inf, "500", 1 + 2j]


def names(parameter):
    return rf"\b{parameter}\b"


def colour_xyz(sd):
    """colour's own XYZ of ``sd`` under D65, scaled so the perfect reflector has Y = 1."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "Aligning ... illuminant shape" runtime warnings
        return colour.sd_to_XYZ(sd, CMFS, D65, method="Integration") / 100.0


def test_spectral_tables_are_colours_cie_1931_observer():
    assert np.array_equal(CMFS.shape.wavelengths, np.arange(360.0, 831.0))
    assert WAVELENGTH_RANGE_NM == (CMFS.shape.start, CMFS.shape.end)


# --------------------------------------------------------------------------- xyz_weights


def test_weights_shape_nodes_and_sign():
    wavelength, weights = xyz_weights()
    assert wavelength.shape == (471,) and weights.shape == (471, 3)
    assert np.array_equal(wavelength, np.arange(360.0, 831.0))
    # colour's CMF table holds zbar = -2e-21 rounding residues near 650 nm: kept as data.
    assert np.all(weights >= -1e-20)
    assert np.all(weights[:, 1] > 0.0)


def test_weights_are_cached_and_read_only():
    first, second = xyz_weights(), xyz_weights()
    assert first[0] is second[0] and first[1] is second[1]
    for table in first:
        with pytest.raises(ValueError):
            table[0] = 1.0


def test_perfect_reflector_is_the_d65_white():
    white = xyz_weights()[1].sum(axis=0)
    assert white[1] == pytest.approx(1.0, abs=EXACT_ATOL)
    # Its chromaticity is D65's (colour's integration of the same tables).
    xy = white[:2] / white.sum()
    assert np.allclose(xy, colour_xyz(colour.sd_ones(SHAPE))[:2] / colour_xyz(
        colour.sd_ones(SHAPE)).sum(), atol=EXACT_ATOL)
    assert np.allclose(xy, colour.CCS_ILLUMINANTS[colorimetry.CMFS_NAME]["D65"], atol=1e-4)
    rgb = xyz_to_linear_srgb(white)
    assert np.allclose(rgb, 1.0, atol=WHITE_ATOL)


def _test_spectra():
    wavelength = SHAPE.wavelengths
    yield "constant", colour.SpectralDistribution(np.full(471, 0.37), wavelength)
    yield "sine", colour.SpectralDistribution(0.5 + 0.45 * np.sin(wavelength / 23.0), wavelength)
    yield "step", colour.SpectralDistribution((wavelength > 580.0).astype(float), wavelength)
    for name in ("dark skin", "blue", "yellow"):
        patch = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"][name].copy()
        yield name, patch.align(SHAPE)  # colour's own interpolation/extrapolation


TEST_SPECTRA = [pytest.param(*case, id=case[0]) for case in _test_spectra()]


@pytest.mark.parametrize(("name", "sd"), TEST_SPECTRA)
def test_weights_match_colour_sd_to_xyz(name, sd):
    wavelength, weights = xyz_weights()
    ours = sd[wavelength] @ weights
    assert np.allclose(ours, colour_xyz(sd), rtol=COLOUR_RTOL, atol=0.0), name


def test_weights_match_colour_for_many_spectra_at_once():
    rng = np.random.default_rng(1)
    wavelength, weights = xyz_weights()
    spectra = rng.random((8, 471))
    msds = colour.MultiSpectralDistributions(spectra.T, wavelength)
    assert np.allclose(spectra @ weights, colour_xyz(msds), rtol=COLOUR_RTOL)


# --------------------------------------------------------------------------- xyz_density


def test_density_interpolates_the_weights_linearly():
    wavelength, weights = xyz_weights()
    assert np.allclose(xyz_density(wavelength), weights, atol=EXACT_ATOL, rtol=0.0)
    middle = xyz_density(wavelength[:-1] + 0.25)
    assert np.allclose(middle, 0.75 * weights[:-1] + 0.25 * weights[1:], atol=EXACT_ATOL)


def test_density_vanishes_outside_the_visible_range():
    assert np.all(xyz_density([0.1, 359.999, 830.001, 2000.0]) == 0.0)
    assert np.all(xyz_density([360.0, 830.0])[:, 1] > 0.0)


def test_density_integrates_to_the_perfect_reflector():
    grid = np.linspace(*WAVELENGTH_RANGE_NM, 47001)
    integral = np.trapezoid(xyz_density(grid), grid, axis=0)
    assert np.allclose(integral, xyz_weights()[1].sum(0), atol=QUADRATURE_ATOL)
    assert integral[1] == pytest.approx(1.0, abs=QUADRATURE_ATOL)


def test_density_n_dimensional():
    wavelength = np.array([[400.5, 500.0, 600.25], [700.0, 800.0, 900.0]])
    value = xyz_density(wavelength)
    assert value.shape == (2, 3, 3)
    assert np.array_equal(value.reshape(-1, 3), xyz_density(wavelength.ravel()))
    assert xyz_density(555.0).shape == (3,)


@pytest.mark.parametrize("function", [xyz_density, cumulative_xyz])
@pytest.mark.parametrize("value", BAD_REALS)
def test_density_and_cumulative_reject_bad_wavelengths(function, value):
    with pytest.raises(ValueError, match=names("wavelength_nm")):
        function([500.0, value])


# --------------------------------------------------------------------------- cumulative_xyz


def test_cumulative_spans_zero_to_the_weights_sum():
    white = xyz_weights()[1].sum(0)
    assert np.array_equal(cumulative_xyz(360.0), np.zeros(3))
    assert np.allclose(cumulative_xyz(830.0), white, rtol=COLOUR_RTOL)
    assert np.allclose(cumulative_xyz(830.0), white, atol=QUADRATURE_ATOL)


def test_cumulative_is_clamped_outside_the_range():
    inside = cumulative_xyz([360.0, 830.0])
    assert np.array_equal(cumulative_xyz([100.0, 359.0]), np.zeros((2, 3)))
    assert np.array_equal(cumulative_xyz([830.5, 5000.0]), np.stack([inside[1], inside[1]]))


def test_cumulative_is_monotone_and_continuous():
    grid = np.linspace(355.0, 835.0, 96001)
    values = cumulative_xyz(grid)
    steps = np.diff(values, axis=0)
    assert np.all(steps >= 0.0)
    assert steps.max() < 1e-4  # no jump at the 1 nm nodes


def test_cumulative_derivative_is_the_density():
    wavelength = np.array([360.0, 361.5, 455.3, 555.0, 555.999, 700.2, 829.0])
    h = 1e-6
    slope = (cumulative_xyz(wavelength + h) - cumulative_xyz(wavelength)) / h
    assert np.allclose(slope, xyz_density(wavelength + h / 2), rtol=1e-5, atol=1e-9)


def test_box_integral_is_exact_for_the_piecewise_linear_density():
    for lo, hi in [(400.3, 401.7), (360.0, 830.0), (512.25, 634.75), (359.0, 361.5)]:
        # The density is linear between nodes (and jumps from 0 at 360 nm).
        start = max(lo, WAVELENGTH_RANGE_NM[0])
        grid = np.union1d(np.linspace(start, hi, 20001),
                          np.arange(math.ceil(start), math.floor(hi) + 1.0))
        direct = np.trapezoid(xyz_density(grid), grid, axis=0)
        box = cumulative_xyz(hi) - cumulative_xyz(lo)
        assert np.allclose(box, direct, rtol=1e-9, atol=1e-15), (lo, hi)


def test_box_integral_of_one_over_the_range_is_the_perfect_reflector():
    box = 1.0 * (cumulative_xyz(WAVELENGTH_RANGE_NM[1]) - cumulative_xyz(WAVELENGTH_RANGE_NM[0]))
    assert np.allclose(box, colour_xyz(colour.sd_ones(SHAPE)), rtol=COLOUR_RTOL)


def test_cumulative_n_dimensional():
    wavelength = np.linspace(350.0, 840.0, 24).reshape(2, 3, 4)
    value = cumulative_xyz(wavelength)
    assert value.shape == (2, 3, 4, 3)
    assert np.array_equal(value.reshape(-1, 3), cumulative_xyz(wavelength.ravel()))


def test_cumulative_table_matches_the_function_and_uploads_as_float32():
    wavelength, table = cumulative_table()
    assert table.shape == (471, 3) and not table.flags.writeable
    assert np.array_equal(wavelength, xyz_weights()[0])
    assert np.allclose(table, cumulative_xyz(wavelength), atol=EXACT_ATOL, rtol=0.0)
    as_f32 = table.astype(np.float32)
    assert np.allclose(as_f32, table, rtol=1e-7, atol=1e-12)


# --------------------------------------------------------------------------- sRGB


def test_srgb_matrix_is_colours():
    assert np.array_equal(XYZ_TO_LINEAR_SRGB, colour.RGB_COLOURSPACES["sRGB"].matrix_XYZ_to_RGB)
    assert not XYZ_TO_LINEAR_SRGB.flags.writeable


def test_srgb_round_trip_and_n_dimensional():
    xyz = np.random.default_rng(2).random((2, 3, 4, 3))
    rgb = xyz_to_linear_srgb(xyz)
    assert rgb.shape == (2, 3, 4, 3)
    assert np.allclose(rgb[1, 2, 3], XYZ_TO_LINEAR_SRGB @ xyz[1, 2, 3], atol=EXACT_ATOL)
    assert np.allclose(linear_srgb_to_xyz(rgb), xyz, atol=EXACT_ATOL)


def test_srgb_matches_colour_conversion_without_adaptation():
    xyz = np.array([[0.2, 0.3, 0.4], [0.95, 1.0, 1.09]])
    expected = colour.XYZ_to_RGB(xyz, "sRGB", apply_cctf_encoding=False)
    assert np.allclose(xyz_to_linear_srgb(xyz), expected, atol=EXACT_ATOL)


@pytest.mark.parametrize("bad", [np.zeros(2), np.zeros((4, 2)), 1.0, [0.1, math.nan, 0.3]])
def test_srgb_rejects_bad_shapes_and_values(bad):
    with pytest.raises(ValueError, match=names("xyz")):
        xyz_to_linear_srgb(bad)


# --------------------------------------------------------------------------- delta_e_2000

# Sharma, Wu & Dalal 2005, Table 1, pairs 1, 7 and 17: (Lab1, Lab2, dE00).
SHARMA_PAIRS = [
    ((50.0, 2.6772, -79.7751), (50.0, 0.0, -82.7485), 2.0425),
    ((50.0, 0.0, 0.0), (50.0, -1.0, 2.0), 2.3669),
    ((50.0, 2.5, 0.0), (73.0, 25.0, -18.0), 27.1492),
]


def _lab_to_linear_srgb(lab):
    xyz = colour.Lab_to_XYZ(np.asarray(lab), colour.CCS_ILLUMINANTS[colorimetry.CMFS_NAME]["D65"])
    return xyz_to_linear_srgb(xyz)


@pytest.mark.parametrize(("lab1", "lab2", "expected"), SHARMA_PAIRS)
def test_delta_e_reproduces_sharma_table(lab1, lab2, expected):
    value = delta_e_2000(_lab_to_linear_srgb(lab1), _lab_to_linear_srgb(lab2))
    assert float(value) == pytest.approx(expected, abs=1e-4)


def test_delta_e_matches_colour_directly():
    rng = np.random.default_rng(3)
    a, b = rng.random((5, 3)), rng.random((5, 3))
    white = colour.CCS_ILLUMINANTS[colorimetry.CMFS_NAME]["D65"]
    lab_a = colour.XYZ_to_Lab(linear_srgb_to_xyz(a), white)
    lab_b = colour.XYZ_to_Lab(linear_srgb_to_xyz(b), white)
    expected = colour.delta_E(lab_a, lab_b, method="CIE 2000")
    assert np.allclose(delta_e_2000(a, b), expected, atol=EXACT_ATOL)


def test_delta_e_zero_for_equal_colours_and_symmetric():
    rng = np.random.default_rng(4)
    a, b = rng.random((6, 3)), rng.random((6, 3))
    assert np.array_equal(delta_e_2000(a, a), np.zeros(6))
    assert np.allclose(delta_e_2000(a, b), delta_e_2000(b, a), atol=EXACT_ATOL)
    assert np.all(delta_e_2000(a, b) > 0.0)


def test_delta_e_of_greys_is_the_weighted_lightness_difference():
    # Neutral colours: a* = b* = 0, so dE00 = |dL*| / S_L with Sharma et al.'s eq. (13)
    # S_L = 1 + 0.015 (L - 50)^2 / sqrt(20 + (L - 50)^2) at the mean lightness L.
    white = np.ones(3)
    lightness = 116.0 * np.cbrt([1.0, 0.18]) - 16.0
    mean = lightness.mean()
    s_l = 1.0 + 0.015 * (mean - 50.0) ** 2 / math.sqrt(20.0 + (mean - 50.0) ** 2)
    expected = abs(lightness[0] - lightness[1]) / s_l
    # (1, 1, 1) is D65 only to the 4-digit rounding of the IEC matrix: a*, b* ~ 1e-3.
    assert float(delta_e_2000(white, 0.18 * white)) == pytest.approx(expected, abs=1e-4)


def test_delta_e_broadcasts_n_dimensional():
    rng = np.random.default_rng(5)
    a = rng.random((2, 3, 3))
    b = rng.random(3)
    value = delta_e_2000(a, b)
    assert value.shape == (2, 3)
    assert value[1, 2] == pytest.approx(float(delta_e_2000(a[1, 2], b)), abs=EXACT_ATOL)


@pytest.mark.parametrize("bad", [np.zeros(2), [0.1, math.nan, 0.3], [0.1, math.inf, 0.2], "rgb"])
def test_delta_e_rejects_bad_input(bad):
    with pytest.raises(ValueError, match=names("rgb_a")):
        delta_e_2000(bad, np.zeros(3))
    with pytest.raises(ValueError, match=names("rgb_b")):
        delta_e_2000(np.zeros(3), bad)


def test_delta_e_rejects_shapes_that_do_not_broadcast():
    with pytest.raises(ValueError, match="broadcast"):
        delta_e_2000(np.zeros((2, 3)), np.zeros((4, 3)))


# --------------------------------------------------------------------------- spectral_xyz


def test_spectral_xyz_accepts_arrays_and_callables():
    wavelength, weights = xyz_weights()
    R = np.random.default_rng(6).random((2, 3, 471))
    from_array = spectral_xyz(R, wavelength, weights)
    assert from_array.shape == (2, 3, 3)
    assert np.allclose(from_array[1, 2], R[1, 2] @ weights, atol=EXACT_ATOL)
    from_function = spectral_xyz(lambda lam: lam / 1000.0, wavelength, weights)
    assert np.allclose(from_function, (wavelength / 1000.0) @ weights, atol=EXACT_ATOL)


def test_spectral_xyz_rejects_mismatched_shapes():
    wavelength, weights = xyz_weights()
    with pytest.raises(ValueError, match=names("reflectance_fn")):
        spectral_xyz(np.ones(470), wavelength, weights)
    with pytest.raises(ValueError, match=names("weights")):
        spectral_xyz(np.ones(471), wavelength, weights[:, :2])
    with pytest.raises(ValueError, match=names("reflectance_fn")):
        spectral_xyz(np.full(471, math.nan), wavelength, weights)
