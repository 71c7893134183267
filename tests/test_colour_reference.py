"""Colour by spectral integration: ``reference_xyz`` and ``spectral_xyz_stratified``.

numpy tests check the methods against colour-science and invariants (perfect reflector, the
K = 471 identity, unbiasedness of the jittered stratified sum that "spectral" self-normalises,
convergence in K; the exact white of "spectral" is tests/test_spectral_white.py's); GPU tests
hold the
float32 kernels to the issue's target, numpy and GPU within CIE dE2000 0.1.

Tolerance policy for "spectral" on the GPU. Each of its K nodes carries 1/K of the colour, so
the float32 kernel's pointwise error passes to the colour undiluted. The kernel takes its angle
geometry and split layer phases from the host in float64 (``colour_gpu.angle_inputs``),
which brought the issue's K = 16 within 0.01 of numpy on the benchmark
grid (0.18 before). Next to a band edge at N = 100, though, R still moves by ~3e-2 per 1e-7
relative change of the wavelength: a phase below one turn carries that much rounding in
float32 whatever its arithmetic. The general criterion is therefore the one of
test_optics_gpu.py carried to colours: the GPU colour lies within ``ISSUE_DE`` of the float64
colour, plus the spread of float64 colours over the +-2-ulp box of (node wavelengths, angle);
the plain dE is held to a p99 of ``ISSUE_DE``, and the issue's K = 16 to ``ISSUE_DE`` at every
angle of the benchmark grid's periods.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import warnings

import colour
import numpy as np
import pytest

from wgbragg import BraggMirror, ThinFilm
from wgbragg.colour import reference_gpu as colour_gpu
from wgbragg.colour.colorimetry import delta_e_2000, xyz_density, xyz_to_linear_srgb, xyz_weights
from wgbragg.colour.reference import (
    STRATA_RANGE_NM,
    integrate_xyz,
    reference_xyz,
    self_normalised_weights,
    spectral_xyz_stratified,
    stratified_nodes,
)

EXACT_ATOL = 1e-12  # float64 identities
WHITE_ATOL = 2e-3  # perfect reflector in linear sRGB; measured 1.7e-4
ISSUE_DE = 0.1  # issue target: numpy and GPU versions of a method agree within dE2000 0.1
REFERENCE_MEDIAN_DE = 1e-3  # median numpy-vs-GPU dE of "reference"; measured 5e-5
BOX_ULPS = 2

DEG = math.pi / 180.0
ANGLES = np.arange(90.0) * DEG  # 0 .. 89 degrees

MIRRORS = [
    BraggMirror(n1=1.0, n2=1.5, d1=fraction * period, d2=(1.0 - fraction) * period, N=N)
    for period, fraction, N in itertools.product((244.0, 500.0, 988.0), (0.25, 0.5, 0.75),
                                                 (3, 20, 100))
]
HOST_MIRRORS = [  # Appendix D (host != n1): jewel beetle in air, and a dense host
    BraggMirror(n1=1.59, n2=1.67, d1=81.6, d2=78.4, N=8, host=1.0),
    BraggMirror(n1=1.59, n2=1.67, d1=81.6, d2=78.4, N=100, host=1.0),
    BraggMirror(n1=1.3, n2=2.5, d1=300.0, d2=20.0, N=20, host=2.0),
]
FILMS = [
    ThinFilm(n_film=1.3, d=290.0),  # soap film in air
    ThinFilm(n_film=1.5, d=500.0, n_base=1.2),
    ThinFilm(n_film=1.33, d=350.0, n_base=0.2, k_base=3.0),  # over a conductor (silver-like)
    ThinFilm(n_film=2.0, d=1500.0, n_base=1.5, k_base=0.5, host=1.33),
    ThinFilm(n_film=1.3, d=0.0, n_base=1.5),  # bare interface
]
MATERIALS = MIRRORS + HOST_MIRRORS + FILMS


def material_id(material):
    if isinstance(material, BraggMirror):
        return f"mirror-{material.d1:g}-{material.d2:g}-N{material.N}-host{material.host:g}"
    return f"film-{material.n_film:g}-{material.d:g}-{material.n_base:g}+{material.k_base:g}i"


def names(parameter):
    return rf"\b{parameter}\b"


def delta_e(xyz_a, xyz_b):
    return delta_e_2000(xyz_to_linear_srgb(xyz_a), xyz_to_linear_srgb(xyz_b))


@dataclasses.dataclass(frozen=True)
class Spectrum:
    """A stand-in material whose reflectance is ``function(wavelength_nm, theta)``."""

    function: object

    def reflectance(self, wavelength_nm, theta, polarization="unpolarized", backend="numpy"):
        wavelength, angle = np.broadcast_arrays(np.asarray(wavelength_nm, float),
                                                np.asarray(theta, float))
        return self.function(wavelength, angle)


PERFECT_REFLECTOR = Spectrum(lambda wavelength, theta: np.ones_like(wavelength))
SMOOTH = Spectrum(lambda wavelength, theta: 0.5 + 0.45 * np.sin(wavelength / 41.0 + theta))


# --------------------------------------------------------------------------- reference (numpy)


def test_reference_perfect_reflector_is_white():
    xyz = reference_xyz(PERFECT_REFLECTOR, ANGLES)
    assert np.allclose(xyz[:, 1], 1.0, atol=EXACT_ATOL, rtol=0.0)
    assert np.allclose(xyz_to_linear_srgb(xyz), 1.0, atol=WHITE_ATOL)


@pytest.mark.parametrize("material", [MIRRORS[13], HOST_MIRRORS[0], FILMS[2]], ids=material_id)
def test_reference_matches_colour_sd_to_xyz(material):
    wavelength = np.arange(360.0, 831.0)
    theta = 0.7
    sd = colour.SpectralDistribution(material.reflectance(wavelength, theta), wavelength)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # colour aligns D65 to the CMF shape, and says so
        expected = colour.sd_to_XYZ(sd, colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"],
                                    colour.SDS_ILLUMINANTS["D65"], method="Integration") / 100
    assert np.allclose(reference_xyz(material, theta), expected, rtol=1e-9, atol=1e-12)


def test_reference_averages_both_polarisations():
    material = HOST_MIRRORS[0]
    wavelength, weights = xyz_weights()
    theta = np.array([0.3, 1.2])[:, None]
    s = material.reflectance(wavelength, theta, "s") @ weights
    p = material.reflectance(wavelength, theta, "p") @ weights
    assert np.allclose(reference_xyz(material, theta[:, 0]), 0.5 * (s + p), atol=EXACT_ATOL)
    assert not np.allclose(s, p, atol=1e-3)  # the test would see a wrong polarisation


def test_reference_quarter_wave_mirror_reflects_its_bragg_colour():
    # Quarter-wave stack centred on 530 nm at normal incidence: a saturated green.
    mirror = BraggMirror(n1=1.0, n2=1.5, d1=530.0 / 4, d2=530.0 / 6, N=100)
    rgb = xyz_to_linear_srgb(reference_xyz(mirror, 0.0))
    assert rgb[1] > 1.5 * max(rgb[0], rgb[2])  # measured (0.58, 1.09, 0.43)


@pytest.mark.parametrize("function", [reference_xyz, spectral_xyz_stratified])
def test_n_dimensional_theta(function):
    material = MIRRORS[4]
    theta = np.linspace(0.0, 1.5, 6).reshape(2, 3)
    xyz = function(material, theta)
    assert xyz.shape == (2, 3, 3)
    assert np.allclose(xyz.reshape(-1, 3), function(material, theta.ravel()), atol=EXACT_ATOL)
    assert function(material, 0.25).shape == (3,)
    assert function(material, np.zeros((0, 4))).shape == (0, 4, 3)


def test_numpy_blocks_give_the_same_colours_as_one_call(monkeypatch):
    import wgbragg.colour.reference as module

    whole = reference_xyz(MIRRORS[4], ANGLES)
    monkeypatch.setattr(module, "_BLOCK", 471 * 7)  # 7 angles per block, a partial last one
    assert np.allclose(reference_xyz(MIRRORS[4], ANGLES), whole, atol=EXACT_ATOL, rtol=0.0)


@pytest.mark.parametrize("function", [reference_xyz, spectral_xyz_stratified])
@pytest.mark.parametrize("theta", [-1e-9, math.pi / 2 + 1e-6, math.nan, [0.1, 2.0], "0.3"])
def test_rejects_bad_angles(function, theta):
    with pytest.raises(ValueError, match=names("theta")):
        function(MIRRORS[0], theta)


@pytest.mark.parametrize("function", [reference_xyz, spectral_xyz_stratified])
def test_rejects_bad_backend_and_material(function):
    with pytest.raises(ValueError, match=names("backend")):
        function(MIRRORS[0], 0.1, backend="cuda")
    with pytest.raises(ValueError, match=names("material")):
        function(object(), 0.1)


def test_integrate_xyz_rejects_mismatched_nodes():
    wavelength, weights = xyz_weights()
    with pytest.raises(ValueError, match=names("weights")):
        integrate_xyz(MIRRORS[0], 0.1, wavelength, weights[:-1])


@pytest.mark.parametrize("backend", ["numpy", pytest.param("gpu", marks=pytest.mark.gpu)])
@pytest.mark.parametrize(("nodes", "node_weights", "name"), [
    ([-5.0], [[1.0, 1.0, 1.0]], r"wavelength_nm must be in \[1, 1e\+06\] nm"),
    ([np.nan], [[1.0, 1.0, 1.0]], "wavelength_nm contains NaN"),
    ([0.0], [[1.0, 1.0, 1.0]], r"wavelength_nm must be in \[1, 1e\+06\] nm"),
    (["500"], [[1.0, 1.0, 1.0]], "wavelength_nm"),
    ([500.0], [[np.nan, 1.0, 1.0]], "weights contains NaN"),
    ([500.0], [[np.inf, 1.0, 1.0]], "weights must be finite"),
])
def test_integrate_xyz_checks_nodes_on_both_backends(backend, nodes, node_weights, name):
    """The GPU integrated bad nodes silently (-5 nm gave 0.096, NaN 0)."""
    with pytest.raises(ValueError, match=name):
        integrate_xyz(MIRRORS[0], 0.3, nodes, node_weights, backend)


# --------------------------------------------------------------------------- spectral (numpy)


@pytest.mark.parametrize("samples", [0, -3, 2.5, True, "16", None, math.nan, 100_001, 10**9])
def test_spectral_rejects_bad_sample_counts(samples):
    with pytest.raises(ValueError, match=names("samples")):
        spectral_xyz_stratified(MIRRORS[0], 0.1, samples=samples)
    with pytest.raises(ValueError, match=names("samples")):
        stratified_nodes(samples)


@pytest.mark.parametrize("seed", ["x", 1.5, -1, True, [1, 2]])
def test_spectral_rejects_bad_seeds(seed):
    with pytest.raises(ValueError, match=names("seed")):
        spectral_xyz_stratified(MIRRORS[0], 0.1, samples=4, seed=seed)


@pytest.mark.parametrize("samples", [1, 4, 17, 471, 1000])
@pytest.mark.parametrize("seed", [None, 11])
def test_stratified_nodes_one_per_stratum(samples, seed):
    wavelength, weights = stratified_nodes(samples, seed)
    start, end = STRATA_RANGE_NM
    width = (end - start) / samples
    stratum = np.floor((wavelength - start) / width)
    assert np.array_equal(stratum, np.arange(samples))
    assert np.array_equal(wavelength, wavelength.astype(np.float32))  # same nodes on the GPU
    assert np.allclose(weights, xyz_density(wavelength) * width, atol=EXACT_ATOL)
    if seed is None:
        assert np.allclose(wavelength, start + (np.arange(samples) + 0.5) * width, atol=1e-4)


def test_stratified_nodes_are_reproducible_per_seed():
    a, _ = stratified_nodes(16, seed=3)
    b, _ = stratified_nodes(16, seed=3)
    c, _ = stratified_nodes(16, seed=4)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    generator = np.random.default_rng(3)
    assert np.array_equal(stratified_nodes(16, seed=generator)[0], a)


def test_471_centred_strata_are_the_reference_nodes():
    wavelength, weights = stratified_nodes(471)
    assert np.array_equal(wavelength, xyz_weights()[0])
    assert np.array_equal(weights, xyz_weights()[1])


@pytest.mark.parametrize("material", [MIRRORS[26], HOST_MIRRORS[1], FILMS[3]], ids=material_id)
def test_spectral_with_471_centred_strata_is_the_reference(material):
    spectral = spectral_xyz_stratified(material, ANGLES, samples=471)
    assert np.allclose(spectral, reference_xyz(material, ANGLES), atol=EXACT_ATOL, rtol=0.0)


def stratified_sum(material, theta, samples, seed=None):
    """The stratified estimate before "spectral" self-normalises it."""
    return integrate_xyz(material, theta, *stratified_nodes(samples, seed))


def test_stratified_sum_of_a_perfect_reflector_tends_to_white():
    # What "spectral" divides by: the nodes' own estimate of the white.
    errors = [abs(stratified_sum(PERFECT_REFLECTOR, 0.0, k)[1] - 1.0)
              for k in (4, 16, 64, 256, 1024)]
    assert errors[0] > 1e-3  # few strata see the shape of ybar * D65
    assert all(b < a for a, b in itertools.pairwise(errors))
    assert errors[-1] < 1e-5


def test_jittered_stratified_sum_is_unbiased():
    # E[sum_k R(l_k) density(l_k) h] = integral R density over the strata, for any K.
    theta = 0.4
    grid = np.linspace(*STRATA_RANGE_NM, 94201)
    exact = np.trapezoid(SMOOTH.reflectance(grid, theta)[:, None] * xyz_density(grid), grid,
                         axis=0)
    draws = np.array([stratified_sum(SMOOTH, theta, 4, seed) for seed in range(3000)])
    standard_error = draws.std(axis=0) / math.sqrt(len(draws))
    assert np.all(np.abs(draws.mean(axis=0) - exact) < 4.0 * standard_error)
    centred = stratified_sum(SMOOTH, theta, 4)
    assert np.any(np.abs(centred - exact) > 10.0 * standard_error)  # the test can tell bias


def test_spectral_is_the_stratified_sum_over_its_own_white():
    theta = np.array([0.0, 0.4, 1.2])
    for samples, seed in ((4, None), (16, 3), (100, 7)):
        ratio = (stratified_sum(SMOOTH, theta, samples, seed)
                 / stratified_sum(PERFECT_REFLECTOR, theta, samples, seed))
        np.testing.assert_allclose(spectral_xyz_stratified(SMOOTH, theta, samples, seed=seed),
                                   ratio * xyz_weights()[1].sum(0), rtol=1e-13)


@pytest.mark.parametrize("material", [MIRRORS[1], MIRRORS[13], MIRRORS[22], FILMS[3]],
                         ids=material_id)
def test_spectral_error_decreases_with_samples(material):
    reference = reference_xyz(material, ANGLES)
    error = {k: delta_e(spectral_xyz_stratified(material, ANGLES, samples=k), reference).mean()
             for k in (4, 16, 128)}
    assert error[128] < error[16] < error[4]


# --------------------------------------------------------------------------- GPU


@pytest.mark.gpu
@pytest.mark.parametrize("material", MATERIALS, ids=material_id)
def test_reference_gpu_matches_numpy(material):
    numpy_xyz = reference_xyz(material, ANGLES)
    gpu_xyz = reference_xyz(material, ANGLES, backend="gpu")
    error = delta_e(gpu_xyz, numpy_xyz)
    assert error.max() <= ISSUE_DE
    assert np.median(error) <= REFERENCE_MEDIAN_DE


def _box_spread(material, theta, wavelength, weights):
    """dE spread of the float64 colour over the +-2-ulp box of float32 nodes and angle."""
    centre = integrate_xyz(material, theta, wavelength, weights)
    spread = np.zeros(theta.shape)
    for dl, dt in itertools.product((-BOX_ULPS, BOX_ULPS), repeat=2):
        nodes = _ulps(wavelength, dl)
        angles = np.clip(_ulps(theta, dt), 0.0, math.pi / 2)
        moved = integrate_xyz(material, angles, nodes, weights)
        spread = np.maximum(spread, delta_e(moved, centre))
    return centre, spread


def _ulps(x, n):
    x32 = np.asarray(x, np.float32)
    step = np.float32(np.inf) if n > 0 else np.float32(-np.inf)
    for _ in range(abs(n)):
        x32 = np.nextafter(x32, step)
    return x32.astype(np.float64)


@pytest.mark.gpu
@pytest.mark.parametrize("material", MATERIALS, ids=material_id)
def test_spectral_gpu_matches_numpy(material):
    plain = []
    for samples, seed in itertools.product((4, 16, 64), (None, 7)):
        wavelength, weights = stratified_nodes(samples, seed)
        weights = self_normalised_weights(weights)
        gpu_xyz = spectral_xyz_stratified(material, ANGLES, samples, backend="gpu", seed=seed)
        numpy_xyz = spectral_xyz_stratified(material, ANGLES, samples, seed=seed)
        plain.append(delta_e(gpu_xyz, numpy_xyz))
        centre, spread = _box_spread(material, ANGLES, wavelength, weights)
        error = delta_e(gpu_xyz, centre)
        worst = np.argmax(error - spread)
        assert error[worst] <= ISSUE_DE + spread[worst], (samples, seed, worst)
    assert np.percentile(np.concatenate(plain), 99) <= ISSUE_DE


@pytest.mark.gpu
@pytest.mark.parametrize("material", [m for m in MIRRORS if m.N == 100], ids=material_id)
def test_issue_spectral_gpu_matches_numpy_at_every_angle(material):
    # The issue's K = 16 at N = 100, where phase rounding mattered most; before the split
    # phases and host angle geometry, (988 nm, 0.25) reached 0.18 at 71 degrees.
    gpu_xyz = spectral_xyz_stratified(material, ANGLES, 16, backend="gpu")
    assert delta_e(gpu_xyz, spectral_xyz_stratified(material, ANGLES, 16)).max() <= ISSUE_DE


@pytest.mark.gpu
def test_spectral_gpu_at_a_sharp_resonance():
    # One node of K = 16 (521.4 nm, weight 0.22 of Y) sits at a transmission resonance, where
    # R moves by 5e-3 per 1e-7 relative wavelength: measured 0.0009 dE2000 (0.18 before).
    mirror = BraggMirror(1.0, 1.5, 247.0, 741.0, 100)
    theta = np.array([71.0 * DEG])
    gpu_xyz = spectral_xyz_stratified(mirror, theta, 16, backend="gpu")
    assert delta_e(gpu_xyz, spectral_xyz_stratified(mirror, theta, 16))[0] <= 0.02


@pytest.mark.gpu
@pytest.mark.parametrize(("thickness", "periods"), [(1e3, 100), (2e4, 5), (2e5, 3)])
def test_gpu_phases_of_thick_cells(thickness, periods):
    # One node at a time: R itself. Up to 700 turns a layer, float32 rounding of the whole phase
    # put R 3e-4 (20 um) and 3e-3 (200 um) off; the split phases measure 3e-6 and 9e-6.
    mirror = BraggMirror(1.0, 1.5, thickness, 1.3 * thickness, periods)
    theta = np.radians([0.0, 30.0, 60.0, 85.0])
    luminance = np.zeros((1, 3))
    luminance[0, 1] = 1.0
    for wavelength in np.linspace(380.0, 780.0, 17) + 0.37:
        gpu_r = integrate_xyz(mirror, theta, [wavelength], luminance, "gpu")[:, 1]
        exact = mirror.reflectance(wavelength, theta, "unpolarized")
        # N = 100 keeps its band-edge sensitivity (3e-4 measured before and after).
        assert np.abs(gpu_r - exact).max() <= (5e-4 if periods == 100 else 5e-5), wavelength


@pytest.mark.gpu
def test_gpu_grazing_incidence_is_white():
    theta = np.array([math.pi / 2, math.pi / 2 - 1e-9])
    for material in (MIRRORS[4], HOST_MIRRORS[0], HOST_MIRRORS[2]):
        white = reference_xyz(PERFECT_REFLECTOR, 0.0)
        assert np.allclose(reference_xyz(material, theta, backend="gpu"), white, rtol=1e-5)


def test_split_float32_heads_multiply_exactly():
    rng = np.random.default_rng(3)
    x = rng.uniform(1e-4, 1e4, 1000) * 10.0 ** rng.integers(-3, 4, 1000)
    split = colour_gpu.split_float32(x)
    head, rest = split[..., 0].astype(np.float64), split[..., 1].astype(np.float64)
    assert np.allclose(head + rest, x, rtol=2.0**-35, atol=0.0)
    mantissa, _ = np.frexp(head)
    scaled = mantissa * 2.0**colour_gpu.SPLIT_BITS
    assert np.array_equal(scaled, np.round(scaled))
    assert np.all(np.abs(rest) <= np.abs(x) * 2.0 ** (1 - colour_gpu.SPLIT_BITS))
    products = head[:-1] * head[1:]
    assert np.array_equal(products.astype(np.float32).astype(np.float64), products)
    assert np.array_equal(colour_gpu.split_float32(0.0), np.zeros(2, np.float32))


def test_angle_inputs_keep_grazing_accuracy():
    mirror = BraggMirror(1.0, 1.5, 100.0, 100.0, 10)
    theta = np.radians([0.0, 45.0, 89.0, 89.99, 90.0])
    inputs = colour_gpu.angle_inputs(mirror, theta).astype(np.float64)
    s, cos_theta, q1, q2sq = inputs[:, :4].T
    assert np.allclose(cos_theta, np.cos(theta), rtol=1e-7, atol=0.0)
    assert np.allclose(q1, np.cos(theta), rtol=1e-7, atol=0.0)
    assert np.allclose(q2sq, 2.25 - np.sin(theta) ** 2, rtol=1e-7)
    assert np.allclose(s, np.sin(theta), rtol=1e-7)
    assert np.allclose(inputs[:, 4] + inputs[:, 5], 100.0 * np.cos(theta), rtol=1e-9, atol=0.0)
    q2 = np.sqrt(2.25 - np.sin(theta) ** 2)
    assert np.allclose(inputs[:, 6] + inputs[:, 7], 100.0 * q2, rtol=1e-9, atol=0.0)
    dense = BraggMirror(1.5, 1.0, 100.0, 200.0, 10, host=1.5)  # n2 evanescent past 41.8 deg
    evanescent = colour_gpu.angle_inputs(dense, np.radians([60.0]))
    assert evanescent[0, 3] < 0.0
    assert np.array_equal(evanescent[:, 6:], np.zeros((1, 2)))


@pytest.mark.gpu
def test_gpu_n_dimensional_and_empty_theta():
    theta = np.linspace(0.0, 1.5, 6).reshape(3, 2)
    for function in (reference_xyz, spectral_xyz_stratified):
        xyz = function(FILMS[0], theta, backend="gpu")
        assert xyz.shape == (3, 2, 3) and xyz.dtype == np.float64
        assert np.array_equal(xyz.reshape(-1, 3), function(FILMS[0], theta.ravel(), backend="gpu"))
        assert function(FILMS[0], np.zeros((0, 2)), backend="gpu").shape == (0, 2, 3)
        assert function(FILMS[0], 0.3, backend="gpu").shape == (3,)


@pytest.mark.gpu
def test_gpu_needs_a_bragg_mirror_or_thin_film():
    with pytest.raises(ValueError, match=names("material")):
        reference_xyz(PERFECT_REFLECTOR, 0.1, backend="gpu")


@pytest.mark.gpu
def test_gpu_pipelines_are_specialised_by_host_match():
    matched = colour_gpu._kernel_and_params(MIRRORS[0])[0]
    other = colour_gpu._kernel_and_params(HOST_MIRRORS[0])[0]
    assert matched.constants["HOST_MATCHED"] is True
    assert other.constants["HOST_MATCHED"] is False
    assert colour_gpu._kernel_and_params(MIRRORS[5])[0] is matched  # cached, not rebuilt


# Mesa 22's llvmpipe ends a SIMD group's loops after 65536 iterations (gpu.loop_budget()):
# unchunked, the node loop of the 100000-sample "spectral" stopped at node 65535 (Y 5% low for
# this mirror).
LOOP_BUDGET_RTOL = 1e-4  # float32 sums of 100000 nodes; measured 1.1e-5


@pytest.mark.gpu
@pytest.mark.parametrize("material", [MIRRORS[1], ThinFilm(n_film=1.45, d=250.0, base="Ag")],
                         ids=["mirror", "film-over-Ag"])
def test_spectral_gpu_integrates_every_node_past_the_loop_budget(material):
    from wgbragg import gpu
    from wgbragg.colour.reference import MAX_SAMPLES

    assert MAX_SAMPLES > (gpu.loop_budget() or 65536)
    theta = np.linspace(0.0, 1.4, 8)
    gpu_xyz = spectral_xyz_stratified(material, theta, MAX_SAMPLES, backend="gpu", seed=1)
    numpy_xyz = spectral_xyz_stratified(material, theta, MAX_SAMPLES, seed=1)
    np.testing.assert_allclose(gpu_xyz, numpy_xyz, rtol=LOOP_BUDGET_RTOL)


@pytest.mark.gpu
@pytest.mark.parametrize("material", [MIRRORS[1], FILMS[2], ThinFilm(n_film=1.45, d=250.0,
                                                                     base="Ag")],
                         ids=material_id)
def test_gpu_chunks_of_nodes_sum_to_one_dispatch(monkeypatch, material):
    whole = reference_xyz(material, ANGLES, backend="gpu")
    monkeypatch.setattr(colour_gpu, "CHUNK_NODES", 100)  # 5 chunks, a partial last one
    chunked = reference_xyz(material, ANGLES, backend="gpu")
    np.testing.assert_allclose(chunked, whole, rtol=1e-5, atol=1e-7)
    assert colour_gpu.benchmark_xyz(material, ANGLES, *xyz_weights(), repeats=1) > 0.0
