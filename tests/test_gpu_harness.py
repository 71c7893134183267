"""Tests of wgbragg.gpu: shader composition, pipelines, dispatch, layouts, timing.

Toy kernels live in ``wgsl/test_kernels/``; include cycles and convention
violations are built in a temporary shader folder instead, so that no more
broken files ship than the one compile-error example.
"""

import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from wgbragg import gpu
from wgbragg.gpu import loops

KERNELS = Path(__file__).resolve().parent / "kernels"
"""The test suite's own WGSL kernels (not shipped in the wheel)."""

pytestmark = pytest.mark.gpu

# One more row of workgroups than a 1D dispatch can hold, plus a ragged tail.
N_2D = 65535 * 64 + 1234

PARAMS_FIELDS = [
    ("a", "f32"),
    ("v3", "vec3<f32>"),
    ("k", "u32"),
    ("v2", "vec2<f32>"),
    ("i", "i32"),
]
# WGSL uniform layout of PARAMS_FIELDS: vec3 aligns to 16 but is 12 bytes, so
# the u32 fits into its last 4; vec2 aligns to 8; the size rounds up to 16.
PARAMS_OFFSETS = {"a": 0, "v3": 16, "k": 28, "v2": 32, "i": 40}
PARAMS_ITEMSIZE = 48


def saxpy_params(a: float) -> np.ndarray:
    params = np.zeros((), gpu.struct_dtype([("a", "f32")]))
    params["a"] = a
    return params


@pytest.fixture
def tmp_shaders(tmp_path, monkeypatch):
    """A private shader folder holding a copy of gpu/harness.wgsl."""
    (tmp_path / "gpu").mkdir()
    shutil.copy(gpu.shader_dir() / "gpu/harness.wgsl", tmp_path / "gpu/harness.wgsl")
    monkeypatch.setattr(gpu.shaders, "shader_dir", lambda: tmp_path)  # load_shader's lookup
    return tmp_path


# ------------------------------------------------------------------ shader loading


@pytest.mark.parametrize("name", ["gpu/harness.wgsl", str(KERNELS / "saxpy.wgsl")])
def test_shader_dir_holds_shaders(name):
    assert (gpu.shader_dir() / name).is_file()


def test_load_shader_inlines_includes_and_maps_lines():
    source = gpu.load_shader(str(KERNELS / "saxpy.wgsl"))
    lines = source.code.splitlines()
    assert len(lines) == len(source.line_map)
    assert "//! include" not in source.code
    harness = (gpu.shader_dir() / "gpu/harness.wgsl").read_text().splitlines()
    composed = next(i for i, t in enumerate(lines) if t.startswith("fn global_index"))
    original = next(i for i, t in enumerate(harness) if t.startswith("fn global_index"))
    assert source.line_map[composed] == ("gpu/harness.wgsl", original + 1)
    saxpy = (KERNELS / "saxpy.wgsl").read_text().splitlines()
    composed = next(i for i, t in enumerate(lines) if t.startswith("fn main"))
    original = next(i for i, t in enumerate(saxpy) if t.startswith("fn main"))
    assert source.line_map[composed] == (str(KERNELS / "saxpy.wgsl"), original + 1)


def test_include_once(tmp_shaders):
    (tmp_shaders / "b.wgsl").write_text("const B: f32 = 1.0;\n")
    (tmp_shaders / "c.wgsl").write_text('//! include "b.wgsl"\nconst C: f32 = B;\n')
    (tmp_shaders / "a.wgsl").write_text('//! include "b.wgsl"\n//! include "c.wgsl"\n')
    code = gpu.load_shader("a.wgsl").code
    assert code.count("const B") == 1
    assert code.index("const B") < code.index("const C")


def test_include_inside_a_block_comment_is_comment_text(tmp_shaders):
    (tmp_shaders / "a.wgsl").write_text(
        '/* not now:\n//! include "nowhere.wgsl"\n*/\nconst A = 1;\n')
    code = gpu.load_shader("a.wgsl").code
    assert '//! include "nowhere.wgsl"' in code and "const A" in code


def test_include_cycle_is_an_error(tmp_shaders):
    (tmp_shaders / "a.wgsl").write_text('// a\n//! include "b.wgsl"\n')
    (tmp_shaders / "b.wgsl").write_text('//! include "a.wgsl"\n')
    with pytest.raises(gpu.ShaderCompileError, match=r"include cycle: a\.wgsl -> b\.wgsl -> a"):
        gpu.load_shader("a.wgsl")


def test_missing_include_names_including_file_and_line(tmp_shaders):
    (tmp_shaders / "a.wgsl").write_text('//! include "b.wgsl"\n')
    (tmp_shaders / "b.wgsl").write_text('// b\n\n//! include "nowhere.wgsl"\n')
    with pytest.raises(gpu.ShaderCompileError) as info:
        gpu.load_shader("a.wgsl")
    assert str(info.value).startswith("b.wgsl:3: ")
    assert "nowhere.wgsl" in str(info.value)


def test_missing_shader_is_file_not_found():
    with pytest.raises(FileNotFoundError):
        gpu.load_shader("no_such_kernel.wgsl")


def test_reloads_when_a_file_changes(tmp_shaders):
    path = tmp_shaders / "a.wgsl"
    path.write_text("const A: f32 = 1.0;\n")
    assert "1.0" in gpu.load_shader("a.wgsl").code
    path.write_text("const A: f32 = 2.0;\n")
    os.utime(path, ns=(path.stat().st_atime_ns, path.stat().st_mtime_ns + 10**9))
    assert "2.0" in gpu.load_shader("a.wgsl").code


# ------------------------------------------------------------------ compile errors


def test_compile_error_names_included_file_and_line():
    with pytest.raises(gpu.ShaderCompileError) as info:
        gpu.compute_pipeline(str(KERNELS / "broken.wgsl"))
    error = info.value
    assert str(error).startswith(f"{KERNELS / 'broken_helper.wgsl'}:5: ")
    assert (error.file, error.line) == (str(KERNELS / "broken_helper.wgsl"), 5)
    assert "f32" in error.detail


def test_binding_order_is_checked(tmp_shaders):
    (tmp_shaders / "bad.wgsl").write_text(
        '//! include "gpu/harness.wgsl"\n'
        "@group(0) @binding(0) var<storage, read_write> out: array<f32>;\n"
        "@group(0) @binding(1) var<storage, read> x: array<f32>;\n"
        "@compute @workgroup_size(WORKGROUP_SIZE) fn main() { out[0] = x[0]; }\n"
    )
    with pytest.raises(gpu.ShaderCompileError, match="binding convention"):
        gpu.compute_pipeline("bad.wgsl")


def test_unknown_constant_is_rejected():
    with pytest.raises(ValueError, match="SCALLE"):
        gpu.compute_pipeline(str(KERNELS / "override_scale.wgsl"), constants={"SCALLE": 2.0})


# ------------------------------------------------------------------ dispatch


def test_saxpy_matches_numpy_beyond_one_dispatch_row():
    # Integers times 2.5 are exact in float32, so fused multiply-add cannot differ;
    # y >= 1 keeps every expected value nonzero, so an unwritten element shows.
    x = np.random.randint(0, 1000, N_2D).astype(np.float32)
    y = np.random.randint(1, 1000, N_2D).astype(np.float32)
    kernel = gpu.compute_pipeline(str(KERNELS / "saxpy.wgsl"))
    assert kernel.workgroup_size * 65535 < N_2D
    (out,) = kernel.run([x, y], [(N_2D, np.float32)], saxpy_params(2.5))
    assert out.shape == (N_2D,) and out.dtype == np.float32
    np.testing.assert_array_equal(out, 2.5 * x + y)
    np.testing.assert_array_equal(out[-1500:], 2.5 * x[-1500:] + y[-1500:])


def test_override_constants_change_the_result():
    x = np.random.standard_normal(1000).astype(np.float32)
    results = {
        scale: gpu.compute_pipeline(
            str(KERNELS / "override_scale.wgsl"), constants={"SCALE": scale}
        ).run([x], [(x.size, np.float32)])[0]
        for scale in (2.0, 3.0)
    }
    np.testing.assert_array_equal(results[2.0], np.float32(2.0) * x)
    np.testing.assert_array_equal(results[3.0], np.float32(3.0) * x)


def test_workgroup_size_constant_is_honoured():
    x = np.arange(1000, dtype=np.float32)
    kernel = gpu.compute_pipeline(
        str(KERNELS / "override_scale.wgsl"), constants={"WORKGROUP_SIZE": 256, "SCALE": 1.0}
    )
    assert kernel.workgroup_size == 256
    np.testing.assert_array_equal(kernel.run([x], [(x.size, np.float32)])[0], x)


def test_pipeline_cache_reuses_compiled_pipelines():
    name = str(KERNELS / "override_scale.wgsl")
    first = gpu.compute_pipeline(name, constants={"SCALE": 5.0})
    before = gpu.pipeline_cache_info()
    again = gpu.compute_pipeline(name, constants={"SCALE": 5.0})
    # Naming the default WORKGROUP_SIZE explicitly is the same pipeline.
    explicit = gpu.compute_pipeline(name, "main", {"WORKGROUP_SIZE": 64, "SCALE": 5.0})
    after = gpu.pipeline_cache_info()
    assert again is first and explicit is first
    assert after["hits"] == before["hits"] + 2
    assert after["misses"] == before["misses"]
    assert after["size"] == before["size"]
    other = gpu.compute_pipeline(name, constants={"SCALE": 6.0})
    assert other is not first
    assert gpu.pipeline_cache_info()["misses"] == before["misses"] + 1


def test_zero_count_returns_empty_without_dispatch():
    kernel = gpu.compute_pipeline(str(KERNELS / "override_scale.wgsl"))
    empty = np.zeros(0, np.float32)
    (out,) = kernel.run([empty], [(0, np.float32)])
    assert out.shape == (0,) and out.dtype == np.float32
    (out,), seconds = kernel.run([empty], [((0, 4), np.float32)], timestamps=True)
    assert out.shape == (0, 4) and seconds == 0.0


def test_bad_arguments_are_rejected():
    kernel = gpu.compute_pipeline(str(KERNELS / "saxpy.wgsl"))
    x = np.ones(8, np.float32)
    with pytest.raises(ValueError, match="2 inputs, 1 outputs, params=True"):
        kernel.run([x], [(8, np.float32)], saxpy_params(1.0))
    with pytest.raises(TypeError, match="float64"):
        kernel.run([x, np.ones(8)], [(8, np.float32)], saxpy_params(1.0))


# ------------------------------------------------------------------ layouts


def test_struct_dtype_follows_wgsl_uniform_layout():
    dtype = gpu.struct_dtype(PARAMS_FIELDS)
    assert dtype.itemsize == PARAMS_ITEMSIZE
    assert {name: dtype.fields[name][1] for name in dtype.names} == PARAMS_OFFSETS
    assert dtype["v3"].shape == (3,) and dtype["v2"].shape == (2,)
    assert gpu.struct_dtype([("a", "f32")]).itemsize == 16
    layout = gpu.struct_dtype([("a", "f32"), ("b", "vec4<f32>"), ("c", "vec3f"), ("d", "f32")])
    assert [layout.fields[n][1] for n in "abcd"] == [0, 16, 32, 44]
    assert layout.itemsize == 48
    with pytest.raises(ValueError, match="f64"):
        gpu.struct_dtype([("x", "f64")])


def test_uniform_fields_round_trip_exactly():
    params = np.zeros((), gpu.struct_dtype(PARAMS_FIELDS))
    params["a"] = np.float32(np.pi)
    params["v3"] = np.random.standard_normal(3)
    params["k"] = 0xDEADBEEF
    params["v2"] = np.random.standard_normal(2)
    params["i"] = -7
    kernel = gpu.compute_pipeline(str(KERNELS / "params_layout.wgsl"))
    (out,) = kernel.run([], [(8, np.uint32)], params, count=1)
    expected = np.concatenate(
        [
            params["a"].reshape(1).view(np.uint32),
            params["v3"].view(np.uint32),
            params["k"].reshape(1),
            params["v2"].view(np.uint32),
            params["i"].reshape(1).view(np.uint32),
        ]
    )
    np.testing.assert_array_equal(out, expected)


# ------------------------------------------------------------------ timing


def test_timestamps_and_benchmark_are_positive_and_finite():
    n = 1 << 20
    x = np.ones(n, np.float32)
    kernel = gpu.compute_pipeline(str(KERNELS / "saxpy.wgsl"))
    (out,), seconds = kernel.run([x, x], [(n, np.float32)], saxpy_params(2.0), timestamps=True)
    assert out[-1] == 3.0
    assert np.isfinite(seconds) and seconds > 0
    median = kernel.benchmark([x, x], [(n, np.float32)], saxpy_params(2.0), repeats=3)
    assert np.isfinite(median) and median > 0


# ------------------------------------------------------------------ chained dispatches

TEXTURE_COPY = (
    '//! include "gpu/harness.wgsl"\n'
    "@group(0) @binding(0) var image: texture_2d<f32>;\n"
    "@group(0) @binding(1) var<storage, read> scale: array<f32>;\n"
    "@group(0) @binding(2) var<storage, read_write> out: array<vec4<f32>>;\n"
    "@compute @workgroup_size(WORKGROUP_SIZE)\n"
    "fn main(@builtin(global_invocation_id) gid: vec3<u32>,\n"
    "        @builtin(num_workgroups) nwg: vec3<u32>) {\n"
    "    let i = global_index(gid, nwg);\n"
    "    let size = textureDimensions(image);\n"
    "    if (i >= size.x * size.y) { return; }\n"
    "    out[i] = scale[0] * textureLoad(image, vec2<u32>(i % size.x, i / size.x), 0);\n"
    "}\n"
)


def test_chained_dispatches_share_device_arrays():
    """saxpy twice in one submission, the second reading the first's output on the device."""
    x = np.random.randint(0, 100, 5000).astype(np.float32)
    y = np.random.randint(1, 100, 5000).astype(np.float32)
    kernel = gpu.compute_pipeline(str(KERNELS / "saxpy.wgsl"))
    on_device = gpu.DeviceArray.upload(x)
    first = kernel.bind([on_device, y], [(x.size, np.float32)], saxpy_params(2.0))
    second = kernel.bind([first.outputs[0], on_device], [(x.size, np.float32)], saxpy_params(3.0))
    (out,) = gpu.submit([first, second], read=second.outputs)
    np.testing.assert_array_equal(out, 3.0 * (2.0 * x + y) + x)
    np.testing.assert_array_equal(first.outputs[0].read(), 2.0 * x + y)
    # Running again with a new input overwrites the outputs it was bound to.
    again = kernel.bind([on_device, on_device], first.outputs, saxpy_params(1.0))
    gpu.submit([again])
    np.testing.assert_array_equal(first.outputs[0].read(), 2.0 * x)


def test_device_arrays_round_trip():
    values = np.arange(12, dtype=np.int32).reshape(3, 4)
    array = gpu.DeviceArray.upload(values)
    assert (array.shape, array.dtype, array.is_texture) == ((3, 4), np.dtype("<i4"), False)
    np.testing.assert_array_equal(array.read(), values)
    empty = gpu.DeviceArray.empty((5, 2), np.uint32)
    np.testing.assert_array_equal(empty.read(), np.zeros((5, 2), np.uint32))
    assert gpu.DeviceArray.empty(0, np.float32).read().shape == (0,)
    with pytest.raises(TypeError, match="float64"):
        gpu.DeviceArray.upload(np.ones(3))


def test_buffers_beyond_the_device_limit_are_refused_naming_them():
    """The largest storage binding (128 MiB on lavapipe) was a wgpu validation traceback."""
    largest = gpu.max_buffer_bytes()
    assert largest == min(gpu.get_device().limits["max-storage-buffer-binding-size"],
                          gpu.get_device().limits["max-buffer-size"])
    with pytest.raises(ValueError, match=rf"array of shape \({largest // 16 + 1}, 4\): "
                                         rf"{largest + 16} bytes exceed .*\({largest} bytes"):
        gpu.DeviceArray.empty((largest // 16 + 1, 4), np.float32)
    with pytest.raises(ValueError, match=rf"the texels: {largest + 4} bytes exceed"):
        gpu.DeviceArray.upload(np.zeros(largest // 4 + 1, np.float32), what="the texels")


def test_texture_inputs(tmp_shaders):
    (tmp_shaders / "texture_copy.wgsl").write_text(TEXTURE_COPY)
    kernel = gpu.compute_pipeline("texture_copy.wgsl")
    assert kernel.input_textures == (True, False)
    assert (kernel.n_inputs, kernel.n_outputs, kernel.has_params) == (2, 1, False)
    image = np.random.standard_normal((5, 7, 4)).astype(np.float32)
    scale = np.array([2.0], np.float32)
    (out,) = kernel.run([image, scale], [((35, 4), np.float32)])
    np.testing.assert_array_equal(out.reshape(5, 7, 4), 2.0 * image)
    texture = gpu.DeviceArray.upload(image, texture=True)
    assert texture.is_texture and texture.shape == (5, 7, 4)
    (out,) = kernel.run([texture, scale], [((35, 4), np.float32)])
    np.testing.assert_array_equal(out.reshape(5, 7, 4), 2.0 * image)
    with pytest.raises(TypeError, match="texture_2d"):
        kernel.run([gpu.DeviceArray.upload(image), scale], [((35, 4), np.float32)])
    with pytest.raises(TypeError, match="storage buffer"):
        kernel.run([texture, texture], [((35, 4), np.float32)])
    with pytest.raises(TypeError, match="output 0 is a storage buffer"):
        kernel.run([texture, scale], [texture])
    with pytest.raises(TypeError, match="rgba32float"):
        gpu.DeviceArray.upload(image[..., :3], texture=True)
    with pytest.raises(ValueError, match="height and width"):
        gpu.DeviceArray.upload(np.zeros((0, 3, 4), np.float32), texture=True)
    with pytest.raises(TypeError, match="read back"):
        texture.read()


def test_texture_after_an_output_breaks_the_convention(tmp_shaders):
    (tmp_shaders / "bad.wgsl").write_text(
        '//! include "gpu/harness.wgsl"\n'
        "@group(0) @binding(0) var<storage, read_write> out: array<f32>;\n"
        "@group(0) @binding(1) var image: texture_2d<f32>;\n"
        "@compute @workgroup_size(WORKGROUP_SIZE) fn main() {\n"
        "    out[0] = textureLoad(image, vec2<u32>(0u, 0u), 0).x;\n"
        "}\n"
    )
    with pytest.raises(gpu.ShaderCompileError, match="binding convention"):
        gpu.compute_pipeline("bad.wgsl")


def test_benchmark_times_each_dispatch():
    n = 1 << 16
    x = np.ones(n, np.float32)
    kernel = gpu.compute_pipeline(str(KERNELS / "saxpy.wgsl"))
    first = kernel.bind([x, x], [(n, np.float32)], saxpy_params(2.0))
    second = kernel.bind([first.outputs[0], x], [(n, np.float32)], saxpy_params(2.0))
    seconds = gpu.benchmark([first, second], repeats=3)
    assert len(seconds) == 2
    assert all(np.isfinite(s) and s > 0 for s in seconds)
    np.testing.assert_array_equal(second.outputs[0].read(), np.full(n, 7.0, np.float32))
    with pytest.raises(ValueError, match=r"1\.\.1024"):
        gpu.benchmark([first, second], repeats=1025)


def test_loop_budget_is_what_the_probe_kernel_shows():
    """The pitfall behind planned_loop_iterations: Mesa 22's llvmpipe ends all loops of a SIMD
    group after 65535 back-edges in total (the probe reads 65536 iterations, all in its first
    loop), silently, and loops_were_cut() tells; Mesa 25.0.7's ends none. The measured budget
    must be what the probe kernel does on this device, the budget shared by both loops."""
    budget = gpu.loop_budget()
    mesa = re.search(r"Mesa (\d+)\.", gpu.adapter_info()["description"])
    if mesa is not None and int(mesa[1]) <= 22:
        assert budget is not None and abs(budget - 65535) <= 2
    if mesa is not None and int(mesa[1]) >= 25:
        assert budget is None
    assert gpu.safe_loop_iterations() == (None if budget is None else budget // 2)
    assert gpu.planned_loop_iterations() == (gpu.ITERATIONS_WITHOUT_BUDGET if budget is None
                                             else budget // 2)
    counts = np.zeros(64, np.uint32)
    counts[:32] = 1
    counts[0] = gpu.planned_loop_iterations() // 2  # first SIMD group (8 or 16 lanes): safe
    counts[32] = 40000  # the last: 80000 iterations asked for, in two loops
    (out,) = gpu.compute_pipeline("gpu/loops_probe.wgsl").run(
        [counts], [((counts.size, 2), np.uint32)])
    taken, cut = out.T
    np.testing.assert_array_equal(taken[:32], 2 * counts[:32])
    np.testing.assert_array_equal(cut[:32], 0)
    if budget is not None:
        assert budget - 2 <= taken[32] < budget  # silently cut short, in the second loop
        assert cut[32] == 1
        with pytest.raises(gpu.LoopBudgetError, match=r"toy kernel.*allows \d+ loop.*numpy"):
            gpu.check_loops(cut, "toy kernel")
    else:
        assert taken[32] == 80000 and cut[32] == 0
        assert loops.probe_loop_budget() is None  # all of PROBE_ITERATIONS, once more
    gpu.check_loops(cut[:32], "toy kernel")


def test_loop_budget_cache_is_validated_not_trusted(tmp_path, monkeypatch):
    """The measured budget is kept per driver in a JSON file of the cache folder. A file that
    is not JSON, of another format or probe length, or whose entry is malformed or out of
    range is probed again and rewritten; a valid entry is read without a probe, and other
    drivers' valid entries survive a rewrite."""
    monkeypatch.setenv("WGBRAGG_CACHE", str(tmp_path / "cache"))
    assert loops.loop_budget_path() == tmp_path / "cache" / loops.CACHE_NAME
    measured = gpu.loop_budget()
    probes = []
    monkeypatch.setattr(loops, "probe_loop_budget", lambda: probes.append(1) or measured)
    path = loops.loop_budget_path()
    assert loops.cached_loop_budget(path) == measured and len(probes) == 1  # no file yet
    assert loops.cached_loop_budget(path) == measured and len(probes) == 1  # read back
    good = json.loads(path.read_text())
    (key,) = good["devices"]
    other = {"name": "other", "description": "Mesa 1.0", "budget": 7}

    def variant(change=None, **entry):
        document = json.loads(json.dumps(good))
        document["devices"][key].update(entry)
        if change is not None:
            change(document)
        return json.dumps(document)

    corrupt = ["{ not json", "[]", "\xff", variant(lambda d: d.update(format="other")),
               variant(lambda d: d.update(version=2)),
               variant(lambda d: d.update(probe_iterations=1024)),
               variant(lambda d: d.update(devices=[])),
               variant(budget=-3), variant(budget=0), variant(budget="65536"),
               variant(budget=True), variant(budget=65536.0),
               variant(budget=loops.PROBE_ITERATIONS + 1), variant(name="another GPU"),
               variant(extra=1), variant(lambda d: d["devices"][key].pop("budget"))]
    for count, text in enumerate(corrupt, start=2):
        path.write_text(text, encoding="latin-1")
        assert loops.cached_loop_budget(path) == measured
        assert len(probes) == count, text
        assert json.loads(path.read_text()) == good
    others = {"other | Mesa 1.0": other}
    path.write_text(variant(lambda d: d["devices"].update(others), budget=12345))
    assert loops.cached_loop_budget(path) == 12345 and len(probes) == len(corrupt) + 1
    path.write_text(variant(lambda d: d["devices"].update(others), budget=-1))
    assert loops.cached_loop_budget(path) == measured
    assert json.loads(path.read_text())["devices"] == {**good["devices"], **others}


@pytest.mark.parametrize(("cut", "where"), [
    (np.array([0, 1, 1, 0]), "at 2 of 4 points"),
    (np.array([1], np.uint32), "at some points"),  # one word shared by every invocation
])
def test_loop_cut_message_counts_only_what_it_knows(cut, where):
    with pytest.raises(gpu.LoopBudgetError, match=rf"toy kernel: .* early {where} \("):
        gpu.check_loops(cut, "toy kernel")


# ------------------------------------------------------------------ adapters

ADAPTERS = [
    {"device": "llvmpipe (LLVM 15.0.6, 256 bits)", "description": "GL", "backend_type": "OpenGL"},
    {"device": "NVIDIA GeForce RTX 4090", "description": "", "backend_type": "Vulkan"},
    {"device": "llvmpipe (LLVM 15.0.6, 256 bits)", "description": "Mesa", "backend_type": "Vulkan"},
]


def test_select_adapter_by_substring_prefers_vulkan():
    assert gpu.select_adapter(ADAPTERS, "LLVMpipe") == 2
    assert gpu.select_adapter(ADAPTERS, "rtx") == 1
    assert gpu.select_adapter(ADAPTERS, "mesa") == 2


def test_select_adapter_without_match_lists_adapters():
    with pytest.raises(RuntimeError, match="no-such-gpu") as info:
        gpu.select_adapter(ADAPTERS, "no-such-gpu")
    assert "NVIDIA GeForce RTX 4090" in str(info.value)
    assert "llvmpipe (LLVM 15.0.6, 256 bits)" in str(info.value)


@pytest.mark.skipif(
    os.environ.get("WGBRAGG_EXPECT_LAVAPIPE") != "1", reason="WGBRAGG_EXPECT_LAVAPIPE is not 1"
)
def test_adapter_is_lavapipe_when_expected():
    info = gpu.adapter_info()
    assert info["is_lavapipe"], info


@pytest.mark.parametrize(("expect", "outcome"), [("0", "1 skipped"), ("1", "1 error")])
def test_missing_adapter_skips_locally_and_fails_in_ci(expect, outcome):
    # A name that matches no adapter stands in for a machine without one.
    env = {**os.environ, "WGBRAGG_ADAPTER": "no-such-adapter", "WGBRAGG_EXPECT_LAVAPIPE": expect}
    here = Path(__file__).resolve()
    node = f"{here}::test_zero_count_returns_empty_without_dispatch"
    result = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", node],
        cwd=here.parents[1],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert outcome in result.stdout, result.stdout + result.stderr
    assert (result.returncode == 0) == (expect == "0")


def test_bilinear_quads_hold_each_cells_corners():
    """Bilinear interpolation from a cell's quad is the table's own, at every cell."""
    rng = np.random.default_rng(5)
    table = rng.random((4, 6))
    quads = gpu.bilinear_quads(table)
    assert quads.shape == (3 * 5, 4) and quads.dtype == np.float32
    r, c = np.meshgrid(np.arange(3), np.arange(5), indexing="ij")
    expected = np.stack([table[r, c], table[r, c + 1], table[r + 1, c], table[r + 1, c + 1]], -1)
    np.testing.assert_array_equal(quads, expected.reshape(-1, 4).astype(np.float32))
    fr, fc = 0.3, 0.8
    q = quads[2 * 5 + 4]
    direct = ((1 - fr) * ((1 - fc) * table[2, 4] + fc * table[2, 5])
              + fr * ((1 - fc) * table[3, 4] + fc * table[3, 5]))
    from_quad = (1 - fr) * ((1 - fc) * q[0] + fc * q[1]) + fr * ((1 - fc) * q[2] + fc * q[3])
    assert from_quad == pytest.approx(direct, rel=1e-6)


@pytest.mark.parametrize("shape", [(5,), (1, 4), (4, 1), (2, 2, 2)])
def test_bilinear_quads_refuse_tables_without_cells(shape):
    with pytest.raises(ValueError, match="table must be 2-D"):
        gpu.bilinear_quads(np.zeros(shape))


def _need_timestamps():
    """Skip where the adapter lacks timestamps, unless lavapipe (which has them) is expected."""
    lacking = "timestamp-query" not in gpu.get_device().features
    if lacking and os.environ.get("WGBRAGG_EXPECT_LAVAPIPE") != "1":
        pytest.skip("the adapter lacks timestamp-query (lavapipe has it)")


def test_pass_clock_counts_the_passes_of_its_block():
    """Every submission inside the block is timed, nested blocks both count, and the GPU time
    lies within the block's wall time; results are unchanged and nothing is counted after."""
    _need_timestamps()
    x = np.arange(4096, dtype=np.float32)
    y = np.ones(4096, np.float32)
    kernel = gpu.compute_pipeline(str(KERNELS / "saxpy.wgsl"))
    with gpu.pass_clock() as outer:
        start = time.perf_counter()
        (first,) = kernel.run([x, y], [(x.size, np.float32)], saxpy_params(2.0))
        with gpu.pass_clock() as inner:
            dispatch = kernel.bind([x, y], [(x.size, np.float32)], saxpy_params(3.0))
            (second,) = gpu.submit([dispatch, dispatch], read=dispatch.outputs)
        wall = time.perf_counter() - start
    np.testing.assert_array_equal(first, 2.0 * x + y)
    np.testing.assert_array_equal(second, 3.0 * x + y)
    assert (outer.passes, inner.passes) == (3, 2)
    assert 0.0 < inner.seconds < outer.seconds <= wall
    kernel.run([x, y], [(x.size, np.float32)], saxpy_params(2.0))
    assert outer.passes == 3


def test_pass_clock_times_more_passes_than_a_query_set_holds():
    _need_timestamps()
    x = np.arange(64, dtype=np.float32)
    kernel = gpu.compute_pipeline(str(KERNELS / "saxpy.wgsl"))
    dispatch = kernel.bind([x, x], [(x.size, np.float32)], saxpy_params(1.0))
    with gpu.pass_clock() as clock:
        (out,) = gpu.submit([dispatch] * 2100, read=dispatch.outputs)
    np.testing.assert_array_equal(out, 2.0 * x)
    assert clock.passes == 2100 and clock.seconds > 0.0


def test_pass_clock_needs_timestamps(monkeypatch):
    class NoTimestamps:
        features = frozenset()

    monkeypatch.setattr(gpu.timing, "get_device", lambda: NoTimestamps())  # pass_clock's
    with pytest.raises(RuntimeError, match="timestamp-query"):
        with gpu.pass_clock():
            pass
