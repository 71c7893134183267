"""Parameter maps: the numpy reference (wgbragg.scene.parameter_maps) against hand computations, and
its float32 WGSL twin (wgsl/scene/parameter_maps.wgsl) against it on the device.

GPU tolerances, relative to a map's range ``hi - lo``, about twenty times the largest error
measured on lavapipe (``pytest -s`` prints them): ``PROCEDURAL_RTOL`` (measured 5.1e-7: the
float32 phase of stripes and rings, the lattice coordinates of the noise) and ``TEXTURE_RTOL``
(measured 2.3e-6: texel weights from ``u' W`` in float32, 64 texels wide).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from wgbragg import gpu
from wgbragg.scene.model import ParameterMap
from wgbragg.scene.parameter_maps import (
    MAP_KINDS,
    MAP_RECORD_DTYPE,
    load_map_texture,
    map_values,
    noise_lattice,
    pack_maps,
)

KERNELS = Path(__file__).resolve().parent / "kernels"
"""The test suite's own WGSL kernels (not shipped in the wheel)."""

ATOL = 1e-12
PROCEDURAL_RTOL = 1e-5
TEXTURE_RTOL = 1e-4


def procedural(kind: str, scale: float = 1.0, lo: float = 0.0, hi: float = 1.0) -> ParameterMap:
    return ParameterMap(None, kind, (lo, hi), scale)


def pcg(x: int) -> int:
    """Jarzynski & Olano's PCG hash in Python integers, reduced modulo 2**32 by hand."""
    state = (x * 747796405 + 2891336453) % 2**32
    word = (((state >> ((state >> 28) + 4)) ^ state) * 277803737) % 2**32
    return (word >> 22) ^ word


def lattice_value(i: int, j: int, n: int) -> float:
    return (pcg((i % n + pcg(j % n)) % 2**32) >> 8) / 2**24


def save_png(path, texels: np.ndarray, mode: str | None = None):
    Image.fromarray(texels, mode).save(path)
    return path


# --- procedural maps ----------------------------------------------------------------------


def test_stripes_at_known_u():
    pmap = procedural("stripes", scale=2.0, lo=100.0, hi=300.0)
    # 0.5 + 0.5 sin(4 pi u): mid-range at u = 0, hi at 1/8, mid at 1/4, lo at 3/8.
    u = np.array([0.0, 0.125, 0.25, 0.375, -0.125, 5.125])
    uv = np.stack([u, np.linspace(-3.0, 7.0, len(u))], axis=-1)
    np.testing.assert_allclose(
        map_values(pmap, uv), [200.0, 300.0, 200.0, 100.0, 100.0, 300.0], atol=1e-9
    )


def test_radial_at_centre_and_corners():
    pmap = procedural("radial", scale=1.0, lo=0.3, hi=0.7)
    corners = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [-1.0, 3.0]]
    values = map_values(pmap, [[0.5, 0.5], [1.5, -0.5], *corners])
    np.testing.assert_allclose(values[:2], 0.3, atol=ATOL)
    np.testing.assert_allclose(values[2:], 0.3 + 0.4 * np.sqrt(0.5), atol=ATOL)
    # Twice the frequency: 2 sqrt(1/2) = 1.414 wraps to 0.414, and 2 * 0.3 = 0.6.
    twice = procedural("radial", scale=2.0)
    np.testing.assert_allclose(
        map_values(twice, [[0.0, 0.0], [0.5, 0.8]]), [np.sqrt(2.0) - 1.0, 0.6], atol=ATOL
    )


@pytest.mark.parametrize("scale", [1.0, 4.0, 5.0, 2.4])
def test_noise_at_lattice_points_is_the_hash(scale):
    n = noise_lattice(scale)
    points = [(i, j) for i in range(int(np.ceil(scale))) for j in range(int(np.ceil(scale)))]
    expected = [lattice_value(i, j, n) for i, j in points]
    # The lattice points of the unit tile, seen from another tile too.
    for shift in ([0.0, 0.0], [-3.0, 2.0]):
        uv = np.array(points, dtype=float) / scale + shift
        np.testing.assert_allclose(map_values(procedural("noise", scale), uv), expected,
                                   atol=1e-9)


def test_noise_at_a_cell_centre_is_the_mean_of_its_corners():
    # Smoothstep weights are 1/2 at t = 1/2.
    values = map_values(procedural("noise", 4.0, lo=10.0, hi=20.0), [1.5 / 4, 2.5 / 4])
    corners = [lattice_value(i, j, 4) for i in (1, 2) for j in (2, 3)]
    assert values.shape == ()
    np.testing.assert_allclose(values, 10.0 + 10.0 * np.mean(corners), atol=1e-9)


def test_lattice_values_spread_over_the_unit_interval():
    values = [lattice_value(i, j, 64) for i in range(64) for j in range(64)]
    assert 0.0 <= min(values) and max(values) < 1.0
    # A hash, not a pattern: the values spread over [0, 1).
    assert np.histogram(values, bins=8, range=(0, 1))[0].min() > 400


@pytest.mark.parametrize("scale", [1.0, 3.0, 8.0, 2.5])
def test_noise_is_continuous_and_in_range(scale):
    pmap = procedural("noise", scale)
    step = 1e-4
    t = np.arange(-1.0, 2.0, step)
    # A line across many cells in both directions, through the tile borders.
    values = map_values(pmap, np.stack([t, 0.37 * t + 0.11], axis=-1))
    assert values.min() >= 0.0 and values.max() < 1.0
    # Lipschitz: smoothstep's slope is at most 3/2 per cell, lattice values differ by < 1.
    slope = 1.5 * scale * (1.0 + 0.37)
    jumps = np.abs(np.diff(values))
    if scale == round(scale):
        assert jumps.max() <= slope * step
    else:
        # The tile borders (u = 0, u = 1, v = 0 on this line) cut a partial lattice cell.
        assert np.count_nonzero(jumps > slope * step) <= 3


@pytest.mark.parametrize("kind", ["stripes", "radial", "noise"])
def test_maps_repeat_with_period_one(kind):
    rng = np.random.default_rng(1)
    uv = rng.random((100, 2))
    shift = rng.integers(-50, 50, size=(100, 2))
    pmap = procedural(kind, 3.0, lo=-2.0, hi=5.0)
    np.testing.assert_allclose(map_values(pmap, uv + shift), map_values(pmap, uv), atol=1e-9)
    values = map_values(pmap, uv)
    assert values.min() >= -2.0 and values.max() <= 5.0


def test_n_dimensional_uv():
    rng = np.random.default_rng(2)
    uv = rng.normal(size=(3, 4, 5, 2))
    for kind in ("stripes", "radial", "noise"):
        pmap = procedural(kind, 2.0)
        values = map_values(pmap, uv)
        assert values.shape == (3, 4, 5) and values.dtype == np.float64
        np.testing.assert_array_equal(values.ravel(), map_values(pmap, uv.reshape(-1, 2)))
        assert map_values(pmap, np.zeros((0, 2))).shape == (0,)


# --- textures -------------------------------------------------------------------------------


@pytest.fixture
def grey_texture(tmp_path):
    """3 rows x 4 columns of 8-bit grey; row 0 is the image's top."""
    texels = np.array([[0, 10, 20, 30], [40, 50, 60, 70], [80, 90, 100, 255]], np.uint8)
    return save_png(tmp_path / "grey.png", texels), texels / 255.0


def test_texture_at_texel_centres(grey_texture):
    path, texels = grey_texture
    rows, columns = np.meshgrid(np.arange(3), np.arange(4), indexing="ij")
    uv = np.stack([(columns + 0.5) / 4, 1.0 - (rows + 0.5) / 3], axis=-1)
    pmap = ParameterMap(path, None, (100.0, 200.0))
    np.testing.assert_allclose(map_values(pmap, uv), 100.0 + 100.0 * texels, atol=1e-5)
    shifted = uv + np.array([-3.0, 7.0])
    np.testing.assert_allclose(map_values(pmap, shifted), 100.0 + 100.0 * texels, atol=1e-5)


def test_texture_is_bilinear_and_wraps(grey_texture):
    path, t = grey_texture
    pmap = ParameterMap(path, None, (0.0, 1.0))
    uv = [
        [0.25, 1.0 - 0.5 / 3],     # between columns 0 and 1 of the top row
        [1.75 / 4, 0.5],           # a quarter of the way from column 1 to 2, middle row
        [0.0, 0.5],                # across the u edge: columns 3 and 0
        [0.5 / 4, 0.0],            # across the v edge: bottom row 2 and top row 0
        [0.0, 1.0],                # the corner: all four corner texels
    ]
    expected = [
        (t[0, 0] + t[0, 1]) / 2,
        0.75 * t[1, 1] + 0.25 * t[1, 2],
        (t[1, 3] + t[1, 0]) / 2,
        (t[2, 0] + t[0, 0]) / 2,
        (t[0, 0] + t[0, 3] + t[2, 0] + t[2, 3]) / 4,
    ]
    np.testing.assert_allclose(map_values(pmap, uv), expected, atol=1e-6)


def test_texture_luminance_of_stored_values(tmp_path):
    rgb = np.array([[[255, 0, 0], [0, 255, 0], [0, 0, 255], [128, 128, 128]]], np.uint8)
    # A map is data: Rec. 709 weights of the stored values, no sRGB decoding.
    np.testing.assert_allclose(
        load_map_texture(save_png(tmp_path / "rgb.png", rgb)),
        [[0.2126, 0.7152, 0.0722, 128 / 255]], atol=1e-6,
    )
    rgba = np.concatenate([rgb, np.zeros((1, 4, 1), np.uint8)], axis=-1)
    np.testing.assert_allclose(load_map_texture(save_png(tmp_path / "rgba.png", rgba)),
                               load_map_texture(tmp_path / "rgb.png"))
    deep = np.array([[0, 1, 65535, 32768]], np.uint16)
    np.testing.assert_allclose(load_map_texture(save_png(tmp_path / "deep.png", deep)),
                               [deep[0] / 65535.0], atol=1e-7)
    exact = np.array([[0.0, 0.125, 1.0]], np.float32)
    Image.fromarray(exact).save(tmp_path / "float.tif")
    np.testing.assert_array_equal(load_map_texture(tmp_path / "float.tif"), exact)
    texels = load_map_texture(tmp_path / "rgb.png")
    assert texels.dtype == np.float32 and texels.shape == (1, 4)


def test_one_texel_texture_is_constant(tmp_path):
    path = save_png(tmp_path / "one.png", np.array([[51]], np.uint8))
    rng = np.random.default_rng(3)
    values = map_values(ParameterMap(path, None, (0.0, 10.0)), rng.normal(size=(50, 2)) * 100)
    np.testing.assert_allclose(values, 2.0, atol=1e-6)


@pytest.mark.parametrize(
    ("name", "content", "problem"),
    [
        ("missing.png", None, "does not exist"),
        ("garbage.png", bytes(range(256)), "cannot be read"),
        # Pillow would run Ghostscript for EPS: only PNG, JPEG and TIFF are opened.
        ("script.png", b"%!PS-Adobe-3.0 EPSF-3.0\n%%BoundingBox: 0 0 1 1\n", "cannot be read"),
        ("wide.tif", "int32", "pixel format"),
        ("bright.tif", "float", r"\[0, 1\]"),
    ],
)
def test_bad_textures_raise_naming_the_file(tmp_path, name, content, problem):
    path = tmp_path / name
    if content == "int32":
        Image.fromarray(np.array([[1, 2]], np.int32)).save(path)
    elif content == "float":
        Image.fromarray(np.array([[0.5, 1.5]], np.float32)).save(path)
    elif content is not None:
        path.write_bytes(content)
    with pytest.raises(ValueError, match=problem) as caught:
        map_values(ParameterMap(path, None, (0.0, 1.0)), [0.5, 0.5])
    assert name in str(caught.value)


# --- bad input ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("pmap", "uv", "name"),
    [
        (procedural("stripes"), [0.5], "uv"),
        (procedural("stripes"), 0.5, "uv"),
        (procedural("stripes"), [[0.5, np.nan]], "uv"),
        (procedural("stripes"), [[0.5, np.inf]], "uv"),
        (procedural("stripes"), [["a", "b"]], "uv"),
        (procedural("waves"), [0.5, 0.5], "procedural"),
        (ParameterMap(None, None, (0.0, 1.0)), [0.5, 0.5], "texture"),
        (procedural("noise", lo=2.0, hi=1.0), [0.5, 0.5], "range"),
        (ParameterMap(None, "noise", (0.0,), 1.0), [0.5, 0.5], "range"),
        (procedural("noise", lo=np.nan), [0.5, 0.5], "range"),
        (procedural("noise", scale=0.0), [0.5, 0.5], "scale"),
        (procedural("noise", scale=np.inf), [0.5, 0.5], "scale"),
        (procedural("noise", scale=True), [0.5, 0.5], "scale"),
        ("stripes", [0.5, 0.5], "pmap"),
    ],
)
def test_bad_input_raises_naming_the_parameter(pmap, uv, name):
    with pytest.raises(ValueError, match=name):
        map_values(pmap, uv)


# --- packing --------------------------------------------------------------------------------


def test_record_dtype_matches_the_wgsl_struct():
    source = (gpu.shader_dir() / "scene/parameter_maps.wgsl").read_text()
    body = re.search(r"struct ParameterMapRecord \{(.*?)\}", source, re.DOTALL).group(1)
    fields = re.findall(r"(\w+):\s*(\w+)", re.sub(r"//[^\n]*", "", body))
    wgsl = {"<u4": "u32", "<f4": "f32"}
    assert fields == [(n, wgsl[MAP_RECORD_DTYPE[n].str]) for n in MAP_RECORD_DTYPE.names]
    assert MAP_RECORD_DTYPE.itemsize == 32
    assert [MAP_RECORD_DTYPE.fields[n][1] for n in MAP_RECORD_DTYPE.names] == list(range(0, 32, 4))


def test_pack_maps_layout(grey_texture, tmp_path):
    path, texels = grey_texture
    other = save_png(tmp_path / "other.png", np.array([[255, 0]], np.uint8))
    maps = [
        procedural("stripes", 4.0, 160.0, 300.0),
        None,
        ParameterMap(other, None, (0.3, 0.7)),
        procedural("noise", 2.5, 0.4, 0.6),
        ParameterMap(path, None, (1.0, 2.0)),
        ParameterMap(other, None, (0.0, 1.0)),
    ]
    records, packed = pack_maps(maps)
    assert records.dtype == MAP_RECORD_DTYPE and packed.dtype == np.float32
    assert list(records["kind"]) == [MAP_KINDS[k] for k in
                                     ("stripes", "constant", "texture", "noise", "texture",
                                      "texture")]
    np.testing.assert_array_equal(records["lo"], np.float32([160.0, 0.0, 0.3, 0.4, 1.0, 0.0]))
    assert records["lattice"][3] == 2 and records["lattice"][0] == 0
    # One copy per file, each row-major from its top row.
    assert len(packed) == 2 + 12
    assert list(records["offset"][[2, 4, 5]]) == [0, 2, 0]
    assert (records["width"][4], records["height"][4]) == (4, 3)
    np.testing.assert_array_equal(packed[2:].reshape(3, 4), np.float32(texels))
    empty_records, empty_texels = pack_maps([procedural("radial")])
    assert len(empty_records) == 1 and list(empty_texels) == [0.0]


@pytest.mark.parametrize(
    ("pmap", "name"),
    [
        (procedural("noise", scale=2.0**25), "scale"),
        (procedural("noise", lo=0.0, hi=1e39), "range"),
        (procedural("spots"), "procedural"),
    ],
)
def test_pack_maps_refuses_what_float32_cannot_hold(pmap, name):
    with pytest.raises(ValueError, match=rf"maps\[1\]: {name}"):
        pack_maps([None, pmap])


# --- the WGSL twin --------------------------------------------------------------------------


def twin_maps(tmp_path) -> list[ParameterMap]:
    rng = np.random.default_rng(4)
    colour = save_png(tmp_path / "colour.png", rng.integers(0, 256, (5, 7, 3), dtype=np.uint8))
    deep = save_png(tmp_path / "deep.png", rng.integers(0, 65536, (48, 64), dtype=np.uint16))
    one = save_png(tmp_path / "one.png", np.array([[200]], np.uint8))
    return [
        procedural("stripes", 1.0, 0.3, 0.7),
        procedural("stripes", 4.0, 160.0, 300.0),
        procedural("stripes", 2.5, 0.0, 1.0),
        procedural("radial", 1.0, 0.3, 0.7),
        procedural("radial", 3.7, 150.0, 250.0),
        procedural("noise", 1.0, 0.0, 1.0),
        procedural("noise", 4.0, 0.4, 0.6),
        procedural("noise", 8.0, 160.0, 300.0),
        procedural("noise", 2.5, 0.0, 1.0),
        ParameterMap(colour, None, (0.3, 0.7)),
        ParameterMap(deep, None, (150.0, 250.0)),
        ParameterMap(one, None, (0.0, 1.0)),
        None,
    ]


def twin_uv(count: int) -> np.ndarray:
    rng = np.random.default_rng(5)
    uv = np.concatenate([
        rng.random((count, 2)),
        rng.uniform(-10.0, 10.0, (count, 2)),
        rng.uniform(-1e4, 1e4, (count, 2)),
        # Exact lattice, texel and tile edges, and a float32 extreme.
        np.array([[0.0, 0.0], [-0.0, 1.0], [-1e-30, 1e-30], [0.25, -0.75], [3e38, -3e38],
                  [1e30, 7.5], [-1.0, -0.5], [0.5, 0.5]]),
    ])
    return uv.astype(np.float32)


def test_wgsl_twin_matches_numpy(device, tmp_path):
    maps = twin_maps(tmp_path)
    uv = twin_uv(4000)
    records, texels = pack_maps(maps)
    kernel = gpu.compute_pipeline(str(KERNELS / "parameter_maps_eval.wgsl"))
    index = np.repeat(np.arange(len(maps), dtype=np.uint32), len(uv))
    points = np.tile(uv, (len(maps), 1))
    (value,) = kernel.run([records, texels, points, index], [(len(points), np.float32)])
    value = value.reshape(len(maps), len(uv)).astype(np.float64)
    assert np.isfinite(value).all()
    np.testing.assert_array_equal(value[-1], 0.0)
    for k, pmap in enumerate(maps[:-1]):
        lo, hi = pmap.range
        expected = map_values(pmap, uv.astype(np.float64))
        error = np.abs(value[k] - expected) / (hi - lo)
        if pmap.procedural == "radial":
            # Both sides of a ring's jump are right: m wraps from 1 to 0 there.
            error = np.minimum(error, np.abs(1.0 - error))
        rtol = TEXTURE_RTOL if pmap.texture is not None else PROCEDURAL_RTOL
        name = pmap.procedural or pmap.texture.name
        print(f"{name} scale {pmap.scale}: max relative error {error.max():.2e}")
        assert error.max() <= rtol, name
