"""Denoising (``wgbragg.render.denoise``): the renderer's feature images, the denoiser on them,
and where it shows: ``Renderer.render(denoise=True)``, ``wgbragg render --denoise``, the viewer's
toggle and ``demo.py --denoise``."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import OpenEXR
import pytest
from PIL import Image

from wgbragg import gpu
from wgbragg.app.cli import main
from wgbragg.app.viewer import DENOISE_AFTER_SPP, DENOISE_GROWTH, Viewer
from wgbragg.common.exr import read_exr
from wgbragg.common.metrics import smape
from wgbragg.render import Renderer, denoise_image
from wgbragg.scene import load_preset, load_scene

ROOT = Path(__file__).resolve().parents[1]

_PLANE = """
[camera]
position = [0.0, 4.0, 0.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 0.0, -1.0]
fov_deg = 20.0

[environment]
type = "uniform"

[materials.grey]
type = "lambertian"
albedo = 0.5

[[objects]]
shape = "plane"
material = "grey"
"""

_SPHERE = """
[camera]
position = [0.0, 0.0, 4.0]
look_at = [0.0, 0.0, 0.0]
fov_deg = 40.0

[environment]
type = "uniform"
radiance = {radiance}

[materials.m]
{material}

[[objects]]
shape = "sphere"
material = "m"
"""
_LAMBERTIAN = 'type = "lambertian"\nalbedo = [0.2, 0.4, 0.6]'
_BRAGG = """type = "layered-bragg"
[[materials.m.layers]]
n1 = 1.0
n2 = 1.5
d1_nm = 100.0
d2_nm = 100.0
N = 10
alpha = 0.1"""


def _scene(tmp_path, text: str, name: str = "scene"):
    path = tmp_path / f"{name}.toml"
    path.write_text(text, encoding="utf-8")
    return load_scene(path)


# ---------------------------------------------------------------------------- the denoiser


def test_denoise_image_smooths_noise_and_passes_negative_parts_through():
    rng = np.random.default_rng(1)
    clean = np.full((32, 32, 3), 0.5, np.float32)
    noisy = (clean * rng.gamma(4.0, 0.25, clean.shape)).astype(np.float32)
    noisy[3, 4] = (-0.2, 0.5, 0.5)
    albedo = np.full_like(clean, 0.8)
    normal = np.broadcast_to(np.float32([0.0, 1.0, 0.0]), clean.shape)
    denoised = denoise_image(noisy, albedo, normal)
    assert denoised.dtype == np.float32 and denoised.shape == noisy.shape
    assert smape(denoised, clean) < 0.5 * smape(noisy, clean)
    # OIDN sees the negative channel as 0; the negative part is added back.
    clipped = denoise_image(np.maximum(noisy, 0.0), albedo, normal)
    np.testing.assert_allclose(denoised - clipped, np.minimum(noisy, 0.0), atol=1e-6)
    assert denoised[3, 4, 0] < clipped[3, 4, 0] - 0.19


@pytest.mark.parametrize(("call", "message"), [
    (lambda: denoise_image(np.zeros((4, 4))), "image must be a real (H, W, 3) image"),
    (lambda: denoise_image(np.zeros((4, 4, 3)), np.zeros((4, 5, 3))),
     "albedo must have the image's shape"),
    (lambda: denoise_image(np.zeros((4, 4, 3)), normal=np.zeros((4, 4, 3))),
     "normal needs albedo too"),
    (lambda: denoise_image(np.full((4, 4, 3), np.nan)), "image must be finite"),
    (lambda: denoise_image(np.zeros((4, 4, 3)), quality="best"), "quality must be one of"),
])
def test_denoise_image_refuses_bad_input(call, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        call()


# ---------------------------------------------------------------------------- features


@pytest.mark.gpu
@pytest.mark.parametrize("mode", ["rgb", "spectral"])
def test_features_of_a_lambertian_plane_facing_up(tmp_path, mode):
    renderer = Renderer(_scene(tmp_path, _PLANE), size=(12, 10), mode=mode)
    _, face = renderer.primary_hits()
    assert (face >= 0).all()  # the plane fills the picture
    renderer.render(3)
    albedo, normal = renderer.features()
    np.testing.assert_array_equal(albedo, 0.5)
    np.testing.assert_array_equal(normal, np.broadcast_to([0.0, 1.0, 0.0], normal.shape))


@pytest.mark.gpu
def test_features_of_misses_and_of_a_sphere(tmp_path):
    renderer = Renderer(_scene(tmp_path, _SPHERE.format(radiance=0.3, material=_LAMBERTIAN)),
                        size=(16, 16))
    t, face = renderer.primary_hits()
    renderer.render(4)
    albedo, normal = renderer.features()
    counts = renderer.sample_counts()
    # Pixels whose every sample missed (their centre rays miss and so do their neighbours').
    missed = np.ones_like(face, bool)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            missed &= np.roll(face, (dy, dx), axis=(0, 1)) < 0
    missed[[0, -1], :] = missed[:, [0, -1]] = False
    inside = np.zeros_like(missed)
    inside[1:-1, 1:-1] = (face[1:-1, 1:-1] >= 0) & (face[:-2, 1:-1] >= 0) & (
        face[2:, 1:-1] >= 0) & (face[1:-1, :-2] >= 0) & (face[1:-1, 2:] >= 0)
    assert missed.sum() > 20 and inside.sum() > 20 and (counts == 4).all()
    # A miss: the environment's radiance (clipped to [0, 1]) and no normal.
    np.testing.assert_allclose(albedo[missed], 0.3, rtol=1e-3)
    np.testing.assert_array_equal(normal[missed], 0.0)
    # The sphere: its albedo, and unit normals towards the camera at (0, 0, 4).
    np.testing.assert_allclose(albedo[inside], np.broadcast_to([0.2, 0.4, 0.6], (inside.sum(), 3)),
                               rtol=1e-3)
    origins, directions = renderer.camera_rays()
    points = origins + t.reshape(-1, 1).astype(np.float64) * directions
    expected = points.reshape(16, 16, 3)[inside]
    # A unit sphere at 0: the normal at the pixel's centre, within the pixel's spread.
    np.testing.assert_allclose(normal[inside], expected, atol=0.08)
    assert (np.linalg.norm(normal, axis=-1) <= 1.0 + 1e-3).all()


@pytest.mark.gpu
@pytest.mark.parametrize("mode", ["rgb", "spectral"])
def test_layered_albedo_is_the_reflectance_colour_in_range(tmp_path, mode):
    """A Bragg layer's albedo is its reflectance seen from the camera (a sample mean): in
    [0, 1], coloured, and the same however the samples were added."""
    scene = _scene(tmp_path, _SPHERE.format(radiance=1.0, material=_BRAGG))
    whole = Renderer(scene, size=(16, 16), mode=mode, seed=4)
    whole.render(8)
    split = Renderer(scene, size=(16, 16), mode=mode, seed=4)
    for _ in range(8):
        split.render(1)
    albedo, normal = whole.features()
    np.testing.assert_allclose(split.features()[0], albedo, atol=1e-5)
    np.testing.assert_allclose(split.features()[1], normal, atol=1e-5)
    _, face = whole.primary_hits()
    hit = albedo[face >= 0]
    assert hit.min() >= 0.0 and hit.max() <= 1.0
    assert hit.mean() > 0.02  # the layer reflects
    assert np.ptp(hit.mean(axis=0)) > 0.02  # in colour
    whole.reset()
    assert not whole.features()[0].any() and not whole.features()[1].any()


@pytest.mark.gpu
def test_denoised_teapot_is_closer_to_the_reference_than_the_raw_one():
    scene = load_preset("teapot")
    reference = Renderer(scene, size=(48, 36), seed=99).render(256)
    renderer = Renderer(scene, size=(48, 36), seed=1)
    renderer.render(4)
    denoised = renderer.render(1, denoise=True)
    raw = renderer.image()  # still the raw mean
    assert not np.array_equal(denoised, raw)
    np.testing.assert_array_equal(denoised, renderer.denoised())
    errors = smape(raw, reference), smape(denoised, reference)
    print(f"SMAPE at 5 spp against 256: raw {errors[0]:.4f}, denoised {errors[1]:.4f}")
    assert errors[1] < 0.85 * errors[0]


# ---------------------------------------------------------------------------- the CLI


@pytest.mark.gpu
def test_render_denoise_writes_the_denoised_images_beside_the_raw_ones(tmp_path, capsys):
    png, exr = tmp_path / "out" / "frame.png", tmp_path / "out" / "frame.exr"
    assert main(["render", "--scene", "teapot", "--size", "24x18", "--spp", "4", "-o", str(png),
                 "--exr", str(exr), "--denoise", "--no-progress"]) == 0
    out = capsys.readouterr().out
    twins = [tmp_path / "out" / "frame.denoised.png", tmp_path / "out" / "frame.denoised.exr"]
    assert out.startswith(f"{png}, {exr}, {twins[0]}, {twins[1]}: 24x18") and "denoised in" in out
    assert sorted(p.name for p in png.parent.iterdir()) == sorted(
        p.name for p in (png, exr, *twins))
    raw, denoised = read_exr(exr), read_exr(twins[1])
    assert raw.shape == denoised.shape == (18, 24, 3) and not np.array_equal(raw, denoised)
    driver = gpu.adapter_info()["driver"]  # the adapter with its Mesa version
    with OpenEXR.File(str(twins[1])) as file:
        header = file.header()
        assert header["spp"] == 4 and "Open Image Denoise" in header["comments"]
        assert header["adapter"] == driver and header["software"].startswith("wgbragg ")
    for path in (png, twins[0]):
        with Image.open(path) as image:
            assert np.asarray(image).shape == (18, 24, 3)
            assert image.text["wgbragg:adapter"] == driver and image.text["wgbragg:spp"] == "4"


# ---------------------------------------------------------------------------- the viewer


@pytest.mark.gpu
def test_the_viewer_denoises_full_size_frames_after_a_few_samples():
    viewer = Viewer("teapot", size=(32, 24), preview_scale=2)
    assert viewer.denoise and viewer.display() is None
    for _ in range(DENOISE_AFTER_SPP - 1):
        viewer.frame()
        assert not viewer.denoised
    first = viewer.frame()
    assert viewer.denoised and viewer.budgets.denoise_ms > 0.0
    # The toggle changes the display only: the same samples, shown raw, then denoised again.
    viewer.denoise = False
    raw = viewer.display()
    assert not viewer.denoised and viewer.passes == DENOISE_AFTER_SPP
    assert np.abs(raw.astype(int) - first).mean() > 1.0
    viewer.denoise = True
    np.testing.assert_array_equal(viewer.display(), first)
    # Renewed only once the samples grew by DENOISE_GROWTH: shown as it was in between.
    passes = viewer.passes
    while viewer.passes + 1 < passes * DENOISE_GROWTH:
        np.testing.assert_array_equal(viewer.frame(), first)
    assert not np.array_equal(viewer.frame(), first)
    # Previews are never denoised.
    viewer.interacting = True
    viewer.frame()
    assert not viewer.denoised
    viewer.interacting = False
    with pytest.raises(ValueError, match="denoise must be True or False"):
        viewer.denoise = "yes"
    # An edit restarts: raw again until the samples are back.
    viewer.set_layer(0, N=4)
    viewer.frame()
    assert not viewer.denoised and viewer.passes == 1


@pytest.mark.gpu
def test_demo_writes_the_denoised_window_beside_the_raw_one(tmp_path):
    target = tmp_path / "demo.png"
    environment = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    result = subprocess.run([sys.executable, str(ROOT / "demo.py"), "--offscreen", "--spp",
                             str(DENOISE_AFTER_SPP), "--size", "32x32", "--denoise", "-o",
                             str(target)],
                            env=environment, capture_output=True, text=True, check=True)
    twin = tmp_path / "demo.denoised.png"
    assert result.stdout.strip().splitlines()[-2:] == [str(target), str(twin)]
    assert f"32x32, {DENOISE_AFTER_SPP} spp" in result.stderr and "denoised in" in result.stderr
    raw, denoised = (np.asarray(Image.open(p).convert("RGB")) for p in (target, twin))
    assert raw.shape == denoised.shape == (760, 1040, 3)
    assert not np.array_equal(raw, denoised)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo.denoised.png", "demo.png"]


def test_demo_refuses_to_denoise_fewer_samples_than_the_window_shows_denoised(tmp_path):
    target = tmp_path / "demo.png"
    environment = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    result = subprocess.run([sys.executable, str(ROOT / "demo.py"), "--offscreen", "--spp",
                             str(DENOISE_AFTER_SPP - 1), "--denoise", "-o", str(target)],
                            env=environment, capture_output=True, text=True)
    assert result.returncode != 0 and "Traceback" not in result.stderr
    assert f"--denoise needs --spp >= {DENOISE_AFTER_SPP}" in result.stderr
    assert not any(tmp_path.iterdir())
