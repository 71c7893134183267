"""Robust colour design (``design_colour(robust=...)``): on its own fixed draws (common random
numbers) the robust design's averaged objective is no worse than the plain design's, the
reported average is what an independent evaluation gives, and bad options are refused by
name."""

from __future__ import annotations

import numpy as np
import pytest

from wgbragg import BraggMirror
from wgbragg.design import design_colour
from wgbragg.design.colour_design import perturbed_delta_e
from wgbragg.design.tolerance import layer_perturbations, perturbations

pytestmark = pytest.mark.gpu

THETA = np.radians([0.0, 45.0])


def test_robust_design_beats_the_plain_one_on_its_draws():
    target = BraggMirror(1.0, 1.6, 140.0, 90.0, 6).xyz(THETA)
    options = {"fixed": {"n1": 1.0}, "bounds": {"N": (2, 8)}, "space": "xyz", "seed": 3,
               "generations": 15, "population": 24, "candidates": 2}
    robust = {"sigma_thickness_nm": 3.0, "samples": 8}
    plain = design_colour(target, THETA, "bragg", **options)[0]
    sturdy = design_colour(target, THETA, "bragg", robust=robust, **options)
    best = sturdy[0]
    draws = perturbations("bragg", 8, 3.0, 0.0, seed=3, quasi_random=True)  # its own
    on_draws = perturbed_delta_e(best.structure, target, THETA, draws, space="xyz")
    # The reported average is the float64 objective on those draws ...
    assert best.robust_delta_e == pytest.approx(on_draws.mean(), rel=1e-9)
    assert plain.robust_delta_e is None
    # ... and no worse than the plain design's on the same draws: the search minimised it.
    plain_on_draws = perturbed_delta_e(plain.structure, target, THETA, draws, space="xyz")
    assert on_draws.mean() <= plain_on_draws.mean()
    assert plain.delta_e <= best.delta_e  # the nominal match is the plain design's job
    ranks = [c.robust_delta_e for c in sturdy]
    assert ranks == sorted(ranks)
    # Without errors every copy is the structure itself: the mean is its own objective.
    zero = perturbations("bragg", 4, 0.0, 0.0, seed=0)
    np.testing.assert_allclose(
        perturbed_delta_e(plain.structure, target, THETA, zero, space="xyz"),
        perturbed_delta_e(plain.structure, target, THETA, zero, space="xyz", backend="gpu"),
        atol=0.05)


def test_per_layer_errors_run_as_stacks_on_both_backends():
    """Per-layer draws: without errors the stacks are the mirror itself (the grid colour of
    its closed form, float64 and float32), with errors the GPU stack kernel colours as the
    float64 transfer-matrix solver does, and a film's one layer moves as its parameters."""
    mirror = BraggMirror(1.0, 1.55, 130.0, 95.0, 5)
    target = BraggMirror(1.0, 1.6, 140.0, 90.0, 6).xyz(THETA)
    zero = layer_perturbations(3, 12, 0.0, 0.0, seed=0)
    nominal = perturbed_delta_e(mirror, target, THETA, perturbations("bragg", 1, 0.0, 0.0),
                                space="xyz", method="grid")
    np.testing.assert_allclose(perturbed_delta_e(mirror, target, THETA, zero, space="xyz"),
                               np.repeat(nominal, 3), rtol=1e-9)
    np.testing.assert_allclose(
        perturbed_delta_e(mirror, target, THETA, zero, space="xyz", backend="gpu"),
        np.repeat(nominal, 3), atol=2e-3)
    draws = layer_perturbations(6, 12, 3.0, 0.01, seed=1)
    cpu = perturbed_delta_e(mirror, target, THETA, draws, space="xyz")
    assert np.all(np.abs(cpu - nominal) > 1e-3)  # every copy moved
    np.testing.assert_allclose(
        perturbed_delta_e(mirror, target, THETA, draws, space="xyz", backend="gpu"), cpu,
        atol=2e-3)
    from wgbragg import ThinFilm

    film = ThinFilm(1.45, 320.0, n_base=1.5)
    film_target = film.xyz(THETA)
    layer = layer_perturbations(4, 1, 5.0, 0.02, seed=2)
    same = {"d": layer["layer_thickness"][:, 0], "n_film": layer["layer_index"][:, 0]}
    np.testing.assert_array_equal(
        perturbed_delta_e(film, film_target, THETA, layer, space="xyz"),
        perturbed_delta_e(film, film_target, THETA, same, space="xyz"))


def test_robust_design_with_per_layer_errors_minimises_its_own_average():
    target = BraggMirror(1.0, 1.6, 140.0, 90.0, 6).xyz(THETA)
    robust = {"sigma_thickness_nm": 3.0, "samples": 8, "per_layer": True}
    best = design_colour(target, THETA, "bragg", fixed={"n1": 1.0}, bounds={"N": (2, 8)},
                         space="xyz", seed=3, generations=12, population=24, candidates=2,
                         robust=robust)[0]
    draws = layer_perturbations(8, 16, 3.0, 0.0, seed=3, quasi_random=True)  # its own
    on_draws = perturbed_delta_e(best.structure, target, THETA, draws, space="xyz")
    assert best.robust_delta_e == pytest.approx(on_draws.mean(), rel=1e-9)
    truth = BraggMirror(1.0, 1.6, 140.0, 90.0, 6)
    assert on_draws.mean() <= perturbed_delta_e(truth, target, THETA, draws,
                                                space="xyz").mean() + 0.05


@pytest.mark.parametrize(("errors", "kwargs", "message"), [
    ({"layer_thickness": np.zeros((2, 9)), "layer_index": np.zeros((2, 9))}, {},
     r"cover the mirror's 2N = 10 layers, got 9 columns"),
    ({"layer_thickness": np.zeros((2, 10))}, {}, r"must have the keys \('layer_index', "),
    ({"d1 ": np.zeros(2)}, {}, r"must have the keys \('d1', 'd2', 'n1', 'n2'\)"),
    ({"d1": np.zeros((2, 3)), "d2": np.zeros((2, 3)), "n1": np.zeros((2, 3)),
      "n2": np.zeros((2, 3))}, {}, r"one shape, \(K,\)"),
    ({"d1": [0.0, np.nan], "d2": [0, 0], "n1": [0, 0], "n2": [0, 0]}, {}, "must be finite"),
    ({"d1": [0.0], "d2": [0.0], "n1": [0.0], "n2": [0.0]}, {"backend": "cuda"},
     "backend must be one of"),
    ({"d1": [0.0], "d2": [0.0], "n1": [0.0], "n2": [0.0]}, {"objective": "median"},
     "objective must be 'mean' or 'max'"),
    ([1.0], {}, "errors must be a dict"),
])
def test_bad_errors_are_refused_by_name(errors, kwargs, message):
    mirror = BraggMirror(1.0, 1.5, 120.0, 90.0, 5)
    with pytest.raises(ValueError, match=message):
        perturbed_delta_e(mirror, ["#d4af37", "#2e8b57"], THETA, errors, **kwargs)


@pytest.mark.parametrize(("robust", "message"), [
    ({"sigma": 1.0}, "robust has unknown key 'sigma'"),
    ({"samples": 0}, r"robust\['samples'\] must be an integer"),
    ({"sigma_thickness_nm": -1.0}, r"robust\['sigma_thickness_nm'\] must be a finite"),
    ({"sigma_thickness_nm": 0.0}, "robust needs sigma_thickness_nm > 0"),
    ("yes", "robust must be None, True or a dict"),
    ({"per_layer": 1}, r"robust\['per_layer'\] must be True or False"),
])
def test_bad_robust_options_are_refused_by_name(robust, message):
    with pytest.raises(ValueError, match=message):
        design_colour(["#d4af37"], [0.0], "bragg", robust=robust)
