"""Bounded work (issue 40, item 4): blockwise evaluation of broadcast elementwise functions
(``wgbragg.common.blocks``), GPU runs of any element count (``gpu.Rows``, ``Kernel.run``),
and ``Renderer.render(seconds=...)`` planned from measured dispatch times (``TimeBudget``).

No test is timed: the GPU split is forced with small limits (a patched largest buffer, a
small ``block_rows``), and the time planning is checked on simulated costs; the real renders
with ``seconds`` use a budget so small that exactly one dispatch (the probe) runs.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from wgbragg import BraggMirror, ThinFilm, gpu
from wgbragg.common import blocks as blocks_module
from wgbragg.common.blocks import DEFAULT_BLOCK, block_ranges, blockwise, flat_block
from wgbragg.gpu import streams
from wgbragg.optics import stacks
from wgbragg.render import time_budget
from wgbragg.render.renderer import Renderer
from wgbragg.render.time_budget import PassPlan, TimeBudget
from wgbragg.scene.reader import load_preset

KERNELS = Path(__file__).resolve().parent / "kernels"


def smooth(w, t):
    """An elementwise function with transcendental and broadcast parts."""
    return np.sqrt(w) * np.cos(t) + np.exp(-t * t) / w


# --------------------------------------------------------------------------- blocks


SHAPES = [
    ((), ()),
    ((7,), ()),
    ((5, 1), (1, 9)),
    ((3, 1, 4), (2, 1)),
    ((1, 6, 1, 5), (4, 1, 3, 1)),
    ((1000, 1), (1, 700)),
]


@pytest.mark.parametrize(("a", "b", "block"), [
    (a, b, block) for a, b in SHAPES for block in (1, 3, 17, 64, 1000, DEFAULT_BLOCK)
    # Blocks of a few elements over 700,000 would take seconds.
    if block >= 64 or math.prod(np.broadcast_shapes(a, b)) <= 10_000])
def test_blockwise_is_bit_identical_to_the_unblocked_call(a, b, block):
    rng = np.random.default_rng(1)
    w = rng.uniform(300.0, 900.0, a)
    t = rng.uniform(0.0, 1.5, b)
    expected = smooth(w, t)
    got = blockwise(smooth, w, t, block=block)
    assert got.shape == np.broadcast_shapes(a, b) and got.dtype == np.float64
    np.testing.assert_array_equal(got, expected)


def test_each_block_holds_at_most_block_elements_and_keeps_the_broadcast_structure():
    w = np.linspace(400.0, 700.0, 50)[:, None]
    t = np.linspace(0.0, 1.0, 30)[None, :]
    seen = []

    def spy(w_part, t_part):
        seen.append((w_part.shape, t_part.shape))
        return smooth(w_part, t_part)

    blockwise(spy, w, t, block=100)
    # 100 // 30 = 3 rows a block: (3, 1) wavelengths against all (1, 30) angles, never
    # broadcast in full.
    assert seen[0] == ((3, 1), (1, 30))
    assert len(seen) == math.ceil(50 / 3)
    assert all(ws[0] * ts[1] <= 100 for ws, ts in seen)
    assert seen[-1] == ((50 - 16 * 3, 1), (1, 30))


def test_blocks_cover_the_array_once_in_order():
    shape = (3, 5, 7)
    for block in (1, 4, 7, 20, 35, 36, 104, 105, 1000):
        covered = np.zeros(shape, int)
        flat_next = 0
        for index, start, stop in block_ranges(shape, block):
            part = covered[index]
            assert part.size == stop - start <= block
            assert start == flat_next
            flat_next = stop
            # The block's index and its flat range name the same elements.
            np.testing.assert_array_equal(
                np.arange(math.prod(shape)).reshape(shape)[index].ravel(),
                np.arange(start, stop))
            covered[index] += 1
        assert flat_next == math.prod(shape)
        np.testing.assert_array_equal(covered, 1)


def test_empty_inputs_give_empty_outputs():
    calls = []

    def spy(w, t):
        calls.append(np.broadcast_shapes(w.shape, t.shape))
        return smooth(w, t)

    out = blockwise(spy, np.ones((0, 1)), np.ones((1, 5)))
    assert out.shape == (0, 5) and out.dtype == np.float64
    assert calls == [(0, 5)]  # once, for the dtype
    out = blockwise(spy, np.ones((4, 0)), 1.0, dtype=np.float32)
    assert out.shape == (4, 0) and out.dtype == np.float32 and len(calls) == 1
    assert list(block_ranges((3, 0, 2), 5)) == []


def test_blockwise_tuples_out_and_errors():
    w = np.linspace(1.0, 2.0, 6)[:, None]
    t = np.linspace(0.0, 1.0, 4)
    first, second = blockwise(lambda a, b: (a + b, a * b), w, t, block=5)
    np.testing.assert_array_equal(first, w + t)
    np.testing.assert_array_equal(second, w * t)
    out = np.full((6, 4), np.nan)
    assert blockwise(np.add, w, t, block=3, out=out) is out
    np.testing.assert_array_equal(out, w + t)
    scalar = blockwise(np.multiply, 2.0, 3.0)
    assert scalar.shape == () and scalar == 6.0
    with pytest.raises(ValueError, match="block must be an integer >= 1"):
        blockwise(np.add, w, t, block=0)
    with pytest.raises(ValueError, match="broadcast shape"):
        blockwise(np.add, w, t, out=np.empty((4, 6)))
    with pytest.raises(ValueError):
        blockwise(np.add, np.ones(3), np.ones(4))


@pytest.mark.parametrize(("a", "b"), SHAPES[:5])
def test_flat_block_is_the_raveled_broadcast(a, b):
    rng = np.random.default_rng(2)
    w, t = rng.standard_normal(a), rng.standard_normal(b)
    shape = np.broadcast_shapes(a, b)
    size = math.prod(shape)
    full = [np.broadcast_to(x, shape).ravel() for x in (w, t)]
    for start, stop in ((0, size), (0, 0), (size // 3, size - size // 4), (size - 1, size)):
        got = flat_block([w, t], start, stop)
        for value, expected in zip(got, full, strict=True):
            assert value.shape == (stop - start,)
            np.testing.assert_array_equal(value, expected[start:stop])
    with pytest.raises(ValueError, match="outside"):
        flat_block([w, t], 0, size + 1)


# --------------------------------------------------------------------------- GPU: any count


def saxpy():
    kernel = gpu.compute_pipeline(str(KERNELS / "saxpy.wgsl"))
    params = np.zeros((), gpu.struct_dtype([("a", "f32")]))
    params["a"] = 2.5
    return kernel, params


@pytest.mark.gpu
def test_rows_stream_any_count_in_blocks_that_fit_the_buffers(monkeypatch):
    # A largest buffer of 4 KiB (1024 floats): 10,000 points need 10 blocks; each block's
    # rows are made on demand, in order, and the result is exact.
    monkeypatch.setattr(gpu.device, "max_buffer_bytes", lambda: 4096)
    kernel, params = saxpy()
    n = 10_000
    x = np.arange(n, dtype=np.float32)
    y = np.ones(n, np.float32)
    made = []

    def rows(start, stop):
        made.append((start, stop))
        return x[start:stop]

    assert kernel.plan_rows([gpu.Rows(rows), gpu.Rows.of(y)], [((n,), np.float32)], n) == 1024
    (out,) = kernel.run([gpu.Rows(rows), gpu.Rows.of(y)], [(n, np.float32)], params)
    np.testing.assert_array_equal(out, 2.5 * x + 1.0)
    assert made == [(s, min(s + 1024, n)) for s in range(0, n, 1024)]
    # Without Rows the same count is refused, naming the input and the limit, before upload.
    with pytest.raises(ValueError, match=r"input 0: 40000 bytes exceed .*\(4096 bytes"):
        kernel.run([x, y], [(n, np.float32)], params)


@pytest.mark.gpu
def test_rows_split_by_the_dispatch_limit_and_by_block_rows(monkeypatch):
    kernel, params = saxpy()
    n = 5000
    x = np.random.default_rng(3).standard_normal(n).astype(np.float32)
    y = np.random.default_rng(4).standard_normal(n).astype(np.float32)
    monkeypatch.setattr(gpu.pipelines, "MAX_INDEX", 640)
    assert kernel.dispatch_limit() == 640
    assert kernel.plan_rows([gpu.Rows.of(x), y], [(n, np.float32)], n) == 640
    # Without Rows a count beyond one dispatch is refused before anything is uploaded.
    with pytest.raises(ValueError, match=r"count 5000 exceeds the 640 invocations"):
        kernel.run([x, y], [(n, np.float32)], params)
    (out,), seconds = kernel.run([gpu.Rows.of(x), gpu.Rows.of(y)], [(n, np.float32)], params,
                                 timestamps=True)
    np.testing.assert_array_equal(out, np.float32(2.5) * x + y)
    assert seconds > 0.0
    (out,) = kernel.run([gpu.Rows.of(x), gpu.Rows.of(y)], [(n, np.float32)], params,
                        block_rows=333)
    np.testing.assert_array_equal(out, np.float32(2.5) * x + y)


@pytest.mark.gpu
def test_rows_refusals_name_the_input_and_the_limit(monkeypatch):
    kernel, params = saxpy()
    n = 100
    x = np.ones(n, np.float32)
    made = []

    def rows(start, stop):
        made.append(start)
        return x[start:stop]

    # A shared input larger than a buffer cannot be split: refused before any row is made.
    monkeypatch.setattr(gpu.device, "max_buffer_bytes", lambda: 256)
    with pytest.raises(ValueError, match=r"input 1: 400 bytes exceed .*\(256 bytes"):
        kernel.run([gpu.Rows(rows), x], [(n, np.float32)], params)
    assert made == []
    # One row wider than a buffer neither.
    wide = gpu.Rows(rows, (128,), np.float32)
    with pytest.raises(ValueError, match=r"input 0: one invocation's row of 512 bytes exceeds"):
        kernel.plan_rows([wide, x[:10]], [(n, np.float32)], n)
    with pytest.raises(ValueError, match="first axis of shape"):
        kernel.run([gpu.Rows(rows), gpu.Rows(rows)], [(n + 1, np.float32)], params, count=n)
    with pytest.raises(TypeError, match="returned dtype float64"):
        kernel.run([gpu.Rows(lambda a, b: np.ones(b - a)), gpu.Rows(rows)],
                   [(n, np.float32)], params)
    with pytest.raises(ValueError, match=r"returned shape \(2,\)"):
        kernel.run([gpu.Rows(lambda a, b: np.ones(2, np.float32)), gpu.Rows(rows)],
                   [(n, np.float32)], params)
    with pytest.raises(TypeError, match="streamed by run"):
        kernel.bind([gpu.Rows(rows), x], [(n, np.float32)], params)
    (empty,) = kernel.run([gpu.Rows(rows), gpu.Rows(rows)], [(0, np.float32)], params)
    assert empty.shape == (0,) and made == []


@pytest.mark.parametrize("structure", [
    BraggMirror(1.0, 1.5, 125.0, 375.0, 20, host=1.2),
    ThinFilm(1.33, 300.0, base="Au"),
], ids=["mirror", "film-over-gold"])
def test_numpy_quantities_run_in_blocks_bit_identical_to_one_call(structure, monkeypatch):
    wavelength = np.linspace(380.0, 780.0, 61)[:, None]
    theta = np.linspace(0.0, 1.5, 37)[None, :]
    quantities = ("reflectance", "transmittance", "absorptance")
    whole = [getattr(structure, q)(wavelength, theta, "p") for q in quantities]
    sizes = []
    real = blocks_module.blockwise

    def small_blocks(function, *arrays, **options):
        def counted(*parts):
            sizes.append(math.prod(np.broadcast_shapes(*(np.shape(p) for p in parts))))
            return function(*parts)
        return real(counted, *arrays, block=100)

    monkeypatch.setattr(stacks, "blockwise", small_blocks)
    for quantity, expected in zip(quantities, whole, strict=True):
        np.testing.assert_array_equal(getattr(structure, quantity)(wavelength, theta, "p"),
                                      expected)
    assert max(sizes) <= 100 and sum(sizes) >= 61 * 37


@pytest.mark.gpu
@pytest.mark.parametrize("structure", [
    BraggMirror(1.0, 1.5, 125.0, 375.0, 20, host=1.2),
    ThinFilm(1.33, 300.0, base="Au"),
], ids=["mirror", "film-over-gold"])
def test_gpu_reflectance_forms_its_points_a_block_at_a_time(structure, monkeypatch):
    # A largest buffer of 4 KiB: 256 points of 4 words a block, formed in place and streamed
    # (wgbragg.gpu.streams); the same values as in one block.
    wavelength = np.linspace(380.0, 780.0, 61)[:, None]
    theta = np.linspace(0.0, 1.5, 37)[None, :]
    whole = structure.reflectance(wavelength, theta, "s", backend="gpu")
    assert np.abs(whole - structure.reflectance(wavelength, theta, "s")).max() < 2e-3
    counts = []
    real = streams.Stream.submit

    def spy(self, count, targets):
        counts.append(count)
        return real(self, count, targets)

    monkeypatch.setattr(streams.Stream, "submit", spy)
    monkeypatch.setattr(gpu.device, "max_buffer_bytes", lambda: 4096)
    np.testing.assert_array_equal(structure.reflectance(wavelength, theta, "s", backend="gpu"),
                                  whole)
    # Blocks of whole units (6 rows of 37 angles: 222 points), each within the buffers.
    assert max(counts) <= 256 and len(counts) >= math.ceil(61 * 37 / 256)
    assert sum(counts) == 61 * 37


# --------------------------------------------------------------------------- time planning


def simulate(budget: TimeBudget, cost, overhead: float = 1e-3):
    """Run ``budget``'s plans on a simulated clock: each dispatch costs ``overhead`` plus
    ``cost(plan)`` seconds. Returns (end time, plans, each plan's planned seconds)."""
    elapsed, plans = 0.0, []
    while (plan := budget.next(elapsed)) is not None:
        seconds = overhead + cost(plan)
        elapsed += seconds
        budget.record(plan, seconds)
        plans.append(plan)
    return elapsed, plans


BIG = 2896 * 2896
BIG_PATH_SECONDS = 93.0 / BIG  # the 2896^2 teapot: 93 s a pass


def test_a_tiny_budget_on_a_huge_image_runs_only_the_probe():
    budget = TimeBudget(0.01, BIG, batch=1)
    end, plans = simulate(budget, lambda p: p.paths * BIG_PATH_SECONDS)
    assert plans == [PassPlan(0, time_budget.PROBE_PATHS, 1)]
    assert end == pytest.approx(1e-3 + 1024 * BIG_PATH_SECONDS)  # 12 ms, not 93 s
    assert budget.cursor == 1024


def test_a_pass_over_a_huge_image_is_split_into_ranges_that_end_in_time():
    budget = TimeBudget(2.0, BIG, batch=1)
    end, plans = simulate(budget, lambda p: p.paths * BIG_PATH_SECONDS)
    assert end <= 2.0
    assert end >= 2.0 - 0.02  # the budget is used, not wasted
    # Ranges of one sample, contiguous from pixel 0, growing 4x from the probe up to the
    # slice limit, then halving the time left.
    assert all(p.samples == 1 for p in plans)
    assert [p.first for p in plans] == list(np.cumsum([0] + [p.count for p in plans[:-1]]))
    assert [p.count for p in plans[:3]] == [1024, 4096, 16384]
    slice_paths = int(time_budget.SLICE_SECONDS / BIG_PATH_SECONDS)
    assert max(p.count for p in plans) <= slice_paths + 1
    assert min(p.count for p in plans) >= TimeBudget.MIN_PATHS
    assert budget.cursor == sum(p.count for p in plans)
    assert len(plans) == 14


def test_small_images_take_whole_passes_of_up_to_batch_samples():
    budget = TimeBudget(1.0, 64, batch=1024)
    end, plans = simulate(budget, lambda p: p.paths * 1e-7)
    assert end <= 1.0
    assert all(p.first == 0 and p.count == 64 and 1 <= p.samples <= 1024 for p in plans)
    assert [p.samples for p in plans[:4]] == [16, 64, 256, 1024]
    assert budget.cursor == 0


def test_a_known_cost_plans_the_first_dispatch_and_ranges_wrap_at_the_image_end():
    budget = TimeBudget(0.1, 1000, batch=1, cursor=900, seconds_per_path=1e-5)
    plan = budget.next(0.0)
    # FILL x 0.1 s at 1e-5 s a path is 5000 paths; the range stops at the image's end.
    assert plan == PassPlan(900, 100, 1)
    budget.record(plan, 1e-3)
    assert budget.cursor == 0
    # 4950 paths fit, but a dispatch grows at most 4x over the last (100 paths).
    assert budget.next(0.001) == PassPlan(0, 400, 1)


def test_costs_that_vary_by_up_to_twice_per_pixel_still_end_in_time():
    # Pixels from 100,000 on cost twice the first ones (a teapot under the sky).
    def cost(plan):
        pixels = np.arange(plan.first, plan.first + plan.count)
        return float(np.where(pixels < 100_000, 1.0, 2.0).sum()) * BIG_PATH_SECONDS

    for seconds in (0.5, 5.0, 20.0):
        end, _ = simulate(TimeBudget(seconds, BIG, batch=1), cost)
        assert seconds - 0.05 <= end <= seconds


# --------------------------------------------------------------------------- real renders


@pytest.mark.gpu
def test_render_for_seconds_splits_passes_and_divides_each_pixel_by_its_count(monkeypatch):
    # A budget far below one dispatch runs exactly the probe: here 100 pixels of 256.
    monkeypatch.setattr(time_budget, "PROBE_PATHS", 100)
    scene = load_preset("fig7")
    split = Renderer(scene, size=(16, 16), seed=5)
    image = split.render(seconds=1e-9)
    counts = split.sample_counts()
    assert split.passes == 0
    assert counts.ravel()[:100].tolist() == [1] * 100 and not counts.ravel()[100:].any()
    assert np.isfinite(image).all()
    assert not image.reshape(-1, 3)[100:].any() and image.reshape(-1, 3)[:100].any()
    split.render(spp=1)
    assert split.passes == 1 and np.bincount(split.sample_counts().ravel()).tolist() == [
        0, 156, 100]
    split.render(seconds=1e-9)  # pixels 100 .. 199
    split.render(seconds=1e-9)  # 200 .. 255: the pass ends at the image's end
    assert split.passes == 2
    np.testing.assert_array_equal(split.sample_counts(), 2)
    whole = Renderer(scene, size=(16, 16), seed=5)
    np.testing.assert_allclose(split.image(), whole.render(2), rtol=1e-5, atol=1e-7)


@pytest.mark.gpu
def test_render_for_seconds_on_a_real_clock_keeps_counts_consistent():
    renderer = Renderer(load_preset("furnace"), size=(24, 20), seed=1)
    image = renderer.render(seconds=0.2)
    counts = renderer.sample_counts()
    assert np.isfinite(image).all() and counts.min() >= 1
    # Every pixel holds passes or passes + 1 samples, the extra ones a prefix of the image.
    flat = counts.ravel()
    assert set(np.unique(flat)) <= {renderer.passes, renderer.passes + 1}
    extra = np.flatnonzero(flat > renderer.passes)
    assert extra.size == 0 or extra.tolist() == list(range(extra.size))
    # The furnace sphere's centre is radiance 1 whatever the counts (loosely: the samples
    # that 0.2 s buys vary with the machine's load).
    np.testing.assert_allclose(image[8:12, 10:14].mean(), 1.0, rtol=0.25)
