"""The demo window: a :class:`wgbragg.app.viewer.Viewer` with its controls, on screen or offscreen.

The picture is the viewer's frame, rasterized while the user interacts and path-traced at rest
(``wgsl/app/viewer_window.wgsl`` draws it), beside a Dear
ImGui side panel of budgets, rendering controls, the material's parameters, and the selected
layer's or film's spectrum and colour strip. ``offscreen=True`` renders the same window
without a display. GUI packages are imported when a window is made. Layout and controls:
``docs/design.md``, "The demo".
"""

from __future__ import annotations

import math
import time

import numpy as np

from wgbragg import gpu
from wgbragg.app.viewer import (
    DENOISE_AFTER_SPP,
    FILM_COLOUR_METHOD,
    FILTER_BUDGET_S,
    LAYER_FIELDS,
    MAX_LAYERS,
    PREVIEW_BUDGET_FPS,
    RASTER_BUDGET_FPS,
    TABLE_BUDGET_MS,
    Viewer,
)
from wgbragg.colour.methods import COLOUR_METHODS

__all__ = ["PANEL_WIDTH", "ViewerWindow"]

PANEL_WIDTH = 400
"""Width of the side panel in logical pixels."""

_BACKGROUND = (0.01, 0.01, 0.012, 1.0)  # linear: the target is sRGB
# Landmark kinds (wgbragg.optics.landmarks.KINDS) in the spectrum plot, as RGBA in [0, 1].
_LANDMARK_COLOURS = {"mode": (1.0, 0.35, 0.3, 1.0), "airy": (0.35, 0.8, 1.0, 1.0),
                     "edge": (1.0, 0.85, 0.3, 1.0), "zero": (0.7, 0.7, 0.7, 1.0)}
_GOOD, _BAD = (0.45, 0.9, 0.45, 1.0), (1.0, 0.45, 0.4, 1.0)
# Orbit degrees per pixel of drag; zoom factor per wheel unit (rendercanvas: 100 a notch).
_DEGREES_PER_PIXEL = 0.4
_ZOOM_PER_WHEEL_UNIT = 2.0 ** (1.0 / 400.0)
# A wheel event counts as interaction for this long (it has no release).
_WHEEL_SECONDS = 0.3
# Weight of the newest frame in the running frame-time averages.
_SMOOTHING = 0.2
# Slider ranges: (low, high, imgui format, logarithmic).
_LAYER_SLIDERS = {
    "period_nm": ("Lambda = d1 + d2", 100.0, 1000.0, "%.0f nm", False),
    "delta": ("delta = d1 / Lambda", 0.0, 1.0, "%.3f", False),
    "N": ("N (cells)", 1, 200, "%d", True),
    "n2": ("n2", 1.0, 3.0, "%.3f", False),
    "alpha": ("alpha (roughness)", 0.01, 1.0, "%.2g", True),
}
_FILM_SLIDERS = {
    "thickness_nm": ("d (film)", 0.0, 1200.0, "%.0f nm", False),
    "n_film": ("n_film", 1.0, 2.5, "%.3f", False),
    "n_base": ("n_base", 1.0, 3.0, "%.3f", False),
    "k_base": ("k_base", 0.0, 5.0, "%.3f", False),
    "alpha": ("alpha (roughness)", 0.01, 1.0, "%.2g", True),
}
_NOISE_SLIDERS = (("d low (noise)", 0), ("d high (noise)", 1))
# The material choice (Viewer.material_type) and the film's bases: a constant index or a metal.
_MATERIAL_LABELS = (("layered-bragg", "Bragg layers"), ("thin-film", "thin film"))
_FILM_BASES = ("dielectric (n, k)", "Au", "Ag", "Cu", "Al")
# Panel geometry in logical pixels: labels right of the controls, plot and strip heights.
_LABEL_WIDTH = 140.0
_PLOT_HEIGHT = 100.0
_STRIP_HEIGHT = 24.0


def _round_alpha(alpha: float) -> float:
    """Two significant digits: each roughness bakes a filter file into the LUT cache, so a
    dragged slider should not leave one per pixel of travel."""
    return max(0.01, float(f"{alpha:.2g}"))


class ViewerWindow:
    """A window showing a viewer, with its controls.

    Parameters
    ----------
    viewer : wgbragg.app.viewer.Viewer
    size : tuple of 2 ints
        Window size in logical pixels; the panel takes :data:`PANEL_WIDTH` of its width.
    offscreen : bool
        Draw on rendercanvas's offscreen canvas instead of a glfw window.
    title : str

    Attributes
    ----------
    viewer : wgbragg.app.viewer.Viewer
    canvas : rendercanvas.BaseRenderCanvas
        The glfw window or the offscreen canvas.
    selected_layer : int
        The layer whose spectrum and colour strip the panel shows.
    fps, raster_fps, preview_fps : float or None
        Window frames per second of path-traced, rasterized and path-traced preview frames
        (:attr:`Viewer.source`): running averages of the time between frames (render,
        display, panel and presentation).
    image_rect : tuple of 4 ints
        Where the last frame drew the picture: x, y, width, height in canvas pixels.
    image_scale : float
        Canvas pixels per image pixel.
    plot_rect, strip_rect : tuple of 4 floats or None
        Where the panel drew the spectrum and the colour strip: x0, y0, x1, y1.
    """

    def __init__(self, viewer: Viewer, size: tuple[int, int] = (1040, 760),
                 offscreen: bool = False, title: str = "wgbragg: Bragg materials"):
        import wgpu
        from imgui_bundle import imgui
        from wgpu.utils.imgui import ImguiRenderer

        if offscreen:
            from rendercanvas.offscreen import RenderCanvas
        else:
            from rendercanvas.glfw import RenderCanvas, poll_glfw_briefly
        if not isinstance(viewer, Viewer):
            raise ValueError(f"viewer must be a Viewer, got {type(viewer).__name__}")
        self.viewer = viewer
        self.selected_layer = 0
        self.image_rect = (0, 0, 0, 0)
        self.image_scale = 1.0
        self.plot_rect = self.strip_rect = None
        self._imgui = imgui
        self._wgpu = wgpu
        self._device = gpu.get_device()
        self.canvas = RenderCanvas(size=size, title=title, update_mode="continuous",
                                   max_fps=60, vsync=False)
        if not offscreen:
            # glfw applies the requested size in its event loop: let it, so that the first
            # frame has the window's size.
            poll_glfw_briefly(0.1)
        self._context = self.canvas.get_wgpu_context()
        self._format = self._context.get_preferred_format(self._device.adapter)
        # COPY_SRC: capture() reads the frame back before it is presented.
        self._context.configure(device=self._device, format=self._format,
                                usage=wgpu.TextureUsage.RENDER_ATTACHMENT
                                | wgpu.TextureUsage.COPY_SRC)
        self._gui_renderer = ImguiRenderer(self._device, self.canvas)
        imgui.get_io().set_ini_filename("")  # no imgui.ini in the working folder
        self._gui_renderer.set_gui(self._gui)
        self._pipeline = self._blit_pipeline()
        self._samplers = {name: self._device.create_sampler(mag_filter=name, min_filter=name)
                          for name in ("nearest", "linear")}
        self._texture = self._bind_groups = None
        self._dragging = False
        self._pointer = (0.0, 0.0)
        self._wheel_time = -math.inf
        self._gui_active = False
        self._tab_shown = 0
        self._last_draw: float | None = None
        self._last_source: str | None = None
        # Running mean time between frames, per source of the frame (Viewer.source).
        self._frame_seconds: dict[str, float] = {}
        self._capture = False
        self._add_sample = True
        self._captured: np.ndarray | None = None
        self._error: Exception | None = None
        self.canvas.add_event_handler(self.on_pointer, "pointer_down", "pointer_move",
                                      "pointer_up")
        self.canvas.add_event_handler(self.on_wheel, "wheel")
        self.canvas.request_draw(self._draw)

    # ------------------------------------------------------------------ public

    def _fps(self, source: str) -> float | None:
        seconds = self._frame_seconds.get(source)
        return None if seconds is None else 1.0 / seconds

    @property
    def fps(self) -> float | None:
        """Path-traced full-size window frames per second (None before two such frames)."""
        return self._fps("path-traced")

    @property
    def raster_fps(self) -> float | None:
        """Rasterized window frames per second (None before two such frames)."""
        return self._fps("rasterized")

    @property
    def preview_fps(self) -> float | None:
        """Path-traced preview window frames per second (None before two such frames)."""
        return self._fps("preview")

    def draw(self) -> None:
        """Draw and present one frame now (one more sample per pixel).

        Raises
        ------
        Exception
            Whatever drawing raised (the canvas itself only logs it).
        """
        self._error = None
        self.canvas.force_draw()
        if self._error is not None:
            error, self._error = self._error, None
            raise error

    def capture(self, sample: bool = True) -> np.ndarray:
        """Draw one frame and return what it put on the canvas.

        Parameters
        ----------
        sample : bool
            Add a sample per pixel, as every frame does; False shows the image so far again
            (:meth:`wgbragg.app.viewer.Viewer.display`: after a display setting changed).

        Returns
        -------
        numpy.ndarray, shape (height, width, 3), uint8
            sRGB, the whole canvas (picture and panel).
        """
        self._capture, self._add_sample = True, bool(sample)
        try:
            self.draw()
        finally:
            self._capture, self._add_sample = False, True
        captured, self._captured = self._captured, None
        if captured is None:
            raise RuntimeError("the canvas drew no frame (closed, or of zero size)")
        return captured

    def picture(self, frame: np.ndarray) -> np.ndarray:
        """The picture's part of a captured frame: one pixel per image pixel when it is drawn
        at a whole scale, else as drawn.

        Parameters
        ----------
        frame : numpy.ndarray, shape (height, width, 3)
            From :meth:`capture`.

        Returns
        -------
        numpy.ndarray, shape (image height, image width, 3)
        """
        x, y, width, height = self.image_rect
        step = max(1, int(self.image_scale))
        return frame[y:y + height:step, x:x + width:step]

    def run(self) -> None:
        """Show the window until it is closed."""
        from rendercanvas.glfw import loop

        loop.run()

    def close(self) -> None:
        """Close the window and release its canvas."""
        self.canvas.close()

    # ------------------------------------------------------------------ drawing

    def _blit_pipeline(self):
        wgpu = self._wgpu
        code = gpu.load_shader("app/viewer_window.wgsl").code
        module = self._device.create_shader_module(code=code)
        return self._device.create_render_pipeline(
            layout="auto",
            vertex={"module": module, "entry_point": "vertex"},
            primitive={"topology": wgpu.PrimitiveTopology.triangle_list},
            fragment={"module": module, "entry_point": "fragment",
                      "targets": [{"format": self._format}]},
        )

    def _upload(self, pixels: np.ndarray) -> None:
        wgpu = self._wgpu
        height, width, _ = pixels.shape
        if self._texture is None or self._texture.size[:2] != (width, height):
            # sRGB bytes: an sRGB texture decodes them for an sRGB target to encode again;
            # a linear target takes them as they are.
            srgb = self._format.endswith("-srgb")
            self._texture = self._device.create_texture(
                size=(width, height, 1),
                format="rgba8unorm-srgb" if srgb else "rgba8unorm",
                usage=wgpu.TextureUsage.TEXTURE_BINDING | wgpu.TextureUsage.COPY_DST)
            view = self._texture.create_view()
            layout = self._pipeline.get_bind_group_layout(0)
            self._bind_groups = {
                name: self._device.create_bind_group(layout=layout, entries=[
                    {"binding": 0, "resource": view}, {"binding": 1, "resource": sampler}])
                for name, sampler in self._samplers.items()}
        rgba = np.empty((height, width, 4), np.uint8)
        rgba[..., :3] = pixels
        rgba[..., 3] = 255
        self._device.queue.write_texture({"texture": self._texture}, rgba,
                                         {"bytes_per_row": 4 * width, "rows_per_image": height},
                                         (width, height, 1))

    def _layout(self, canvas_width: int, canvas_height: int, width: int, height: int) -> None:
        """Place the picture left of the panel: the largest whole scale that fits, centred."""
        panel = round(PANEL_WIDTH * self.canvas.get_pixel_ratio())
        area = max(canvas_width - panel, 1)
        fit = min(area / width, canvas_height / height)
        scale = math.floor(fit) if fit >= 1.0 else fit
        shown_width = max(1, round(width * scale))
        shown_height = max(1, round(height * scale))
        self.image_scale = scale
        self.image_rect = ((area - shown_width) // 2, (canvas_height - shown_height) // 2,
                           shown_width, shown_height)

    def _draw(self) -> None:
        try:
            self._draw_frame()
        except Exception as error:
            self._error = error
            raise

    def _draw_frame(self) -> None:
        now = time.perf_counter()
        if self._last_draw is not None:
            # The time since the last frame, counted to that frame's source.
            seconds = now - self._last_draw
            average = self._frame_seconds.get(self._last_source)
            self._frame_seconds[self._last_source] = seconds if average is None else (
                (1.0 - _SMOOTHING) * average + _SMOOTHING * seconds)
        viewer = self.viewer
        viewer.interacting = (self._dragging or self._gui_active
                              or now - self._wheel_time < _WHEEL_SECONDS)
        self._last_draw = now
        pixels = viewer.display() if not self._add_sample else None
        if pixels is None:
            pixels = viewer.frame()
        self._last_source = viewer.source
        self._upload(pixels)
        texture = self._context.get_current_texture()
        canvas_width, canvas_height = texture.size[:2]
        self._layout(canvas_width, canvas_height, pixels.shape[1], pixels.shape[0])
        encoder = self._device.create_command_encoder()
        render_pass = encoder.begin_render_pass(color_attachments=[{
            "view": texture.create_view(), "clear_value": _BACKGROUND,
            "load_op": "clear", "store_op": "store"}])
        x, y, width, height = self.image_rect
        render_pass.set_viewport(x, y, width, height, 0.0, 1.0)
        render_pass.set_pipeline(self._pipeline)
        sampler = "nearest" if self.image_scale >= 1.0 else "linear"
        render_pass.set_bind_group(0, self._bind_groups[sampler])
        render_pass.draw(3)
        render_pass.end()
        self._device.queue.submit([encoder.finish()])
        self._gui_renderer.render()
        if self._capture:
            self._captured = self._read(texture)

    def _read(self, texture) -> np.ndarray:
        wgpu = self._wgpu
        width, height = texture.size[:2]
        row = -(-4 * width // 256) * 256  # texture copies need rows aligned to 256 bytes
        buffer = self._device.create_buffer(
            size=row * height, usage=wgpu.BufferUsage.COPY_DST | wgpu.BufferUsage.MAP_READ)
        encoder = self._device.create_command_encoder()
        encoder.copy_texture_to_buffer({"texture": texture},
                                       {"buffer": buffer, "bytes_per_row": row,
                                        "rows_per_image": height}, (width, height, 1))
        self._device.queue.submit([encoder.finish()])
        buffer.map_sync(wgpu.MapMode.READ)
        try:
            data = np.frombuffer(buffer.read_mapped(), np.uint8).reshape(height, row)
            pixels = data[:, :4 * width].reshape(height, width, 4)
            channels = [2, 1, 0] if self._format.startswith("bgra") else [0, 1, 2]
            return np.ascontiguousarray(pixels[..., channels])
        finally:
            buffer.unmap()
            buffer.destroy()

    # ------------------------------------------------------------------ events

    def on_pointer(self, event: dict) -> None:
        """Handle a rendercanvas ``pointer_down``, ``pointer_move`` or ``pointer_up`` event:
        a left drag that starts on the picture orbits the camera (the panel's events are
        Dear ImGui's, which stops them before they get here)."""
        kind, position = event["event_type"], (event["x"], event["y"])
        if kind == "pointer_down":
            x, y, width, height = self.image_rect
            ratio = self.canvas.get_pixel_ratio()
            inside = (x <= position[0] * ratio < x + width and y <= position[1] * ratio
                      < y + height)
            self._dragging = event["button"] == 1 and inside
        elif kind == "pointer_up":
            self._dragging = False
        elif self._dragging:
            dx, dy = position[0] - self._pointer[0], position[1] - self._pointer[1]
            if dx or dy:
                self.viewer.orbit(-_DEGREES_PER_PIXEL * dx, _DEGREES_PER_PIXEL * dy)
        self._pointer = position

    def on_wheel(self, event: dict) -> None:
        """Handle a rendercanvas ``wheel`` event: zoom (``dy > 0`` away from the target)."""
        self._wheel_time = time.perf_counter()
        factor = _ZOOM_PER_WHEEL_UNIT ** event["dy"]
        # Stay where the picture still shows the scene: 0.1 to 20 units from the target.
        distance = min(max(self.viewer.distance * factor, 0.1), 20.0)
        if distance != self.viewer.distance:
            self.viewer.edit(distance=distance)

    # ------------------------------------------------------------------ panel

    def _gui(self) -> None:
        imgui = self._imgui
        io = imgui.get_io()
        width, height = io.display_size.x, io.display_size.y
        imgui.set_next_window_pos((width - PANEL_WIDTH, 0.0), imgui.Cond_.always)
        imgui.set_next_window_size((PANEL_WIDTH, height), imgui.Cond_.always)
        flags = (imgui.WindowFlags_.no_move | imgui.WindowFlags_.no_resize
                 | imgui.WindowFlags_.no_collapse | imgui.WindowFlags_.no_saved_settings)
        imgui.begin("wgbragg", None, flags)
        imgui.push_item_width(-_LABEL_WIDTH)
        try:
            self._status()
            self._spectrum_panel()
            self._rendering_controls()
            self._structure_controls()
        finally:
            imgui.pop_item_width()
            imgui.end()
        self._gui_active = imgui.is_any_item_active()

    def _budget_line(self, text: str, met: bool | None) -> None:
        imgui = self._imgui
        if met is None:
            imgui.text(text)
        else:
            imgui.text_colored(imgui.ImVec4(*(_GOOD if met else _BAD)), text)

    def _status(self) -> None:
        imgui = self._imgui
        viewer, budgets = self.viewer, self.viewer.budgets
        width, height = viewer.size
        denoised = (f", denoised ({budgets.denoise_ms:.0f} ms)"
                    if viewer.denoised and budgets.denoise_ms is not None else "")
        imgui.text(f"{width} x {height}, {viewer.mode.upper()} mode, path tracer "
                   f"{viewer.passes} spp")
        imgui.text(f"showing: {viewer.source}{denoised}")
        imgui.separator_text("budgets (wall clock, green: met)")
        refusal = viewer.raster_refusal
        if refusal is not None:
            imgui.text_wrapped(f"not rasterized: {refusal}; interaction is previewed by paths")
            if self.preview_fps is None:
                self._budget_line(f"preview: drag the picture (>= {PREVIEW_BUDGET_FPS:g} "
                                  "frames/s)", None)
            else:
                self._budget_line(f"preview: {self.preview_fps:.1f} frames/s (render "
                                  f"{budgets.preview_fps:.1f} at 1/{budgets.preview_scale} "
                                  "size)", self.preview_fps >= PREVIEW_BUDGET_FPS)
        elif self.raster_fps is None:
            self._budget_line(f"rasterized: drag the picture (>= {RASTER_BUDGET_FPS:g} "
                              "frames/s)", None)
        else:
            self._budget_line(f"rasterized: {self.raster_fps:.1f} frames/s (render "
                              f"{budgets.raster_fps:.1f})", self.raster_fps >= RASTER_BUDGET_FPS)
        if self.fps is not None:
            self._budget_line(f"path-traced: {self.fps:.1f} frames/s (render "
                              f"{budgets.fps:.1f})", None)
        if budgets.table_ms is None:
            self._budget_line(f"tables: edit a layer (<= {TABLE_BUDGET_MS:g} ms)", None)
        else:
            self._budget_line(f"tables re-baked in {budgets.table_ms:.1f} ms (update "
                              f"{budgets.update_ms:.0f} ms)", budgets.table_ms <= TABLE_BUDGET_MS)
        if budgets.filter_s is None:
            self._budget_line(f"filter: edit alpha (<= {FILTER_BUDGET_S:g} s)", None)
        else:
            self._budget_line(f"filter of alpha {budgets.filter_alpha:.2g} {budgets.filter_source}"
                              f" in {budgets.filter_s:.3f} s", budgets.filter_s <= FILTER_BUDGET_S)

    def _spectrum_panel(self) -> None:
        imgui, viewer = self._imgui, self.viewer
        index = min(self.selected_layer, len(viewer.layers) - 1)
        width = imgui.get_content_region_avail().x
        film = viewer.material_type == "thin-film"
        self._spectrum_plot(index, width, film)
        self._colour_strip(index, width, film)

    def _spectrum_plot(self, index: int, width: float, film: bool) -> None:
        """The reflectance spectrum at normal incidence, with the layer's landmarks."""
        imgui, viewer = self._imgui, self.viewer
        colour = imgui.color_convert_float4_to_u32
        draw = imgui.get_window_draw_list()
        if film:
            imgui.separator_text(f"thin film, d = {viewer.film_thickness_nm:.0f} nm: R at "
                                 "normal incidence")
            wavelength, reflectance = viewer.film_spectrum()
            marks = None
        else:
            imgui.separator_text(f"layer {index}: R at normal incidence")
            wavelength, reflectance = viewer.spectrum(index)
            marks = viewer.landmarks(index)
        origin = imgui.get_cursor_screen_pos()
        x0, y0 = origin.x, origin.y
        x1, y1 = x0 + width, y0 + _PLOT_HEIGHT
        self.plot_rect = (x0, y0, x1, y1)
        draw.add_rect_filled((x0, y0), (x1, y1), colour(imgui.ImVec4(0.12, 0.12, 0.14, 1.0)))
        draw.add_line((x0, 0.5 * (y0 + y1)), (x1, 0.5 * (y0 + y1)),
                      colour(imgui.ImVec4(0.3, 0.3, 0.32, 1.0)), 1.0)
        low, high = wavelength[0], wavelength[-1]

        def x_of(nm):
            return x0 + (nm - low) / (high - low) * (x1 - x0)

        for nm, kind in () if marks is None else zip(marks.wavelength_nm, marks.kind,
                                                     strict=True):
            draw.add_line((x_of(nm), y0), (x_of(nm), y1),
                          colour(imgui.ImVec4(*_LANDMARK_COLOURS[str(kind)])), 1.0)
        points = [imgui.ImVec2(x_of(nm), y1 - r * (y1 - y0))
                  for nm, r in zip(wavelength[::2], reflectance[::2], strict=True)]
        draw.add_polyline(points, colour(imgui.ImVec4(0.95, 0.95, 0.95, 1.0)), 1.5, 0)
        draw.add_rect((x0, y0), (x1, y1), colour(imgui.ImVec4(0.4, 0.4, 0.45, 1.0)))
        imgui.dummy((width, _PLOT_HEIGHT))
        imgui.text(f"{low:.0f} nm")
        for kind, rgba in () if film else _LANDMARK_COLOURS.items():
            imgui.same_line()
            imgui.text_colored(imgui.ImVec4(*rgba), kind)
        imgui.same_line(width - 45.0)
        imgui.text(f"{high:.0f} nm")

    def _colour_strip(self, index: int, width: float, film: bool) -> None:
        """The colour of the layer (or film) from 0 to 90 degrees."""
        imgui, viewer = self._imgui, self.viewer
        colour = imgui.color_convert_float4_to_u32
        draw = imgui.get_window_draw_list()
        if film:
            imgui.separator_text(f"thin film: colour, 0 to 90 deg ({FILM_COLOUR_METHOD})")
            theta, colours = viewer.film_colour_strip()
        else:
            imgui.separator_text(f"layer {index}: colour, 0 to 90 deg in n1 "
                                 f"({viewer.colour_method})")
            theta, colours = viewer.colour_strip(index)
        origin = imgui.get_cursor_screen_pos()
        x0, y0 = origin.x, origin.y
        x1, y1 = x0 + width, y0 + _STRIP_HEIGHT
        self.strip_rect = (x0, y0, x1, y1)
        packed = [colour(imgui.ImVec4(*(c / 255.0), 1.0)) for c in colours]
        step = (x1 - x0) / (len(theta) - 1)
        for k in range(len(theta) - 1):
            left, right = x0 + k * step, x0 + (k + 1) * step
            draw.add_rect_filled_multi_color((left, y0), (right, y1), packed[k], packed[k + 1],
                                             packed[k + 1], packed[k])
        imgui.dummy((width, _STRIP_HEIGHT))

    def _rendering_controls(self) -> None:
        imgui, viewer = self._imgui, self.viewer
        imgui.separator_text("rendering")
        for mode in ("rgb", "spectral"):
            if imgui.radio_button(mode.upper(), viewer.mode == mode) and viewer.mode != mode:
                viewer.edit(mode=mode)
            imgui.same_line()
        changed, exposure = imgui.slider_float("exposure", viewer.exposure, -4.0, 4.0,
                                               "%.1f EV")
        if changed:
            viewer.edit(exposure=exposure)
        changed, denoise = imgui.checkbox(f"denoise from {DENOISE_AFTER_SPP} spp",
                                          viewer.denoise)
        imgui.set_item_tooltip("Intel Open Image Denoise on the CPU, guided by the first hits' "
                               "albedo and normal: full-size frames only, the samples go on")
        if changed:
            viewer.denoise = denoise
        methods = tuple(COLOUR_METHODS)
        changed, index = imgui.combo("colour method", methods.index(viewer.colour_method),
                                     methods)
        imgui.set_item_tooltip("RGB mode's layer colours, and the colour strip's")
        if changed:
            viewer.edit(colour_method=methods[index])
        environments = viewer.environments
        changed, index = imgui.combo("environment",
                                     environments.index(viewer.scene.environment.type),
                                     environments)
        if changed:
            viewer.edit(environment=environments[index])

    def _structure_controls(self) -> None:
        imgui, viewer = self._imgui, self.viewer
        imgui.separator_text(f"material {viewer.material_name!r}")
        for k, (kind, label) in enumerate(_MATERIAL_LABELS):
            if k:
                imgui.same_line()
            if imgui.radio_button(label, viewer.material_type == kind) and (
                    viewer.material_type != kind):
                viewer.edit(material_type=kind)
        if viewer.material_type == "thin-film":
            self._film_controls()
            return
        changed, count = imgui.slider_int("layers", len(viewer.layers), 1, MAX_LAYERS)
        if changed:
            viewer.edit(layers=count)
        changed, n1 = imgui.slider_float("n1 (all layers)", viewer.layers[0].n1, 1.0, 2.0,
                                         "%.3f")
        if changed:
            viewer.edit(n1=n1)
        albedo = viewer.bragg.base_albedo
        rgb = [0.0] * 3 if albedo is None else (
            [float(albedo)] * 3 if np.isscalar(albedo) else list(albedo))
        changed, rgb = imgui.color_edit3("rho_d (base)", rgb, imgui.ColorEditFlags_.float)
        if changed:
            viewer.edit(base_albedo=tuple(min(max(c, 0.0), 1.0) for c in rgb))
        if not imgui.begin_tab_bar("layers"):
            return
        requested = self.selected_layer
        for index, spec in enumerate(viewer.layers):
            flags = imgui.TabItemFlags_.set_selected if (
                index == requested and requested != self._tab_shown) else 0
            if imgui.begin_tab_item(f"layer {index}", None, flags)[0]:
                self.selected_layer = self._tab_shown = index
                self._layer_sliders(index, spec)
                imgui.end_tab_item()
        imgui.end_tab_bar()

    def _layer_sliders(self, index: int, spec) -> None:
        imgui, viewer = self._imgui, self.viewer
        values = {"period_nm": spec.period_nm, "delta": spec.delta, "N": spec.N,
                  "n2": spec.n2, "alpha": spec.alpha}
        for field in LAYER_FIELDS:
            label, low, high, shown, logarithmic = _LAYER_SLIDERS[field]
            flags = imgui.SliderFlags_.logarithmic if logarithmic else 0
            slider = imgui.slider_int if field == "N" else imgui.slider_float
            changed, value = slider(label, values[field], low, high, shown, flags)
            if field == "alpha":
                value = _round_alpha(value)
            if changed and value != values[field]:
                viewer.set_layer(index, **{field: value})

    def _film_controls(self) -> None:
        imgui, viewer = self._imgui, self.viewer
        film = viewer.film
        noise = film.thickness_map is not None
        values = {"thickness_nm": film.thickness_nm, "n_film": film.n_film,
                  "n_base": film.n_base, "k_base": film.k_base, "alpha": film.alpha}

        def slider(field):
            label, low, high, shown, logarithmic = _FILM_SLIDERS[field]
            flags = imgui.SliderFlags_.logarithmic if logarithmic else 0
            changed, value = imgui.slider_float(label, values[field], low, high, shown, flags)
            if changed and value != values[field]:
                viewer.set_film(**{field: value})

        imgui.begin_disabled(noise)  # the noise map replaces the uniform thickness
        slider("thickness_nm")
        imgui.end_disabled()
        changed, on = imgui.checkbox("vary d by noise", noise)
        imgui.set_item_tooltip("value noise over the surface's texture coordinates")
        if changed:
            viewer.set_film(noise=on)
        if on:
            bounds = list(viewer.noise_range_nm)
            for label, k in _NOISE_SLIDERS:
                changed, value = imgui.slider_float(label, bounds[k], 0.0, 1200.0, "%.0f nm")
                if changed and value != bounds[k]:
                    bounds[k] = value
                    # The other end follows, so that low <= high.
                    bounds[1 - k] = max(bounds[1 - k], value) if k == 0 else min(
                        bounds[1 - k], value)
                    viewer.set_film(noise_range_nm=tuple(bounds))
        slider("n_film")
        base = 0 if film.base is None else _FILM_BASES.index(film.base)
        changed, base = imgui.combo("base", base, _FILM_BASES)
        if changed:
            viewer.set_film(base=None if base == 0 else _FILM_BASES[base])
        if film.base is None:
            slider("n_base")
            slider("k_base")
        slider("alpha")
