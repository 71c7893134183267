"""Fitting a rough Bragg layer (``fit_spectrum("rough", ...)``) to its in-plane BRDF: the
population model against the library's float64 ``LayeredBragg.brdf``, recovery of alpha and
the mirror from noiseless and noisy goniometric data, and validation by message."""

from __future__ import annotations

import numpy as np
import pytest

from wgbragg import BraggMirror, LayeredBragg, RoughBraggLayer
from wgbragg.design import design_colour, fit_spectrum
from wgbragg.design.families import parameter_space
from wgbragg.design.fit import population_evaluator
from wgbragg.design.rough import in_plane_directions

pytestmark = pytest.mark.gpu

WAVELENGTH = np.linspace(400.0, 750.0, 36)[:, None, None]
THETA_I = np.radians([15.0, 35.0, 55.0])[:, None]
THETA_O = THETA_I + np.radians([-10.0, 0.0, 10.0])  # specular and 10 degrees either side
TRUTH = RoughBraggLayer(BraggMirror(1.0, 1.55, 130.0, 85.0, 9), 0.13)


def _brdf(layer, wavelength=WAVELENGTH, theta_i=THETA_I, theta_o=THETA_O):
    wi, wo = in_plane_directions(theta_i, theta_o)
    return LayeredBragg([layer]).brdf(wi, wo, wavelength)


def test_population_brdf_is_the_layered_model():
    """Under a coating (host 1.4 = n1), and a mirror seen from air (n1 1.5, host 1), on both
    backends, including a detector on the light's side."""
    wl = np.linspace(420.0, 720.0, 7)[:, None]
    ti, to = np.radians([0.0, 20.0, 50.0, 70.0]), np.radians([5.0, -30.0, 50.0, 40.0])
    shape = np.broadcast_shapes(wl.shape, ti.shape)
    flat_wl = np.broadcast_to(wl, shape).ravel()
    angles = np.stack([np.broadcast_to(ti, shape).ravel(), np.broadcast_to(to, shape).ravel()])
    for host, n1 in ((1.4, 1.4), (1.0, 1.5)):
        space = parameter_space("rough", fixed={"host": host, "n1": n1})
        layers = [RoughBraggLayer(BraggMirror(n1, 1.8, 110.0, 70.0, 6, host=host), 0.2),
                  RoughBraggLayer(BraggMirror(n1, 1.3, 150.0, 90.0, 3, host=host), 0.05)]
        x = np.array([space.vector(layer) for layer in layers])
        cpu = population_evaluator(space, flat_wl, angles, "unpolarized", "numpy")(x)
        gpu = population_evaluator(space, flat_wl, angles, "unpolarized", "gpu")(x)
        for k, layer in enumerate(layers):
            assert space.structure(x[k]) == layer
            expected = _brdf(layer, wl, ti, to).ravel()
            np.testing.assert_allclose(cpu[k], expected, rtol=1e-12, atol=1e-14)
            np.testing.assert_allclose(gpu[k], expected, rtol=2e-3, atol=1e-5)
    held = parameter_space(RoughBraggLayer, fixed={"alpha": 0.3, "n1": 1.0})
    assert held.names == ("n2", "d1", "d2", "N")
    assert held.structure(held.vector(TRUTH.mirror)).alpha == 0.3


def test_alpha_and_the_mirror_are_recovered_from_noiseless_data():
    measured = _brdf(TRUTH)
    result = fit_spectrum(RoughBraggLayer, WAVELENGTH, THETA_I, measured, fixed={"n1": 1.0},
                          bounds={"N": (2, 16)}, theta_out=THETA_O, seed=1, generations=40)
    p = result.parameters
    assert isinstance(result.structure, RoughBraggLayer) and p["N"] == 9 and p["host"] == 1.0
    assert p["alpha"] == pytest.approx(0.13, rel=1e-6)
    for name in ("n2", "d1", "d2"):
        assert p[name] == pytest.approx(getattr(TRUTH.mirror, name), rel=1e-6), name
    assert result.rms < 1e-8 * measured.max()
    assert set(result.standard_errors) == {"n2", "d1", "d2", "alpha"}


def test_noisy_data_recover_alpha_within_its_standard_error():
    measured = _brdf(TRUTH)
    rng = np.random.default_rng(0)
    noisy = measured * (1.0 + 0.02 * rng.standard_normal(measured.shape))  # 2 % of reading
    result = fit_spectrum("rough", WAVELENGTH, THETA_I, noisy, fixed={"n1": 1.0},
                          bounds={"N": (2, 16)}, theta_out=THETA_O, seed=1, generations=40)
    assert result.parameters["N"] == 9
    for name, true in (("alpha", 0.13), ("n2", 1.55), ("d1", 130.0), ("d2", 85.0)):
        error = result.standard_errors[name]
        assert 0 < error < 0.02 * true, name
        assert abs(result.parameters[name] - true) < 3 * error, name


def test_rough_options_are_refused_by_name():
    data = np.ones((36, 3, 3))
    with pytest.raises(ValueError, match="host of a rough layer must be fixed"):
        fit_spectrum("rough", WAVELENGTH, THETA_I, data, bounds={"host": (1.0, 1.5)})
    with pytest.raises(ValueError, match="polarization must be 'unpolarized'"):
        fit_spectrum("rough", WAVELENGTH, THETA_I, data, polarization="s", theta_out=THETA_O)
    with pytest.raises(ValueError, match="theta_out must be finite angles"):
        fit_spectrum("rough", WAVELENGTH, THETA_I, data, theta_out=THETA_O + 2.0)
    with pytest.raises(ValueError, match=r"broadcast\(wavelength_nm, theta, theta_out\)"):
        fit_spectrum("rough", WAVELENGTH, THETA_I, data[:, :, :2], theta_out=THETA_O)
    with pytest.raises(ValueError, match="theta_out applies to the rough family"):
        fit_spectrum("bragg", WAVELENGTH[..., 0], THETA_I[:, 0], data[..., 0],
                     theta_out=THETA_I[:, 0])
    with pytest.raises(ValueError, match=r"bounds\['alpha'\] must satisfy 0.01"):
        fit_spectrum("rough", WAVELENGTH, THETA_I, data, bounds={"alpha": (0.0, 0.5)},
                     theta_out=THETA_O)
    with pytest.raises(ValueError, match="design_colour designs 'bragg' or 'film'"):
        design_colour(["#d4af37"], [0.0], "rough")
