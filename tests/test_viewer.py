"""The demo: the viewer's edits, frames and budgets (``wgbragg.app.viewer``), which renderer
draws each frame (``wgbragg.app.viewer_frames``: rasterized while interacting, path-traced at
rest), its window in a real glfw window under Xvfb (``wgbragg.app.viewer_window``) compared with
reference screenshots, and ``demo.py``'s headless mode.

Reference screenshots are ``tests/screenshots/*.png``; ``pytest --regenerate-screenshots``
rewrites them. A mismatch writes the frame and its difference under pytest's tmp folder and
names them in the failure.
"""

from __future__ import annotations

import colorsys
import gc
import os
import re
import select
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import EXPECT_LAVAPIPE
from PIL import Image

from wgbragg.app.viewer import DEFAULT_FILM, HANDOVER_SPP, PREVIEW_SCALES, Viewer
from wgbragg.render import Renderer, display_transform
from wgbragg.render.rasterizer import Rasterizer
from wgbragg.scene.model import LayeredBraggMaterial, ThinFilmMaterial

pytestmark = pytest.mark.gpu

ROOT = Path(__file__).resolve().parents[1]
SCREENSHOTS = Path(__file__).parent / "screenshots"
SIZE = (128, 128)
# Mean |difference| per channel, in 8-bit levels, between a frame and its reference: the
# render is seeded (the same paths on every run), so this only absorbs another CPU's rounding
# in lavapipe (a path that turns elsewhere moves one pixel, not the mean) and font rasterisation.
SCREENSHOT_TOLERANCE = 2.0
# A rasterized frame against the path tracer's at HANDOVER_SPP raw samples, the teapot at 128 x
# 128, in 8-bit levels: the mean |difference| (14.0 measured, of which the 4-spp noise is 9.6:
# 4 spp against 64) and the difference of the channel means (<= 5.9 measured, blue; 4.1
# against 64 spp: filtered lighting has no interreflection and shadow maps for shadow rays).
RASTER_PATH_MEAN_ABS = 18.0
RASTER_PATH_CHANNEL_MEANS = 8.0


def saturation(pixels: np.ndarray) -> np.ndarray:
    """HSV saturation of 8-bit RGB pixels, shape pixels.shape[:-1]."""
    rgb = pixels.astype(np.float64)
    high, low = rgb.max(axis=-1), rgb.min(axis=-1)
    return np.where(high > 0, (high - low) / np.maximum(high, 1e-9), 0.0)


def differs(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a.astype(np.float64) - b.astype(np.float64)).mean())


def mean_hue(pixels: np.ndarray, min_saturation: float = 0.25) -> float:
    """Circular mean HSV hue, in degrees, of the 8-bit RGB pixels at least this saturated."""
    chosen = pixels.reshape(-1, 3)[saturation(pixels).ravel() >= min_saturation] / 255.0
    assert len(chosen) >= 5, "too few saturated pixels for a hue"
    angle = 2.0 * np.pi * np.array([colorsys.rgb_to_hsv(*rgb)[0] for rgb in chosen])
    return float(np.degrees(np.arctan2(np.sin(angle).mean(), np.cos(angle).mean())) % 360.0)


def hue_distance(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)


# ---------------------------------------------------------------------------------- the model


@pytest.fixture
def viewer():
    return Viewer("teapot", size=(64, 64), preview_scale=2)


@pytest.mark.parametrize(("call", "message"), [
    (lambda v: v.set_layer(2, N=3), "index must be an integer in [0, 2)"),
    (lambda v: v.set_layer(0, N=0), "N must be an integer"),
    (lambda v: v.set_layer(0, alpha=2.0), "alpha must be in [0.01, 1]"),
    (lambda v: v.set_layer(0, delta=1.5), "delta must be a real number in [0, 1]"),
    (lambda v: v.set_layer(0, period_nm=0.0), "period_nm must be > 0"),
    (lambda v: v.set_layer(0, n2=float("nan")), "n2 is NaN"),
    (lambda v: v.set_layer(0, n1=1.3), "n1 belongs to all layers"),
    (lambda v: v.edit(n1=0.9), "n1 must be >= 1"),
    (lambda v: v.edit(layers=5), "layers must be an integer in [1, 4]"),
    (lambda v: v.edit(base_albedo=(0.2, 2.0, 0.1)), "base_albedo must be a real number"),
    (lambda v: v.edit(mode="hyperspectral"), "mode must be one of"),
    (lambda v: v.edit(colour_method="guess"), "colour_method must be one of"),
    (lambda v: v.edit(environment="exr"), "environment must be one of"),
    (lambda v: v.edit(pitch_deg=95.0), "pitch_deg must be a real number in [-89, 89]"),
    (lambda v: v.edit(distance=0.0), "distance must be a finite real number > 0"),
    (lambda v: v.edit(yaw_deg=float("inf")), "yaw_deg must be a finite real number"),
    (lambda v: v.edit(exposure=float("nan")), "exposure must be a real number in [-64, 64]"),
    (lambda v: v.edit(exposure=100.0), "exposure must be a real number in [-64, 64]"),
    (lambda v: v.edit(zoom=2.0), "unknown edit(s) ['zoom']"),
    (lambda v: v.zoom(0.0), "factor must be a finite real number > 0"),
    (lambda v: v.colour_strip(0, samples=1), "samples must be >= 2"),
    (lambda v: v.edit(material_type="metal"), "material_type must be one of"),
    (lambda v: v.set_film(thickness_nm=-1.0), "thickness_nm must be a thickness in [0, "),
    (lambda v: v.set_film(n_film=0.0), "n_film must be a refractive index in [0.01, "),
    (lambda v: v.set_film(alpha=0.001), "alpha must be in [0.01, 1]"),
    (lambda v: v.set_film(base="Pt"), "base must be None or one of ('Ag', 'Al', 'Au', 'Cu')"),
    (lambda v: v.set_film(base="Au", n_base=1.5), "a metal base replaces n_base and k_base"),
    (lambda v: v.set_film(k_base=-0.1), "k_base must be an extinction coefficient in [0, "),
    (lambda v: v.set_film(noise_range_nm=(600.0, 200.0)), "lo <= hi, got (600.0, 200.0)"),
    (lambda v: v.set_film(noise_range_nm=(600.0,)), "noise_range_nm must be (lo, hi)"),
    (lambda v: v.set_film(noise="yes"), "noise must be True or False"),
    (lambda v: v.set_film(d=400.0), "unknown film field(s) ['d']"),
    (lambda v: v.film_colour_strip(samples=1), "samples must be >= 2"),
])
def test_bad_edits_name_the_parameter_and_change_nothing(viewer, call, message):
    viewer.frame()
    scene, passes = viewer.scene, viewer.passes
    with pytest.raises(ValueError, match=re.escape(message)):
        call(viewer)
    assert viewer.scene is scene and viewer.passes == passes


def test_viewer_refuses_bad_construction():
    with pytest.raises(ValueError, match="size must be two integers"):
        Viewer("teapot", size=(0, 64))
    with pytest.raises(ValueError, match="no layered-bragg material or thin-film material"):
        Viewer("furnace")
    with pytest.raises(ValueError, match="material must be one of"):
        Viewer("teapot", material="floor")


def test_edits_restart_the_accumulation_and_measure_their_budgets(viewer, monkeypatch,
                                                                  tmp_path):
    viewer.frame()
    viewer.frame()
    assert viewer.passes == 2 and viewer.budgets.fps > 0
    viewer.set_layer(0, period_nm=250.0, delta=0.4, N=12, n2=1.6)
    assert viewer.passes == 0
    spec = viewer.layers[0]
    assert spec.period_nm == pytest.approx(250.0) and spec.delta == pytest.approx(0.4)
    assert (spec.N, spec.n2) == (12, 1.6)
    budgets = viewer.budgets
    assert 0 < budgets.table_ms <= budgets.update_ms
    # A roughness this process never used, in an empty cache: its filter is baked.
    monkeypatch.setenv("WGBRAGG_CACHE", str(tmp_path))
    viewer.set_layer(1, alpha=0.2)
    assert (budgets.filter_source, budgets.filter_alpha) == ("baked", 0.2)
    assert budgets.filter_s > 0
    viewer.set_layer(0, alpha=0.2)
    assert budgets.filter_source == "in memory"
    viewer.edit(n1=1.2, base_albedo=0.3, layers=3, environment="studio",
                colour_method="reference")
    assert [s.n1 for s in viewer.layers] == [1.2] * 3
    assert viewer.layers[2] == viewer.layers[1]  # a new layer copies the lowest
    assert viewer.material.base_albedo == 0.3
    assert viewer.scene.environment.type == "studio" and viewer.colour_method == "reference"
    viewer.frame()
    viewer.edit(exposure=1.0)  # display only: the samples stay
    assert viewer.passes == 1 and viewer.exposure == 1.0


def test_camera_edits_keep_the_material_tables(viewer, monkeypatch):
    yaw = viewer.yaw_deg
    built = []
    to_structure = LayeredBraggMaterial.to_structure
    monkeypatch.setattr(LayeredBraggMaterial, "to_structure",
                        lambda self, *a, **k: built.append(self) or to_structure(self, *a, **k))
    viewer.orbit(25.0, -10.0)
    viewer.zoom(0.8)
    viewer.edit(environment="uniform")
    assert built == []
    assert viewer.yaw_deg == pytest.approx(yaw + 25.0)
    viewer.set_layer(1, N=4)
    assert len(built) == 1


def test_interaction_is_rasterized_at_full_size_and_the_path_tracer_takes_over_at_rest():
    """While interacting every frame is the rasterizer's at full size, an edit showing in the
    next one; at rest the path tracer adds a sample a frame behind the rasterized picture and
    replaces it from HANDOVER_SPP samples."""
    size = (40, 32)
    viewer = Viewer("teapot", size=size, seed=3, denoise=False)
    viewer.interacting = True
    first = viewer.frame()
    assert viewer.source == "rasterized" and viewer.raster_refusal is None
    reference = Rasterizer(viewer.scene, size=size)
    np.testing.assert_array_equal(first, reference.frame_srgb(viewer.exposure))
    assert viewer.passes == 0 and viewer.budgets.raster_fps > 0 and viewer.budgets.fps is None
    viewer.set_layer(0, period_nm=300.0)  # a layer edit shows in the next frame
    edited = viewer.frame()
    reference.update(viewer.scene)
    np.testing.assert_array_equal(edited, reference.frame_srgb(viewer.exposure))
    assert differs(edited, first) > 1.0
    viewer.interacting = False
    for k in range(1, HANDOVER_SPP):
        pixels = viewer.frame()
        assert (viewer.source, viewer.passes) == ("rasterized", k)
        # Drawn on, jittered, while the path tracer gathers samples.
        np.testing.assert_array_equal(pixels, reference.frame_srgb(viewer.exposure))
    traced = viewer.frame()
    assert (viewer.source, viewer.passes) == ("path-traced", HANDOVER_SPP)
    path = Renderer(viewer.scene, size=size, seed=3, mode="rgb", colour_method="averaged",
                    ibl="monte-carlo")
    np.testing.assert_array_equal(traced, display_transform(path.render(HANDOVER_SPP),
                                                            viewer.exposure))
    assert viewer.budgets.fps > 0
    # refine() shows the path tracer's picture whatever its samples.
    viewer.set_layer(0, N=5)
    viewer.refine(1)
    assert (viewer.source, viewer.passes) == ("path-traced", 1)


def test_scenes_the_rasterizer_cannot_shade_are_previewed_by_paths():
    """Spectral mode: interaction falls back to the path-traced preview at a reduced
    resolution, and at rest the path tracer shows from its first sample. A smooth coating is
    rasterized (filtered lighting shades it)."""
    spectral = Viewer("fig11", size=(16, 16), preview_scale=2)
    assert spectral.mode == "spectral" and spectral.raster_refusal.startswith("spectral mode")
    spectral.interacting = True
    preview = spectral.frame()
    assert spectral.source == "preview" and preview.shape == (16, 16, 3)
    blocks = preview.reshape(8, 2, 8, 2, 3)
    assert (blocks == blocks[:, :1, :, :1]).all()  # each pixel of the preview shown 2 x 2
    assert spectral.budgets.preview_scale == 2 and spectral.budgets.preview_fps > 0
    spectral.interacting = False
    spectral.frame()
    assert (spectral.source, spectral.passes) == ("path-traced", 1)
    spectral.edit(mode="rgb")  # the coated layers
    assert spectral.raster_refusal is None
    spectral.interacting = True
    spectral.frame()
    assert spectral.source == "rasterized"
    viewer = Viewer("teapot", size=(16, 16))
    assert viewer.raster_refusal is None and viewer.preview_scale() == 2  # not measured yet
    viewer.edit(mode="spectral")
    assert viewer.raster_refusal.startswith("spectral mode")
    viewer.interacting = True
    viewer.frame()
    assert viewer.source == "preview" and viewer.budgets.preview_scale == 2
    assert viewer.preview_scale() in PREVIEW_SCALES  # from the cost just measured
    viewer.edit(mode="rgb")
    assert viewer.raster_refusal is None
    viewer.frame()
    assert viewer.source == "rasterized"


def test_side_panel_data(viewer):
    wavelength, reflectance = viewer.spectrum(0)
    assert wavelength.shape == reflectance.shape == (471,)
    assert wavelength[0] == 360.0 and wavelength[-1] == 830.0
    assert 0.0 <= reflectance.min() and reflectance.max() <= 1.0
    # N = 8, n = 1 / 1.5: the first-order gap at normal incidence is nearly total.
    assert reflectance.max() > 0.9
    marks = viewer.landmarks(0)
    assert len(marks.kind) > 0 and set(marks.kind) <= {"mode", "airy", "edge", "zero"}
    assert ((360.0 <= marks.wavelength_nm) & (marks.wavelength_nm <= 830.0)).all()
    theta, colours = viewer.colour_strip(0)
    assert theta[0] == 0.0 and theta[-1] == 90.0
    assert colours.shape == (46, 3) and colours.dtype == np.uint8
    assert saturation(colours).max() > 0.5
    viewer.edit(colour_method="approx")
    assert not np.array_equal(viewer.colour_strip(0)[1], colours)


def test_the_thin_film_is_edited_and_each_kind_keeps_its_settings(viewer):
    viewer.frame()
    assert viewer.material_type == "layered-bragg" and viewer.film == DEFAULT_FILM
    viewer.edit(material_type="thin-film")
    assert viewer.passes == 0 and viewer.material is viewer.film
    assert viewer.scene.materials["two_layers"] == DEFAULT_FILM
    viewer.set_film(thickness_nm=320.0, n_film=1.8, base="Cu", alpha=0.2, noise=False)
    film = viewer.film
    assert (film.thickness_nm, film.n_film, film.base, film.alpha) == (320.0, 1.8, "Cu", 0.2)
    assert (film.n_base, film.k_base, film.thickness_map) == (1.0, 0.0, None)
    # Rendered with a constant map, so that the noise toggle keeps the pipeline.
    shown = viewer.scene.materials["two_layers"]
    assert isinstance(shown, ThinFilmMaterial) and shown.thickness_map.range == (320.0, 320.0)
    assert viewer.budgets.table_ms == 0.0  # films bake no tables
    # A dielectric base comes back as it was; the noise map too, with a new range.
    viewer.set_film(base=None)
    assert (viewer.film.base, viewer.film.n_base, viewer.film.k_base) == (None, 1.5, 0.0)
    viewer.set_film(k_base=0.5, noise=True, noise_range_nm=(100.0, 300.0))
    assert viewer.film.thickness_map.range == (100.0, 300.0) == viewer.noise_range_nm
    assert viewer.film.thickness_map.procedural == "noise" and viewer.film_thickness_nm == 200.0
    viewer.frame()
    # Bragg edits while the film is shown change the kept layers, not the image.
    viewer.set_layer(0, N=4)
    viewer.edit(n1=1.1)
    assert viewer.passes == 1 and viewer.layers[0].N == 4
    viewer.edit(material_type="layered-bragg")
    assert viewer.passes == 0 and viewer.material is viewer.bragg
    assert viewer.scene.materials["two_layers"].layers[0].N == 4
    viewer.edit(material_type="thin-film")
    assert viewer.film.k_base == 0.5 and viewer.film.thickness_map.range == (100.0, 300.0)


def test_the_thin_film_preset_opens_on_its_film():
    viewer = Viewer("thin_film", size=(32, 32), preview_scale=2)
    assert viewer.material_type == "thin-film" and viewer.material_name == "film"
    assert viewer.film.thickness_map.procedural == "noise"
    # The Bragg layers it can switch to are the teapot preset's.
    assert len(viewer.layers) == 2
    assert np.isfinite(viewer.frame()).all()


def test_film_side_panel_data(viewer):
    viewer.edit(material_type="thin-film")
    viewer.set_film(noise=False, thickness_nm=250.0, n_film=2.0, base=None, n_base=1.5,
                    k_base=0.0)
    wavelength, reflectance = viewer.film_spectrum()
    assert wavelength.shape == reflectance.shape == (471,)
    # A 250 nm film of index 2 over glass: Airy fringes between the bare interfaces' 4 %
    # and the quarter-wave maximum ((r12 - r23) / (1 - r12 r23))^2 = 0.23.
    assert 0.03 < reflectance.min() < 0.05 and 0.2 < reflectance.max() < 0.24
    theta, colours = viewer.film_colour_strip()
    assert theta[0] == 0.0 and theta[-1] == 90.0 and colours.shape == (46, 3)
    assert saturation(colours[:10]).min() > 0.3  # magenta-red near normal incidence
    viewer.set_film(thickness_nm=450.0)
    assert hue_distance(mean_hue(viewer.film_colour_strip()[1][:10], 0.0),
                        mean_hue(colours[:10], 0.0)) > 90.0


# --------------------------------------------------------------------------------- the window


@pytest.fixture(scope="module")
def display(tmp_path_factory):
    """A private Xvfb server, DISPLAY pointing at it for the module's tests."""
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        reason = "no Xvfb: apt-get install xvfb (make test installs it)"
        if EXPECT_LAVAPIPE:
            pytest.fail(f"WGBRAGG_EXPECT_LAVAPIPE=1 but {reason}")
        pytest.skip(reason)
    read, write = os.pipe()
    # -displayfd: Xvfb picks a free display number and writes it here once it accepts clients.
    server = subprocess.Popen([xvfb, "-displayfd", str(write), "-screen", "0", "1280x1024x24",
                               "-nolisten", "tcp"], pass_fds=(write,),
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write)
    written = b""
    try:
        # Up to its newline: a reader that left early would make Xvfb's last write fail,
        # which is fatal to it.
        while not written.endswith(b"\n") and select.select([read], [], [], 30.0)[0]:
            chunk = os.read(read, 32)
            if not chunk:
                break
            written += chunk
    finally:
        os.close(read)
    number = written.decode().strip()
    if not written.endswith(b"\n") or server.poll() is not None:
        server.kill()
        pytest.fail(f"Xvfb did not start within 30 s (it wrote {written!r})")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("DISPLAY", f":{number}")
        patch.delenv("WAYLAND_DISPLAY", raising=False)
        patch.setenv("XDG_RUNTIME_DIR", str(tmp_path_factory.mktemp("xdg")))
        try:
            yield f":{number}"
        finally:
            import glfw

            # Windows and their surfaces go before glfw, and glfw before its X server.
            gc.collect()
            glfw.terminate()
            glfw._rc_alive = False  # rendercanvas's flag: glfw must be initialised again
            server.terminate()
            server.wait(10)


@pytest.fixture
def window(display):
    from wgbragg.app.viewer_window import ViewerWindow

    # The frames' tests read the raw samples at 4 spp: the denoised display has tests of its own
    # (tests/test_denoise.py).
    shown = ViewerWindow(Viewer("teapot", size=SIZE, preview_scale=2, denoise=False),
                         size=(1040, 760))
    yield shown
    shown.close()


def panel_region(window, frame: np.ndarray) -> np.ndarray:
    """The spectrum plot down to the colour strip, the panel's drawing (no live numbers)."""
    x0, y0 = (round(v) for v in window.plot_rect[:2])
    x1, y1 = (round(v) for v in window.strip_rect[2:])
    return frame[y0:y1, x0:x1]


def test_window_shows_the_render_and_the_panel(window):
    frames = [window.capture() for _ in range(4)]
    frame = frames[-1]
    assert window.viewer.source == "path-traced"
    assert frame.shape == (760, 1040, 3)
    picture = window.picture(frame)
    assert picture.shape == (*SIZE[::-1], 3)
    # The picture is the viewer's frame, byte for byte (sRGB texture to sRGB target at 5:1).
    assert np.abs(picture.astype(int) - window.viewer.last_frame).max() <= 1
    assert picture.std() > 10, "blank picture"
    assert (saturation(picture) > 0.5).mean() > 0.01, "no saturated hues in the render"
    x0, y0, x1, y1 = (round(v) for v in window.strip_rect)
    strip = frame[y0 + 2:y1 - 2, x0 + 2:x1 - 2]
    assert (saturation(strip) > 0.5).mean() > 0.2, "no saturated hues in the colour strip"
    assert panel_region(window, frame).std() > 20
    assert differs(frames[0], frames[-1]) > 0  # progressive: the picture refines


def test_the_window_shows_a_rasterized_frame_then_a_path_traced_one(window):
    """The first frame is rasterized, at full size; once the view has rested for HANDOVER_SPP
    frames the path tracer's replaces it, showing the same picture within the noise."""
    viewer = window.viewer
    raster = window.picture(window.capture())
    assert viewer.source == "rasterized" and raster.shape == (*SIZE[::-1], 3)
    assert np.abs(raster.astype(int) - viewer.last_frame).max() <= 1
    blocks = raster.reshape(SIZE[1] // 2, 2, SIZE[0] // 2, 2, 3)
    assert not (blocks == blocks[:, :1, :, :1]).all(), "not at full resolution"
    assert raster.std() > 10 and (saturation(raster) > 0.5).mean() > 0.01
    for _ in range(HANDOVER_SPP - 2):
        window.draw()
        assert viewer.source == "rasterized"
    traced = window.picture(window.capture())
    assert viewer.source == "path-traced" and viewer.passes == HANDOVER_SPP
    mean_abs = differs(traced, raster)
    channels = np.abs(traced.reshape(-1, 3).mean(0) - raster.reshape(-1, 3).mean(0))
    print(f"rasterized vs path-traced: mean |difference| {mean_abs:.2f}, channel means "
          f"{np.round(channels, 2)} (8-bit levels)")
    assert 0.0 < mean_abs <= RASTER_PATH_MEAN_ABS
    assert channels.max() <= RASTER_PATH_CHANNEL_MEANS
    assert window.raster_fps > 0 and window.fps is None  # one path-traced frame so far


def test_frames_change_after_edits(window):
    viewer = window.viewer
    previous = window.capture()
    edits = [
        lambda: viewer.set_layer(0, period_nm=260.0),
        lambda: viewer.set_layer(0, delta=0.3),
        lambda: viewer.set_layer(1, N=4),
        lambda: viewer.set_layer(1, n2=1.9),
        lambda: viewer.set_layer(0, alpha=0.3),
        lambda: viewer.edit(n1=1.3),
        lambda: viewer.edit(layers=1),
        lambda: viewer.edit(base_albedo=(0.6, 0.2, 0.1)),
        lambda: viewer.edit(environment="studio"),
        lambda: viewer.edit(colour_method="reference"),
        lambda: viewer.orbit(40.0, 10.0),
        lambda: viewer.zoom(0.7),
        lambda: viewer.edit(mode="spectral"),
    ]
    for edit in edits:
        edit()
        assert viewer.passes == 0  # every edit restarts
        frame = window.capture()
        assert viewer.passes == 1
        assert differs(window.picture(frame), window.picture(previous)) > 0
        assert window.picture(frame).std() > 5, "blank picture"
        previous = frame


def test_switching_to_the_thin_film_changes_the_frame_and_the_panel(window):
    viewer = window.viewer
    first = window.capture()  # 1 spp
    bragg = window.capture()  # Dear ImGui lays the panel out from its second frame
    viewer.edit(material_type="thin-film")
    assert viewer.passes == 0
    film = window.capture()
    assert viewer.passes == 1
    assert differs(window.picture(film), window.picture(first)) > 2.0
    assert window.picture(film).std() > 5, "blank picture"
    # The panel shows the film's spectrum and colours instead of the layer's.
    assert differs(panel_region(window, film), panel_region(window, bragg)) > 2.0
    # Back to the layers, as they were: the same first sample.
    viewer.edit(material_type="layered-bragg")
    assert differs(window.picture(window.capture()), window.picture(first)) == 0.0


def test_film_thickness_changes_the_hue(window):
    viewer = window.viewer
    viewer.edit(material_type="thin-film")
    pictures, strips = [], []
    # n_film 2 over glass at normal incidence: magenta-red at 250 nm, green at 450 nm.
    for d in (250.0, 450.0):
        viewer.set_film(noise=False, thickness_nm=d, alpha=0.05)
        for _ in range(3):
            window.draw()
        frame = window.capture()  # 4 spp
        pictures.append(window.picture(frame))
        # The strip's first third: the colour up to 30 degrees.
        x0, y0, x1, y1 = (round(v) for v in window.strip_rect)
        strips.append(frame[y0 + 2:y1 - 2, x0 + 2:x0 + (x1 - x0) // 3])
    # The same seed draws the same paths: pixels whose paths never meet the teapot are equal.
    teapot = (pictures[0] != pictures[1]).any(axis=-1)
    hues = [mean_hue(p[teapot]) for p in pictures] + [mean_hue(s) for s in strips]
    print(f"hues: teapot {hues[0]:.0f} -> {hues[1]:.0f} deg, strip {hues[2]:.0f} -> "
          f"{hues[3]:.0f} deg ({teapot.mean():.0%} of the picture)")
    assert hue_distance(hues[0], hues[1]) > 45.0
    assert hue_distance(hues[2], hues[3]) > 90.0


def test_the_noise_toggle_changes_the_frame(window):
    viewer = window.viewer
    viewer.edit(material_type="thin-film")
    viewer.set_film(noise=False, thickness_nm=500.0)
    window.draw()
    uniform = window.capture()
    viewer.set_film(noise=True, noise_range_nm=(250.0, 750.0))
    assert viewer.passes == 0
    noisy = window.capture()
    assert viewer.source == "rasterized"
    viewer.set_film(noise_range_nm=(300.0, 400.0))
    narrow = window.picture(window.capture())
    # Rasterized frames have no noise: the pixels that change are the film's (the teapot,
    # about a quarter of the picture), and each frame is compared there.
    for before, after in ((window.picture(uniform), window.picture(noisy)),
                          (window.picture(noisy), narrow)):
        changed = (before != after).any(axis=-1)
        print(f"noise toggle: {changed.mean():.0%} of the picture changed, by "
              f"{differs(before[changed], after[changed]):.1f} levels")
        assert changed.mean() > 0.08  # measured 18 % and 13 %, by 9.0 and 15.5 levels
        assert differs(before[changed], after[changed]) > 4.0


def test_dragging_the_picture_orbits_with_rasterized_frames(window):
    window.draw()  # lays the picture out
    x, y, width, height = window.image_rect
    yaw = window.viewer.yaw_deg
    distance = window.viewer.distance
    window.on_pointer({"event_type": "pointer_down", "x": x + width / 2, "y": y + height / 2,
                       "button": 1})
    window.on_pointer({"event_type": "pointer_move", "x": x + width / 2 + 50,
                       "y": y + height / 2})
    frame = window.capture()
    assert window.viewer.yaw_deg == pytest.approx(yaw - 20.0)
    assert window.viewer.source == "rasterized" and window.viewer.passes == 0
    blocks = window.picture(frame).reshape(64, 2, 64, 2, 3)
    assert not (blocks == blocks[:, :1, :, :1]).all()  # full resolution
    window.capture()
    assert window.raster_fps > 0
    window.on_pointer({"event_type": "pointer_up", "x": x, "y": y, "button": 1})
    window.on_wheel({"event_type": "wheel", "dx": 0.0, "dy": 400.0})
    assert window.viewer.distance == pytest.approx(min(2.0 * distance, 20.0))  # 400: 2x


def test_screenshots_match_the_references(window, request, tmp_path):
    for _ in range(3):
        window.draw()
    frame = window.capture()  # 4 spp
    regenerate = request.config.getoption("--regenerate-screenshots")
    problems = []
    for name, image in (("viewer_picture", window.picture(frame)),
                        ("viewer_panel", panel_region(window, frame))):
        reference = SCREENSHOTS / f"{name}.png"
        if regenerate:
            SCREENSHOTS.mkdir(exist_ok=True)
            Image.fromarray(image).save(reference)
            continue
        if not reference.is_file():
            problems.append(f"{name}: no reference {reference}")
            continue
        expected = np.asarray(Image.open(reference).convert("RGB"))
        if expected.shape != image.shape:
            problems.append(f"{name}: shape {image.shape}, reference {expected.shape}")
            continue
        error = np.abs(image.astype(np.float64) - expected).mean(axis=(0, 1))
        if error.max() > SCREENSHOT_TOLERANCE:
            Image.fromarray(image).save(tmp_path / f"{name}.png")
            diff = np.abs(image.astype(np.int16) - expected).astype(np.uint8)
            Image.fromarray(diff).save(tmp_path / f"{name}_diff.png")
            problems.append(f"{name}: mean |difference| per channel {np.round(error, 2)} > "
                            f"{SCREENSHOT_TOLERANCE} (frame and diff in {tmp_path})")
    assert not problems, "; ".join(problems) + " (pytest --regenerate-screenshots rewrites them)"


# ---------------------------------------------------------------------------- headless demo


def test_demo_renders_offscreen_without_a_display(tmp_path):
    target = tmp_path / "demo.png"
    environment = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    result = subprocess.run([sys.executable, str(ROOT / "demo.py"), "--offscreen", "--spp", "2",
                             "--size", "32x32", "-o", str(target)], env=environment,
                            capture_output=True, text=True, check=True)
    assert result.stdout.strip().splitlines()[-1] == str(target)
    assert "32x32, 2 spp path-traced" in result.stderr
    pixels = np.asarray(Image.open(target).convert("RGB"))
    assert pixels.shape == (760, 1040, 3) and pixels.std() > 20
    assert [p.name for p in tmp_path.iterdir()] == ["demo.png"]  # no temporary file left
