"""The position-free Monte Carlo simulation of layered Bragg structures
(wgsl/bsdf/layered/simulation.wgsl)
against the single-reflection model (numpy, eq 34), analytic values and itself.

- Mode "single" estimates eq 34: deterministically with ballistic transmission (no variance,
  float32 and table interpolation only), stochastically with naive transmission (a visible
  normal per crossing, no tables), on the configurations of the paper's Fig. 7.
- Mode "all": both transmissions agree, every path adds to the single-reflection ones, and
  where no path can reflect twice both modes coincide.
- Energy: the albedo of the paths stays below 1, and an index-matched layer (R = 0) over a
  white Lambertian base, with and without a coating, has a closed form.
- Determinism for a seed, finiteness at the extremes, and the errors raised for bad input.

Filters are baked on the GPU, those of Fig. 7 at 0.125 degree: naive transmission estimates
eq 28 without discretisation, and at the default 0.25 degree the filter's quadrature leaves the
model off by up to 0.6% for configuration B at 70 degrees (its thick layers make T oscillate
quickly in theta_d), 10 standard errors at 2**18 paths; 0.125 degree brings that within the
noise.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from conftest import LAYERED_PAIRS, coating_internal_reflectance, cosine_mean
from conftest import paper_smape as smape
from conftest import unit_direction as direction

from wgbragg import BraggMirror, LayeredBragg, RoughBraggLayer, gpu
from wgbragg.bsdf.layered import simulation as layered_simulation
from wgbragg.bsdf.layered.model import coating_reflectance
from wgbragg.bsdf.microfacet import ggx_G1
from wgbragg.bsdf.transmission_filter import TransmissionFilter
from wgbragg.colour.colorimetry import linear_srgb_to_xyz, xyz_to_linear_srgb, xyz_weights

pytestmark = pytest.mark.gpu

A = BraggMirror(1.0, 1.5, 250.0, 250.0, 10)          # Fig. 7, configuration A (alpha 0.1)
B = BraggMirror(1.0, 1.5, 494.0, 494.0, 10)          # configuration B (alpha 0.05)
A_COATED = BraggMirror(1.35, 1.5, 250.0, 250.0, 10)  # A', under a smooth coating
WAVELENGTHS = np.array([420.0, 500.0, 580.0, 660.0])
PATHS = 2**16
SIGMAS = 4.0          # agreement of two estimates, in standard errors
F32_RTOL = 1e-3  # float32 kernel (Yeh, tables, directions) vs float64 numpy
SMAPE_MAX = 0.03
WHITE_ATOL = 3e-3     # the 1 nm sRGB white point: a flat spectrum gives 1 within this
FIG7_RESOLUTION_DEG = 0.125


PAIRS = LAYERED_PAIRS
WI = direction(PAIRS[:, 0])
WO = direction(PAIRS[:, 1], PAIRS[:, 2])


def within_sigmas(a, b, error):
    """Whether a and b agree within SIGMAS standard errors elementwise, beyond float32 (some
    estimates have no variance at all), and the worst ratio in standard errors."""
    excess = np.maximum(np.abs(a - b) - F32_RTOL * np.abs(b), 0.0)
    ratio = np.divide(excess, error, out=np.zeros_like(excess), where=excess > 0.0)
    ratio[(excess > 0.0) & (error == 0.0)] = np.inf
    return bool(np.all(ratio <= SIGMAS)), float(ratio.max())


@pytest.fixture(scope="module")
def filters():
    return {a: TransmissionFilter.bake(a) for a in (0.01, 0.1, 0.4, 1.0)}


@pytest.fixture(scope="module")
def structures():
    """The configurations of Fig. 7 with an absorbing base and a grey one (0.5), and A over B
    (where single-reflection paths cross a layer before and after reflecting)."""
    fine = {a: TransmissionFilter.bake(a, resolution_deg=FIG7_RESOLUTION_DEG)
            for a in (0.05, 0.1)}
    layers = {name: RoughBraggLayer(m, alpha, transmission_filter=fine[alpha])
              for name, m, alpha in (("A", A, 0.1), ("B", B, 0.05), ("A'", A_COATED, 0.1))}
    found = {f"{name}, base {albedo}": LayeredBragg([layer], base_albedo=albedo)
             for name, layer in layers.items() for albedo in (None, 0.5)}
    found["A over B, base None"] = LayeredBragg([layers["A"], layers["B"]])
    return found


@pytest.fixture(scope="module")
def reference(structures):
    """Eq 34 in float64 at every pair and wavelength, shape (pairs, wavelengths)."""
    return {name: s.brdf(WI[:, None], WO[:, None], WAVELENGTHS) for name, s in structures.items()}


# --------------------------------------------------------------------- single reflection


def test_single_ballistic_reproduces_the_model_without_variance(structures, reference):
    for name, s in structures.items():
        f, error = s.simulate(WI, WO, WAVELENGTHS, paths=256, mode="single",
                              return_error=True)
        assert np.all(error == 0.0), name
        np.testing.assert_allclose(f, reference[name], rtol=F32_RTOL, err_msg=name)


@pytest.mark.parametrize(("host", "base"), [(1.0, None), (1.33, 0.5)])
def test_single_reflection_of_a_layer_seen_from_another_medium(filters, host, base):
    """Appendix D (the jewel beetle's cuticle in air): the walk evaluated the mirror as if
    embedded in its n1, 0.0003 for 1.06 at 520 nm."""
    beetle = BraggMirror(1.59, 1.67, 81.6, 78.4, 8, host=host)
    s = LayeredBragg([RoughBraggLayer(beetle, 0.1, transmission_filter=filters[0.1])],
                     base_albedo=base)
    f = s.simulate(WI, WO, WAVELENGTHS, paths=256, mode="single")
    np.testing.assert_allclose(f, s.brdf(WI[:, None], WO[:, None], WAVELENGTHS),
                               rtol=F32_RTOL)


def test_single_naive_estimates_the_model(structures, reference):
    for name, s in structures.items():
        f, error = s.simulate(WI, WO, WAVELENGTHS, paths=PATHS, mode="single",
                              transmission="naive", seed=7, return_error=True)
        assert smape(f, reference[name]) <= SMAPE_MAX, name
        ok, worst = within_sigmas(f, reference[name], error)
        assert ok, f"{name}: {worst:.2f} standard errors"


def test_single_rgb_is_the_colour_of_the_spectral_model(structures):
    """Hero wavelengths against the 1 nm integral of the spectral eq 34, XYZ -> sRGB."""
    grid, weights = xyz_weights()
    for name in ("A, base 0.5", "A', base 0.5"):
        s = structures[name]
        expected = xyz_to_linear_srgb(s.brdf(WI[:, None], WO[:, None], grid) @ weights)
        f, error = s.simulate(WI, WO, paths=PATHS, mode="single", return_error=True)
        ok, worst = within_sigmas(f, expected, error)
        assert ok, f"{name}: {worst:.2f} standard errors"


# --------------------------------------------------------------------- all paths


def test_all_paths_ballistic_and_naive_agree(structures):
    for name in ("B, base 0.5", "A', base 0.5"):
        s = structures[name]
        ballistic, e1 = s.simulate(WI, WO, WAVELENGTHS, paths=PATHS, return_error=True)
        naive, e2 = s.simulate(WI, WO, WAVELENGTHS, paths=PATHS, transmission="naive",
                               return_error=True)
        ok, worst = within_sigmas(ballistic, naive, np.hypot(e1, e2))
        assert ok, f"{name}: {worst:.2f} standard errors"


def test_all_paths_add_to_the_single_reflection_ones(structures, reference):
    for name in ("A, base 0.5", "B, base 0.5", "A', base None", "A', base 0.5"):
        f, error = structures[name].simulate(WI, WO, WAVELENGTHS, paths=PATHS, return_error=True)
        assert np.all(f >= reference[name] * (1.0 - F32_RTOL) - SIGMAS * error), name
    # A bright base and a coating send many paths back: clearly more than eq 34 there.
    f = structures["A', base 0.5"].simulate(WI, WO, WAVELENGTHS, paths=PATHS)
    assert np.mean(f / reference["A', base 0.5"]) > 1.05


def test_one_layer_over_an_absorbing_base_reflects_once(structures):
    """No coating, absorbing base: a path that reflects on the layer leaves, one that crosses it
    is absorbed, so every path reflects at most once and both modes are the same estimate."""
    s = structures["A, base None"]
    single = s.simulate(WI, WO, WAVELENGTHS, paths=1024, mode="single")
    every, error = s.simulate(WI, WO, WAVELENGTHS, paths=1024, return_error=True)
    np.testing.assert_array_equal(error, 0.0)
    np.testing.assert_allclose(every, single, rtol=1e-6)
    for wavelength in (WAVELENGTHS, None):
        d1, w1 = s.simulate(WI, None, wavelength, paths=4096, seed=3)
        d2, w2 = s.simulate(WI, None, wavelength, paths=4096, seed=3, mode="single")
        np.testing.assert_array_equal(d1, d2)
        np.testing.assert_array_equal(w1, w2)


def test_one_bounce_is_the_single_reflection_estimate(structures, reference):
    """max_bounces=1 cuts every path after its first reflection: mode "all" then estimates
    what mode "single" does, by sampling instead of forcing transmissions."""
    name = "A', base 0.5"
    s = structures[name]
    f, error = s.simulate(WI, WO, WAVELENGTHS, paths=PATHS, max_bounces=1, return_error=True)
    ok, worst = within_sigmas(f, reference[name], error)
    assert ok, f"{worst:.2f} standard errors"
    _, every = s.simulate(WI[:3], None, WAVELENGTHS, paths=PATHS, max_bounces=1, seed=1)
    _, single = s.simulate(WI[:3], None, WAVELENGTHS, paths=PATHS, mode="single", seed=2)
    spread = np.hypot(every.std(axis=-2), single.std(axis=-2)) / math.sqrt(PATHS)
    ok, worst = within_sigmas(every.mean(axis=-2), single.mean(axis=-2), spread)
    assert ok, f"paths: {worst:.2f} standard errors"


# --------------------------------------------------------------------- energy


def test_albedo_of_the_paths_is_at_most_one(filters):
    """Furnace: bright base, a coating and two layers; luminance in RGB."""
    layers = [RoughBraggLayer(A_COATED, 0.1, transmission_filter=filters[0.1]),
              RoughBraggLayer(BraggMirror(1.35, 1.8, 150.0, 120.0, 30), 0.4,
                              transmission_filter=filters[0.4])]
    s = LayeredBragg(layers, base_albedo=1.0)
    wi = direction(np.array([0.0, 30.0, 60.0, 85.0]))
    for transmission in ("ballistic", "naive"):
        _, weights = s.simulate(wi, None, WAVELENGTHS, paths=PATHS,
                                transmission=transmission)
        mean, error = weights.mean(axis=-2), weights.std(axis=-2) / math.sqrt(PATHS)
        assert np.all(mean <= 1.0 + SIGMAS * error), transmission
        assert np.all(mean > 0.5)
        _, weights = s.simulate(wi, None, paths=PATHS, transmission=transmission)
        luminance = linear_srgb_to_xyz(weights)[..., 1]
        mean, error = luminance.mean(axis=-1), luminance.std(axis=-1) / math.sqrt(PATHS)
        assert np.all(mean <= 1.0 + SIGMAS * error), transmission


@pytest.mark.parametrize("n", [1.0, 1.35])
def test_index_matched_layer_over_a_white_base(filters, n):
    """R = 0: the layer only lets through G1 (eq 30) each way, and the base reflects all.

    From the base, a cosine-distributed path leaves with probability
    a = E[G1 (1 - F_in)] or comes back down to the base with b = E[G1^2 F_in] (F_in: the coating
    seen from inside, 0 without one), so, summing over base bounces,

        albedo  = F(wi) + (1 - F(wi)) G1(theta_i') a / (1 - b),
        f       = T_c(wi) T_c(wo) / n^2  G1(theta_i') G1(theta_o') / pi / (1 - b).
    """
    alpha = 0.4
    layer = RoughBraggLayer(BraggMirror(n, n, 200.0, 200.0, 10), alpha,
                            transmission_filter=filters[alpha])
    s = LayeredBragg([layer], base_albedo=1.0)

    def inside(t):
        return coating_internal_reflectance(t, n)

    a = cosine_mean(lambda t: ggx_G1(math.cos(t), alpha) * (1.0 - inside(t)))
    b = cosine_mean(lambda t: ggx_G1(math.cos(t), alpha) ** 2 * inside(t))
    wi, wo = WI[:4], WO[:4]
    ci, co = (np.sqrt(1.0 - (1.0 - w[:, 2] ** 2) / n**2) for w in (wi, wo))
    fresnel_i, fresnel_o = coating_reflectance(wi[:, 2], n), coating_reflectance(wo[:, 2], n)
    albedo = fresnel_i + (1.0 - fresnel_i) * ggx_G1(ci, alpha) * a / (1.0 - b)
    brdf = ((1.0 - fresnel_i) * (1.0 - fresnel_o) / n**2 * ggx_G1(ci, alpha)
            * ggx_G1(co, alpha) / np.pi / (1.0 - b))

    for transmission in ("ballistic", "naive"):
        f, error = s.simulate(wi, wo, WAVELENGTHS[:2], paths=PATHS, transmission=transmission,
                              return_error=True)
        # Without a coating, naive transmission gives f exactly (T = 1: the weight is G1);
        # the tables reproduce G1 to ~1e-4 (Appendix C), within F32_RTOL.
        ok, worst = within_sigmas(f, brdf[:, None], error)
        assert ok, f"{transmission}, f: {worst:.2f} standard errors"
        _, weights = s.simulate(wi, None, WAVELENGTHS[:2], paths=PATHS,
                                transmission=transmission)
        mean, spread = weights.mean(axis=-2), weights.std(axis=-2) / math.sqrt(PATHS)
        ok, worst = within_sigmas(mean, albedo[:, None], spread)
        assert ok, f"{transmission}, albedo: {worst:.2f} standard errors"
    # RGB: a flat spectrum is white.
    _, weights = s.simulate(wi, None, paths=PATHS)
    mean, spread = weights.mean(axis=-2), weights.std(axis=-2) / math.sqrt(PATHS)
    assert np.all(np.abs(mean - albedo[:, None]) <= SIGMAS * spread + WHITE_ATOL)


# --------------------------------------------------------------------- robustness


def test_deterministic_for_a_seed(structures, monkeypatch):
    s = structures["A', base 0.5"]
    first = s.simulate(WI, WO, paths=2048, seed=11)
    np.testing.assert_array_equal(first, s.simulate(WI, WO, paths=2048, seed=11))
    # One query per dispatch, its batches over several: each path keeps its random numbers
    # (the statistics are combined in another order).
    monkeypatch.setattr(layered_simulation, "_MAX_INVOCATIONS", 32)
    np.testing.assert_allclose(first, s.simulate(WI, WO, paths=2048, seed=11), rtol=1e-12)
    monkeypatch.undo()
    assert not np.array_equal(first, s.simulate(WI, WO, paths=2048, seed=12))
    d1, w1 = s.simulate(WI[:2], None, WAVELENGTHS, paths=512, seed=5)
    d2, w2 = s.simulate(WI[:2], None, WAVELENGTHS, paths=512, seed=5)
    np.testing.assert_array_equal(d1, d2)
    np.testing.assert_array_equal(w1, w2)
    assert not np.array_equal(w1, s.simulate(WI[:2], None, WAVELENGTHS, paths=512, seed=6)[1])


def test_shapes_and_exit_directions(structures):
    s = structures["A', base 0.5"]
    f = s.simulate(WI[:, None], WO[None, :3], paths=64)
    assert f.shape == (len(WI), 3, 3)
    assert s.simulate(WI[0], WO[0], WAVELENGTHS[:3], paths=64).shape == (3,)
    # Below the horizon, wo gives 0 as LayeredBragg.brdf does.
    below = s.simulate(WI[0], direction(100.0), WAVELENGTHS, paths=64)
    np.testing.assert_array_equal(below, 0.0)
    directions, weights = s.simulate(WI[:2], None, WAVELENGTHS[:3], paths=1000)
    assert directions.shape == (2, 1000, 3) and weights.shape == (2, 1000, 3)
    left = np.any(weights != 0.0, axis=-1)
    np.testing.assert_allclose(np.linalg.norm(directions[left], axis=-1), 1.0, atol=1e-5)
    assert np.all(directions[left][:, 2] >= 0.0)
    np.testing.assert_array_equal(directions[~left], 0.0)
    # The coating's Dirac reflection: weight 1 in the mirror direction.
    mirror = WI[:2] * np.array([-1.0, -1.0, 1.0])
    dirac = np.all(np.abs(directions - mirror[:, None]) < 1e-6, axis=-1)
    fraction = coating_reflectance(WI[:2, 2], 1.35)
    assert np.all(np.abs(dirac.mean(axis=-1) - fraction) < 5.0 * np.sqrt(fraction / 1000))
    np.testing.assert_array_equal(weights[dirac], 1.0)


def test_grazing_incidence_without_a_coating(structures):
    """At 89.999 degrees no path may slip through horizontally: one layer over an absorbing
    base reflects once, like the model's albedo (numpy, Sobol samples)."""
    s = structures["A, base None"]
    theta = np.radians([89.9, 89.999])
    _, weights = s.simulate(direction(np.degrees(theta)), None, WAVELENGTHS[:2], paths=PATHS)
    expected = s.albedo(theta[:, None], WAVELENGTHS[:2], samples=2**14)
    np.testing.assert_allclose(weights.mean(axis=-2), expected, atol=0.01)


@pytest.mark.parametrize("alpha", [0.01, 1.0])
@pytest.mark.parametrize("periods", [1, 10**6])
def test_finite_at_the_extremes(filters, alpha, periods):
    m = BraggMirror(1.35, 1.6, 200.0, 180.0, periods)
    layer = RoughBraggLayer(m, alpha, transmission_filter=filters[alpha])
    s = LayeredBragg([layer, layer], base_albedo=0.8)
    wi = direction(np.array([0.0, 45.0, 89.9, 89.999]))
    wo = direction(np.array([89.999, 30.0, 0.0, 89.9]), 180.0)
    for transmission in ("ballistic", "naive"):
        for wavelength in (WAVELENGTHS, None):
            f, error = s.simulate(wi, wo, wavelength, paths=1024, transmission=transmission,
                                  return_error=True)
            assert np.all(np.isfinite(f)) and np.all(np.isfinite(error))
            if wavelength is not None:  # sRGB may leave the gamut, spectra may not
                assert np.all(f >= 0.0)
            directions, weights = s.simulate(wi, None, wavelength, paths=1024,
                                             transmission=transmission)
            assert np.all(np.isfinite(directions)) and np.all(np.isfinite(weights))


@pytest.mark.parametrize(("arguments", "name"), [
    ({"paths": 0}, "paths"),
    ({"paths": 2.5}, "paths"),
    ({"mode": "double"}, "mode"),
    ({"transmission": "ballistics"}, "transmission"),
    ({"wavelength_nm": [350.0]}, "wavelength_nm"),
    ({"wavelength_nm": [[500.0]]}, "wavelength_nm"),
    ({"wavelength_nm": np.linspace(400.0, 700.0, 65)}, "wavelength_nm"),
    ({"wavelength_nm": np.linspace(400.0, 700.0, 5), "wo": None}, "wavelength_nm"),
    ({"wi": direction(95.0)}, "wi"),
    ({"wi": [0.0, 0.0]}, "wi"),
    ({"wi": [0.0, 0.6, 0.6]}, "wi"),
    ({"wo": np.tile(direction(10.0), (3, 1)), "wi": np.tile(direction(10.0), (2, 1))}, "wi"),
    ({"wo": [1.0, 0.0]}, "wo"),
    ({"seed": -1}, "seed"),
    ({"max_bounces": 0}, "max_bounces"),
    ({"return_error": True, "wo": None}, "return_error"),
])
def test_bad_arguments_raise(structures, arguments, name):
    call = {"wi": direction(20.0), "wo": direction(30.0, 180.0), **arguments}
    with pytest.raises(ValueError, match=name):
        structures["A, base None"].simulate(**call)


def test_max_bounces_beyond_the_bounce_limit_is_refused(structures):
    """One layer: 1023 reflections under Mesa 22's loop budget, 32767 without a budget."""
    most = layered_simulation.bounce_limit(1)
    with pytest.raises(ValueError, match=rf"max_bounces must be an integer in \[1, {most}\]"):
        structures["A, base None"].simulate(direction(20.0), direction(30.0, 180.0),
                                            max_bounces=most + 1)


@pytest.mark.parametrize("wavelength_nm", [None, [450.0, 550.0, 650.0]])
def test_no_queries_give_empty_results(structures, wavelength_nm):
    """As brdf and sample do: shapes of the same call with an empty leading axis."""
    s = structures["A, base None"]
    channels = 3
    directions, weights = s.simulate(np.zeros((0, 3)), paths=5, wavelength_nm=wavelength_nm)
    assert directions.shape == (0, 5, 3) and weights.shape == (0, 5, channels)
    estimate = s.simulate(np.zeros((2, 0, 3)), np.zeros((2, 0, 3)), paths=4,
                          wavelength_nm=wavelength_nm)
    assert estimate.shape == (2, 0, channels)
    estimate, error = s.simulate(np.zeros((0, 3)), np.zeros((0, 3)), paths=4,
                                 wavelength_nm=wavelength_nm, return_error=True)
    assert estimate.shape == error.shape == (0, channels)


# --------------------------------------------------------------------- the loop budget
# Mesa 22's llvmpipe ends an invocation's loops after 65536 iterations (wgbragg.gpu.loops);
# Mesa 25's has no budget, and the limits below are then a dispatch's time.


def _trap(filters, layers):
    """Long walks: transparent layers (R = 0, alpha 0.01: G1 ~ 1, so roulette spares them)
    between a white base and a coating of index 10, which reflects nearly everything back."""
    layer = RoughBraggLayer(BraggMirror(10.0, 10.0, 200.0, 200.0, 10), 0.01,
                            transmission_filter=filters[0.01])
    return LayeredBragg([layer] * layers, base_albedo=1.0)


def test_long_walks_fit_in_an_invocation(filters, monkeypatch):
    """64 paths of up to 64 reflections through 4 layers ran in one invocation, and Mesa 22's
    llvmpipe ended the later ones early: 5 % off in RGB. The paths are the same however they are
    grouped into invocations, so one path per invocation is the reference."""
    s = _trap(filters, 4)
    wi, wo = direction(np.array([10.0, 50.0])), direction(np.array([20.0, 70.0]), 180.0)
    f = s.simulate(wi, wo, paths=4096, transmission="naive")
    monkeypatch.setattr(layered_simulation, "_PATHS_PER_INVOCATION", 1)
    np.testing.assert_allclose(f, s.simulate(wi, wo, paths=4096, transmission="naive"),
                               rtol=1e-6)


def test_max_bounces_is_bounded_by_the_loop_budget(filters):
    """233 reflections through 4 layers and 62 layers under Mesa 22's budget; without a
    budget 7488 and 360, the bounds of a dispatch's time."""
    from wgbragg import gpu

    planned = gpu.planned_loop_iterations()
    most_layers = layered_simulation.max_layers()
    for layers in (1, 4, 8, most_layers):
        most = layered_simulation.bounce_limit(layers)
        assert most >= 1
        assert layered_simulation.walk_iterations(layers, most) <= planned
        assert layered_simulation.walk_iterations(layers, most + 1) > planned
    assert layered_simulation.bounce_limit(most_layers + 1) == 0
    most = layered_simulation.bounce_limit(4)
    if gpu.loop_budget() is None:
        assert (most, most_layers) == (7488, 360)
    elif gpu.loop_budget() == 65536:  # Mesa 22's
        assert (most, most_layers) == (233, 62)
    with pytest.raises(ValueError, match=rf"max_bounces must be an integer in \[1, {most}\]"):
        _trap(filters, 4).simulate(direction(10.0), direction(20.0), max_bounces=most + 1)
    with pytest.raises(ValueError, match=rf"structure: .*1 to {most_layers} rough layers.*got "
                                         rf"{most_layers + 1}"):
        _trap(filters, most_layers + 1).simulate(direction(10.0), direction(20.0),
                                                 max_bounces=1)


@pytest.mark.parametrize("wo", [direction(20.0), None])
def test_walks_cut_short_are_refused(filters, monkeypatch, wo):
    """Should the plan of walk_iterations be wrong, the kernel's report refuses the result
    where the device has a loop budget. Without one the long walks are run: the paths are
    the same however they are grouped into invocations, so one path per invocation is the
    reference (float32 statistics: 1e-6)."""
    from wgbragg import gpu

    monkeypatch.setattr(layered_simulation, "walk_iterations", lambda layers, bounces: 1)
    monkeypatch.setattr(layered_simulation, "_PARTICLES_PER_INVOCATION", 64)
    trap = _trap(filters, 4)

    def walks():
        return trap.simulate(direction(10.0), wo, paths=2048, transmission="naive",
                             max_bounces=1000)

    if gpu.loop_budget() is not None:
        with pytest.raises(gpu.LoopBudgetError, match="4 layers with max_bounces=1000"):
            walks()
        return
    grouped = walks()
    monkeypatch.setattr(layered_simulation, "_PATHS_PER_INVOCATION", 1)
    monkeypatch.setattr(layered_simulation, "_PARTICLES_PER_INVOCATION", 1)
    one_each = walks()
    if wo is None:  # each path's exit direction and weight
        for a, b in zip(grouped, one_each, strict=True):
            np.testing.assert_allclose(a, b, rtol=1e-6)
    else:  # the BRDF estimate
        np.testing.assert_allclose(grouped, one_each, rtol=1e-6)


def test_single_ballistic_on_different_grids_and_several_groups(filters):
    """Two layers on filters of different resolutions (0.25 and 1 degree) over a grey base and
    nine wavelengths (three groups of four, the last padded): each layer's table and each
    group's columns are read where they lie."""
    coarse = TransmissionFilter.bake(0.4, resolution_deg=1.0, psi_samples=128, backend="numpy")
    s = LayeredBragg([RoughBraggLayer(A, 0.1, transmission_filter=filters[0.1]),
                      RoughBraggLayer(B, 0.4, transmission_filter=coarse)], base_albedo=0.5)
    wavelength = np.linspace(400.0, 700.0, 9)
    f, error = s.simulate(WI, WO, wavelength, paths=256, mode="single", return_error=True)
    assert np.all(error == 0.0)
    np.testing.assert_allclose(f, s.brdf(WI[:, None], WO[:, None], wavelength), rtol=F32_RTOL)


def test_plain_rgb_tables_give_the_quads_results(structures, monkeypatch):
    """Past gpu.BILINEAR_QUADS_MAX_BYTES the walk reads the plain 1 nm tables, four loads per
    lookup: the same arithmetic and random numbers, so the same estimates."""
    with_quads = dataclasses.replace(structures["A over B, base None"])  # fresh caches
    expected = with_quads.simulate(WI, WO, paths=64, mode="single", seed=3)
    assert layered_simulation._layers(with_quads, None, True)[2] is True
    monkeypatch.setattr(gpu.layouts, "BILINEAR_QUADS_MAX_BYTES", 0)
    plain = dataclasses.replace(structures["A over B, base None"])
    got = plain.simulate(WI, WO, paths=64, mode="single", seed=3)
    assert layered_simulation._layers(plain, None, True)[2] is False
    np.testing.assert_allclose(got, expected, rtol=1e-6, atol=1e-7)
    assert np.all(np.isfinite(expected)) and np.any(expected != 0.0)



@pytest.mark.parametrize("structure", [object(), BraggMirror(1.0, 1.5, 250.0, 250.0, 10)])
def test_simulate_refuses_what_is_not_a_layered_structure(structure):
    with pytest.raises(ValueError, match=r"structure must be a LayeredBragg"):
        layered_simulation.simulate(structure, [0.0, 0.0, 1.0], paths=16)
