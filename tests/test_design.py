"""Inverse design (wgbragg.design): the population kernels against their float64 twin, fits
that recover known structures and whose standard errors cover the truth, colour design whose
dE2000 is recomputed independently, tolerance, and validation by message."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from wgbragg import BraggMirror, ThinFilm
from wgbragg.colour.colorimetry import delta_e_2000, xyz_to_lab, xyz_to_linear_srgb
from wgbragg.design import design_colour, fit_spectrum, population, population_gpu, tolerance
from wgbragg.design.colour_design import pareto_front, search_xyz
from wgbragg.design.colour_targets import grid_xyz_weights, parse_targets
from wgbragg.design.families import parameter_space

pytestmark = pytest.mark.gpu

THETA = np.radians([0.0, 30.0, 60.0])
WAVELENGTH = np.linspace(400.0, 750.0, 48)[:, None]


def _light(count=37):
    wl = np.linspace(380.0, 780.0, count)
    return np.repeat(wl, 3), np.tile(THETA, count)


def test_population_gpu_matches_numpy():
    """Both entry points (mirrors with and without a host interface, a bulk member; films over
    a constant and over a dispersive base) against the float64 twin, member by member."""
    rng = np.random.default_rng(3)
    wl, th = _light()
    space = parameter_space("bragg", bounds={"host": (1.0, 1.6), "N": (1, 20)})
    x = space.lower + rng.random((24, space.size)) * (space.upper - space.lower)
    x[0, space.names.index("n2")] = x[0, space.names.index("n1")]  # bulk: no n2 layer
    members = space.members(x)
    members["host"][:8] = members["n1"][:8]  # matched hosts
    gpu_r = population_gpu.population_reflectance("bragg", members, wl, th)
    cpu_r = population.population_reflectance("bragg", members, wl, th)
    assert gpu_r.shape == (24, wl.size)
    np.testing.assert_allclose(gpu_r, cpu_r, atol=3e-4)
    # Members alone through the public API (a matched bulk one, one under another host).
    for i in (0, 9):
        m = BraggMirror(*(members[k][i] for k in ("n1", "n2", "d1", "d2")),
                        int(members["N"][i]), host=members["host"][i])
        np.testing.assert_allclose(cpu_r[i], m.reflectance(wl, th), rtol=1e-12, atol=1e-15)
    assert np.all(cpu_r[0] == 0.0)  # matched host, n2 = n1: nothing reflects
    for fixed, bounds in (({"base": "Au"}, None), ({}, {"n_base": (1.2, 2.0),
                                                        "k_base": (0.0, 2.0)})):
        space = parameter_space("film", bounds=bounds, fixed=fixed)
        x = space.lower + rng.random((16, space.size)) * (space.upper - space.lower)
        base = None if space.base is None else space.base(wl)
        members = space.members(x)
        for pol in ("s", "unpolarized"):
            gpu_r = population_gpu.population_reflectance("film", members, wl, th, pol, base)
            cpu_r = population.population_reflectance("film", members, wl, th, pol, base)
            np.testing.assert_allclose(gpu_r, cpu_r, atol=2e-5)


def test_population_colour_gpu_matches_numpy():
    """The "averaged" colour of a population (matched and unmatched hosts, a bulk member, N
    from 1 to 30, beyond the critical angle of n2 and grazing) against the float64 twin, and
    the twin against the public ``xyz(method="averaged")`` member by member."""
    rng = np.random.default_rng(4)
    space = parameter_space("bragg", bounds={"host": (1.0, 1.6), "N": (1, 30)})
    x = space.lower + rng.random((20, space.size)) * (space.upper - space.lower)
    x[0, space.names.index("n2")] = x[0, space.names.index("n1")]  # bulk: no n2 layer
    members = space.members(x)
    members["host"][:10] = members["n1"][:10]
    theta = np.radians([0.0, 25.0, 50.0, 75.0, 90.0])
    gpu_xyz = population_gpu.population_xyz(members, theta)
    cpu_xyz = population.population_xyz(members, theta)
    assert gpu_xyz.shape == cpu_xyz.shape == (20, 5, 3)
    np.testing.assert_allclose(gpu_xyz, cpu_xyz, atol=2e-4)
    for i in (0, 3, 12):
        m = BraggMirror(*(members[k][i] for k in ("n1", "n2", "d1", "d2")),
                        int(members["N"][i]), host=members["host"][i])
        np.testing.assert_allclose(cpu_xyz[i], m.xyz(theta, method="averaged"), rtol=1e-12,
                                   atol=1e-15)
        np.testing.assert_allclose(m.xyz(theta, method="averaged", backend="gpu"), gpu_xyz[i],
                                   atol=2e-5)


def test_colours_whose_loops_were_cut_come_back_as_nan(monkeypatch):
    """The loop-cut flag (w = 1) turns that member's colour into NaN, never a partial
    sum that a search would trust."""
    members = {"n1": np.ones(2), "n2": np.full(2, 1.5), "d1": np.full(2, 100.0),
               "d2": np.full(2, 90.0), "N": np.array([4.0, 6.0]), "host": np.ones(2)}
    theta = np.radians([0.0, 40.0])
    whole = population_gpu.population_xyz(members, theta)
    real = population_gpu.gpu.compute_pipeline

    def flagged(*args, **kwargs):
        kernel = real(*args, **kwargs)

        class Cut:
            def run(self, *a, **k):
                (out,) = kernel.run(*a, **k)
                out[1, 3] = 1.0  # member 0, second angle
                return (out,)
        return Cut()

    monkeypatch.setattr(population_gpu.gpu, "compute_pipeline", flagged)
    cut = population_gpu.population_xyz(members, theta)
    assert np.all(np.isnan(cut[0, 1])) and np.isfinite(cut[0, 0]).all()
    np.testing.assert_array_equal(np.delete(cut.reshape(-1, 3), 1, axis=0),
                                  np.delete(whole.reshape(-1, 3), 1, axis=0))


def test_fit_recovers_a_mirror_from_noiseless_spectra():
    truth = BraggMirror(1.0, 1.55, 130.0, 85.0, 9)
    measured = truth.reflectance(WAVELENGTH, THETA)
    result = fit_spectrum("bragg", WAVELENGTH, THETA, measured, fixed={"n1": 1.0},
                          bounds={"N": (2, 16)}, seed=1, generations=80)
    p = result.parameters
    assert p["N"] == 9 and p["host"] == 1.0 and isinstance(result.structure, BraggMirror)
    for name in ("n2", "d1", "d2"):
        assert p[name] == pytest.approx(getattr(truth, name), rel=1e-6), name
    assert result.rms < 1e-7 and result.residual.shape == measured.shape
    assert set(result.standard_errors) == {"n2", "d1", "d2"}


def test_standard_errors_cover_the_truth_under_noise():
    truth = BraggMirror(1.0, 1.5, 120.0, 90.0, 12)
    rng = np.random.default_rng(7)
    measured = truth.reflectance(WAVELENGTH, THETA) + 0.01 * rng.standard_normal((48, 3))
    result = fit_spectrum("bragg", WAVELENGTH, THETA, measured, fixed={"n1": 1.0}, seed=0,
                          generations=80)
    assert result.parameters["N"] == 12
    assert result.rms == pytest.approx(0.01, rel=0.2)  # the noise, not a misfit
    for name in ("n2", "d1", "d2"):
        error = result.standard_errors[name]
        assert 0 < error < 0.01 * getattr(truth, name)
        assert abs(result.parameters[name] - getattr(truth, name)) < 3 * error, name
    corr = result.correlation
    np.testing.assert_allclose(np.diag(corr), 1.0, atol=1e-9)
    np.testing.assert_allclose(corr, corr.T, atol=1e-12)
    assert np.all(np.abs(corr) <= 1 + 1e-9)


def test_thin_film_fit_on_gold_with_the_numpy_backend_and_cma():
    truth = ThinFilm(1.38, 310.0, base="Au")
    measured = truth.reflectance(WAVELENGTH, THETA)
    for backend, method in (("numpy", "de"), ("gpu", "cma")):
        result = fit_spectrum("film", WAVELENGTH, THETA, measured, fixed={"base": "Au"},
                              backend=backend, method=method, seed=2, generations=40,
                              population=24)
        assert result.parameters["base"] == "Au"
        assert result.parameters["n_film"] == pytest.approx(1.38, rel=1e-6)
        assert result.parameters["d"] == pytest.approx(310.0, rel=1e-6)
        assert result.structure.base.name == "Au"


def test_the_base_metal_is_chosen_among_a_list():
    truth = ThinFilm(1.6, 250.0, base="Cu")
    measured = truth.reflectance(WAVELENGTH, THETA)
    result = fit_spectrum("film", WAVELENGTH, THETA, measured, bounds={"base": ["Au", "Cu"]},
                          seed=0, generations=20, population=24, starts=2)
    assert result.parameters["base"] == "Cu" and result.structure.base.name == "Cu"
    assert result.parameters["d"] == pytest.approx(250.0, rel=1e-6)
    assert result.optima[0].rms == result.rms < 1e-8
    assert all(o.structure.base.name == "Cu" for o in result.optima)  # gold fits far worse


def test_film_thickness_orders_are_reported_as_distinct_optima():
    """One angle, a narrow band and n_film free: films of several orders fit equally well;
    the result lists them instead of picking one."""
    truth = ThinFilm(1.5, 600.0, n_base=1.5)
    wl = np.linspace(500.0, 560.0, 13)
    measured = truth.reflectance(wl, 0.0)
    result = fit_spectrum("film", wl, 0.0, measured, fixed={"n_base": 1.5},
                          bounds={"n_film": (1.2, 2.4), "d": (100.0, 1500.0)}, seed=0,
                          generations=40, starts=8, optima_tolerance=5.0)
    assert len(result.optima) >= 2
    thickness = sorted(o.parameters["d"] for o in result.optima)
    assert thickness[-1] - thickness[0] > 50.0
    for optimum in result.optima:  # every reported optimum is what it claims
        r = optimum.structure.reflectance(wl, 0.0)
        assert math.sqrt(np.mean((r - measured) ** 2)) == pytest.approx(optimum.rms, rel=1e-6)


def test_max_seconds_stops_the_search_with_a_valid_result():
    truth = BraggMirror(1.0, 1.5, 120.0, 90.0, 6)
    measured = truth.reflectance(WAVELENGTH, THETA)
    result = fit_spectrum("bragg", WAVELENGTH, THETA, measured, generations=100000,
                          max_seconds=0.5, seed=0)
    assert result.stopped_by_time
    assert np.isfinite(result.rms) and isinstance(result.structure, BraggMirror)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"bounds": {"n3": (1, 2)}}, "unknown parameter 'n3'"),
    ({"bounds": {"n2": (2.0, 1.2)}}, r"bounds\['n2'\] must satisfy"),
    ({"bounds": {"n2": (1.2, float("nan"))}}, r"bounds\['n2'\] high must be finite"),
    ({"bounds": {"N": (2.5, 10)}}, r"bounds\['N'\] must be integers"),
    ({"bounds": {"d1": 5.0}}, r"bounds\['d1'\] must be a pair"),
    ({"bounds": {"n1": (1, 2)}, "fixed": {"n1": 1.0}}, "both in bounds and in fixed"),
    ({"fixed": {"N": 0}}, r"fixed\['N'\] must be in"),
    ({"fixed": {"n1": 1, "n2": 1.5, "d1": 1, "d2": 1, "N": 2}}, "leave at least one free"),
    ({"backend": "cuda"}, "backend must be"),
    ({"max_seconds": -1}, "max_seconds must be"),
    ({"method": "pso"}, "method must be one of"),
])
def test_bad_options_are_refused_by_name(kwargs, message):
    measured = np.full((48, 3), 0.5)
    with pytest.raises(ValueError, match=message):
        fit_spectrum("bragg", WAVELENGTH, THETA, measured, **kwargs)


def test_bad_data_are_refused_by_name():
    measured = np.full((48, 3), 0.5)
    measured[3, 1] = np.nan
    with pytest.raises(ValueError, match="measured holds 1 NaN"):
        fit_spectrum("bragg", WAVELENGTH, THETA, measured)
    with pytest.raises(ValueError, match=r"measured must have the shape .* \(48, 3\)"):
        fit_spectrum("bragg", WAVELENGTH, THETA, np.zeros((3, 48)))
    with pytest.raises(ValueError, match="family must be"):
        fit_spectrum("prism", WAVELENGTH, THETA, np.zeros((48, 3)))
    with pytest.raises(ValueError, match="weights must be finite"):
        fit_spectrum("bragg", WAVELENGTH, THETA, np.zeros((48, 3)), weights=-1.0)
    with pytest.raises(ValueError, match=r"bounds\['base'\] must list metals"):
        fit_spectrum("film", WAVELENGTH, THETA, np.zeros((48, 3)), bounds={"base": (0, 1)})
    with pytest.raises(ValueError, match=r"bounds\['base'\] applies to films only"):
        fit_spectrum("bragg", WAVELENGTH, THETA, np.zeros((48, 3)), bounds={"base": ["Au"]})
    with pytest.raises(ValueError, match=r"base .* is searched only by fit_spectrum"):
        design_colour(["#ffffff"], [0.0], "film", bounds={"base": ["Au"]})


def test_targets_in_every_space_agree():
    xyz = BraggMirror(1.0, 1.5, 110.0, 100.0, 6).xyz(THETA)
    linear = xyz_to_linear_srgb(xyz)
    lab = xyz_to_lab(xyz)
    np.testing.assert_allclose(parse_targets(xyz, 3, "xyz"), lab, atol=1e-9)
    np.testing.assert_allclose(parse_targets(linear, 3, "linear-srgb"), lab, atol=1e-9)
    np.testing.assert_allclose(parse_targets(lab, 3, "lab"), lab, atol=1e-12)
    white = parse_targets(["#ffffff", "#000000"], 2)
    np.testing.assert_allclose(white[:, 0], [100.0, 0.0], atol=1e-2)
    np.testing.assert_allclose(white[0, 1:], 0.0, atol=1e-2)
    encoded = np.array([[212, 175, 55]]) / 255.0
    np.testing.assert_allclose(parse_targets(["#d4af37"], 1), parse_targets(encoded, 1),
                               atol=1e-12)
    for targets, space, message in (
            (["#12345"], "srgb", "hex colour must look like"),
            (["#123456"], "xyz", "hex colours are encoded sRGB"),
            ([[1.2, 0.0, 0.0]], "srgb", "encoded sRGB targets must be in"),
            ([[0.1, 0.2]], "srgb", r"shape \(len\(theta\), 3\)"),
            ([[0.1, -0.2, 0.1]], "xyz", "negative luminance"),
            ([[0.1, 0.2, 0.3]], "rgb", "space must be one of")):
        with pytest.raises(ValueError, match=message):
            parse_targets(targets, 1, space)


def test_grid_weights_integrate_like_the_reference():
    nodes, weights = grid_xyz_weights()
    from wgbragg.colour.colorimetry import xyz_weights

    np.testing.assert_allclose(weights.sum(0), xyz_weights()[1].sum(0), rtol=1e-12)
    film = ThinFilm(1.4, 350.0, n_base=1.5)
    grid = film.reflectance(nodes[None, :], THETA[:, None]) @ weights
    assert np.max(delta_e_2000(xyz_to_linear_srgb(grid),
                               film.rgb(THETA, method="reference"))) < 0.2


def test_design_reaches_a_reachable_colour_travel():
    truth = BraggMirror(1.0, 1.6, 140.0, 90.0, 8)
    target = truth.xyz(THETA)
    candidates = design_colour(target, THETA, "bragg", fixed={"n1": 1.0}, space="xyz",
                               bounds={"N": (2, 12)}, seed=0, generations=40)
    best = candidates[0]
    assert best.delta_e <= 1.0
    # dE recomputed independently: the public colour and colorimetry's dE2000.
    achieved = best.structure.rgb(THETA, method="reference")
    independent = delta_e_2000(achieved, xyz_to_linear_srgb(target))
    np.testing.assert_allclose(best.delta_e_per_angle, independent, rtol=1e-9, atol=1e-9)
    assert best.delta_e == pytest.approx(independent.mean(), rel=1e-9)
    averaged = delta_e_2000(best.structure.rgb(THETA, method="averaged"),
                            xyz_to_linear_srgb(target))
    assert best.method == "averaged" and best.delta_e_method == pytest.approx(averaged.mean())
    # A Pareto set: sorted by dE, complexity strictly falling along it.
    de = [c.delta_e for c in candidates]
    n = [c.complexity for c in candidates]
    assert de == sorted(de) and all(a > b for a, b in itertools.pairwise(n))
    assert all(c.complexity == c.structure.N for c in candidates)


def test_the_search_colour_method_is_a_knob():
    """method="grid" searches the same target as the default "averaged"; each candidate
    reports its objective with the method it was searched with, recomputed here."""
    truth = BraggMirror(1.0, 1.45, 160.0, 120.0, 5)
    target = truth.xyz(THETA)
    best = design_colour(target, THETA, "bragg", fixed={"n1": 1.0}, space="xyz",
                         bounds={"N": (2, 8)}, seed=1, generations=20, method="grid")[0]
    assert best.delta_e <= 1.0 and best.method == "grid"
    grid = search_xyz(best.structure, THETA, "grid")
    np.testing.assert_allclose(grid, best.structure.xyz(THETA, method="reference"), atol=2e-3)
    assert best.delta_e_method == pytest.approx(float(np.mean(delta_e_2000(
        xyz_to_linear_srgb(grid), xyz_to_linear_srgb(target)))), rel=1e-6)
    with pytest.raises(ValueError, match=r"method \(the search's colour method\) for a 'film' "
                                         r"design must be one of \('grid',\)"):
        design_colour(["#808080"], [0.0], "film", method="averaged")
    with pytest.raises(ValueError, match="must be one of"):
        design_colour(["#808080"], [0.0], "bragg", method="reference")


def test_an_unreachable_target_returns_the_best_achievable():
    # A film over glass cannot be a saturated, dark, out-of-gamut violet at every angle.
    candidates = design_colour([[30.0, 60.0, -100.0]] * 2, np.radians([0, 45]), "film",
                               space="lab", fixed={"n_base": 1.5}, seed=0, generations=10,
                               population=16)
    assert candidates and candidates[0].delta_e > 10.0
    assert np.isfinite(candidates[0].delta_e)


def test_pareto_front():
    points = [(1.0, 9), (2.0, 5), (1.5, 9), (3.0, 5), (0.5, 12), (4.0, 1)]
    assert list(pareto_front(points)) == [4, 0, 1, 5]


def test_tolerance():
    mirror = BraggMirror(1.0, 1.5, 120.0, 90.0, 12)
    exact = tolerance(mirror, sigma_thickness_nm=0.0, sigma_index=0.0, samples=16, seed=0)
    np.testing.assert_array_equal(exact.delta_e, 0.0)
    gpu_r = tolerance(mirror, sigma_thickness_nm=2.0, samples=400, seed=1)
    cpu_r = tolerance(mirror, sigma_thickness_nm=2.0, samples=400, seed=1, backend="numpy")
    # Same samples: float32 against float64 colours agree closely.
    np.testing.assert_allclose(gpu_r.delta_e, cpu_r.delta_e, atol=0.05)
    assert gpu_r.delta_e.shape == (400,) and gpu_r.delta_e_per_angle.shape == (400, 3)
    assert 0 < gpu_r.percentiles[50] < gpu_r.percentiles[90] <= gpu_r.percentiles[99]
    # Sensitivity: dE per nm times a small shift is the dE of that shift (to linearity).
    nominal = mirror.rgb(THETA, method="reference")
    shifted = BraggMirror(1.0, 1.5, 120.5, 90.0, 12).rgb(THETA, method="reference")
    moved = float(delta_e_2000(shifted, nominal).mean())
    assert gpu_r.sensitivity["d1"] * 0.5 == pytest.approx(moved, rel=0.15)
    assert set(gpu_r.sensitivity) == {"d1", "d2", "n1", "n2"}
    # Independent errors per layer: exact without errors; with them, the peak moves with the
    # mean optical thickness, whose error shrinks as 1/sqrt(N), so colours spread less than
    # under the same error shared by every layer.
    layers = tolerance(mirror, sigma_thickness_nm=0.0, samples=3, per_layer=True, seed=1)
    np.testing.assert_array_equal(layers.delta_e, 0.0)
    layers = tolerance(mirror, sigma_thickness_nm=2.0, samples=60, per_layer=True, seed=1)
    assert 0 < layers.percentiles[50] < 0.8 * gpu_r.percentiles[50]
    with pytest.raises(ValueError, match="sigma_thickness_nm must be a finite number"):
        tolerance(mirror, sigma_thickness_nm=-1.0)
    with pytest.raises(ValueError, match="samples must be an integer"):
        tolerance(mirror, samples=0)
