"""Hero-wavelength colour of LayeredBragg.sample (``colour_method="hero"``): the sampler's
four wavelengths (colorimetry.hero_wavelengths and its WGSL twin,
wgsl/colour/colorimetry_hero.wgsl, shared with
the simulation and the renderer), unbiased for the integrated colour, numpy against GPU."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import unit_direction

from wgbragg import BraggMirror, LayeredBragg, RoughBraggLayer
from wgbragg.bsdf.layered.model import HERO
from wgbragg.colour import colorimetry

A = BraggMirror(1.0, 1.5, 250.0, 250.0, 10)
COATED = BraggMirror(1.35, 1.5, 250.0, 250.0, 10)
STRUCTURES = {
    "absorbing": LayeredBragg([RoughBraggLayer(A, 0.1)]),
    "lambertian": LayeredBragg([RoughBraggLayer(A, 0.1)], base_albedo=[0.6, 0.3, 0.1]),
    "coated": LayeredBragg([RoughBraggLayer(COATED, 0.2)], base_albedo=0.5),
}


def _strata(count: int) -> np.ndarray:
    """Offsets at the midpoints of ``count`` strata: the hero estimate averaged over them is a
    4 x ``count`` point quadrature of the colour integral."""
    return (np.arange(count) + 0.5) / count


def _stratified_u(direction_u, count: int) -> np.ndarray:
    u = np.empty((count, 4))
    u[:, :3] = direction_u
    u[:, 3] = _strata(count)
    return u


def _inside_segments(offset: np.ndarray) -> np.ndarray:
    """Offsets whose hero wavelengths all lie 1e-3 of a segment or more from the ends of their
    segment of the inverse CDF. The density is constant per segment: at a segment's end float32
    may take the neighbour's (the same wavelength, another weight, unbiased either way)."""
    position = (offset[:, None] + np.arange(4)) / 4 * colorimetry.HERO_SEGMENTS
    return np.all(np.abs(position - np.round(position)) > 1e-3, axis=-1)


# --------------------------------------------------------------------------- wavelengths


def test_hero_wavelengths_stratify_the_inverse_cdf():
    wavelength, scale = colorimetry.hero_wavelengths(np.array([[0.0, 0.37], [0.99, 1.0]]))
    assert wavelength.shape == scale.shape == (2, 2, colorimetry.HERO_WAVELENGTHS)
    low, high = colorimetry.WAVELENGTH_RANGE_NM
    assert np.all((wavelength >= low) & (wavelength <= high)) and np.all(scale > 0.0)
    assert np.all(np.diff(wavelength, axis=-1) > 0.0)
    # Wavelength k sits at the cumulative fraction (offset + k) / 4 of x + y + z.
    total = colorimetry.cumulative_xyz(wavelength).sum(axis=-1)
    fraction = total / colorimetry.cumulative_xyz(high).sum()
    offsets = np.array([[0.0, 0.37], [0.99, 1.0]])[..., None]
    expected = (offsets + np.arange(4)) / 4
    np.testing.assert_allclose(fraction, expected, atol=2e-3)


@pytest.mark.parametrize("spectrum", [lambda nm: np.ones_like(nm),
                                      lambda nm: 0.5 + 0.5 * np.sin(nm / 23.0)])
def test_hero_estimate_is_the_colour_integral(spectrum):
    wavelength, scale = colorimetry.hero_wavelengths(_strata(4096))
    xyz = np.einsum("sk,skc->c", spectrum(wavelength) * scale,
                    colorimetry.xyz_density(wavelength)) / 4096
    grid, weights = colorimetry.xyz_weights()
    np.testing.assert_allclose(xyz, spectrum(grid) @ weights, atol=2e-4)


@pytest.mark.parametrize("offset", [-0.1, 1.5, np.nan])
def test_hero_offsets_out_of_range_raise(offset):
    with pytest.raises(ValueError, match="offset"):
        colorimetry.hero_wavelengths([0.2, offset])


# --------------------------------------------------------------------------- the sampler


@pytest.mark.gpu
@pytest.mark.parametrize("name", STRUCTURES)
@pytest.mark.parametrize("method", ["single-reflection", "single-reflection-lut"])
def test_gpu_hero_is_the_spectral_kernel_at_the_hero_wavelengths(name, method):
    """The kernel's wavelengths and colour (colour/colorimetry_hero.wgsl) against
    colorimetry.hero_wavelengths
    and the numpy colour of the kernel's own spectral weights there."""
    s = STRUCTURES[name]
    u = np.random.default_rng(3).random((4096, 4))
    wi = unit_direction(35.0, 20.0)
    wo, weight, pdf = s.sample(wi, u, method=method, colour_method=HERO, backend="gpu")
    assert np.all(np.isfinite(weight)) and weight.shape == (4096, 3)
    wavelength, scale = colorimetry.hero_wavelengths(u[:, 3])
    wo_k, spectral, pdf_k = s.sample(wi, u[:, None, :3], wavelength, method=method,
                                     backend="gpu")
    np.testing.assert_allclose(wo, wo_k[:, 0], atol=1e-6)
    np.testing.assert_allclose(pdf, pdf_k[:, 0], rtol=1e-6)
    dirac = np.all(spectral == 1.0, axis=-1, keepdims=True)
    xyz = np.einsum("sk,skc->sc", spectral * scale, colorimetry.xyz_density(wavelength))
    expected = np.where(dirac, 1.0, colorimetry.xyz_to_linear_srgb(xyz))
    inside = _inside_segments(u[:, 3])
    assert inside.mean() > 0.99
    np.testing.assert_allclose(weight[inside], expected[inside], rtol=1e-3,
                               atol=1e-4 * np.abs(expected).max())


@pytest.mark.gpu
@pytest.mark.parametrize("name", STRUCTURES)
def test_gpu_matches_numpy(name):
    """Against the float64 model: float32 and the kernel's tables, linear between 1 nm nodes
    (measured: 2.5e-4 of the largest weight)."""
    s = STRUCTURES[name]
    u = np.random.default_rng(3).random((1024, 4))
    wi = unit_direction(35.0, 20.0)
    wo_n, w_n, _ = s.sample(wi, u, colour_method=HERO)
    wo_g, w_g, _ = s.sample(wi, u, colour_method=HERO, backend="gpu")
    # A u[0] at eq 35's boundary between the layer and the base may pick the other lobe in
    # float32 (tests/test_layered_gpu.py, PICK_MARGIN).
    same = np.all(np.abs(wo_g - wo_n) <= 1e-4, axis=-1)
    compared = same & _inside_segments(u[:, 3])
    assert compared.mean() >= 0.99
    np.testing.assert_allclose(w_g[compared], w_n[compared], atol=2e-3 * np.abs(w_n).max())


# (backend, strata, tolerance): the strata's quadrature error shrinks as 1 / count^2.
@pytest.mark.parametrize("backend, count, tolerance", [
    ("numpy", 1024, 6e-3), pytest.param("gpu", 4096, 2e-3, marks=pytest.mark.gpu)])
@pytest.mark.parametrize("name", STRUCTURES)
def test_unbiased_for_the_integrated_colour(name, backend, count, tolerance):
    s = STRUCTURES[name]
    wi = unit_direction(30.0)
    lit = 0
    for direction_u in ([0.9, 0.3, 0.6], [0.2, 0.7, 0.1], [0.99, 0.5, 0.5], [0.5, 0.4, 0.9]):
        _, hero, _ = s.sample(wi, _stratified_u(direction_u, count), colour_method=HERO,
                              backend=backend)
        _, integrated, _ = s.sample(wi, np.array(direction_u), backend=backend)
        lit += bool(np.any(integrated != 0.0))
        np.testing.assert_allclose(hero.mean(axis=0), integrated,
                                   atol=tolerance * max(1.0, np.abs(integrated).max()))
    assert lit >= 3  # rejected directions (weight 0 both ways) are not what this checks


@pytest.mark.parametrize("backend", ["numpy", pytest.param("gpu", marks=pytest.mark.gpu)])
def test_coating_reflection_stays_white(backend):
    s = STRUCTURES["coated"]
    wi = unit_direction(70.0)
    u = _stratified_u([0.0, 0.5, 0.5], 64)  # u[0] below the coating's Fresnel reflectance
    wo, weight, pdf = s.sample(wi, u, colour_method=HERO, backend=backend)
    np.testing.assert_array_equal(weight, 1.0)
    np.testing.assert_array_equal(pdf, 0.0)
    np.testing.assert_allclose(wo, np.broadcast_to(wi * [-1.0, -1.0, 1.0], wo.shape), atol=1e-6)


@pytest.mark.gpu
def test_albedo_agrees_with_the_integrated_colour():
    s = STRUCTURES["lambertian"]
    theta = np.radians([10.0, 60.0])
    hero = s.albedo(theta, colour_method=HERO, samples=8192, backend="gpu")
    integrated = s.albedo(theta, samples=8192, backend="gpu")
    assert hero.shape == (2, 3)
    np.testing.assert_allclose(hero, integrated, atol=0.01)


def test_refusals_name_the_parameter():
    s = STRUCTURES["absorbing"]
    wi = unit_direction(30.0)
    with pytest.raises(ValueError, match="sample"):
        s.brdf(wi, unit_direction(40.0, 180.0), colour_method=HERO)
    with pytest.raises(ValueError, match="wavelength_nm"):
        s.sample(wi, np.full(4, 0.5), 550.0, colour_method=HERO)
    with pytest.raises(ValueError, match="length 4"):
        s.sample(wi, np.full(3, 0.5), colour_method=HERO)
    with pytest.raises(ValueError, match="length 3"):
        s.sample(wi, np.full(4, 0.5))
    with pytest.raises(ValueError, match="u contains NaN"):
        s.sample(wi, [0.5, 0.5, 0.5, np.nan], colour_method=HERO)
    with pytest.raises(ValueError, match=r"u must be in \[0, 1\]"):
        s.sample(wi, [0.5, 0.5, 0.5, 1.5], colour_method=HERO)


@pytest.mark.gpu
def test_benchmark_refuses_hero_outside_sampling():
    from wgbragg.bsdf.layered import model_gpu as layered_gpu

    s = STRUCTURES["absorbing"]
    wi, wo = unit_direction(30.0), unit_direction(40.0, 180.0)
    with pytest.raises(ValueError, match="hero"):
        layered_gpu.benchmark(s, "brdf", wi, wo, colour_method=HERO)
    with pytest.raises(ValueError, match="trailing length 4"):
        layered_gpu.benchmark(s, "sample", wi, np.full(3, 0.5), colour_method=HERO)


def test_kernel_segments_match_the_table():
    """wgsl/colour/colorimetry_hero.wgsl hard-codes the table's segment count."""
    import re
    from pathlib import Path

    source = (Path(__file__).resolve().parents[1] / "wgsl/colour/colorimetry_hero.wgsl").read_text()
    segments = re.search(r"const HERO_SEGMENTS: u32 = (\d+)u;", source)
    assert segments and int(segments.group(1)) == colorimetry.HERO_SEGMENTS
    assert colorimetry.hero_inverse_cdf().shape == (colorimetry.HERO_SEGMENTS + 1,)
