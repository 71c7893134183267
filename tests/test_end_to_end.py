"""The public array calls at their kernel's speed (issue 57): what the fast path changes must
not change a value.

- float32 inputs are taken without a copy and give, bit for bit, the values of the same
  inputs widened to float64 (the host forms the kernel's inputs in float64 from either);
- flat inputs that hold a grid (:func:`pointwise_gpu.grid_view`) give, bit for bit, what the
  broadcast grid and an unstructured (shuffled) order give;
- buffers reused across blocks and calls (:mod:`wgbragg.gpu.streams`) give identical values
  whatever was run before, for calls of any size and blocks of any length;
- a preallocated ``out=`` is filled in place (float32 holds the kernel's values exactly) and
  refused, naming ``out``, where its shape, dtype or layout is wrong;
- the host's threads (:func:`blocks.parallel_map`) keep order and errors.

The values themselves are held against the float64 twins by ``test_optics_gpu.py`` and
``test_float32_domain.py``; here a few points per call check that the fast path still
computes the mirror (within their tolerance of 2e-3). Speeds live in
``benchmarks/end_to_end.py`` (via ``python -m benchmarks.reflectance``), never here.
"""

from __future__ import annotations

import tracemalloc
from pathlib import Path

import numpy as np
import pytest
import wgpu

from wgbragg import BraggMirror, ThinFilm, gpu
from wgbragg.colour import colorimetry
from wgbragg.common import blocks
from wgbragg.common.validation import check_angle, check_wavelength
from wgbragg.gpu import buffers, streams
from wgbragg.optics import pointwise_gpu, thin_film_gpu, yeh_gpu

MIRROR = BraggMirror(1.0, 1.5, 125.0, 375.0, 20)
HOSTED = BraggMirror(1.59, 1.67, 81.6, 78.4, 8, host=1.0)
FILMS = (ThinFilm(1.33, 290.0), ThinFilm(1.45, 250.0, base="Cu"),
         ThinFilm(1.45, 120.0, n_base=1.2, k_base=0.5, host=1.3))
KERNELS = Path(__file__).parent / "kernels"
TWIN_TOLERANCE = 2e-3
"""|R32 - R64| at the same float64 inputs away from unresolved points (docs/design.md)."""


def _stats() -> dict[str, int]:
    return {**buffers.pool_info(), **streams.stream_info()}


def _flat_grid(rows: int, columns: int, dtype=np.float32):
    """A raveled (angle, wavelength) grid, wavelength fastest, and its axes."""
    wavelength = np.linspace(360.0, 830.0, columns).astype(dtype)
    theta = np.radians(np.linspace(0.0, 89.0, rows)).astype(dtype)
    angle, wave = np.meshgrid(theta, wavelength, indexing="ij")
    return wave.ravel(), angle.ravel(), wavelength, theta


# --------------------------------------------------------------------------- no device


def test_grid_view_of_angle_runs_and_periods():
    wave, angle, _, _ = _flat_grid(64, 96)
    w, a, shape = pointwise_gpu.grid_view(wave, angle, wave.shape)
    assert shape == (64, 96) and a.shape == (64, 1) and w.shape == (1, 96)
    np.testing.assert_array_equal(np.broadcast_to(a, shape).ravel(), angle)
    np.testing.assert_array_equal(np.broadcast_to(w, shape).ravel(), wave)
    # The angle fastest: a period of 64 angles, the wavelengths in runs of 64.
    wave_t, angle_t = wave.reshape(64, 96).T.ravel(), angle.reshape(64, 96).T.ravel()
    w, a, shape = pointwise_gpu.grid_view(wave_t, angle_t, wave_t.shape)
    assert shape == (96, 64) and a.shape == (1, 64) and w.shape == (96, 1)
    np.testing.assert_array_equal(np.broadcast_to(a, shape).ravel(), angle_t)
    np.testing.assert_array_equal(np.broadcast_to(w, shape).ravel(), wave_t)
    # Runs of angles beside wavelengths that are no grid's: every wavelength kept.
    scrambled = wave.copy()
    scrambled[100] = 400.0
    w, a, shape = pointwise_gpu.grid_view(scrambled, angle, wave.shape)
    assert shape == (64, 96) and a.shape == (64, 1) and w.shape == (64, 96)
    np.testing.assert_array_equal(np.broadcast_to(w, shape).ravel(), scrambled)
    # One wavelength for every point.
    w, a, shape = pointwise_gpu.grid_view(np.float32(550.0), angle, angle.shape)
    assert shape == (64, 96) and w.shape == (1, 1)


@pytest.mark.parametrize("case", ["shuffled", "uneven runs", "broken period", "small"])
def test_grid_view_leaves_other_inputs_alone(case):
    wave, angle, _, _ = _flat_grid(64, 96)
    if case == "shuffled":
        order = np.random.default_rng(0).permutation(wave.size)
        wave, angle = wave[order], angle[order]
    elif case == "uneven runs":
        wave, angle = wave[:-5], angle[:-5]
    elif case == "broken period":
        wave_t, angle_t = wave.reshape(64, 96).T.ravel(), angle.reshape(64, 96).T.copy().ravel()
        angle_t[-1] = angle_t[-2]
        wave, angle = wave_t, angle_t
    else:
        wave, angle = wave[:1000], angle[:1000]
    w, a, shape = pointwise_gpu.grid_view(wave, angle, wave.shape)
    assert w is wave and a is angle and shape == wave.shape


def test_checks_keep_float32_and_float64_arrays_without_a_copy():
    for dtype in (np.float32, np.float64):
        wavelength = np.linspace(360.0, 830.0, 11).astype(dtype)
        theta = np.linspace(0.0, 1.2, 11).astype(dtype)
        assert check_wavelength(wavelength, copy=False) is wavelength
        assert check_angle(theta, copy=False) is theta
        # The default still makes a float64 copy (callers may write into it).
        copied = check_wavelength(wavelength)
        assert copied.dtype == np.float64 and not np.shares_memory(copied, wavelength)


def test_checks_without_a_copy_refuse_and_clip_alike():
    pi_2 = np.array([0.5, np.float32(np.pi / 2)], np.float32)
    clipped = check_angle(pi_2, copy=False)
    assert clipped.dtype == np.float64 and clipped[1] == np.pi / 2
    assert float(pi_2[1]) > np.pi / 2  # float32's pi/2, above pi/2
    np.testing.assert_array_equal(clipped, check_angle(pi_2))
    for bad, match in (([1.0, np.nan], "theta contains NaN"), ([0.1, 1.6], r"theta must be in"),
                       ([-0.1], r"theta must be in")):
        with pytest.raises(ValueError, match=match):
            check_angle(np.array(bad, np.float32), copy=False)
    with pytest.raises(ValueError, match=r"wavelength_nm must be in \[1, 1e\+06\] nm"):
        check_wavelength(np.array([0.5, 500.0], np.float32), copy=False)
    with pytest.raises(ValueError, match="wavelength_nm contains NaN"):
        check_wavelength(np.array([500.0, np.nan]), copy=False)


def test_parallel_map_keeps_order_and_errors():
    items = list(range(37))
    for threads in (1, 2, 5):
        assert blocks.parallel_map(lambda k: k * k, items, threads) == [k * k for k in items]

    def fails(k):
        if k == 20:
            raise KeyError("item 20")
        return k

    with pytest.raises(KeyError, match="item 20"):
        blocks.parallel_map(fails, items, 3)
    assert blocks.parallel_map(str, []) == []


def test_host_threads_setting(monkeypatch):
    monkeypatch.setenv("WGBRAGG_HOST_THREADS", "3")
    assert blocks.host_threads() == 3
    monkeypatch.setenv("WGBRAGG_HOST_THREADS", "many")
    with pytest.raises(ValueError, match="WGBRAGG_HOST_THREADS"):
        blocks.host_threads()
    monkeypatch.delenv("WGBRAGG_HOST_THREADS")
    assert 1 <= blocks.host_threads() <= blocks.MAX_HOST_THREADS


def test_check_out_names_the_parameter():
    shape = (3, 4)
    assert blocks.check_out(None, shape).shape == shape
    good = np.empty(shape, np.float32)
    assert blocks.check_out(good, shape) is good
    read_only = np.empty(shape)
    read_only.flags.writeable = False
    for bad, problem in ((np.empty((4, 3)), r"shape \(4, 3\) \(expected the broadcast shape "
                                            r"\(3, 4\)\)"),
                         (np.empty(shape, np.int32), "dtype int32"),
                         (np.empty((3, 8))[:, ::2], "not C-contiguous"),
                         (read_only, "read-only"),
                         ([[0.0] * 4] * 3, "out must be a numpy array, got list")):
        with pytest.raises(ValueError, match=problem):
            blocks.check_out(bad, shape)


def test_colour_matrix_in_blocks_is_the_product():
    rng = np.random.default_rng(1)
    xyz = rng.uniform(0.0, 1.0, (3, 70001, 3))
    np.testing.assert_allclose(colorimetry.xyz_to_linear_srgb(xyz),
                               xyz @ colorimetry.XYZ_TO_LINEAR_SRGB.T, rtol=0, atol=1e-15)
    np.testing.assert_allclose(colorimetry.linear_srgb_to_xyz(
        colorimetry.xyz_to_linear_srgb(xyz)), xyz, rtol=0, atol=1e-14)
    assert colorimetry.xyz_to_linear_srgb(np.ones(3)).shape == (3,)


# --------------------------------------------------------------------------- on the device


@pytest.mark.gpu
@pytest.mark.parametrize("structure", [MIRROR, HOSTED, *FILMS],
                         ids=["mirror", "hosted", "film", "film-cu", "film-conductor"])
@pytest.mark.parametrize("quantity", ["reflectance", "transmittance"])
def test_float32_inputs_give_the_values_of_their_float64_widening(structure, quantity):
    wave, angle, _, _ = _flat_grid(37, 53)
    call = getattr(structure, quantity)
    got = call(wave, angle, "unpolarized", backend="gpu")
    want = call(wave.astype(np.float64), angle.astype(np.float64), "unpolarized",
                backend="gpu")
    assert got.dtype == np.float64 and got.shape == wave.shape
    np.testing.assert_array_equal(got, want)
    twin = call(wave.astype(np.float64), angle.astype(np.float64), "unpolarized")
    assert np.median(np.abs(got - twin)) < 1e-5
    assert np.mean(np.abs(got - twin) < TWIN_TOLERANCE) > 0.99


@pytest.mark.gpu
@pytest.mark.parametrize("structure", [MIRROR, HOSTED, FILMS[1]], ids=["mirror", "hosted", "cu"])
def test_grids_flat_broadcast_and_shuffled_give_the_same_bits(structure):
    wave, angle, wavelength, theta = _flat_grid(61, 130, np.float64)
    flat = structure.reflectance(wave, angle, "s", backend="gpu")
    grid = structure.reflectance(wavelength[None, :], theta[:, None], "s", backend="gpu")
    transposed = structure.reflectance(wavelength[:, None], theta[None, :], "s", backend="gpu")
    order = np.random.default_rng(2).permutation(wave.size)
    shuffled = np.empty_like(flat)
    shuffled[order] = structure.reflectance(wave[order], angle[order], "s", backend="gpu")
    np.testing.assert_array_equal(flat, grid.ravel())
    np.testing.assert_array_equal(flat, transposed.T.ravel())
    np.testing.assert_array_equal(flat, shuffled)


@pytest.mark.gpu
def test_point_inputs_are_those_a_call_forms():
    """The all-at-once twin of the streamed forming (kernel benchmarks use it) reads the same
    bits as every point of a call: the kernel run on them gives the call's values."""
    wave, angle, _, _ = _flat_grid(29, 41)
    points, inverse, _ = yeh_gpu.point_inputs(1.0, 1.5, 125.0, 375.0, 1.0, wave, angle)
    assert points.shape == (wave.size, 4) and inverse.shape == (wave.size,)
    kernel = gpu.compute_pipeline("optics/yeh_reflectance.wgsl",
                                  constants=yeh_gpu.bragg_constants(1.0, 1.0, "s"))
    (direct,) = kernel.run([points, inverse], [(wave.size, np.float32)],
                           yeh_gpu.bragg_params(1.0, 1.5, 125.0, 375.0, 20, 1.0))
    np.testing.assert_array_equal(MIRROR.reflectance(wave, angle, "s", backend="gpu"), direct)
    # The phases are the float64 reduction of the optical paths, rounded once.
    wide = np.asarray(wave, np.float64)
    s, cos_theta, _, _ = yeh_gpu.angle_geometry(1.0, 1.5, 1.0, np.asarray(angle, np.float64))
    q2 = np.sqrt(np.maximum(yeh_gpu.float32_geometry(1.5, 1.0, s, cos_theta), 0.0))
    np.testing.assert_array_equal(points[:, 3], pointwise_gpu.reduced_turns(
        q2 * 375.0 * (1.0 / wide)).astype(np.float32))
    film_points, _ = thin_film_gpu.point_inputs(1.0, 1.33, 290.0, wave, angle)
    np.testing.assert_array_equal(film_points[:, 3], (1.0 / wide).astype(np.float32))


@pytest.mark.gpu
def test_reused_buffers_give_identical_results_across_calls_of_any_size():
    wave, angle, wavelength, theta = _flat_grid(90, 300)
    first = MIRROR.reflectance(wave, angle, "p", backend="gpu")
    before = _stats()
    for rows in (1, 7, 300, 5000, 5001, 6000):  # other sizes in between, some in one class
        MIRROR.reflectance(wavelength[:rows % 300 + 1, None], theta[None, :5], backend="gpu")
        FILMS[1].reflectance(wave[:rows], angle[:rows], "s", backend="gpu")
    again = MIRROR.reflectance(wave, angle, "p", backend="gpu")
    np.testing.assert_array_equal(first, again)
    after = _stats()
    assert after["streams"] - before["streams"] == 13
    assert after["states_reused"] - before["states_reused"] >= 3  # 5000-6000, and `first`
    assert after["idle_bytes"] <= buffers.POOL_BYTES
    assert after["state_bytes"] <= streams.STATE_BYTES


@pytest.mark.gpu
def test_buffer_pool_hands_out_idle_buffers_of_the_class(monkeypatch):
    monkeypatch.setattr(buffers, "POOL_BYTES", 1 << 40)  # room whatever earlier tests left
    usage = wgpu.BufferUsage.STORAGE | wgpu.BufferUsage.COPY_DST
    first = buffers.take_buffer(3000, usage)
    assert first.size == 4096
    buffers.give_buffer(first)
    again = buffers.take_buffer(2100, usage)  # the same class: the idle one
    assert again is first
    other = buffers.take_buffer(2100, usage)  # none idle: a new one
    assert other is not first and other.size == 4096
    for buffer in (again, other):
        buffers.give_buffer(buffer)


@pytest.mark.gpu
@pytest.mark.parametrize("depth", [1, 2, 3])
@pytest.mark.parametrize("block_rows", [1, 37, 1000, None])
def test_stream_blocks_of_any_length_and_depth(block_rows, depth):
    """Rows formed in place, any block length (the last one short), any number in flight:
    each output row lands in its place of the caller's array (float32 into float64)."""
    n = 2500
    x = np.arange(n, dtype=np.float32)
    y = np.linspace(1.0, 2.0, n, dtype=np.float32)
    saxpy = _saxpy()
    params = np.zeros((), gpu.struct_dtype([("a", "f32")]))
    params["a"] = 3.0
    out = np.full(n, -1.0)
    with streams.Stream(saxpy, [streams.Streamed(), streams.Streamed()], [((), np.float32)],
                        params, count=n, block_rows=block_rows, depth=depth) as stream:
        assert stream.rows == min(n, block_rows or n)
        for start in range(0, n, stream.rows):
            stop = min(start + stream.rows, n)
            host_x, host_y = stream.inputs()
            host_x[:stop - start], host_y[:stop - start] = x[start:stop], y[start:stop]
            stream.submit(stop - start, [out[start:stop]])
    np.testing.assert_array_equal(out, (np.float32(3.0) * x + y).astype(np.float64))


def _saxpy() -> gpu.Kernel:
    """The test kernel ``out = a x + y``, bounds-checked by ``arrayLength(&out)``."""
    return gpu.compute_pipeline(str(KERNELS / "saxpy.wgsl"))


@pytest.mark.gpu
@pytest.mark.parametrize("backend", ["gpu", "numpy"])
@pytest.mark.parametrize("structure", [MIRROR, FILMS[1]], ids=["mirror", "film-cu"])
@pytest.mark.parametrize("quantity", ["reflectance", "transmittance", "absorptance"])
def test_out_is_filled_in_place(structure, quantity, backend):
    wavelength, theta = np.linspace(380.0, 780.0, 23), np.radians([0.0, 30.0, 60.0, 89.0])
    call = getattr(structure, quantity)
    want = call(wavelength[:, None], theta, "s", backend)
    for dtype in (np.float64, np.float32):
        out = np.full((23, 4), -1.0, dtype)
        assert call(wavelength[:, None], theta, "s", backend, out=out) is out
        # float32 holds the kernel's float32 values exactly; float64's are rounded once.
        np.testing.assert_array_equal(out, want.astype(dtype))


@pytest.mark.gpu
@pytest.mark.parametrize("backend", ["gpu", "numpy"])
def test_a_wrong_out_is_refused_naming_it(backend):
    wavelength, theta = np.linspace(380.0, 780.0, 5), np.radians([0.0, 30.0])
    read_only = np.zeros((5, 2))
    read_only.flags.writeable = False
    for bad in (np.zeros((2, 5)), np.zeros((5, 2), np.int64), np.zeros((5, 4))[:, ::2],
                read_only, np.zeros(10)):
        with pytest.raises(ValueError, match=r"^out "):
            MIRROR.reflectance(wavelength[:, None], theta, "s", backend, out=bad)
    with pytest.raises(ValueError, match="out must be a numpy array, got list"):
        FILMS[0].reflectance(wavelength[:, None], theta, "s", backend, out=[[0.0] * 2] * 5)


@pytest.mark.gpu
def test_a_float32_call_copies_no_input():
    """4M float32 points into a float32 ``out``: the host holds the blocks in flight and the
    per-angle terms, not a float64 copy of the inputs (64 MB) nor a new output."""
    wave, angle, _, _ = _flat_grid(2048, 2048)
    order = np.random.default_rng(3).permutation(wave.size)  # no grid: every point formed
    out = np.empty(wave.size, np.float32)
    for wavelength, theta in ((wave, angle), (wave[order], angle[order])):
        MIRROR.reflectance(wavelength[:1024], theta[:1024], "s", backend="gpu")  # warm
        tracemalloc.start()
        try:
            MIRROR.reflectance(wavelength, theta, "s", backend="gpu", out=out)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        copies = 2 * wave.size * 8
        assert peak < copies / 2, (peak, copies)


@pytest.mark.gpu
def test_pass_clock_counts_every_block():
    wave, angle, _, _ = _flat_grid(512, 2048)  # 1M points: two blocks of 2^19 rows
    with gpu.pass_clock() as clock:
        values = MIRROR.reflectance(wave, angle, "s", backend="gpu")
    assert clock.passes == 2 and clock.seconds > 0.0
    np.testing.assert_array_equal(values, MIRROR.reflectance(wave, angle, "s", backend="gpu"))


@pytest.mark.gpu
@pytest.mark.parametrize("document", [
    {"material": "bragg-mirror", "fixed": {"n1": 1.0, "n2": 1.5, "N": 12, "delta": 0.4},
     "coords": {"period_nm": [150.0, 200.0, 260.0], "theta_deg": [0.0, 35.0, 70.0],
                "wavelength_nm": [400.0, 500.0, 600.0, 700.0]},
     "chunks": {"period_nm": 2},
     "quantities": [{"kind": "reflectance", "polarization": "p"}, {"kind": "transmittance"}]},
    {"material": "thin-film", "fixed": {"n_film": 1.45, "base": "Cu", "theta_deg": 30.0},
     "coords": {"thickness_nm": [100.0, 250.0, 400.0], "wavelength_nm": [450.0, 550.0, 650.0]},
     "chunks": {"thickness_nm": 2},
     "dtype": "float32",
     "quantities": [{"kind": "reflectance"}, {"kind": "transmittance"}]},
], ids=["mirror", "film-fixed-angle"])
def test_sweep_chunks_written_in_place_are_the_calls_values(document):
    """A chunk's spectra written straight into it by deferred calls (the last ones still in
    flight as the next structure is formed) hold each structure's own call's values."""
    from wgbragg.sweep import parse_sweep
    from wgbragg.sweep.evaluate import evaluate_block
    from wgbragg.sweep.spec import ANGLE, WAVELENGTH

    sweep = parse_sweep(document)
    structure_dim = sweep.structure_dims[0]
    for quantity in sweep.quantities:
        for index in sweep.blocks(quantity):
            chunk = evaluate_block(sweep, quantity, index)
            ranges = sweep.block_slices(quantity, index)
            theta = np.radians(sweep.angle_deg(ranges.get(ANGLE)))
            wavelength = sweep.coords[WAVELENGTH][ranges[WAVELENGTH]]
            assert chunk.dtype == np.dtype(sweep.dtype)
            for local, value in enumerate(sweep.coords[structure_dim][ranges[structure_dim]]):
                structure = sweep.structure({structure_dim: float(value)})
                want = getattr(structure, quantity.kind)(
                    wavelength[None, :], theta[:, None], quantity.polarization, "gpu")
                if ANGLE not in ranges:
                    want = want[0]
                np.testing.assert_array_equal(chunk[local], want.astype(chunk.dtype))


@pytest.mark.gpu
def test_deferred_streams_fill_their_targets_by_the_end_and_do_not_nest():
    wavelength, theta = np.linspace(380.0, 780.0, 200), np.radians(np.linspace(0, 80, 300))
    mirrors = [BraggMirror(1.0, 1.5, d, 2 * d, 15) for d in (80.0, 100.0, 120.0)]
    want = [m.reflectance(wavelength[:, None], theta, "s", "gpu") for m in mirrors]
    outs = [np.full((200, 300), np.nan) for _ in mirrors] * 4  # more than DEFERRED_STREAMS
    with streams.deferred():
        for k, out in enumerate(outs):
            mirrors[k % 3].reflectance(wavelength[:, None], theta, "s", "gpu", out=out)
        with pytest.raises(RuntimeError, match="do not nest"), streams.deferred():
            pass
    for k, out in enumerate(outs):
        np.testing.assert_array_equal(out, want[k % 3])
    # An error inside the block drops what is in flight; later calls are unaffected.
    with pytest.raises(KeyError), streams.deferred():
        mirrors[0].reflectance(wavelength[:, None], theta, "s", "gpu", out=outs[0])
        raise KeyError("inside")
    np.testing.assert_array_equal(mirrors[1].reflectance(wavelength[:, None], theta, "s", "gpu"),
                                  want[1])


@pytest.mark.gpu
@pytest.mark.parametrize("mapped", [True, False], ids=["storage-mapped", "staging-copies"])
def test_streams_give_the_same_bits_mapped_or_through_staging(mapped, monkeypatch):
    """A CPU adapter's streams map their storage buffers (``maps_storage``); a GPU's copy
    through mappable staging buffers. Both give the values of the all-at-once inputs, over
    several blocks."""
    monkeypatch.setattr(streams, "maps_storage", lambda: mapped)
    wave, angle, _, _ = _flat_grid(300, 1000)
    points, inverse, _ = yeh_gpu.point_inputs(1.59, 1.67, 81.6, 78.4, 1.0, wave, angle)
    kernel = gpu.compute_pipeline("optics/yeh_reflectance.wgsl",
                                  constants=yeh_gpu.bragg_constants(1.59, 1.0, "p"))
    (direct,) = kernel.run([points, inverse], [(wave.size, np.float32)],
                           yeh_gpu.bragg_params(1.59, 1.67, 81.6, 78.4, 8, 1.0))
    monkeypatch.setattr(gpu.device, "max_buffer_bytes", lambda: 1 << 20)  # 16 blocks
    np.testing.assert_array_equal(HOSTED.reflectance(wave, angle, "p", backend="gpu"), direct)
