"""The stack population kernel (wgsl/design/stack_population.wgsl: float32 Abeles matrices
for any lossless stack) against the float64 transfer-matrix solver, and per-layer tolerance
on the GPU against the float64 backend from the same draws."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from wgbragg import BraggMirror
from wgbragg.design import stack, stack_gpu, tolerance
from wgbragg.design.tolerance import layer_perturbations, layer_spectra, structure_members
from wgbragg.optics.transfer_matrix import transfer_matrix_reflectance

pytestmark = pytest.mark.gpu


def _random_stacks(rng, count, dense_host=False):
    """Stacks of 2-60 layers (indices 1-2.5, 10-400 nm) padded with zero thicknesses to one
    layer count, each with its own host and base (some absorbing)."""
    sizes = rng.integers(2, 61, count)
    sizes[0], sizes[1] = 2, 60
    width = int(sizes.max())
    indices = rng.uniform(1.0, 2.5, (count, width))
    thicknesses = rng.uniform(10.0, 400.0, (count, width))
    for p, size in enumerate(sizes):
        thicknesses[p, size:] = 0.0
    host = rng.uniform(2.0, 2.5, count) if dense_host else rng.uniform(1.0, 1.6, count)
    base = rng.uniform(1.0, 2.5, count) + 1j * np.where(rng.random(count) < 0.3,
                                                         rng.uniform(0.0, 3.0, count), 0.0)
    return sizes, host, indices, thicknesses, base


def _reference(sizes, host, indices, thicknesses, base, wl, th, polarization):
    """float64, each stack without its padding."""
    return np.stack([
        transfer_matrix_reflectance([host[p], *indices[p, :s], base[p]], thicknesses[p, :s],
                                    wl, th, polarization)
        for p, s in enumerate(sizes)])


@pytest.mark.parametrize("dense_host", [False, True], ids=["rare-host", "evanescent-layers"])
def test_stack_kernel_matches_the_transfer_matrix_solver(dense_host):
    """Random non-periodic stacks at 0-80 degrees (a dense host makes some layers
    evanescent beyond their critical angle), s, p and unpolarized: float32 within 2e-3 of
    float64 (measured max 4.0e-5 here; 1.2e-4 over 160 random stacks in development)."""
    rng = np.random.default_rng(7 + dense_host)
    sizes, host, indices, thicknesses, base = _random_stacks(rng, 16, dense_host)
    wl = rng.uniform(360.0, 830.0, 48)
    th = np.radians(np.concatenate([[0.0, 80.0], rng.uniform(0.0, 80.0, 46)]))
    for polarization in ("s", "p", "unpolarized"):
        expected = _reference(sizes, host, indices, thicknesses, base, wl, th, polarization)
        got = stack_gpu.stack_reflectance(host, indices, thicknesses, base, wl, th,
                                          polarization)
        np.testing.assert_allclose(got, expected, atol=2e-3, err_msg=polarization)
        # The float64 twin pads the same way and agrees with the solver exactly.
        twin = stack.stack_reflectance(host, indices, thicknesses, base, wl, th, polarization)
        np.testing.assert_allclose(twin, expected, atol=1e-12)
    # Grazing incidence reflects everything; a stack index-matched to its host nothing.
    grazing = stack_gpu.stack_reflectance(host, indices, thicknesses, base, 500.0, np.pi / 2)
    np.testing.assert_allclose(grazing, 1.0, atol=1e-6)
    matched = stack_gpu.stack_reflectance(1.5, np.full((1, 4), 1.5), np.full((1, 4), 200.0),
                                          1.5, wl, th)
    np.testing.assert_allclose(matched, 0.0, atol=1e-7)


def test_stack_kernel_blocks_and_refusals(monkeypatch):
    """Blocks of stacks give what one dispatch gives; bad inputs are refused by name."""
    rng = np.random.default_rng(2)
    _, host, indices, thicknesses, base = _random_stacks(rng, 7)
    wl, th = np.linspace(380.0, 780.0, 9), np.radians(30.0)
    whole = stack_gpu.stack_reflectance(host, indices, thicknesses, base, wl, th)
    monkeypatch.setattr(stack_gpu, "MAX_LAYER_ROWS", 2 * indices.shape[1])
    np.testing.assert_array_equal(
        stack_gpu.stack_reflectance(host, indices, thicknesses, base, wl, th), whole)
    with pytest.raises(ValueError, match="thicknesses_nm must have the shape"):
        stack_gpu.stack_reflectance(1.0, indices, thicknesses[:, 1:], 1.5, wl, th)
    with pytest.raises(ValueError, match="indices must be real"):
        stack_gpu.stack_reflectance(1.0, indices + 0.1j, thicknesses, 1.5, wl, th)
    most = stack_gpu.max_layers()
    with pytest.raises(ValueError, match=rf"indices must hold at most {most} layers"):
        stack_gpu.stack_reflectance(1.0, np.ones((1, most + 1)), np.ones((1, most + 1)), 1.5,
                                    wl, th)


def test_stacks_beyond_mesa_22s_loop_budget_are_right_or_refused():
    """32769 layers, one more than Mesa 22's loop budget allows (refused there): a weak
    quarter-wave mirror at 550 nm (indices 1.50001 and 1.5) whose reflectance, 0.012 at its
    peak, needs every layer (half of them reflect 0.003). Without a budget: within 2e-4 of the
    float64 twin (measured 8.3e-5, float32 phases over 32769 layers)."""
    layers = 32769
    indices = np.where(np.arange(layers) % 2 == 0, 1.50001, 1.5)[None]
    thicknesses = 550.0 / 4.0 / indices
    wl, th = np.array([545.0, 550.0, 555.0]), np.array(0.0)
    if stack_gpu.max_layers() < layers:
        with pytest.raises(ValueError, match=r"indices must hold at most \d+ layers"):
            stack_gpu.stack_reflectance(1.5, indices, thicknesses, 1.5, wl, th)
        return
    expected = stack.stack_reflectance(1.5, indices, thicknesses, 1.5, wl, th)
    assert expected[0, 1] > 0.01
    np.testing.assert_allclose(stack_gpu.stack_reflectance(1.5, indices, thicknesses, 1.5, wl,
                                                           th), expected, atol=2e-4)


def test_per_layer_draws_do_not_depend_on_the_block_size(monkeypatch):
    """Draws in blocks from one generator equal one draw, so a per-layer tolerance taken a
    few stacks at a time is bit-identical to one taken at once; row 0 is the mirror itself."""
    whole = layer_perturbations(9, 6, 2.0, 0.01, np.random.default_rng(4))
    rng = np.random.default_rng(4)
    parts = [layer_perturbations(n, 6, 2.0, 0.01, rng) for n in (3, 1, 5)]
    for key, value in whole.items():
        np.testing.assert_array_equal(np.concatenate([p[key] for p in parts]), value)
    mirror = BraggMirror(1.0, 1.5, 120.0, 90.0, 3)
    kwargs = dict(sigma_thickness_nm=2.0, sigma_index=0.01, samples=9, per_layer=True, seed=4,
                  backend="numpy")
    at_once = tolerance(mirror, **kwargs)
    # Two stacks a block (the module, not the function the package exports under its name).
    monkeypatch.setattr(sys.modules["wgbragg.design.tolerance"], "_LAYER_BLOCK_ROWS", 12)
    np.testing.assert_array_equal(tolerance(mirror, **kwargs).delta_e_per_angle,
                                  at_once.delta_e_per_angle)
    members = structure_members(mirror, "bragg")
    zero = {"layer_thickness": np.zeros((1, 6)), "layer_index": np.zeros((1, 6))}
    wl, th = np.array([450.0, 600.0]), np.zeros(2)
    np.testing.assert_allclose(layer_spectra(members, zero, wl, th, "numpy")[0],
                               mirror.reflectance(wl, th), rtol=1e-10)
    assert np.all(at_once.delta_e > 0)  # every copy moved


def test_per_layer_tolerance_gpu_matches_numpy():
    """Same seed, same perturbed stacks: the GPU's dE2000 per sample and angle match the
    float64 backend's (measured max difference 3.3e-5)."""
    mirror = BraggMirror(1.0, 1.5, 120.0, 90.0, 12)
    kwargs = dict(sigma_thickness_nm=2.0, sigma_index=0.01, samples=40, per_layer=True, seed=5)
    gpu_r = tolerance(mirror, **kwargs)
    cpu_r = tolerance(mirror, backend="numpy", **kwargs)
    np.testing.assert_allclose(gpu_r.delta_e_per_angle, cpu_r.delta_e_per_angle, atol=2e-3)
    assert gpu_r.delta_e.min() > 0.1  # the errors do move the colour
    for q in (50, 90, 99):
        assert gpu_r.percentiles[q] == pytest.approx(cpu_r.percentiles[q], abs=2e-3)
