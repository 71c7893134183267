"""The viewer's frames: which renderer draws each one, its display and what it cost.

A :class:`FrameScheduler` holds the renderers behind :class:`wgbragg.app.viewer.Viewer`'s
frames, each updated to the current scene when it next draws:

- while the user interacts (and at rest until the path tracer's picture is ready), the
  real-time :class:`wgbragg.render.rasterizer.Rasterizer` at full resolution: one frame a
  call, averaged over jittered frames while nothing changes;
- at rest, the progressive path tracer (:class:`wgbragg.render.Renderer`, one sample per pixel
  a frame), whose picture replaces the rasterized one once it holds :data:`HANDOVER_SPP`
  samples (switched, not blended: docs/design.md, "The demo");
- where the rasterizer cannot shade the scene (spectral mode, or a scene it refuses), interaction
  falls back to a path-traced preview at a reduced resolution (:data:`PREVIEW_SCALES`).

Rasterized frames go through the display transform on the device
(:meth:`Rasterizer.frame_srgb`), path-traced ones through
:func:`wgbragg.render.display_transform`; full-resolution path-traced pictures are shown
denoised from :data:`DENOISE_AFTER_SPP`.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from wgbragg.render import Renderer, display_transform
from wgbragg.render.rasterizer import Rasterizer
from wgbragg.scene.model import Scene

__all__ = [
    "DENOISE_AFTER_SPP",
    "DENOISE_GROWTH",
    "DENOISE_QUALITY",
    "HANDOVER_SPP",
    "PREVIEW_BUDGET_FPS",
    "PREVIEW_SCALES",
    "RASTER_BUDGET_FPS",
    "SOURCES",
    "Budgets",
    "FrameScheduler",
    "SceneState",
]

RASTER_BUDGET_FPS = 30.0
"""Rasterized frames per second while interacting (issue 49's target at 512 x 512 on
lavapipe, two cores; 60 at 256 x 256), readback and display transform included."""
PREVIEW_BUDGET_FPS = 10.0
"""Path-traced preview frames per second, where the rasterizer cannot shade the scene."""
PREVIEW_SCALES = (1, 2, 4, 8)
"""Resolution divisors the path-traced preview chooses from."""
HANDOVER_SPP = 4
"""At rest, the path tracer's picture replaces the rasterized one once it holds this many
samples per pixel (then denoised, :data:`DENOISE_AFTER_SPP`)."""
DENOISE_AFTER_SPP = 4
"""Full-resolution path-traced frames of at least this many samples per pixel are shown
denoised (while the viewer's ``denoise`` is on)."""
DENOISE_GROWTH = 1.25
"""The denoised picture is renewed once the samples have grown by this factor since the last
one (5, 7, 9, 12, 15, 19, ... spp), and shown as it was in between: denoising costs about a
frame's time at full size, which each frame would otherwise pay."""
DENOISE_QUALITY = "high"
"""OIDN's filter quality for the viewer (:data:`wgbragg.render.denoise.QUALITIES`)."""
SOURCES = ("rasterized", "path-traced", "preview")
"""What a frame shows: the rasterizer's image, the full-resolution path tracer's, or the
reduced-resolution path-traced preview (:attr:`FrameScheduler.source`)."""

# Share of a preview frame's time left to the window's own drawing when choosing the scale.
_PREVIEW_HEADROOM = 0.75
# Weight of the newest frame in the running frame-time averages.
_SMOOTHING = 0.2


@dataclasses.dataclass
class Budgets:
    """What edits and frames cost, wall clock (``time.perf_counter``); None until measured.

    Attributes
    ----------
    table_ms : float or None
        Tables of the edited material re-baked by the last path tracer update that followed a
        material edit: :attr:`Renderer.table_seconds`.
    update_ms : float or None
        That whole :meth:`Renderer.update` (tables, uploads, pipeline, restart).
    raster_update_ms : float or None
        The last :meth:`Rasterizer.update` that followed a material edit.
    filter_s, filter_source, filter_alpha : float, str, float or None
        The transmission filter of the last roughness edit: its time, how it came
        (``"baked"``, ``"loaded"``, ``"re-baked"`` or ``"in memory"``) and its roughness.
    fps : float or None
        Full-resolution path-traced frames per second (one sample, readback, display
        transform when shown), a running average.
    raster_fps : float or None
        Rasterized frames per second (draw, readback, display transform).
    preview_fps : float or None
        Path-traced preview frames per second.
    preview_scale : int or None
        Resolution divisor of the last preview frame.
    denoise_ms : float or None
        The last denoising of a full-resolution frame (feature readback and OIDN).
    """

    table_ms: float | None = None
    update_ms: float | None = None
    raster_update_ms: float | None = None
    filter_s: float | None = None
    filter_source: str | None = None
    filter_alpha: float | None = None
    fps: float | None = None
    raster_fps: float | None = None
    preview_fps: float | None = None
    preview_scale: int | None = None
    denoise_ms: float | None = None


@dataclasses.dataclass
class _Slot:
    """A renderer (path tracer or rasterizer) and the scene version it shows."""

    renderer: Renderer | Rasterizer
    version: int
    material_version: int


@dataclasses.dataclass(frozen=True)
class SceneState:
    """What the renderers draw: a scene, its transport and colour method, and the versions
    that tell a renderer it is stale (any change; a material change). A version is never
    reused for another scene, a refused one included."""

    scene: Scene
    mode: str
    colour_method: str
    version: int = 0
    material_version: int = 0


class FrameScheduler:
    """The renderers of a viewer's frames, and which one draws each frame.

    Parameters
    ----------
    state : SceneState
    size : tuple of 2 ints
    seed, max_bounces : int
        As :class:`wgbragg.render.Renderer`'s.
    preview_scale : int or None
        Fixed divisor of the path-traced preview; None chooses it from the measured cost.
    handover_spp : int
        Samples per pixel from which the path tracer's picture is shown at rest.
    budgets : Budgets
        Filled as frames and updates are measured.

    Raises
    ------
    ValueError
        From the path tracer, for a scene or parameter it refuses.
    """

    def __init__(self, state: SceneState, size: tuple[int, int], seed: int, max_bounces: int,
                 preview_scale: int | None, handover_spp: int, budgets: Budgets):
        self.state, self.size = state, size
        self.handover_spp, self.budgets = handover_spp, budgets
        self._seed, self._max_bounces = seed, max_bounces
        self._preview_scale = preview_scale
        self._slots: dict[object, _Slot] = {}
        self._raster_refusal: tuple[int, str | None] | None = None
        # Running mean frame seconds per source, and seconds per pixel of the preview.
        self._seconds: dict[str, float] = {}
        self._pixel_seconds: float | None = None
        self._interaction_scale = 1
        # (renderer, scene version, passes, denoised linear image) of the last denoising.
        self._denoised_image: tuple | None = None
        self._last: tuple | None = None  # (slot, linear image, source, scale)
        self.source = "rasterized"
        self.denoised = False
        self._path_slot(1)

    # ------------------------------------------------------------------ state

    @property
    def raster_refusal(self) -> str | None:
        """Why the rasterizer cannot shade the current scene (None where it can)."""
        state = self.state
        if self._raster_refusal is None or self._raster_refusal[0] != state.version:
            reason = None
            if state.mode != "rgb":
                reason = "spectral mode (the rasterizer shades in RGB)"
            else:
                try:
                    self._raster_slot()
                except ValueError as error:
                    reason = str(error)
            self._raster_refusal = (state.version, reason)
        return self._raster_refusal[1]

    @property
    def passes(self) -> int:
        """Samples per pixel the full-resolution path tracer holds of the current state (0
        while it is stale: it restarts when it next draws)."""
        slot = self._slots[1]
        return slot.renderer.passes if slot.version == self.state.version else 0

    def update(self, state: SceneState, interacting: bool) -> None:
        """Show ``state``, updating the renderer that draws the next frame now (the others
        when they next draw).

        Raises
        ------
        ValueError
            From that renderer; the scheduler then keeps showing the previous state.
        """
        previous, self.state = self.state, state
        try:
            if interacting and self.raster_refusal is not None:
                self._path_slot(self._interaction_scale)
            elif not interacting or self.raster_refusal is not None:
                self._path_slot(1)
        except ValueError:
            self.state = previous
            raise

    def start_interaction(self) -> None:
        """Choose the preview's divisor for the interaction starting now (kept until it ends,
        so that one interaction stays on one preview renderer)."""
        self._interaction_scale = self.preview_scale()

    def preview_scale(self) -> int:
        """Resolution divisor of path-traced preview frames: the fixed one, or the smallest
        of :data:`PREVIEW_SCALES` whose frames, at the measured cost per pixel, fit
        :data:`PREVIEW_BUDGET_FPS` with some headroom (1/2 until measured)."""
        if self._preview_scale is not None:
            return self._preview_scale
        if self._pixel_seconds is None:
            return 2
        budget = _PREVIEW_HEADROOM / PREVIEW_BUDGET_FPS
        width, height = self.size
        for scale in PREVIEW_SCALES:
            if self._pixel_seconds * -(-width // scale) * -(-height // scale) <= budget:
                return scale
        return PREVIEW_SCALES[-1]

    # ------------------------------------------------------------------ frames

    def frame(self, interacting: bool, denoise: bool, exposure: float) -> np.ndarray:
        """Draw the next frame: rasterized while interacting, else one more path-traced sample
        per pixel, shown once there are :attr:`handover_spp` of them (the rasterized image,
        drawn on while it converges, until then).

        Returns
        -------
        numpy.ndarray, shape (height, width, 3), uint8
            sRGB after the display transform, at full size.
        """
        raster = self.raster_refusal is None
        if interacting and not raster:
            scale = self._interaction_scale
            slot = self._path_slot(scale)
            start = time.perf_counter()
            image = slot.renderer.render(1)
            pixels = self._show(slot, image, "preview", scale, denoise, exposure)
            seconds = time.perf_counter() - start
            self._pixel_seconds = seconds / image.shape[0] / image.shape[1]
            self._measure("preview", seconds)
            self.budgets.preview_scale = scale
            return pixels
        if not interacting:
            slot = self._path_slot(1)
            start = time.perf_counter()
            image = slot.renderer.render(1)
            if not raster or slot.renderer.passes >= self.handover_spp:
                pixels = self._show(slot, image, "path-traced", 1, denoise, exposure)
                self._measure("path-traced", time.perf_counter() - start)
                return pixels
            self._measure("path-traced", time.perf_counter() - start)
        slot = self._raster_slot()
        drawing = not slot.renderer.converged
        start = time.perf_counter()
        pixels = self._show_raster(slot, exposure)
        if drawing:
            self._measure("rasterized", time.perf_counter() - start)
        return pixels

    def refine(self, spp: int, denoise: bool, exposure: float) -> np.ndarray:
        """Add ``spp`` path-traced samples per pixel at full resolution and show them."""
        slot = self._path_slot(1)
        return self._show(slot, slot.renderer.render(spp), "path-traced", 1, denoise, exposure)

    def display(self, denoise: bool, exposure: float) -> np.ndarray | None:
        """The last frame's image shown again (None before the first frame); a rasterized
        one through the rasterizer, which adds a jittered frame unless it has converged."""
        if self._last is None:
            return None
        slot, image, source, scale = self._last
        if source == "rasterized":
            return self._show_raster(slot, exposure)
        return self._show(slot, image, source, scale, denoise, exposure)

    # ------------------------------------------------------------------ internals

    def _raster_slot(self) -> _Slot:
        """The rasterizer, made or updated to the current state (a new colour method makes a
        new one)."""
        state = self.state
        slot = self._slots.get("raster")
        if slot is None or slot.renderer.colour_method != state.colour_method:
            rasterizer = Rasterizer(state.scene, size=self.size,
                                    colour_method=state.colour_method)
            slot = self._slots["raster"] = _Slot(rasterizer, state.version,
                                                 state.material_version)
        elif slot.version != state.version:
            start = time.perf_counter()
            slot.renderer.update(state.scene)
            if slot.material_version != state.material_version:
                self.budgets.raster_update_ms = 1e3 * (time.perf_counter() - start)
            slot.version, slot.material_version = state.version, state.material_version
        return slot

    def _path_slot(self, scale: int) -> _Slot:
        """The path tracer of resolution divisor ``scale``, made or updated to the current
        state."""
        state = self.state
        slot = self._slots.get(scale)
        if slot is None:
            width, height = self.size
            renderer = Renderer(state.scene, size=(-(-width // scale), -(-height // scale)),
                                seed=self._seed, mode=state.mode,
                                max_bounces=self._max_bounces,
                                colour_method=state.colour_method, ibl="monte-carlo")
            slot = self._slots[scale] = _Slot(renderer, state.version, state.material_version)
        elif slot.version != state.version:
            start = time.perf_counter()
            slot.renderer.update(state.scene, state.mode, state.colour_method, "monte-carlo")
            seconds = time.perf_counter() - start
            if slot.material_version != state.material_version:
                self.budgets.update_ms = 1e3 * seconds
                self.budgets.table_ms = 1e3 * slot.renderer.table_seconds
            slot.version, slot.material_version = state.version, state.material_version
        return slot

    def _show_raster(self, slot: _Slot, exposure: float) -> np.ndarray:
        """The rasterizer's next frame, through the display transform on the device."""
        self._last, self.source, self.denoised = (slot, None, "rasterized", 1), "rasterized", False
        return slot.renderer.frame_srgb(exposure)

    def _show(self, slot: _Slot, image: np.ndarray, source: str, scale: int, denoise: bool,
              exposure: float) -> np.ndarray:
        self.denoised = (denoise and source == "path-traced"
                         and slot.renderer.passes >= DENOISE_AFTER_SPP)
        shown = self._denoised(slot) if self.denoised else image
        pixels = display_transform(shown, exposure)
        if scale > 1:
            width, height = self.size
            pixels = np.repeat(np.repeat(pixels, scale, axis=0), scale, axis=1)[:height, :width]
        self._last, self.source = (slot, image, source, scale), source
        return pixels

    def _denoised(self, slot: _Slot) -> np.ndarray:
        """The full-resolution image denoised: renewed when the scene, the renderer or the
        samples changed (:data:`DENOISE_GROWTH`), else the last one."""
        renderer, passes = slot.renderer, slot.renderer.passes
        if self._denoised_image is not None:
            known, version, known_passes, image = self._denoised_image
            if (known is renderer and version == slot.version
                    and known_passes <= passes < known_passes * DENOISE_GROWTH):
                return image
        start = time.perf_counter()
        image = renderer.denoised(DENOISE_QUALITY)
        self.budgets.denoise_ms = 1e3 * (time.perf_counter() - start)
        self._denoised_image = (renderer, slot.version, passes, image)
        return image

    def _measure(self, source: str, seconds: float) -> None:
        previous = self._seconds.get(source)
        average = seconds if previous is None else (
            (1.0 - _SMOOTHING) * previous + _SMOOTHING * seconds)
        self._seconds[source] = average
        name = {"rasterized": "raster_fps", "path-traced": "fps", "preview": "preview_fps"}
        setattr(self.budgets, name[source], 1.0 / average)
