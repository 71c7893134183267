"""LayeredBragg's single-reflection model by the float32 WGSL kernel (``backend="gpu"``,
wgsl/bsdf/layered/model.wgsl) against the float64 numpy model (``backend="numpy"``).

Both sides get the same float32-rounded directions and whole-nanometre wavelengths (where the
kernel's 1 nm tables need no interpolation in wavelength). What remains is float32: the
kernel's arithmetic, and its tables, built on the GPU by the float32 Yeh kernel and filter
product. Tolerances, relative to the largest value of a batch (per wavelength or channel),
about ten times the largest difference measured on lavapipe (``pytest -s`` prints them):

- ``F_RTOL`` on ``f`` (measured: 1.9e-5, the coated structure, spectral): the float32 tables
  and direction algebra; the half vector moves by ~1e-7 rad, a relative change of
  2/alpha * 1e-7 in a GGX peak.
- ``PDF_RTOL`` on ``pdf`` (measured 2.2e-4, the coated structure): its component
  probabilities read the wavelength-averaged transmissivity, whose float32 cell means of T
  (rough_layer._cell_transmittance, from the Bloch phases at the cell's ends) agree with
  float64 to 1.6e-5 of t, against 3e-6 for the point values they replaced.
- ``WEIGHT_RTOL`` on sample weights (measured 5.8e-5): ``f cos / pdf`` at a wo that itself
  moved by up to ``WO_ATOL``.
- ``LANDMARK_RTOL`` for factored RGB with in-kernel landmark colours (measured 5.4e-6, but
  the GPU landmark colours may differ from numpy's by 1e-4 in XYZ, tests/
  test_colour_landmarks_gpu).
- ``WO_ATOL`` on sampled directions (measured 1.1e-5): the VNDF map u -> m is
  ill-conditioned near the rim of its disk, where float32 rounding moves m as a 2-ulp change
  of u does (tests/test_microfacet).

N = 10**6 is checked for finiteness and bounds only: there float32 cannot resolve the phase of
the pass-band oscillation and the kernel returns its average (optics/yeh.wgsl), as it does inside
the
tables; the float64 model keeps the oscillation, sampled at whatever angles it is evaluated.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from wgbragg import BraggMirror, LayeredBragg, RoughBraggLayer, ShiftedPoints, gpu
from wgbragg.bsdf.layered import model_gpu as layered_gpu
from wgbragg.bsdf.layered.model import refract_in
from wgbragg.bsdf.transmission_filter import TransmissionFilter

pytestmark = pytest.mark.gpu

F_RTOL = 2e-4
PDF_RTOL = 2e-3
WEIGHT_RTOL = 5e-4
LANDMARK_RTOL = 1e-3
WO_ATOL = 1e-4
# Samples whose u picks a component within this of eq 35's boundary may pick the neighbour:
# the GPU's mean transmissivity tables differ from numpy's in float32.
PICK_MARGIN = 1e-4

A = BraggMirror(1.0, 1.5, 250.0, 250.0, 10)
B = BraggMirror(1.0, 1.6, 180.0, 220.0, 20)
COATED = BraggMirror(1.35, 1.5, 250.0, 250.0, 10)
COATED_LOWER = BraggMirror(1.35, 1.6, 200.0, 200.0, 5)
THIN = BraggMirror(1.0, 1.5, 120.0, 180.0, 1)
THICK = BraggMirror(1.0, 1.5, 250.0, 250.0, 10**6)
BEETLE = BraggMirror(1.59, 1.67, 81.6, 78.4, 8, host=1.0)  # Appendix D: seen from air

WAVELENGTHS = np.array([380.0, 451.0, 550.0, 642.0, 829.0])
METHODS = ("single-reflection", "single-reflection-lut")


@pytest.fixture(scope="module")
def filters():
    # Coarse filters (1 degree, 128 azimuths) keep the set-up fast; the twins share them.
    return {a: TransmissionFilter.bake(a, resolution_deg=1.0, psi_samples=128, backend="numpy")
            for a in (0.01, 0.05, 0.1, 0.4, 1.0)}


@pytest.fixture(scope="module")
def structures(filters):
    def rough(mirror, alpha):
        return RoughBraggLayer(mirror, alpha, transmission_filter=filters[alpha])

    return {
        # The default filter (0.25 degrees): another grid than the coarse ones.
        "one-layer": LayeredBragg([RoughBraggLayer(A, 0.1)]),
        "two-layers": LayeredBragg([rough(A, 0.05), rough(B, 0.4)], base_albedo=(0.8, 0.5, 0.2)),
        "coated": LayeredBragg([rough(COATED, 0.1), rough(COATED_LOWER, 1.0)], base_albedo=0.5),
        "N1-alpha0.01": LayeredBragg([rough(THIN, 0.01)], base_albedo=0.3),
        "N1e6-alpha1": LayeredBragg([rough(THICK, 1.0)], base_albedo=0.3),
        "appendix-D": LayeredBragg([rough(BEETLE, 0.1)]),
    }


COMPARED = ("one-layer", "two-layers", "coated", "N1-alpha0.01")


def unit(theta, phi):
    return np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)],
                    axis=-1)


def float32_directions(directions):
    """What the kernel sees (float32), in float64 for the numpy twin."""
    return np.asarray(directions, np.float64).astype(np.float32).astype(np.float64)


def random_directions(n, seed):
    rng = np.random.default_rng(seed)
    return float32_directions(unit(np.arccos(rng.uniform(0.0, 1.0, n)),
                                   rng.uniform(-np.pi, np.pi, n)))


def edge_pairs():
    """Normal incidence, wi == wo, the specular pair, grazing (z -> 0 and exactly 0)."""
    normal = np.array([0.0, 0.0, 1.0])
    tilted = unit(0.7, 0.3)
    grazing = [np.array([math.sqrt(1.0 - z * z), 0.0, z]) for z in (1e-3, 1e-5, 1e-7)]
    horizon = np.array([1.0, 0.0, 0.0])
    below = np.array([0.6, 0.0, -0.8])
    mirrored = tilted * np.array([-1.0, -1.0, 1.0])
    listed = [(normal, normal), (tilted, tilted), (tilted, mirrored), (normal, tilted),
              (horizon, normal), (normal, horizon), (horizon, horizon), (below, normal)]
    for g in grazing:
        listed += [(g, normal), (normal, g), (g, g), (g, g * np.array([-1.0, 1.0, 1.0])),
                   (g, tilted)]
    wi, wo = (np.array(side) for side in zip(*listed, strict=True))
    return float32_directions(wi), float32_directions(wo)


def pairs(n, seed):
    wi, wo = edge_pairs()
    return (np.concatenate([wi, random_directions(n, seed)]),
            np.concatenate([wo, random_directions(n, seed + 1)]))


def assert_close(gpu, reference, rtol, what):
    """|gpu - reference| <= rtol * max|reference| along each wavelength or channel."""
    assert gpu.shape == reference.shape
    assert np.all(np.isfinite(gpu)), f"{what}: non-finite GPU values"
    scale = np.abs(reference).reshape(-1, *reference.shape[-1:]).max(axis=0)
    error = np.abs(gpu - reference).reshape(-1, *reference.shape[-1:]).max(axis=0)
    print(f"{what}: max |gpu - numpy| / max|numpy| = {np.max(error / scale):.2e}")
    assert np.all(error <= rtol * scale), f"{what}: {error / scale} > {rtol}"


def limit_buffers(monkeypatch, nbytes):
    """Make the device's largest buffer ``nbytes`` wherever it is looked up: by the layered
    engine, which splits requests by it (``gpu.max_buffer_bytes``), and inside the harness,
    whose device arrays refuse larger buffers (``gpu.device``) and whose quads must fit it
    (``gpu.layouts``). An engine that stopped splitting then fails with a ValueError."""
    for module in (gpu, gpu.device, gpu.layouts):
        monkeypatch.setattr(module, "max_buffer_bytes", lambda: nbytes)


# --------------------------------------------------------------------------- layouts


def test_struct_layouts():
    assert layered_gpu.LAYER_DTYPE.itemsize == 80  # 20 words, a multiple of 16 as numpy pads
    assert layered_gpu.LAYER_DTYPE.fields["transmissivity_elsewhere"][1] == 64
    assert layered_gpu.PARAMS_DTYPE.itemsize == 64
    assert layered_gpu.PARAMS_DTYPE.fields["count"][1] == 48  # after a 48-byte LayeredStructure


# --------------------------------------------------------------------------- eq 34


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", COMPARED)
def test_brdf_spectral(structures, name, method):
    s = structures[name]
    wi, wo = pairs(400, seed=1)
    # Multiplexed: one invocation per pair, five wavelengths each.
    args = (wi[:, None], wo[:, None], WAVELENGTHS)
    gpu = s.brdf(*args, method=method, backend="gpu")
    assert_close(gpu, s.brdf(*args, method=method), F_RTOL, f"{name} {method} spectral")
    up = (wi[:, 2] > 0) & (wo[:, 2] > 0)
    assert np.all(gpu[~up] == 0.0)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", COMPARED)
def test_brdf_integrated_rgb(structures, name, method):
    s = structures[name]
    wi, wo = pairs(40, seed=2)
    gpu = s.brdf(wi, wo, method=method, backend="gpu")
    assert_close(gpu, s.brdf(wi, wo, method=method), F_RTOL, f"{name} {method} integrated")


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", COMPARED)
def test_brdf_factored_rgb(structures, name, method):
    """Factored RGB, each layer's colour by "reference": from the LUT, or in the kernel."""
    s = structures[name]
    wi, wo = pairs(60, seed=3)
    gpu = s.brdf(wi, wo, method=method, backend="gpu", colour_method="reference")
    reference = s.brdf(wi, wo, method=method, colour_method="reference")
    assert_close(gpu, reference, F_RTOL, f"{name} {method} reference")


def few_pairs(seed):
    """Normal, grazing, wi == wo, and random pairs: a dozen, for numpy's slow colour methods."""
    wi, wo = edge_pairs()
    pick = [0, 1, 2, 3, 8, 12, 18, 21]
    return (np.concatenate([wi[pick], random_directions(4, seed)]),
            np.concatenate([wo[pick], random_directions(4, seed + 1)]))


@pytest.mark.parametrize(("name", "colour_method"), [("two-layers", "averaged"),
                                                     ("coated", "approx")])
def test_brdf_factored_landmark_colours(structures, name, colour_method):
    """In-kernel landmark colours (colour/landmark_methods.wgsl) against numpy's."""
    s = structures[name]
    wi, wo = few_pairs(seed=4)
    gpu = s.brdf(wi, wo, backend="gpu", colour_method=colour_method)
    assert_close(gpu, s.brdf(wi, wo, colour_method=colour_method), LANDMARK_RTOL,
                 f"{name} {colour_method}")


def test_layer_seen_from_another_medium(structures):
    """Appendix D host (Yeh's complex amplitude path, HOST_MATCHED = false), over an absorbing
    base, where the layer's transmissivity does not enter eq 34."""
    s = structures["appendix-D"]
    wi, wo = pairs(200, seed=5)
    for method in METHODS:
        args = (wi[:, None], wo[:, None], WAVELENGTHS)
        assert_close(s.brdf(*args, method=method, backend="gpu"), s.brdf(*args, method=method),
                     F_RTOL, f"appendix-D {method}")
    wi, wo = few_pairs(seed=5)
    assert_close(s.brdf(wi, wo, backend="gpu", colour_method="averaged"),
                 s.brdf(wi, wo, colour_method="averaged"), LANDMARK_RTOL, "appendix-D averaged")


# --------------------------------------------------------------------------- eq 35


@pytest.mark.parametrize("name", COMPARED)
def test_pdf(structures, name):
    s = structures[name]
    wi, wo = pairs(1000, seed=6)
    gpu = s.pdf(wi, wo, backend="gpu")
    assert_close(gpu[:, None], s.pdf(wi, wo)[:, None], PDF_RTOL, f"{name} pdf")
    assert np.all(gpu[(wi[:, 2] <= 0) | (wo[:, 2] <= 0)] == 0.0)


def sample_inputs(n, seed):
    """wi from normal to grazing incidence; u with its corners."""
    rng = np.random.default_rng(seed)
    wi = np.concatenate([float32_directions([[0.0, 0.0, 1.0], [math.sqrt(1 - 1e-14), 0.0, 1e-7],
                                             [0.6, 0.0, 0.8], [0.6, 0.0, 0.8]]),
                         random_directions(n, seed)])
    wi = wi[wi[:, 2] > 0.0]
    u = rng.random((wi.shape[0], 3)).astype(np.float32).astype(np.float64)
    u[:4] = [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [0.5, 0.0, 1.0], [0.999, 1.0, 0.0]]
    return wi, u


def near_component_boundary(s, wi, u):
    """Samples whose u[..., 0] lies within PICK_MARGIN of a boundary of eq 35's choice."""
    n = s.host_index
    fresnel = s.coating_reflectance(wi)
    pick = (u[:, 0] - fresnel) / (1.0 - fresnel)
    edges = np.cumsum(s._component_probabilities(refract_in(wi, n)[:, 2], "numpy"), axis=-1)
    near_pick = np.min(np.abs(pick[:, None] - edges), axis=-1) < PICK_MARGIN
    return near_pick | (np.abs(u[:, 0] - fresnel) < PICK_MARGIN)


@pytest.mark.parametrize("spectral", [True, False], ids=["spectral", "rgb"])
@pytest.mark.parametrize("name", COMPARED)
def test_sample(structures, name, spectral):
    s = structures[name]
    wi, u = sample_inputs(2000, seed=7)
    wavelength = np.resize(WAVELENGTHS, wi.shape[0]) if spectral else None
    # RGB: the LUT's factored colours keep the numpy side fast.
    options = {} if spectral else {"method": "single-reflection-lut", "colour_method": "reference"}
    wo, weight, pdf = s.sample(wi, u, wavelength, backend="gpu", **options)
    wo_np, weight_np, pdf_np = s.sample(wi, u, wavelength, **options)
    same = ~near_component_boundary(s, wi, u)
    assert np.count_nonzero(same) > 0.99 * wi.shape[0]
    moved = np.abs(wo - wo_np).max(axis=-1)
    print(f"{name} sample: max |wo - wo_numpy| = {moved[same].max():.2e}")
    assert np.all(moved[same] <= WO_ATOL)
    assert np.all(np.isfinite(weight)) and np.all(np.isfinite(pdf)) and np.all(np.isfinite(wo))
    weight_np, weight = weight_np[same], weight[same]
    if spectral:
        weight, weight_np = weight[:, None], weight_np[:, None]
    assert_close(weight, weight_np, WEIGHT_RTOL, f"{name} sample weight")
    # A narrow lobe's density moves with wo: 1e-6 rad shifts a GGX peak of width 0.01 by 0.1%,
    # and near-grazing back-scattering (|wi + wo| ~ 0.01) magnifies that 100 times in the half
    # vector. So compare the density at the GPU's own float32 wo, not renormalised. 0 marks
    # the Dirac lobe and rejected directions.
    continuous = pdf > 0.0
    assert np.array_equal(continuous[same], pdf_np[same] > 0.0)
    assert_close(pdf[continuous][:, None], s.pdf(wi[continuous], wo[continuous])[:, None],
                 PDF_RTOL, f"{name} sample pdf")


def test_albedo(structures):
    s = structures["coated"]
    theta = np.radians([0.0, 40.0, 80.0])
    gpu = s.albedo(theta, 550.0, samples=1024, backend="gpu")
    assert_close(gpu[:, None], s.albedo(theta, 550.0, samples=1024)[:, None], WEIGHT_RTOL,
                 "coated albedo")
    rgb = s.albedo(theta, samples=256, backend="gpu")
    assert np.all(np.isfinite(rgb)) and np.all(rgb >= 0.0) and np.all(rgb <= 1.0 + 1e-3)


# --------------------------------------------------------------------------- extremes, shapes


@pytest.mark.parametrize("name", ["N1e6-alpha1", *COMPARED])
def test_extremes_are_finite(structures, name):
    s = structures[name]
    wi, wo = edge_pairs()
    up = (wi[:, 2] > 0) & (wo[:, 2] > 0)
    for method in METHODS:
        f = s.brdf(wi[:, None], wo[:, None], WAVELENGTHS, method=method, backend="gpu")
        rgb = s.brdf(wi, wo, method=method, backend="gpu")
        for value in (f, rgb):
            assert np.all(np.isfinite(value)) and np.all(value[~up] == 0.0)
        assert np.all(f >= 0.0)
    assert np.all(np.isfinite(s.pdf(wi, wo, backend="gpu")))
    wi_s, u = sample_inputs(60, seed=8)
    wo_s, weight, pdf = s.sample(wi_s, u, 550.0, backend="gpu")
    for value in (wo_s, weight, pdf):
        assert np.all(np.isfinite(value))
    assert np.all(weight >= 0.0) and np.all(pdf >= 0.0)
    np.testing.assert_allclose(np.linalg.norm(wo_s, axis=-1), 1.0, atol=1e-6)


def test_thick_mirror_albedo_bounded(structures):
    s = structures["N1e6-alpha1"]
    albedo = s.albedo(np.radians([0.0, 60.0]), WAVELENGTHS[:, None], samples=512, backend="gpu")
    assert np.all(albedo >= 0.0) and np.all(albedo <= 1.0 + 1e-2)


def test_shapes_and_multiplexing(structures):
    """Multiplexed, per-pair and broadcast wavelengths give the same values (pipelines with
    other WAVELENGTHS may contract float operations differently: 1e-6)."""
    s = structures["two-layers"]
    wi, wo = random_directions(6, seed=9), random_directions(6, seed=10)
    grid = s.brdf(wi[:, None], wo[:, None], WAVELENGTHS, backend="gpu")
    assert grid.shape == (6, WAVELENGTHS.size)
    for k, wavelength in enumerate(WAVELENGTHS):
        np.testing.assert_allclose(grid[:, k], s.brdf(wi, wo, wavelength, backend="gpu"),
                                   rtol=1e-6)
    # Each pair its own wavelengths, multiplexed; then one wavelength per pair.
    sets = WAVELENGTHS - np.arange(6)[:, None]
    mixed = s.brdf(wi[:, None], wo[:, None], sets, backend="gpu")
    for k in range(WAVELENGTHS.size):
        np.testing.assert_allclose(mixed[:, k], s.brdf(wi, wo, sets[:, k], backend="gpu"),
                                   rtol=1e-6)
    np.testing.assert_allclose(mixed[0], grid[0], rtol=1e-6)
    assert s.brdf(wi.reshape(2, 3, 3), wo[:3], backend="gpu").shape == (2, 3, 3)
    u = np.random.default_rng(11).random((4, 3))
    wo_s, weight, pdf = s.sample(wi[:, None], u, WAVELENGTHS[:, None, None], backend="gpu")
    assert wo_s.shape == (6, 4, 3) and pdf.shape == (6, 4)
    assert weight.shape == (WAVELENGTHS.size, 6, 4)
    one = s.sample(wi[:, None], u, WAVELENGTHS[0], backend="gpu")
    np.testing.assert_array_equal(one[0], wo_s)
    np.testing.assert_allclose(one[1], weight[0], rtol=1e-6)
    empty = s.brdf(np.zeros((0, 3)), wo[0], backend="gpu")
    assert empty.shape == (0, 3)


@pytest.mark.parametrize("name", ["one-layer", "two-layers"])
def test_a_view_shared_by_many_samples_is_uploaded_once(structures, name, monkeypatch):
    """wi shared along the trailing axes (a pixel's view and its samples) is uploaded once per
    pixel and read by the kernel as invocation / repeat: the same values, bit for bit, as the
    explicitly repeated request, with float32 or float64 u."""
    s = structures[name]
    wi = random_directions(5, seed=40)[:, None]
    u = np.random.default_rng(41).random((5, 7, 4), dtype=np.float32)
    wo = random_directions(35, seed=42).reshape(5, 7, 3)
    uploads = []
    real = layered_gpu._shared_vec4
    monkeypatch.setattr(layered_gpu, "_shared_vec4",
                        lambda a, shape: uploads.append(real(a, shape)) or uploads[-1])
    requests = {
        "hero": lambda w, v: s.sample(w, v, backend="gpu", colour_method="hero"),
        "float64 u": lambda w, v: s.sample(w, v[..., :3].astype(np.float64), backend="gpu"),
        "spectral": lambda w, v: s.sample(w[..., None, :], v[..., None, :3],
                                          np.array([450.0, 610.0]), backend="gpu"),
        "brdf": lambda w, v: s.brdf(w, wo, backend="gpu"),
        "brdf, multiplexed": lambda w, v: s.brdf(w[..., None, :], wo[..., None, :],
                                                 np.array([450.0, 610.0]), backend="gpu"),
    }
    for label, request in requests.items():
        uploads.clear()
        shared = request(wi, u)
        (rows, repeat), _ = [(upload.shape[0], r) for upload, r in uploads]
        assert (rows, repeat) == (5, 7), label
        repeated = request(np.repeat(wi, 7, axis=1), u)
        assert uploads[-2][0].shape[0] == 35 and uploads[-2][1] == 1, label
        if isinstance(shared, np.ndarray):
            shared, repeated = (shared,), (repeated,)
        for a, b in zip(shared, repeated, strict=True):
            np.testing.assert_array_equal(a, b, err_msg=label)


@pytest.mark.parametrize("name", ["one-layer", "coated"])
def test_shifted_points_are_expanded_by_the_kernel(structures, name, monkeypatch):
    """A ShiftedPoints u goes up as its points and one shift per group (not a number per
    sample), and the kernel's expansion gives the samples of its float32 values bit for bit;
    groups that are not the samples' leading axes, and the numpy backend, read the values."""
    s = structures[name]
    wi = random_directions(6, seed=60)[:, None]
    uploads = []
    real = layered_gpu._operand
    monkeypatch.setattr(layered_gpu, "_operand",
                        lambda *args: uploads.append(real(*args)) or uploads[-1])
    for width, options in ((4, {"colour_method": "hero"}), (3, {})):
        u = ShiftedPoints.sobol(16, width, (6,), seed=61)
        uploads.clear()
        compact = s.sample(wi, u, backend="gpu", **options)
        rows, repeat, shifted = uploads[-1]
        assert shifted and repeat == 16 and rows.shape == (16 + 6, 4)
        expanded = s.sample(wi, u.values(np.float32), backend="gpu", **options)
        assert not uploads[-1][2]
        for a, b in zip(compact, expanded, strict=True):
            np.testing.assert_array_equal(a, b)
        # One group for all: the groups are not the samples' leading axes.
        alone = ShiftedPoints(u.points, u.shifts[0])
        fallback = s.sample(wi, alone, backend="gpu", **options)
        assert not uploads[-1][2]
        for a, b in zip(fallback, s.sample(wi, alone.values(np.float32), backend="gpu",
                                           **options), strict=True):
            np.testing.assert_array_equal(a, b)
    # The numpy backend reads the same numbers: the same directions, up to float32.
    u = ShiftedPoints.sobol(16, 3, (6,), seed=62)
    wo_gpu = s.sample(wi, u, backend="gpu")[0].reshape(-1, 3)
    wo_np = s.sample(wi, u)[0].reshape(-1, 3)
    views = np.broadcast_to(wi, (6, 16, 3)).reshape(-1, 3)
    same = ~near_component_boundary(s, views, np.asarray(u).reshape(-1, 3))
    assert np.count_nonzero(same) > 0.9 * same.size
    assert np.all(np.abs(wo_gpu - wo_np).max(axis=-1)[same] <= WO_ATOL)


def test_shifted_points_beyond_one_buffer_are_expanded_by_the_host(structures, monkeypatch):
    """Requests larger than the device's largest buffer are split over dispatches, where the
    host expands a ShiftedPoints: the same samples as in one dispatch."""
    s = structures["one-layer"]
    wi = random_directions(6, seed=63)[:, None]
    u = ShiftedPoints.sobol(16, 4, (6,), seed=64)
    whole = s.sample(wi, u, backend="gpu", colour_method="hero")
    limit_buffers(monkeypatch, 16 * 40)  # 40 samples a dispatch
    split = s.sample(wi, u, backend="gpu", colour_method="hero")
    for a, b in zip(whole, split, strict=True):
        np.testing.assert_array_equal(a, b)


def test_shifted_points_are_timed_as_sample_inputs_only(structures):
    s = structures["one-layer"]
    wi = random_directions(6, seed=65)[:, None]
    u = ShiftedPoints.sobol(16, 4, (6,), seed=66)
    assert layered_gpu.benchmark(s, "sample", wi, u, colour_method="hero", repeats=1) > 0.0
    with pytest.raises(ValueError, match="second: a ShiftedPoints is the u of operation='sample'"):
        layered_gpu.benchmark(s, "brdf", wi, ShiftedPoints.sobol(16, 3, (6,)), repeats=1)
    with pytest.raises(ValueError, match="3 or 4 numbers per point"):
        layered_gpu.benchmark(s, "sample", wi, ShiftedPoints.sobol(16, 5, (6,)), repeats=1)


def test_tables_stay_on_the_device(structures, monkeypatch):
    """The read-only layer tables are uploaded by the first call of each kind (the model's and
    the simulation's), not by the calls after it; each call uploads only its own inputs."""
    s = dataclasses.replace(structures["two-layers"])  # fresh caches: nothing uploaded yet
    uploaded = []
    real = gpu.DeviceArray.upload
    monkeypatch.setattr(gpu.DeviceArray, "upload", classmethod(
        lambda cls, array, **kw: uploaded.append(kw.get("what")) or real(array, **kw)))
    wi, u = random_directions(6, seed=50), np.full((6, 4), 0.5, np.float32)
    per_round = []
    for _ in range(3):
        uploaded.clear()
        s.sample(wi, u, backend="gpu", colour_method="hero")
        s.simulate(wi, paths=4, mode="single", seed=1)
        per_round.append(list(uploaded))
    first, second, third = per_round
    tables = ("layer tables", "node colours", "transmissivity quads")
    # The first round also builds the tables (on the GPU, with uploads of its own).
    assert first.count("layer tables") == 2  # the model's and the simulation's
    assert first.count("node colours") == first.count("transmissivity quads") == 1  # model
    # Later rounds upload the per-call inputs alone (wi, u, layer records, spectra).
    assert not set(tables) & set(second + third)
    assert len(second) == len(third) > 0


@pytest.mark.parametrize(("call", "match"), [
    (lambda s: s.brdf([0, 0, 1.0], [0, 0, 1.0], 300.0, backend="gpu"), "360-830 nm"),
    (lambda s: s.sample([0, 0, 1.0], [0.5] * 3, 900.0, backend="gpu"), "360-830 nm"),
    (lambda s: s.brdf([0, 0, 1.0], [0, 0, 1.0], backend="gpu", colour_method="spectral"),
     "single-reflection-lut"),
])
def test_gpu_refusals(structures, call, match):
    with pytest.raises(ValueError, match=match):
        call(structures["one-layer"])


def test_landmark_colours_need_matched_hosts(structures):
    with pytest.raises(ValueError, match="host == n1"):
        structures["appendix-D"].brdf([0, 0, 1.0], [0, 0, 1.0], backend="gpu",
                                      colour_method="approx")


def test_shared_wavelengths_with_leading_unit_axes():
    """Wavelengths of shape (1, K) shared by every pair are uploaded once, as (K,) are."""
    s = LayeredBragg([RoughBraggLayer(A, 0.1)], base_albedo=0.5)
    wi = np.array([[0.3, 0.0, math.sqrt(0.91)]])
    wo = np.array([[-0.2, 0.1, math.sqrt(0.95)]])
    flat = s.brdf(wi[:, None], wo[:, None], WAVELENGTHS, backend="gpu")
    nested = s.brdf(wi[:, None], wo[:, None], WAVELENGTHS[None], backend="gpu")
    np.testing.assert_array_equal(nested, flat)


# --------------------------------------------------------------------------- loop budget
# llvmpipe ends an invocation's loops after 65535 iterations (wgbragg.gpu, "Loop budget").


def test_long_multiplexed_wavelength_axis_is_split(structures):
    """20000 wavelengths sharing their directions: at two layers one invocation loops 4 times
    a wavelength, and llvmpipe returned garbage from the 16384th on. Split over dispatches,
    they equal the same wavelengths evaluated one per invocation."""
    s = structures["two-layers"]
    wavelength = np.linspace(360.0, 830.0, 20000)
    wi, wo = random_directions(2, seed=20), random_directions(2, seed=21)
    multiplexed = s.brdf(wi[:, None], wo[:, None], wavelength, backend="gpu")
    one_each = s.brdf(wi, wo, wavelength[:, None], backend="gpu")
    np.testing.assert_allclose(multiplexed, one_each.T, rtol=1e-6, atol=0.0)
    u = np.random.default_rng(22).random((2, 3))
    wo_s, weight, pdf = s.sample(wi[:, None], u[:, None], wavelength, backend="gpu")
    wo_one, weight_one, pdf_one = s.sample(wi, u, wavelength[:, None], backend="gpu")
    assert wo_s.shape == (2, 1, 3) and weight.shape == (2, wavelength.size)
    np.testing.assert_array_equal(wo_s[:, 0], wo_one)
    np.testing.assert_array_equal(pdf[:, 0], pdf_one)
    np.testing.assert_allclose(weight, weight_one.T, rtol=1e-6, atol=0.0)
    assert 2 * layered_gpu.wavelengths_per_invocation(2) < wavelength.size


def test_grazing_mirror_pair_has_its_specular_value(structures):
    """wi and wo 1e-40 above the horizon (float32 subnormals), mirror images of each other:
    the half vector is the normal, whose square underflowed to NaN in brdf, pdf and RGB."""
    s = structures["one-layer"]
    wi, wo = np.array([1.0, 0.0, 1e-40]), np.array([-1.0, 0.0, 1e-40])
    np.testing.assert_allclose(s.brdf(wi, wo, 550.0, backend="gpu"), s.brdf(wi, wo, 550.0),
                               rtol=1e-5)
    np.testing.assert_allclose(s.pdf(wi, wo, backend="gpu"), s.pdf(wi, wo), rtol=1e-5)
    assert np.all(np.isfinite(s.brdf(wi, wo, backend="gpu")))


def test_batches_beyond_the_largest_buffer_are_dispatched_in_parts(structures, monkeypatch):
    """A batch of more invocations than the device's largest buffer holds (8.4 million
    directions on lavapipe: the scatterogram's sensor at 2900 x 2900) was a wgpu validation
    error. With the limit lowered to 256 KiB, 25000 directions take two to three dispatches
    and give the same values as one."""
    s = structures["one-layer"]
    wi, wo = random_directions(25000, seed=30), random_directions(25000, seed=31)
    u = np.random.default_rng(32).random((25000, 3))
    wavelength = np.linspace(400.0, 700.0, 7)
    whole = (s.brdf(wi, wo, backend="gpu"),
             s.brdf(wi[:, None], wo[:, None], wavelength, backend="gpu"),
             *s.sample(wi, u, backend="gpu"))
    dispatches = []
    real_dispatch = layered_gpu._dispatch
    monkeypatch.setattr(layered_gpu, "_dispatch",
                        lambda *args: dispatches.append(args[5].count) or real_dispatch(*args))
    limit_buffers(monkeypatch, 2**18)
    parts = (s.brdf(wi, wo, backend="gpu"),
             s.brdf(wi[:, None], wo[:, None], wavelength, backend="gpu"),
             *s.sample(wi, u, backend="gpu"))
    assert dispatches == [16384, 8616, 9362, 9362, 6276, 16384, 8616]
    for a, b in zip(whole, parts, strict=True):
        np.testing.assert_array_equal(a, b)


def test_benchmark_refuses_more_wavelengths_than_one_dispatch_takes(structures):
    s = structures["two-layers"]
    most = layered_gpu.wavelengths_per_invocation(2)
    with pytest.raises(ValueError, match=rf"wavelength: .*1 to {most} .*got {most + 1}"):
        layered_gpu.benchmark(s, "brdf", [0.0, 0.0, 1.0], [0.0, 0.0, 1.0],
                              np.linspace(400.0, 700.0, most + 1))


def test_benchmark_of_nothing_takes_no_time(structures):
    """An empty request whose shared axes would hold more than 2**32 repeats: nothing to run."""
    wi = np.zeros((0, 1, 1, 3))
    u = np.zeros((0, 70000, 70000, 4))
    assert layered_gpu.benchmark(structures["one-layer"], "sample", wi, u,
                                 colour_method="hero") == 0.0


@pytest.mark.parametrize(("method", "colour_method"), [
    ("single-reflection", "integrated"),
    ("single-reflection-lut", "integrated"),
    ("single-reflection", "reference"),
])
def test_colour_summed_in_the_kernel_bounds_the_layers(filters, method, colour_method):
    """The 471 nodes cost layers + 2 loop iterations each: 200 layers came out 0.3 % off in
    red on Mesa 22's llvmpipe (the last nodes were never summed). The bound follows the
    device's loop budget: 67 layers under Mesa 22's, 2224 without a budget."""
    from wgbragg import gpu

    layer = RoughBraggLayer(A, 0.1, transmission_filter=filters[0.1])
    most = layered_gpu.max_integrated_layers()
    assert 471 * (most + 2) <= gpu.planned_loop_iterations() < 471 * (most + 3)
    if gpu.loop_budget() is None:
        assert most == 2224
    elif gpu.loop_budget() == 65536:  # Mesa 22's
        assert most == 67
    s = LayeredBragg([layer] * (most + 1))
    with pytest.raises(ValueError, match=rf"layers: .*1 to {most} layers.*got {most + 1}"):
        s.brdf([0, 0, 1.0], [0, 0, 1.0], backend="gpu", method=method,
               colour_method=colour_method)
    if gpu.loop_budget() is None:
        # What Mesa 22 refused, 68 layers, is summed in the kernel as numpy sums it.
        s = LayeredBragg([layer] * 68)
        wi, wo = unit(0.3, 0.0), unit(0.2, 2.0)
        assert_close(s.brdf(wi, wo, backend="gpu", method=method, colour_method=colour_method),
                     s.brdf(wi, wo, method=method, colour_method=colour_method), F_RTOL,
                     "68 layers")


def test_landmark_colours_beyond_the_loop_budget_are_refused(filters):
    """Four layers of 20 um periods: their "averaged" colours need more loop iterations than
    Mesa 22's llvmpipe runs, which returned red 9 % off; now refused there (without a loop
    budget: the numpy value, within LANDMARK_RTOL)."""
    from wgbragg import gpu

    thick = BraggMirror(1.0, 1.5, 20000.0, 20000.0, 10)
    s = LayeredBragg([RoughBraggLayer(thick, 0.1, transmission_filter=filters[0.1])] * 4)
    wi, wo = unit(0.3, 0.0), unit(0.2, 2.0)
    if gpu.loop_budget() is not None:
        with pytest.raises(gpu.LoopBudgetError, match=r"4 layers.*50000 nm.*'averaged'"):
            s.brdf(wi, wo, backend="gpu", colour_method="averaged")
    else:
        assert_close(s.brdf(wi, wo, backend="gpu", colour_method="averaged"),
                     s.brdf(wi, wo, colour_method="averaged"), LANDMARK_RTOL, "thick")


def test_layers_on_different_filter_grids(filters):
    """Each layer's transmissivity is read on its own filter's grid (0.25 and 1 degree here),
    from the tables as cell corners (one offset per layer)."""
    s = LayeredBragg([RoughBraggLayer(A, 0.1),
                      RoughBraggLayer(B, 0.4, transmission_filter=filters[0.4])], base_albedo=0.5)
    assert s.layers[0].filter.theta_i.size != s.layers[1].filter.theta_i.size
    wi, wo = pairs(200, seed=8)
    args = (wi[:, None], wo[:, None], WAVELENGTHS)
    assert_close(s.brdf(*args, backend="gpu"), s.brdf(*args), F_RTOL, "different grids")


def test_plain_transmissivity_tables_give_the_quads_results(structures, monkeypatch):
    """Past gpu.BILINEAR_QUADS_MAX_BYTES the kernel reads the plain tables, four loads per
    lookup: the same arithmetic, so the same samples."""
    wi = random_directions(64, seed=54)
    u = np.random.default_rng(55).random((64, 4))
    with_quads = dataclasses.replace(structures["two-layers"])  # fresh caches
    expected = with_quads.sample(wi, u, backend="gpu", colour_method="hero")
    monkeypatch.setattr(gpu.layouts, "BILINEAR_QUADS_MAX_BYTES", 0)
    plain = dataclasses.replace(structures["two-layers"])
    got = plain.sample(wi, u, backend="gpu", colour_method="hero")
    for layout, s in ((True, with_quads), (False, plain)):
        variant = layered_gpu.gpu_variant(s, "spectral", False, "hero")
        assert variant.constants["TRANSMISSIVITY_QUADS"] is layout
    for a, b in zip(got, expected, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-7)
    assert np.any(expected[1] != 0.0)
