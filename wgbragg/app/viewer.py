"""The interactive demo's model: a progressive render whose Bragg or thin-film material is
edited live.

A :class:`Viewer` holds a scene, the material being edited, the camera orbit and the display
settings; :meth:`Viewer.frame` adds one sample per pixel and every edit restarts the
accumulation. It keeps the interactive budgets (:attr:`Viewer.budgets`), a low-resolution or
filtered-lighting preview while :attr:`Viewer.interacting` is set, the denoised display of
full-resolution frames (:attr:`Viewer.denoise`) and the side panel's data.
It has no window of its own (:mod:`wgbragg.app.viewer_window` draws it); an example and the
preview's rules: ``docs/design.md``, "The demo".
"""

from __future__ import annotations

import dataclasses
import functools
import math
import numbers
import time
import types

import numpy as np

from wgbragg.bsdf import filter_cache
from wgbragg.bsdf.materials import BraggMirror
from wgbragg.bsdf.transmission_filter import check_filter_alpha
from wgbragg.colour.colorimetry import xyz_weights
from wgbragg.colour.methods import COLOUR_METHODS
from wgbragg.common.validation import (
    check_count,
    check_extinction,
    check_index,
    check_real,
    check_thickness,
)
from wgbragg.optics.metals import METALS
from wgbragg.render import Renderer, display_transform, ibl_levels
from wgbragg.render.display import encode_srgb
from wgbragg.scene import load_preset
from wgbragg.scene.model import (
    ENVIRONMENT_TYPES,
    MAX_EXPOSURE,
    MAX_IMAGE_SIDE,
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
    "LAYER_FIELDS",
    "MATERIAL_TYPES",
    "MAX_LAYERS",
    "PREVIEW_BUDGET_FPS",
    "PREVIEW_SCALES",
    "TABLE_BUDGET_MS",
    "Budgets",
    "Viewer",
]

TABLE_BUDGET_MS = 40.0
"""Tables of an edited Bragg layer re-baked within this many milliseconds."""
FILTER_BUDGET_S = 0.6
"""The transmission filter of a new roughness ready within this many seconds."""
PREVIEW_BUDGET_FPS = 10.0
"""Preview frames per second while interacting."""
PREVIEW_SCALES = (1, 2, 4, 8)
"""Resolution divisors the automatic preview chooses from."""
PREVIEW_IBL = "split-sum"
"""How preview frames light the scene where it allows filtered image-based lighting (the
cheapest filtered mode; ``"monte-carlo"`` elsewhere)."""
MAX_LAYERS = 4
"""Most Bragg layers the viewer stacks."""
LAYER_FIELDS = ("period_nm", "delta", "N", "n2", "alpha")
"""What :meth:`Viewer.set_layer` edits (``n1`` is the whole structure's: :meth:`Viewer.edit`)."""
MATERIAL_TYPES = ("layered-bragg", "thin-film")
"""What the edited material can be (:meth:`Viewer.edit`'s ``material_type``): rough Bragg
layers, or GGX microfacets coated by a thin film."""
FILM_FIELDS = ("thickness_nm", "n_film", "base", "n_base", "k_base", "alpha", "noise",
               "noise_range_nm")
"""What :meth:`Viewer.set_film` edits."""
DEFAULT_FILM = ThinFilmMaterial(n_film=2.0, thickness_nm=500.0, alpha=0.08, n_base=1.5,
                                thickness_map=ParameterMap(None, "noise", (250.0, 750.0), 4.0))
"""The film a scene without one starts from (that of the ``thin_film`` preset)."""
FILM_COLOUR_METHOD = "fourier-table"
"""How the renderer colours films in RGB mode (order 3), and so the film's colour strip."""
DENOISE_AFTER_SPP = 4
"""Full-resolution frames of at least this many samples per pixel are shown denoised (while
:attr:`Viewer.denoise` is on): the first few frames after an edit show the raw samples, for a
user judging an edit's first frames as they are."""
DENOISE_GROWTH = 1.25
"""The denoised picture is renewed once the samples have grown by this factor since the last
one (5, 7, 9, 12, 15, 19, ... spp), and shown as it was in between: denoising costs about a
frame's time at full size, which each frame would otherwise pay."""
DENOISE_QUALITY = "high"
"""OIDN's filter quality for the viewer (:data:`wgbragg.render.denoise.QUALITIES`)."""

# Share of a preview frame's time left to the window's own drawing when choosing the scale.
_PREVIEW_HEADROOM = 0.75
# A filtered-lighting pixel's cost relative to a path's, the guess until one is measured:
# camera rays and shadow rays to the lights, no bounces (docs/performance.md, "The demo's
# budgets").
_FILTERED_PIXEL_COST_SHARE = 0.3
# Weight of the newest frame in the running frame-time averages.
_SMOOTHING = 0.2
_PITCH_LIMIT_DEG = 89.0


@dataclasses.dataclass
class Budgets:
    """What edits and frames cost, wall clock (``time.perf_counter``); None until measured.

    Attributes
    ----------
    table_ms : float or None
        Tables of the edited material (transmissivity tables and reflectance LUTs) re-baked by
        the last update that followed a material edit: :attr:`Renderer.table_seconds`.
    update_ms : float or None
        That whole :meth:`Renderer.update` (tables, uploads, pipeline, restart).
    filter_s : float or None
        The transmission filter of the last roughness edit, from the LUT cache or baked.
    filter_source : str or None
        How it came: ``"baked"``, ``"loaded"`` (a valid cache file), ``"re-baked"`` (an
        invalid one) or ``"in memory"`` (already read by this process).
    filter_alpha : float or None
        Its roughness.
    fps : float or None
        Full-resolution frames per second (render, readback, display transform), a running
        average.
    preview_fps : float or None
        The same for preview frames.
    preview_scale : int or None
        Resolution divisor of the last preview frame.
    denoise_ms : float or None
        The last denoising of a full-resolution frame (feature readback and OIDN).
    """

    table_ms: float | None = None
    update_ms: float | None = None
    filter_s: float | None = None
    filter_source: str | None = None
    filter_alpha: float | None = None
    fps: float | None = None
    preview_fps: float | None = None
    preview_scale: int | None = None
    denoise_ms: float | None = None


@dataclasses.dataclass
class _Slot:
    """A renderer and the scene version it shows."""

    renderer: Renderer
    version: int
    material_version: int


def _finite(name: str, value, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(
            value) or (positive and value <= 0):
        raise ValueError(f"{name} must be a finite real number{' > 0' if positive else ''}, "
                         f"got {value!r}")
    return float(value)


def _choice(name: str, value, choices) -> str:
    if value not in choices:
        raise ValueError(f"{name} must be one of {tuple(choices)}, got {value!r}")
    return value


def _checked_size(size) -> tuple[int, int]:
    if not (isinstance(size, tuple | list) and len(size) == 2 and all(
            isinstance(n, int) and not isinstance(n, bool) and 1 <= n <= MAX_IMAGE_SIDE
            for n in size)):
        raise ValueError(f"size must be two integers in [1, {MAX_IMAGE_SIDE}], got "
                         f"{size!r}")
    return tuple(size)


def _albedo(value) -> float | tuple[float, float, float] | None:
    if value is None:
        return None
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        return check_real("base_albedo", value, 0.0, 1.0)
    try:
        channels = tuple(value)
    except TypeError:
        channels = ()
    if len(channels) != 3:
        raise ValueError(f"base_albedo must be None, a number or 3 numbers in [0, 1], got "
                         f"{value!r}")
    return tuple(check_real("base_albedo", c, 0.0, 1.0) for c in channels)


def _thickness_range(value) -> tuple[float, float]:
    try:
        bounds = tuple(value)
    except TypeError:
        bounds = ()
    if len(bounds) != 2:
        raise ValueError(f"noise_range_nm must be (lo, hi) in nm, got {value!r}")
    lo, hi = (check_thickness(f"noise_range_nm[{k}]", b) for k, b in enumerate(bounds))
    if lo > hi:
        raise ValueError(f"noise_range_nm must be (lo, hi) with lo <= hi, got ({lo}, {hi})")
    return lo, hi


def _srgb_bytes(linear: np.ndarray) -> np.ndarray:
    """Linear sRGB, clipped to [0, 1], as 8-bit sRGB (no tone map: a reflectance colour)."""
    return np.round(encode_srgb(np.clip(linear, 0.0, 1.0)) * 255.0).astype(np.uint8)


def _mirror(spec: BraggLayerSpec) -> BraggMirror:
    return BraggMirror(spec.n1, spec.n2, spec.d1_nm, spec.d2_nm, spec.N, host=spec.host)


@functools.lru_cache(maxsize=32)
def _spectrum(spec: BraggLayerSpec) -> np.ndarray:
    wavelength = xyz_weights()[0]
    values = _mirror(spec).reflectance(wavelength, 0.0, "unpolarized", backend="numpy")
    values.setflags(write=False)
    return values


@functools.lru_cache(maxsize=32)
def _landmarks(spec: BraggLayerSpec):
    # At normal incidence s and p coincide.
    return _mirror(spec).landmarks(0.0, "s")


@functools.lru_cache(maxsize=32)
def _strip(spec: BraggLayerSpec, method: str, samples: int) -> np.ndarray:
    theta = np.radians(np.linspace(0.0, 90.0, samples))
    colours = _srgb_bytes(_mirror(spec).rgb(theta, method=method, backend="gpu"))
    colours.setflags(write=False)
    return colours


@functools.lru_cache(maxsize=32)
def _film_spectrum(material: ThinFilmMaterial, thickness_nm: float) -> np.ndarray:
    wavelength = xyz_weights()[0]
    values = material.to_film(thickness_nm).reflectance(wavelength, 0.0, "unpolarized")
    values.setflags(write=False)
    return values


@functools.lru_cache(maxsize=32)
def _film_strip(material: ThinFilmMaterial, thickness_nm: float, samples: int) -> np.ndarray:
    theta = np.radians(np.linspace(0.0, 90.0, samples))
    colours = _srgb_bytes(material.to_film(thickness_nm).rgb(theta, method=FILM_COLOUR_METHOD))
    colours.setflags(write=False)
    return colours


def _strip_angles(samples) -> np.ndarray:
    """The angles of a colour strip, 0 to 90 degrees in ``samples`` (>= 2) steps."""
    samples = check_count("samples", samples)
    if samples < 2:
        raise ValueError(f"samples must be >= 2, got {samples}")
    return np.linspace(0.0, 90.0, samples)


def _filtered_ibl_allowed(scene: Scene) -> bool:
    """Whether filtered image-based lighting can shade ``scene`` (no smooth coating)."""
    try:
        ibl_levels(scene, PREVIEW_IBL, "rgb")
    except ValueError:
        return False
    return True


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
    """A scene rendered progressively while its Bragg or thin-film material is edited.

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
        Resolution divisor of preview frames (>= 1); by default the smallest of
        :data:`PREVIEW_SCALES` whose frames, at the measured cost per pixel, fit
        :data:`PREVIEW_BUDGET_FPS` with some headroom.
    environment_path : path-like, optional
        An equirectangular EXR that ``edit(environment="exr")`` uses; by default the
        scene's own, if it has one.
    preview_ibl : bool
        Preview with filtered image-based lighting (:data:`PREVIEW_IBL`) where the scene
        allows it; False previews with paths at reduced resolution.
    denoise : bool
        The initial :attr:`denoise`.

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
        The last image returned by :meth:`frame` or :meth:`refine`.
    denoise : bool
        Show full-resolution frames of at least :data:`DENOISE_AFTER_SPP` samples per pixel
        denoised (:meth:`wgbragg.render.Renderer.denoised`, renewed as :data:`DENOISE_GROWTH`
        says); previews are never denoised. Only the display changes: the accumulation goes on.
    denoised : bool
        Whether :attr:`last_frame` was denoised.
    """

    def __init__(self, scene: Scene | str = "teapot", size: tuple[int, int] = (256, 256),
                 material: str | None = None, mode: str | None = None,
                 colour_method: str = "averaged", seed: int = 0, max_bounces: int = 8,
                 preview_scale: int | None = None, environment_path=None,
                 preview_ibl: bool = True, denoise: bool = True):
        if isinstance(scene, str):
            scene = load_preset(scene)
        if not isinstance(scene, Scene):
            raise ValueError(f"scene must be a Scene or a preset name, got {scene!r}")
        self._take_material(scene, material)
        if preview_scale is not None:
            check_count("preview_scale", preview_scale)
        self.size = _checked_size(size)
        self.mode = _choice("mode", scene.settings.mode if mode is None else mode, MODES)
        self.colour_method = _choice("colour_method", colour_method, COLOUR_METHODS)
        self.exposure = scene.settings.exposure
        self._interacting = False
        self._interaction_scale = 1
        self._preview_ibl = bool(preview_ibl)
        self._interaction_ibl = "monte-carlo"
        self.budgets = Budgets()
        self.last_frame: np.ndarray | None = None
        self.denoise = denoise
        self.denoised = False
        # (renderer, scene version, passes, denoised linear image) of the last denoising.
        self._denoised_image: tuple | None = None
        self._last_scale = 1
        self.scene = self._with_material(scene, self.material)
        if environment_path is None and scene.environment.type == "exr":
            environment_path = scene.environment.path
        self._environment_path = environment_path
        self._seed, self._max_bounces = seed, max_bounces
        self._preview_scale = preview_scale
        # Running mean seconds per pixel of a frame, per lighting ("monte-carlo" or PREVIEW_IBL).
        self._pixel_seconds: dict[str, float] = {}
        # Running mean frame time of preview (True) and full-resolution (False) frames.
        self._frame_seconds: dict[bool, float] = {}
        self._version = self._material_version = 0
        self._slots: dict[tuple[int, str], _Slot] = {}
        self._orbit(scene.camera)
        # The full-resolution renderer, validating size, seed and max_bounces.
        self._slot(1, "monte-carlo")

    def _take_material(self, scene: Scene, material: str | None) -> None:
        """Choose the edited material (the first editable one by default) and keep what its
        toggles restore: the other kind's default, the noise map and the dielectric base."""
        editable = [name for name, m in scene.materials.items()
                    if isinstance(m, LayeredBraggMaterial | ThinFilmMaterial)]
        if material is None and not editable:
            raise ValueError("scene has no layered-bragg material or thin-film material to edit")
        self.material_name = _choice("material", editable[0] if material is None else material,
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
    def passes(self) -> int:
        """Samples per pixel behind :attr:`last_frame`."""
        return self._last_slot.renderer.passes

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
        """Whether the user is dragging or holding a control: frames are then previews.

        The preview's resolution is chosen when this becomes True and kept until it is
        False again, so that one interaction stays on one preview renderer.
        """
        return self._interacting

    @interacting.setter
    def interacting(self, value: bool) -> None:
        if value and not self._interacting:
            self._interaction_ibl = PREVIEW_IBL if (
                self._preview_ibl and _filtered_ibl_allowed(self.scene)) else "monte-carlo"
            self._interaction_scale = self.preview_scale(self._interaction_ibl)
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
        if isinstance(index, bool) or not isinstance(index, int) or not (
                0 <= index < len(layers)):
            raise ValueError(f"index must be an integer in [0, {len(layers)}), got {index!r}")
        unknown = set(fields) - set(LAYER_FIELDS)
        if unknown:
            extra = " (n1 belongs to all layers: use edit(n1=...))" if "n1" in unknown else ""
            raise ValueError(f"unknown layer field(s) {sorted(unknown)}: accepted are "
                             f"{LAYER_FIELDS}{extra}")
        spec = layers[index]
        changes = {}
        if "period_nm" in fields or "delta" in fields:
            period = spec.period_nm
            if "period_nm" in fields:
                period = check_thickness("period_nm", fields["period_nm"])
                if period <= 0.0:
                    raise ValueError(f"period_nm must be > 0, got {period}")
            delta = check_real("delta", fields.get("delta", spec.delta), 0.0, 1.0)
            changes.update(d1_nm=delta * period, d2_nm=period - delta * period)
        if "N" in fields:
            changes["N"] = check_count("N", fields["N"])
        if "n2" in fields:
            changes["n2"] = check_index("n2", fields["n2"])
        if "alpha" in fields:
            changes["alpha"] = check_filter_alpha(fields["alpha"])
        edited = dataclasses.replace(spec, **changes)
        try:
            _mirror(edited)
        except ValueError as error:
            raise ValueError(f"layer {index}: {error}") from None
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
        unknown = set(fields) - set(FILM_FIELDS)
        if unknown:
            raise ValueError(f"unknown film field(s) {sorted(unknown)}: accepted are "
                             f"{FILM_FIELDS}")
        film, noise_map, dielectric = self._film, self._noise_map, self._dielectric
        changes = {}
        if "thickness_nm" in fields:
            changes["thickness_nm"] = check_thickness("thickness_nm", fields["thickness_nm"])
        if "n_film" in fields:
            changes["n_film"] = check_index("n_film", fields["n_film"])
        if "alpha" in fields:
            changes["alpha"] = check_filter_alpha(fields["alpha"])
        metal = film.base
        if "base" in fields:
            metal = fields["base"]
            if metal is not None and metal not in METALS:
                raise ValueError(f"base must be None or one of {tuple(METALS)}, got {metal!r}")
        if "n_base" in fields or "k_base" in fields:
            if fields.get("base") is not None:
                raise ValueError("base: a metal base replaces n_base and k_base: give one or "
                                 "the other")
            dielectric = (check_index("n_base", fields.get("n_base", dielectric[0])),
                          check_extinction("k_base", fields.get("k_base", dielectric[1])))
            metal = None
        changes["base"] = metal
        changes["n_base"], changes["k_base"] = (1.0, 0.0) if metal is not None else dielectric
        if "noise_range_nm" in fields:
            noise_map = dataclasses.replace(noise_map,
                                            range=_thickness_range(fields["noise_range_nm"]))
        noise = fields.get("noise", film.thickness_map is not None)
        if not isinstance(noise, bool | np.bool_):
            raise ValueError(f"noise must be True or False, got {noise!r}")
        changes["thickness_map"] = noise_map if noise else None
        edited = dataclasses.replace(film, **changes)
        try:
            edited.to_film()
        except ValueError as error:
            raise ValueError(f"film: {error}") from None
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
            material["base_albedo"] = _albedo(changes["base_albedo"])
        if "layers" in changes:
            count = changes["layers"]
            if isinstance(count, bool) or not isinstance(count, int) or not (
                    1 <= count <= MAX_LAYERS):
                raise ValueError(f"layers must be an integer in [1, {MAX_LAYERS}], got "
                                 f"{count!r}")
            current = material.get("layers", self.layers)
            material["layers"] = (current + (current[-1],) * count)[:count]
        mode = _choice("mode", changes.get("mode", self.mode), MODES)
        colour_method = _choice("colour_method", changes.get("colour_method",
                                                             self.colour_method),
                                COLOUR_METHODS)
        scene = self.scene
        if "environment" in changes:
            kind = _choice("environment", changes["environment"], self.environments)
            scene = dataclasses.replace(scene, environment=self._environment(kind))
        camera = {name: changes.get(name, getattr(self, name))
                  for name in ("yaw_deg", "pitch_deg", "distance")}
        camera["yaw_deg"] = _finite("yaw_deg", camera["yaw_deg"])
        camera["pitch_deg"] = check_real("pitch_deg", camera["pitch_deg"], -_PITCH_LIMIT_DEG,
                                         _PITCH_LIMIT_DEG)
        camera["distance"] = _finite("distance", camera["distance"], positive=True)
        exposure = check_real("exposure", changes.get("exposure", self.exposure), -MAX_EXPOSURE,
                              MAX_EXPOSURE)
        state = {}
        if "material_type" in changes:
            state["material_type"] = _choice("material_type", changes["material_type"],
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
        self.edit(distance=self.distance * _finite("factor", factor, positive=True))

    # ------------------------------------------------------------------ frames

    def frame(self) -> np.ndarray:
        """Add one sample per pixel to the image shown (a preview while :attr:`interacting`).

        Returns
        -------
        numpy.ndarray, shape (height, width, 3), uint8
            sRGB after the display transform; a preview has its pixels repeated to the full
            size.
        """
        scale, ibl = self._key_now()
        slot = self._slot(scale, ibl)
        start = time.perf_counter()
        image = slot.renderer.render(1)
        pixels = self._show(slot, image, scale)
        seconds = time.perf_counter() - start
        self._measure(self._interacting, scale, ibl, seconds, image.shape[0] * image.shape[1])
        return pixels

    def refine(self, spp: int) -> np.ndarray:
        """Add ``spp`` samples per pixel at full resolution at once (no preview).

        Returns
        -------
        numpy.ndarray, shape (height, width, 3), uint8
            As :meth:`frame`.
        """
        slot = self._slot(1, "monte-carlo")
        return self._show(slot, slot.renderer.render(check_count("spp", spp)), 1)

    def display(self) -> np.ndarray:
        """The image of :attr:`last_frame` shown again without adding a sample, after a display
        setting changed (:attr:`exposure`, :attr:`denoise`).

        Returns
        -------
        numpy.ndarray, shape (height, width, 3), uint8
            As :meth:`frame`; None before the first frame.
        """
        if self.last_frame is None:
            return None
        slot = self._last_slot
        return self._show(slot, slot.renderer.image(), self._last_scale)

    @property
    def preview_lighting(self) -> str:
        """How the preview lights the scene: :data:`PREVIEW_IBL`, or ``"monte-carlo"`` (paths)
        where the scene does not allow filtered lighting or ``preview_ibl`` was False."""
        return self._interaction_ibl if self._interacting else (
            PREVIEW_IBL if self._preview_ibl and _filtered_ibl_allowed(self.scene)
            else "monte-carlo")

    def preview_scale(self, lighting: str | None = None) -> int:
        """Resolution divisor of preview frames: the given one, or the automatic choice for
        the preview's ``lighting`` (by default :attr:`preview_lighting`)."""
        if self._preview_scale is not None:
            return self._preview_scale
        lighting = self.preview_lighting if lighting is None else lighting
        pixel_seconds = self._pixel_seconds.get(lighting)
        paths = self._pixel_seconds.get("monte-carlo")
        if pixel_seconds is None and paths is not None:
            # The window has shown full-resolution paths before any interaction.
            pixel_seconds = paths * _FILTERED_PIXEL_COST_SHARE
        if pixel_seconds is None:
            # Filtered lighting traces camera rays and light shadow rays only, no bounces: full
            # resolution until measured.
            return 1 if lighting != "monte-carlo" else 2
        budget = _PREVIEW_HEADROOM / PREVIEW_BUDGET_FPS
        width, height = self.size
        for scale in PREVIEW_SCALES:
            if pixel_seconds * -(-width // scale) * -(-height // scale) <= budget:
                return scale
        return PREVIEW_SCALES[-1]

    # ------------------------------------------------------------------ side panel

    def spectrum(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        """Layer ``index``'s mirror at normal incidence: wavelengths (360..830 nm, 1 nm) and
        unpolarized reflectance (float64 reference)."""
        return xyz_weights()[0], _spectrum(self._layer(index))

    def landmarks(self, index: int):
        """Layer ``index``'s landmarks at normal incidence
        (:class:`wgbragg.optics.landmarks.Landmarks`)."""
        return _landmarks(self._layer(index))

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
        theta_deg = _strip_angles(samples)
        return theta_deg, _strip(self._layer(index), self.colour_method, theta_deg.size)

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
        return xyz_weights()[0], _film_spectrum(self._film_key(), self.film_thickness_nm)

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
        theta_deg = _strip_angles(samples)
        return theta_deg, _film_strip(self._film_key(), self.film_thickness_nm, theta_deg.size)

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
        the edited material, and update the renderer in use now; on a ValueError from the
        renderer, restore the previous state. An edit of materials that leaves the image as
        it was (the kind not shown) keeps the samples."""
        names = ("scene", "mode", "colour_method", "_version", "_material_version", *state)
        saved = {name: getattr(self, name) for name in names}
        for name, value in state.items():
            setattr(self, name, value)
        scene = self._with_material(scene, self.material)
        if state and (scene, mode, colour_method) == (self.scene, self.mode, self.colour_method):
            for name, value in camera.items():
                setattr(self, name, value)
            return
        material_changed = (scene.materials[self.material_name]
                            != self.scene.materials[self.material_name])
        self.scene, self.mode, self.colour_method = scene, mode, colour_method
        self._version += 1
        self._material_version += material_changed
        try:
            self._slot(*self._key_now())
        except ValueError:
            for name, value in saved.items():
                setattr(self, name, value)
            raise
        for name, value in camera.items():
            setattr(self, name, value)

    def _key_now(self) -> tuple[int, str]:
        if self._interacting:
            return self._interaction_scale, self._interaction_ibl
        return 1, "monte-carlo"

    def _slot(self, scale: int, ibl: str) -> _Slot:
        """The renderer of resolution divisor ``scale`` and lighting ``ibl``, created or
        updated to the current scene (filtered lighting in RGB mode, which it needs)."""
        slot = self._slots.get((scale, ibl))
        mode = self.mode if ibl == "monte-carlo" else "rgb"
        if slot is None:
            width, height = self.size
            renderer = Renderer(self.scene, size=(-(-width // scale), -(-height // scale)),
                                seed=self._seed, mode=mode, max_bounces=self._max_bounces,
                                colour_method=self.colour_method, ibl=ibl)
            slot = self._slots[scale, ibl] = _Slot(renderer, self._version,
                                                   self._material_version)
        elif slot.version != self._version:
            start = time.perf_counter()
            slot.renderer.update(self.scene, mode, self.colour_method, ibl)
            seconds = time.perf_counter() - start
            if slot.material_version != self._material_version:
                self.budgets.update_ms = 1e3 * seconds
                self.budgets.table_ms = 1e3 * slot.renderer.table_seconds
            slot.version, slot.material_version = self._version, self._material_version
        self._last_slot = slot
        return slot

    def _show(self, slot: _Slot, image: np.ndarray, scale: int) -> np.ndarray:
        renderer = slot.renderer
        self.denoised = (self._denoise and scale == 1 and renderer.ibl == "monte-carlo"
                         and renderer.passes >= DENOISE_AFTER_SPP)
        if self.denoised:
            image = self._denoised(slot)
        pixels = display_transform(image, self.exposure)
        if scale > 1:
            width, height = self.size
            pixels = np.repeat(np.repeat(pixels, scale, axis=0), scale, axis=1)[:height, :width]
        self._last_slot, self._last_scale = slot, scale
        self.last_frame = pixels
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

    def _measure(self, preview: bool, scale: int, ibl: str, seconds: float,
                 pixels: int) -> None:
        previous = self._frame_seconds.get(preview)
        average = seconds if previous is None else (
            (1.0 - _SMOOTHING) * previous + _SMOOTHING * seconds)
        self._frame_seconds[preview] = average
        per_pixel = seconds / pixels
        known = self._pixel_seconds.get(ibl)
        # A renderer's first frame also builds its tables and pipelines (0.5-0.7 s, 10-30
        # preview frames): a cost far below the estimate replaces it rather than decaying into
        # it over dozens of frames.
        self._pixel_seconds[ibl] = per_pixel if known is None or per_pixel < 0.5 * known else (
            (1.0 - _SMOOTHING) * known + _SMOOTHING * per_pixel)
        if preview:
            self.budgets.preview_fps = 1.0 / average
            self.budgets.preview_scale = scale
        else:
            self.budgets.fps = 1.0 / average
