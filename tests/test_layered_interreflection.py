"""``LayeredBragg(base_interreflection=True)``: the Lambertian base's light sent back down by the
stack, summed in closed form, against the series it sums, the closed form of an index-matched
layer (which the simulation also reproduces, tests/test_layered_simulation.py), the all-paths
simulation of the paper's Fig. 7 configurations, energy conservation and the GPU kernel.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from conftest import LAYERED_PAIRS, coating_internal_reflectance, cosine_mean
from conftest import paper_smape as smape
from conftest import unit_direction as direction

from wgbragg import BraggMirror, LayeredBragg, RoughBraggLayer
from wgbragg.bsdf.layered.model import coating_reflectance
from wgbragg.bsdf.microfacet import ggx_G1
from wgbragg.bsdf.transmission_filter import TransmissionFilter

A = BraggMirror(1.0, 1.5, 250.0, 250.0, 10)          # Fig. 7, configuration A (alpha 0.1)
B = BraggMirror(1.0, 1.5, 494.0, 494.0, 10)          # configuration B (alpha 0.05)
A_COATED = BraggMirror(1.35, 1.5, 250.0, 250.0, 10)  # A', under a smooth coating
WAVELENGTHS = np.array([420.0, 500.0, 580.0, 660.0])
TABLE_RTOL = 2e-3  # the transmissivity tables reproduce G1 to ~1e-4, theta rows 0.25 degree


PAIRS = LAYERED_PAIRS
WI = direction(PAIRS[:, 0])
WO = direction(PAIRS[:, 1], PAIRS[:, 2])


@pytest.fixture(scope="module")
def filters():
    return {a: TransmissionFilter.bake(a) for a in (0.05, 0.1, 0.4)}


def structure(mirror, alpha, albedo, filters, interreflection=True):
    layer = RoughBraggLayer(mirror, alpha, transmission_filter=filters[alpha])
    return LayeredBragg([layer], base_albedo=albedo, base_interreflection=interreflection)


@pytest.mark.parametrize("value", [1, "yes", None, np.bool_(True)])
def test_the_flag_must_be_a_bool(value):
    with pytest.raises(ValueError, match="base_interreflection"):
        LayeredBragg([RoughBraggLayer(A, 0.1)], base_albedo=0.5, base_interreflection=value)


def test_an_absorbing_base_is_unchanged(filters):
    plain = structure(A, 0.1, None, filters, interreflection=False)
    summed = structure(A, 0.1, None, filters)
    np.testing.assert_array_equal(summed.brdf(WI[:, None], WO[:, None], WAVELENGTHS),
                                  plain.brdf(WI[:, None], WO[:, None], WAVELENGTHS))
    np.testing.assert_array_equal(summed.brdf(WI, WO, colour_method="averaged"),
                                  plain.brdf(WI, WO, colour_method="averaged"))


@pytest.mark.parametrize("n", [1.0, 1.35])
def test_index_matched_layer_returns_the_closed_form(filters, n):
    """R = 0: only the coating sends light back, b = E[G1^2 F_in] (G1 each way), and a white
    base's series is f = T_c T_c / n^2 G1 G1 / pi / (1 - b): what the all-paths simulation
    gives (tests/test_layered_simulation.py, test_index_matched_layer_over_a_white_base)."""
    alpha = 0.4
    s = structure(BraggMirror(n, n, 200.0, 200.0, 10), alpha, 1.0, filters)
    b = cosine_mean(lambda t: ggx_G1(math.cos(t), alpha) ** 2 * coating_internal_reflectance(t, n))
    returned = s.base_return(WAVELENGTHS)
    assert returned.shape == WAVELENGTHS.shape
    np.testing.assert_allclose(returned, b, atol=1e-3)
    ci, co = (np.sqrt(1.0 - (1.0 - w[:, 2] ** 2) / n**2) for w in (WI, WO))
    brdf = ((1.0 - coating_reflectance(WI[:, 2], n)) * (1.0 - coating_reflectance(WO[:, 2], n))
            / n**2 * ggx_G1(ci, alpha) * ggx_G1(co, alpha) / np.pi / (1.0 - b))
    f = s.brdf(WI[:, None], WO[:, None], WAVELENGTHS)
    np.testing.assert_allclose(f, np.broadcast_to(brdf[:, None], f.shape), rtol=TABLE_RTOL)


@pytest.mark.parametrize("albedo", [0.5, 1.0, (0.9, 0.2, 0.4),
                                    (np.array([360.0, 600.0, 830.0]), np.array([0.1, 0.9, 0.3]))])
def test_the_base_term_is_the_geometric_series(filters, albedo):
    """Per wavelength, the base's term of eq 34 times 1 / (1 - rho R_down)."""
    summed = structure(A_COATED, 0.1, albedo, filters)
    plain = dataclasses.replace(summed, base_interreflection=False)
    layers_only = LayeredBragg(summed.layers)
    wi, wo = WI[:, None], WO[:, None]
    base_plain = plain.brdf(wi, wo, WAVELENGTHS) - layers_only.brdf(wi, wo, WAVELENGTHS)
    base_summed = summed.brdf(wi, wo, WAVELENGTHS) - layers_only.brdf(wi, wo, WAVELENGTHS)
    rho = summed.base_spectrum(WAVELENGTHS)
    series = 1.0 / (1.0 - rho * summed.base_return(WAVELENGTHS))
    np.testing.assert_allclose(base_summed, base_plain * series, rtol=1e-9)
    assert np.all(series > 1.0)


def test_base_return_is_a_fraction_and_grows_with_the_layers(filters):
    one = structure(A, 0.1, 0.5, filters)
    returned = one.base_return()
    assert returned.shape == (471,) and np.all((returned >= 0.0) & (returned <= 1.0))
    coated = structure(A_COATED, 0.1, 0.5, filters).base_return()
    two = LayeredBragg([one.layers[0], RoughBraggLayer(B, 0.05,
                                                       transmission_filter=filters[0.05])],
                       base_albedo=0.5).base_return()
    assert np.all(two >= returned - 1e-12) and np.mean(two) > np.mean(returned) + 0.05
    assert np.mean(coated) > np.mean(returned) + 0.1  # the coating's internal reflection
    with pytest.raises(ValueError, match="wavelength"):
        one.base_return([500.0, np.nan])


@pytest.mark.gpu
def test_a_white_base_conserves_energy(filters):
    """Albedo <= 1 at every incidence under a coating, where the series is longest."""
    s = structure(A_COATED, 0.1, 1.0, filters)
    theta = np.radians(np.arange(0.0, 89.0, 8.0))
    spectral = s.albedo(theta[:, None], WAVELENGTHS[None, :], samples=2048)
    rgb = s.albedo(theta, samples=2048, backend="gpu", colour_method="averaged")
    assert np.all(spectral <= 1.0 + 0.01) and np.all(rgb <= 1.0 + 0.01)
    plain = dataclasses.replace(s, base_interreflection=False)
    assert np.all(spectral > plain.albedo(theta[:, None], WAVELENGTHS[None, :], samples=2048))


@pytest.mark.gpu
@pytest.mark.parametrize(("name", "bound"), [("A", 0.01), ("B", 0.01), ("A'", 0.03)])
def test_closer_to_all_paths_than_single_reflection(filters, name, bound):
    """Over a grey base (0.5), against the all-paths simulation's next-event estimate at fixed
    directions: the summed model's SMAPE is a fraction of eq 34's (measured 0.002 / 0.001 /
    0.022 against 0.073 / 0.080 / 0.230; under the coating the light it reflects back is not
    Lambertian, which the series assumes)."""
    mirror, alpha = {"A": (A, 0.1), "B": (B, 0.05), "A'": (A_COATED, 0.1)}[name]
    s = structure(mirror, alpha, 0.5, filters)
    plain = dataclasses.replace(s, base_interreflection=False)
    every = s.simulate(WI, WO, WAVELENGTHS, paths=2**16, seed=3)
    summed_error = smape(s.brdf(WI[:, None], WO[:, None], WAVELENGTHS), every)
    plain_error = smape(plain.brdf(WI[:, None], WO[:, None], WAVELENGTHS), every)
    assert summed_error <= bound and summed_error < 0.2 * plain_error, (summed_error,
                                                                        plain_error)


@pytest.mark.gpu
@pytest.mark.parametrize("method", ["single-reflection", "single-reflection-lut"])
def test_gpu_twin(filters, method):
    s = structure(A_COATED, 0.1, (0.9, 0.2, 0.4), filters)
    wi, wo = WI[:, None], WO[:, None]
    np.testing.assert_allclose(s.brdf(wi, wo, WAVELENGTHS, method=method, backend="gpu"),
                               s.brdf(wi, wo, WAVELENGTHS, method=method), rtol=3e-3)
    # Factored RGB (the LUT reads the same base colour; its numpy colour table takes seconds).
    np.testing.assert_allclose(
        s.brdf(WI, WO, backend="gpu", colour_method="averaged"),
        s.brdf(WI, WO, colour_method="averaged"), rtol=3e-3, atol=1e-5)
