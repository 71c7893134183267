"""The interactive demo's model: a scene whose Bragg or thin-film material is edited live,
rasterized while the user interacts and path-traced progressively at rest.

A :class:`Viewer` holds a scene, the material being edited, the camera orbit and the display
settings; :meth:`Viewer.frame` draws the next frame (:mod:`wgbragg.app.viewer_frames` chooses
the renderer) and every edit restarts the path tracer's accumulation. It keeps the interactive
budgets (:attr:`Viewer.budgets`) and the side panel's data. It has no window of its own
(:mod:`wgbragg.app.viewer_window` draws it); an example and the frames' rules:
``docs/design.md``, "The demo".
"""

from __future__ import annotations

import dataclasses
import math
import time
import types

import numpy as np

from wgbragg.app.viewer_edits import (
    FILM_FIELDS,
    LAYER_FIELDS,
    check_albedo,
    check_layer_index,
    check_size,
    choice,
    edited_film,
    edited_layer,
    finite,
)
from wgbragg.app.viewer_frames import (
    DENOISE_AFTER_SPP,
    DENOISE_GROWTH,
    DENOISE_QUALITY,
    HANDOVER_SPP,
    PREVIEW_BUDGET_FPS,
    PREVIEW_SCALES,
    RASTER_BUDGET_FPS,
    Budgets,
    FrameScheduler,
    SceneState,
)
from wgbragg.app.viewer_panel import (
    FILM_COLOUR_METHOD,
    film_spectrum,
    film_strip,
    layer_landmarks,
    layer_spectrum,
    layer_strip,
    strip_angles,
)
from wgbragg.bsdf import filter_cache
from wgbragg.colour.colorimetry import xyz_weights
from wgbragg.colour.methods import COLOUR_METHODS
from wgbragg.common.validation import (
    check_count,
    check_index,
    check_real,
)
from wgbragg.scene import load_preset
from wgbragg.scene.model import (
    ENVIRONMENT_TYPES,
    MAX_EXPOSURE,
    MODES,
    BraggLayerSpec,
    Environment,
    LayeredBraggMaterial,
    ParameterMap,
    Scene,
    ThinFilmMaterial,
)

__all__ = [
    "DEFAULT_FILM",
    "DENOISE_AFTER_SPP",
    "DENOISE_GROWTH",
    "DENOISE_QUALITY",
    "FILM_COLOUR_METHOD",
    "FILM_FIELDS",
    "FILTER_BUDGET_S",
    "HANDOVER_SPP",
    "LAYER_FIELDS",
    "MATERIAL_TYPES",
    "MAX_LAYERS",
    "PREVIEW_BUDGET_FPS",
    "PREVIEW_SCALES",
    "RASTER_BUDGET_FPS",
    "TABLE_BUDGET_MS",
    "Budgets",
    "Viewer",
]

TABLE_BUDGET_MS = 40.0
"""Tables of an edited Bragg layer re-baked within this many milliseconds."""
FILTER_BUDGET_S = 0.6
"""The transmission filter of a new roughness ready within this many seconds."""
MAX_LAYERS = 4
"""Most Bragg layers the viewer stacks."""
MATERIAL_TYPES = ("layered-bragg", "thin-film")
"""What the edited material can be (:meth:`Viewer.edit`'s ``material_type``): rough Bragg
layers, or GGX microfacets coated by a thin film."""
DEFAULT_FILM = ThinFilmMaterial(n_film=2.0, thickness_nm=500.0, alpha=0.08, n_base=1.5,
                                thickness_map=ParameterMap(None, "noise", (250.0, 750.0), 4.0))
"""The film a scene without one starts from (that of the ``thin_film`` preset)."""
_PITCH_LIMIT_DEG = 89.0


def _default_bragg() -> LayeredBraggMaterial:
    """The Bragg layers a scene without any starts from: the teapot preset's."""
    return load_preset("teapot").materials["two_layers"]


def _rendered(material):
    """A material as the viewer puts it in the scene: a film always with a thickness map
    (a constant one for a uniform film: the same image, and the same pipeline as with the
    noise on)."""
    if isinstance(material, ThinFilmMaterial) and material.thickness_map is None:
        d = material.thickness_nm
        return dataclasses.replace(material, thickness_map=ParameterMap(None, "noise", (d, d)))
    return material


class Viewer:
    """A scene rasterized while its Bragg or thin-film material is edited, path-traced
    progressively while the view rests.

    Parameters
    ----------
    scene : wgbragg.scene.model.Scene or str
        A scene, or the name of a preset (:data:`wgbragg.scene.model.PRESETS`).
    size : tuple of 2 ints
        Width and height of the image in pixels.
    material : str, optional
        The layered Bragg or thin-film material to edit; the scene's first by default. It
        starts as it is in the scene; the other kind (:meth:`edit`'s ``material_type``) from
        the teapot preset's layers or :data:`DEFAULT_FILM`.
    mode : {"rgb", "spectral"}, optional
        The scene's ``settings.mode`` by default.
    colour_method : str
        RGB mode's layer colours, and the colour strip's: one of
        :data:`wgbragg.colour.methods.COLOUR_METHODS`.
    seed : int
        Renderer seed: the same edits and frames give the same images.
    max_bounces : int
        As for :class:`wgbragg.render.renderer.Renderer`.
    preview_scale : int, optional
        Resolution divisor of the path-traced preview that replaces rasterized frames where
        the rasterizer cannot shade the scene (>= 1); by default the smallest of
        :data:`PREVIEW_SCALES` whose frames, at the measured cost per pixel, fit
        :data:`PREVIEW_BUDGET_FPS` with some headroom.
    environment_path : path-like, optional
        An equirectangular EXR that ``edit(environment="exr")`` uses; by default the
        scene's own, if it has one.
    denoise : bool
        The initial :attr:`denoise`.
    handover_spp : int
        At rest, the path tracer's picture replaces the rasterized one from this many samples
        per pixel (:data:`HANDOVER_SPP`; 1: from the first).

    Raises
    ------
    ValueError
        For a parameter out of range, or a scene without a layered Bragg or thin-film
        material.

    Attributes
    ----------
    scene : wgbragg.scene.model.Scene
        As last edited.
    size : tuple of 2 ints
    material_name : str
    material_type : {"layered-bragg", "thin-film"}
        What the edited material is now.
    mode, colour_method : str
    yaw_deg, pitch_deg, distance : float
        The camera about its target (see :meth:`edit`), from the scene's camera at first.
    exposure : float
        EV stops applied by the display transform (not a render parameter).
    budgets : Budgets
    last_frame : numpy.ndarray or None
        The last image returned by :meth:`frame`, :meth:`refine` or :meth:`display`.
    denoise : bool
        Show full-resolution path-traced frames of at least :data:`DENOISE_AFTER_SPP` samples
        per pixel denoised (:meth:`wgbragg.render.Renderer.denoised`, renewed as
        :data:`DENOISE_GROWTH` says); rasterized frames and previews never are. Only the
        display changes: the accumulation goes on.
    """

    def __init__(self, scene: Scene | str = "teapot", size: tuple[int, int] = (256, 256),
                 material: str | None = None, mode: str | None = None,
                 colour_method: str = "averaged", seed: int = 0, max_bounces: int = 8,
                 preview_scale: int | None = None, environment_path=None,
                 denoise: bool = True, handover_spp: int = HANDOVER_SPP):
        if isinstance(scene, str):
            scene = load_preset(scene)
        if not isinstance(scene, Scene):
            raise ValueError(f"scene must be a Scene or a preset name, got {scene!r}")
        self._take_material(scene, material)
        if preview_scale is not None:
            check_count("preview_scale", preview_scale)
        self.size = check_size(size)
        mode = choice("mode", scene.settings.mode if mode is None else mode, MODES)
        colour_method = choice("colour_method", colour_method, COLOUR_METHODS)
        self.exposure = scene.settings.exposure
        self._interacting = False
        self.budgets = Budgets()
        self.last_frame: np.ndarray | None = None
        self.denoise = denoise
        if environment_path is None and scene.environment.type == "exr":
            environment_path = scene.environment.path
        self._environment_path = environment_path
        # Versions tell the renderers they are stale; never reused (a refused edit's too).
        self._version = self._material_version = 0
        self._orbit(scene.camera)
        # The full-resolution path tracer, validating size, seed and max_bounces.
        self._frames = FrameScheduler(
            SceneState(self._with_material(scene, self.material), mode, colour_method),
            self.size, seed, max_bounces, preview_scale,
            check_count("handover_spp", handover_spp), self.budgets)

    def _take_material(self, scene: Scene, material: str | None) -> None:
        """Choose the edited material (the first editable one by default) and keep what its
        toggles restore: the other kind's default, the noise map and the dielectric base."""
        editable = [name for name, m in scene.materials.items()
                    if isinstance(m, LayeredBraggMaterial | ThinFilmMaterial)]
        if material is None and not editable:
            raise ValueError("scene has no layered-bragg material or thin-film material to edit")
        self.material_name = choice("material", editable[0] if material is None else material,
                                     editable)
        edited = scene.materials[self.material_name]
        if isinstance(edited, ThinFilmMaterial):
            self.material_type = "thin-film"
            self._bragg, self._film = _default_bragg(), edited
        else:
            self.material_type = "layered-bragg"
            self._bragg, self._film = edited, DEFAULT_FILM
        # The noise map that `noise` turns on, and the dielectric base that a metal replaces,
        # kept while they are off.
        self._noise_map = self._film.thickness_map or DEFAULT_FILM.thickness_map
        if self._film.thickness_map is not None:
            # The uniform thickness the film gets when its noise is turned off.
            self._film = dataclasses.replace(self._film,
                                             thickness_nm=0.5 * sum(self._noise_map.range))
        self._dielectric = ((self._film.n_base, self._film.k_base) if self._film.base is None
                            else (DEFAULT_FILM.n_base, DEFAULT_FILM.k_base))

    def _orbit(self, camera) -> None:
        """Set the orbit (distance, yaw, pitch) from a camera looking at its target."""
        offset = np.subtract(camera.position, camera.look_at)
        self.distance = float(np.linalg.norm(offset))
        self.yaw_deg = math.degrees(math.atan2(offset[0], offset[2]))
        self.pitch_deg = math.degrees(math.asin(offset[1] / self.distance))

    # ------------------------------------------------------------------ state

    @property
    def material(self) -> LayeredBraggMaterial | ThinFilmMaterial:
        """The edited material, as shown: :attr:`bragg` or :attr:`film`."""
        return self._film if self.material_type == "thin-film" else self._bragg

    @property
    def bragg(self) -> LayeredBraggMaterial:
        """The Bragg layers, shown or kept while the film is."""
        return self._bragg

    @property
    def film(self) -> ThinFilmMaterial:
        """The thin film, shown or kept while the Bragg layers are (its ``thickness_map`` is
        None for a uniform thickness, the noise map otherwise)."""
        return self._film

    @property
    def noise_range_nm(self) -> tuple[float, float]:
        """The thickness range of the film's noise map, nm (kept while the noise is off)."""
        return self._noise_map.range

    @property
    def layers(self) -> tuple[BraggLayerSpec, ...]:
        """The Bragg layers, from the top down."""
        return self._bragg.layers

    @property
    def scene(self) -> Scene:
        """The scene as last edited, with the edited material as shown."""
        return self._frames.state.scene

    @property
    def mode(self) -> str:
        return self._frames.state.mode

    @property
    def colour_method(self) -> str:
        return self._frames.state.colour_method

    @property
    def passes(self) -> int:
        """Samples per pixel the full-resolution path tracer has accumulated since the last
        edit (it adds one a frame at rest)."""
        return self._frames.passes

    @property
    def source(self) -> str:
        """What :attr:`last_frame` shows: ``"rasterized"``, ``"path-traced"`` (full size) or
        ``"preview"`` (path-traced at reduced size, where the rasterizer cannot shade the
        scene); see :data:`wgbragg.app.viewer_frames.SOURCES`."""
        return self._frames.source

    @property
    def denoised(self) -> bool:
        """Whether :attr:`last_frame` was denoised."""
        return self._frames.denoised

    @property
    def raster_refusal(self) -> str | None:
        """Why the rasterizer cannot shade the scene, whose interaction is then previewed by
        paths (None where it can)."""
        return self._frames.raster_refusal

    @property
    def denoise(self) -> bool:
        return self._denoise

    @denoise.setter
    def denoise(self, value: bool) -> None:
        if not isinstance(value, bool | np.bool_):
            raise ValueError(f"denoise must be True or False, got {value!r}")
        self._denoise = bool(value)

    @property
    def interacting(self) -> bool:
        """Whether the user is dragging or holding a control: frames are then rasterized (or
        path-traced previews where the rasterizer cannot shade the scene)."""
        return self._interacting

    @interacting.setter
    def interacting(self, value: bool) -> None:
        if value and not self._interacting:
            self._frames.start_interaction()
        self._interacting = bool(value)

    @property
    def environments(self) -> tuple[str, ...]:
        """The environments :meth:`edit` accepts (``"exr"`` only with ``environment_path``)."""
        return tuple(e for e in ENVIRONMENT_TYPES
                     if e != "exr" or self._environment_path is not None)

    # ------------------------------------------------------------------ edits

    def set_layer(self, index: int, **fields) -> None:
        """Edit Bragg layer ``index`` (0 is the top) and restart the accumulation.

        Parameters
        ----------
        index : int
            In ``[0, len(layers))``.
        **fields
            Any of :data:`LAYER_FIELDS`: ``period_nm`` (Lambda = d1 + d2, nm, > 0), ``delta``
            (d1 / Lambda, in [0, 1]), ``N`` (cells, >= 1), ``n2`` (> 0), ``alpha`` (GGX
            roughness in [0.01, 1]).

        Raises
        ------
        ValueError
            Naming the index or field out of range; the viewer is then left as it was.
        """
        layers = self.layers
        spec = layers[check_layer_index(index, len(layers))]
        edited = edited_layer(spec, index, fields)
        if edited.alpha != spec.alpha:
            self._load_filter(edited.alpha)
        material = dataclasses.replace(self._bragg,
                                       layers=(*layers[:index], edited, *layers[index + 1:]))
        self._apply(self.scene, self.mode, self.colour_method, {}, _bragg=material)

    def set_film(self, **fields) -> None:
        """Edit the thin film and restart the accumulation (while it is shown).

        Parameters
        ----------
        **fields
            Any of :data:`FILM_FIELDS`: ``thickness_nm`` (the uniform thickness, nm, >= 0),
            ``n_film`` (> 0), ``base`` (a bundled metal, one of
            :data:`wgbragg.optics.metals.METALS`, or None for a base of constant index),
            ``n_base`` (> 0) and ``k_base`` (>= 0) of that base (giving one turns a metal
            base into it), ``alpha`` (GGX roughness in [0.01, 1]), ``noise`` (bool: the
            thickness varies over the surface by value noise) and ``noise_range_nm`` (its
            ``(lo, hi)``, nm, 0 <= lo <= hi; kept while the noise is off).

        Raises
        ------
        ValueError
            Naming the field out of range; the viewer is then left as it was.
        """
        edited, noise_map, dielectric = edited_film(self._film, self._noise_map,
                                                    self._dielectric, fields)
        self._apply(self.scene, self.mode, self.colour_method, {}, _film=edited,
                    _noise_map=noise_map, _dielectric=dielectric)

    def edit(self, **changes) -> None:
        """Change the material, the rendering or the camera; restart the accumulation.

        Parameters
        ----------
        material_type : {"layered-bragg", "thin-film"}
            Show the Bragg layers or the thin film (:data:`MATERIAL_TYPES`); the other keeps
            its settings.
        n1 : float
            Index of every layer's ``n1``, the host around the layers (>= 1; above 1 a smooth
            coating covers them).
        base_albedo : None, float or 3 floats
            rho_d, the Lambertian base's albedo in [0, 1] (linear sRGB); None: absorbing.
        layers : int
            Number of Bragg layers, 1 to :data:`MAX_LAYERS`: new ones copy the lowest, the
            lowest go first.
        mode : {"rgb", "spectral"}
        colour_method : str
            One of :data:`wgbragg.colour.methods.COLOUR_METHODS`.
        environment : str
            One of :attr:`environments`.
        yaw_deg, pitch_deg : float
            The camera's direction from its target: azimuth about +y, elevation in
            [-89, 89] degrees.
        distance : float
            The camera's distance from its target (> 0).
        exposure : float
            EV stops of the display, in [-64, 64]; the only edit that keeps the samples.

        The structure's edits (``n1``, ``base_albedo``, ``layers``) apply to the Bragg layers
        whichever material is shown; alone, they leave the film's image (and its samples) as
        they are.

        Raises
        ------
        ValueError
            Naming the parameter out of range (or unknown); nothing is changed then.
        """
        accepted = ("material_type", "n1", "base_albedo", "layers", "mode", "colour_method",
                    "environment", "yaw_deg", "pitch_deg", "distance", "exposure")
        unknown = set(changes) - set(accepted)
        if unknown:
            raise ValueError(f"unknown edit(s) {sorted(unknown)}: accepted are {accepted}")
        material = {}
        if "n1" in changes:
            n1 = check_index("n1", changes["n1"])
            if n1 < 1.0:
                raise ValueError(f"n1 must be >= 1 (the structure lies under air), got {n1}")
            material["layers"] = tuple(dataclasses.replace(s, n1=n1) for s in self.layers)
        if "base_albedo" in changes:
            material["base_albedo"] = check_albedo(changes["base_albedo"])
        if "layers" in changes:
            count = changes["layers"]
            if isinstance(count, bool) or not isinstance(count, int) or not (
                    1 <= count <= MAX_LAYERS):
                raise ValueError(f"layers must be an integer in [1, {MAX_LAYERS}], got "
                                 f"{count!r}")
            current = material.get("layers", self.layers)
            material["layers"] = (current + (current[-1],) * count)[:count]
        mode = choice("mode", changes.get("mode", self.mode), MODES)
        colour_method = choice("colour_method", changes.get("colour_method",
                                                             self.colour_method),
                                COLOUR_METHODS)
        scene = self.scene
        if "environment" in changes:
            kind = choice("environment", changes["environment"], self.environments)
            scene = dataclasses.replace(scene, environment=self._environment(kind))
        camera = {name: changes.get(name, getattr(self, name))
                  for name in ("yaw_deg", "pitch_deg", "distance")}
        camera["yaw_deg"] = finite("yaw_deg", camera["yaw_deg"])
        camera["pitch_deg"] = check_real("pitch_deg", camera["pitch_deg"], -_PITCH_LIMIT_DEG,
                                         _PITCH_LIMIT_DEG)
        camera["distance"] = finite("distance", camera["distance"], positive=True)
        exposure = check_real("exposure", changes.get("exposure", self.exposure), -MAX_EXPOSURE,
                              MAX_EXPOSURE)
        state = {}
        if "material_type" in changes:
            state["material_type"] = choice("material_type", changes["material_type"],
                                             MATERIAL_TYPES)
        if any(name in changes for name in camera):
            scene = dataclasses.replace(scene, camera=self._camera(**camera))
        if material:
            state["_bragg"] = dataclasses.replace(self._bragg, **material)
        if set(changes) != {"exposure"}:
            self._apply(scene, mode, colour_method, camera, **state)
        self.exposure = exposure

    def orbit(self, d_yaw_deg: float, d_pitch_deg: float) -> None:
        """Turn the camera about its target (a mouse drag); the pitch stops at +-89 degrees."""
        pitch = min(max(self.pitch_deg + d_pitch_deg, -_PITCH_LIMIT_DEG), _PITCH_LIMIT_DEG)
        self.edit(yaw_deg=self.yaw_deg + d_yaw_deg, pitch_deg=pitch)

    def zoom(self, factor: float) -> None:
        """Multiply the camera's distance from its target by ``factor`` (> 0)."""
        self.edit(distance=self.distance * finite("factor", factor, positive=True))

    # ------------------------------------------------------------------ frames

    def frame(self) -> np.ndarray:
        """Draw the next frame: rasterized while :attr:`interacting`, else one more
        path-traced sample per pixel, shown from :data:`HANDOVER_SPP` of them (the rasterized
        image until then); :attr:`source` says which.

        Returns
        -------
        numpy.ndarray, shape (height, width, 3), uint8
            sRGB after the display transform, at full size (a preview's pixels repeated).
        """
        self.last_frame = self._frames.frame(self._interacting, self._denoise, self.exposure)
        return self.last_frame

    def refine(self, spp: int) -> np.ndarray:
        """Add ``spp`` path-traced samples per pixel at full resolution at once, and show them.

        Returns
        -------
        numpy.ndarray, shape (height, width, 3), uint8
            As :meth:`frame`.
        """
        self.last_frame = self._frames.refine(check_count("spp", spp), self._denoise,
                                              self.exposure)
        return self.last_frame

    def display(self) -> np.ndarray:
        """The image of :attr:`last_frame` shown again without adding a sample, after a display
        setting changed (:attr:`exposure`, :attr:`denoise`).

        Returns
        -------
        numpy.ndarray, shape (height, width, 3), uint8
            As :meth:`frame`; None before the first frame.
        """
        pixels = self._frames.display(self._denoise, self.exposure)
        if pixels is not None:
            self.last_frame = pixels
        return pixels

    def preview_scale(self) -> int:
        """Resolution divisor of path-traced preview frames (where the rasterizer cannot
        shade the scene): the given one, or the automatic choice."""
        return self._frames.preview_scale()

    # ------------------------------------------------------------------ side panel

    def spectrum(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        """Layer ``index``'s mirror at normal incidence: wavelengths (360..830 nm, 1 nm) and
        unpolarized reflectance (float64 reference)."""
        return xyz_weights()[0], layer_spectrum(self._layer(index))

    def landmarks(self, index: int):
        """Layer ``index``'s landmarks at normal incidence
        (:class:`wgbragg.optics.landmarks.Landmarks`)."""
        return layer_landmarks(self._layer(index))

    def colour_strip(self, index: int, samples: int = 46) -> tuple[np.ndarray, np.ndarray]:
        """Layer ``index``'s mirror colour against the angle in ``n1``, by the current colour
        method.

        Returns
        -------
        theta_deg : numpy.ndarray, shape (samples,)
            0 to 90 degrees.
        colours : numpy.ndarray, shape (samples, 3), uint8
            The reflectance colours as sRGB bytes (clipped, not tone mapped).
        """
        theta_deg = strip_angles(samples)
        return theta_deg, layer_strip(self._layer(index), self.colour_method, theta_deg.size)

    @property
    def film_thickness_nm(self) -> float:
        """The thickness the film's side panel shows, nm: the uniform one, or the middle of
        the noise range."""
        if self._film.thickness_map is None:
            return self._film.thickness_nm
        return 0.5 * sum(self._film.thickness_map.range)

    def film_spectrum(self) -> tuple[np.ndarray, np.ndarray]:
        """The film (of :attr:`film_thickness_nm`) at normal incidence: wavelengths (360..830
        nm, 1 nm) and unpolarized Airy reflectance (float64 reference)."""
        return xyz_weights()[0], film_spectrum(self._film_key(), self.film_thickness_nm)

    def film_colour_strip(self, samples: int = 46) -> tuple[np.ndarray, np.ndarray]:
        """The film's colour (of :attr:`film_thickness_nm`) against the angle in air, as RGB
        mode renders it (:data:`FILM_COLOUR_METHOD`).

        Returns
        -------
        theta_deg : numpy.ndarray, shape (samples,)
            0 to 90 degrees.
        colours : numpy.ndarray, shape (samples, 3), uint8
            The reflectance colours as sRGB bytes (clipped, not tone mapped).
        """
        theta_deg = strip_angles(samples)
        return theta_deg, film_strip(self._film_key(), self.film_thickness_nm, theta_deg.size)

    # ------------------------------------------------------------------ internals

    def _film_key(self) -> ThinFilmMaterial:
        """The film without its map: what its spectrum and colours depend on."""
        return dataclasses.replace(self._film, thickness_map=None)

    def _layer(self, index: int) -> BraggLayerSpec:
        if isinstance(index, bool) or not isinstance(index, int) or not (
                0 <= index < len(self.layers)):
            raise ValueError(f"index must be an integer in [0, {len(self.layers)}), got "
                             f"{index!r}")
        return self.layers[index]

    def _environment(self, kind: str) -> Environment:
        current = self.scene.environment
        if kind == "uniform":
            return Environment("uniform")
        return Environment(kind, intensity=current.intensity if current.type != "uniform"
                           else 1.0, path=self._environment_path if kind == "exr" else None)

    def _camera(self, yaw_deg: float, pitch_deg: float, distance: float):
        yaw, pitch = math.radians(yaw_deg), math.radians(pitch_deg)
        offset = distance * np.array([math.cos(pitch) * math.sin(yaw), math.sin(pitch),
                                      math.cos(pitch) * math.cos(yaw)])
        camera = self.scene.camera
        position = tuple(float(x) for x in np.add(camera.look_at, offset))
        return dataclasses.replace(camera, position=position)

    def _with_material(self, scene: Scene, material) -> Scene:
        materials = {**scene.materials, self.material_name: _rendered(material)}
        return dataclasses.replace(scene, materials=types.MappingProxyType(materials))

    def _load_filter(self, alpha: float) -> None:
        """Time the roughness's filter, which the renderer's update then finds in memory."""
        events = []
        start = time.perf_counter()
        filter_cache.transmission_filter(alpha, progress=events.append)
        budgets = self.budgets
        budgets.filter_s = time.perf_counter() - start
        budgets.filter_source = events[-1].action if events else "in memory"
        budgets.filter_alpha = alpha

    def _apply(self, scene: Scene, mode: str, colour_method: str, camera: dict,
               **state) -> None:
        """Make ``state`` (the viewer's material attributes) current, with ``scene`` showing
        the edited material, and update the renderer that draws next; on a ValueError from
        it, restore the previous state. An edit of materials that leaves the image as it was
        (the kind not shown) keeps the samples."""
        saved = {name: getattr(self, name) for name in state}
        for name, value in state.items():
            setattr(self, name, value)
        scene = self._with_material(scene, self.material)
        if state and (scene, mode, colour_method) == (self.scene, self.mode, self.colour_method):
            for name, value in camera.items():
                setattr(self, name, value)
            return
        self._version += 1
        self._material_version += (scene.materials[self.material_name]
                                   != self.scene.materials[self.material_name])
        try:
            self._frames.update(SceneState(scene, mode, colour_method, self._version,
                                           self._material_version), self._interacting)
        except ValueError:
            for name, value in saved.items():
                setattr(self, name, value)
            raise
        for name, value in camera.items():
            setattr(self, name, value)
