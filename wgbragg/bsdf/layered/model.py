"""Layered Bragg structures and their single-reflection BRDF (Fourneau et al. 2024, sec. 4).

A structure is, from the top: air; a smooth coating when the host index ``n1`` is not 1;
``L >= 1`` rough Bragg layers (:class:`~wgbragg.bsdf.rough_layer.RoughBraggLayer`) separated
by thick ``n1``; and a base, absorbing or Lambertian. :class:`LayeredBragg` evaluates, samples
and simulates it; eq 34 and its terms: ``docs/physics.md``, section 11.

Conventions, stated once: directions are unit vectors with a trailing axis of 3 in the surface
frame (+z is the normal), pointing away from the surface, in air; wavelengths are in nm; a
BRDF is in 1/sr; spectral results carry one value per wavelength, RGB results are linear sRGB
(D65) with a spectrally flat BRDF ``f`` giving ``f (1, 1, 1)``.
"""

from __future__ import annotations

import dataclasses
import functools
import numbers
from collections.abc import Sequence

import numpy as np

from wgbragg.bsdf.layered import model_gpu
from wgbragg.bsdf.layered.coating import (
    HERO,
    INTEGRATED,
    coating_reflectance,
    coating_scale,
    polar_angle,
    refract_in,
    refract_out,
)
from wgbragg.bsdf.layered.simulation import simulate
from wgbragg.bsdf.microfacet import (
    ggx_D_unchecked,
    ggx_G1_over_cos,
    ggx_lobe,
    ggx_sample_visible_normal,
    half_vector,
)
from wgbragg.bsdf.rough_layer import RoughBraggLayer
from wgbragg.colour import colorimetry
from wgbragg.colour.methods import COLOUR_METHODS
from wgbragg.common.sampling import ShiftedPoints
from wgbragg.common.validation import (
    as_float_array,
    check_angle,
    check_backend,
    check_broadcast,
    check_directions,
    check_seed,
    check_wavelength,
)
from wgbragg.optics.yeh import yeh_reflectance

__all__ = ["BRDF_METHODS", "HERO", "INTEGRATED", "LayeredBragg", "coating_reflectance"]

BRDF_METHODS = ("single-reflection", "single-reflection-lut")
"""``method=`` of :meth:`LayeredBragg.brdf`: the model with the mirrors' reflectance evaluated
exactly (Yeh), or read from a table over (theta_d, wavelength) per layer."""

LUT_RESOLUTION_DEG = 0.25
"""Step in theta_d of the reflectance tables of ``"single-reflection-lut"`` (the filter's step)."""

_INTEGRATION_CHUNK = 1024
_TABLE_CACHE_SIZE = 8


class _BaseAlbedo:
    """The base's albedo as a spectrum and as linear sRGB (absorbing: zero)."""

    def __init__(self, value):
        self.given = value
        self._spectrum = None
        if value is None:
            self.rgb = np.zeros(3)
            return
        if isinstance(value, numbers.Real) and not isinstance(value, bool):
            grey = _check_unit_interval(np.asarray(float(value)), "base_albedo")
            self.rgb = np.full(3, float(grey))
            self._spectrum = lambda wavelength: np.full(wavelength.shape, float(grey))
            return
        if isinstance(value, tuple) and len(value) == 2 and all(np.ndim(v) == 1 for v in value):
            wavelength = check_wavelength(value[0], "base_albedo wavelengths")
            albedo = _check_unit_interval(as_float_array("base_albedo", value[1]), "base_albedo")
            if wavelength.ndim != 1 or albedo.shape != wavelength.shape or wavelength.size < 2:
                raise ValueError("a spectral base_albedo is (wavelength_nm, albedo): two 1-D "
                                 "arrays of the same length >= 2")
            if np.any(np.diff(wavelength) <= 0.0):
                raise ValueError("base_albedo wavelengths must increase")
            self._spectrum = lambda wl: np.interp(wl, wavelength, albedo)
            grid, weights = colorimetry.xyz_weights()
            self.rgb = colorimetry.xyz_to_linear_srgb(self._spectrum(grid) @ weights)
            return
        rgb = _check_unit_interval(as_float_array("base_albedo", value), "base_albedo")
        if rgb.shape != (3,):
            raise ValueError("base_albedo must be None, a number in [0, 1], a linear sRGB triple "
                             f"in [0, 1] or a (wavelength_nm, albedo) pair, got shape {rgb.shape}")
        self.rgb = rgb
        basis = mallett_basis()
        self._spectrum = lambda wl: np.stack(
            [np.interp(wl, basis[0], basis[1][:, c]) for c in range(3)], axis=-1) @ rgb

    @classmethod
    def tabulated(cls, wavelength: np.ndarray, values: np.ndarray) -> _BaseAlbedo:
        """An albedo tabulated on increasing wavelengths, unchecked: the effective albedo of a
        base with its interreflections may exceed 1."""
        base = cls(None)
        base.given = (wavelength, values)
        base._spectrum = lambda wl: np.interp(wl, wavelength, values)
        grid, weights = colorimetry.xyz_weights()
        base.rgb = colorimetry.xyz_to_linear_srgb(base._spectrum(grid) @ weights)
        return base

    @property
    def absorbing(self) -> bool:
        return self._spectrum is None

    def spectrum(self, wavelength: np.ndarray) -> np.ndarray:
        if self._spectrum is None:
            return np.zeros(wavelength.shape)
        return self._spectrum(wavelength)

    def mean(self) -> float:
        return float(np.mean(self.spectrum(colorimetry.xyz_weights()[0])))


def _check_wavelength(wavelength_nm, method: str) -> np.ndarray | None:
    """Wavelengths of a spectral query: the library's range, and for the LUT method its
    table's (the colorimetry's 1 nm nodes), which it would otherwise read clamped."""
    if wavelength_nm is None:
        return None
    wavelength = check_wavelength(wavelength_nm)
    low, high = colorimetry.WAVELENGTH_RANGE_NM
    if method == "single-reflection-lut" and not np.all((wavelength >= low)
                                                        & (wavelength <= high)):
        raise ValueError(f"method='single-reflection-lut' tabulates the Yeh term over "
                         f"{low:g}-{high:g} nm: wavelength_nm must lie in that range (use "
                         "method='single-reflection' beyond it)")
    return wavelength


def _check_unit_interval(array: np.ndarray, name: str) -> np.ndarray:
    if not np.all((array >= 0.0) & (array <= 1.0)):
        raise ValueError(f"{name} must be in [0, 1]")
    return array


@functools.cache
def mallett_basis() -> tuple[np.ndarray, np.ndarray]:
    """Mallett & Yuksel's sRGB basis spectra on 360-830 nm: reflectances in [0, 1] that add up to
    1 and whose linear sRGB are the unit primaries, so an RGB albedo maps to a bounded spectrum."""
    import colour

    basis = colour.recovery.MSDS_BASIS_FUNCTIONS_sRGB_MALLETT2019.copy()
    basis = basis.align(colour.SpectralShape(360, 830, 1))
    return basis.wavelengths.copy(), np.clip(basis.values, 0.0, 1.0)


@dataclasses.dataclass(frozen=True, eq=False)
class LayeredBragg:
    """Rough Bragg layers over a base, under a smooth coating when ``n1 != 1`` (sec. 4.1).

    Parameters
    ----------
    layers : sequence of RoughBraggLayer
        From the top down, at least one. All share their mirrors' ``n1``, the host index of the
        structure (>= 1). A single layer may be seen from another medium (its mirror's
        ``host``, Appendix D: the jewel beetle in air); it is then the only layer.
    base_albedo : None, float, sequence of 3 floats or (wavelength_nm, albedo), optional
        ``None``: an absorbing base. Otherwise a Lambertian base: a grey albedo, a linear sRGB
        albedo (a bounded spectrum from Mallett & Yuksel's basis in spectral evaluations), or a
        tabulated spectrum (linear interpolation, end values held), all in [0, 1].
    base_interreflection : bool, optional
        ``False`` (default): eq 34 as published, the base's light reflected once. ``True``:
        the Lambertian base's term also carries the light that the layers (and the coating)
        above send back down to it, summed as a geometric series: the base albedo ``rho``
        becomes ``rho / (1 - rho R_down)`` per wavelength, with ``R_down`` the cosine-weighted
        hemispherical reflectance of the stack seen from the base (:meth:`base_return`). The
        paths this adds are the main part of what a single-reflection model misses over a
        bright base (the Bragg paper's Fig. 7); :meth:`simulate` is unaffected.

    Raises
    ------
    ValueError
        If there is no layer, an item is not a RoughBraggLayer, the layers' ``n1`` differ or are
        below 1, or the albedo is out of [0, 1].

    Examples
    --------
    >>> from wgbragg import BraggMirror, LayeredBragg, RoughBraggLayer
    >>> m = BraggMirror(n1=1.0, n2=1.5, d1=250.0, d2=250.0, N=10)
    >>> s = LayeredBragg(layers=[RoughBraggLayer(m, alpha=0.1)], base_albedo=0.2)
    """

    layers: tuple[RoughBraggLayer, ...]
    base_albedo: object = None
    base_interreflection: bool = False

    def __post_init__(self) -> None:
        layers = self.layers
        if isinstance(layers, RoughBraggLayer) or not isinstance(layers, Sequence):
            raise ValueError("layers must be a sequence of RoughBraggLayer")
        layers = tuple(layers)
        if not layers:
            raise ValueError("layers must hold at least one RoughBraggLayer")
        for layer in layers:
            if not isinstance(layer, RoughBraggLayer):
                raise ValueError(f"layers must hold RoughBraggLayer, got {type(layer).__name__}")
        hosts = {layer.mirror.host for layer in layers}
        if len(hosts) != 1:
            raise ValueError(f"every layer's mirror must share n1 (the host index), got "
                             f"{sorted(hosts)}")
        if layers[0].mirror.host < 1.0:
            raise ValueError(f"the host index n1 must be >= 1 (air above a coating), got "
                             f"{layers[0].mirror.host}")
        if len(layers) > 1 and not all(layer.ballistic for layer in layers):
            raise ValueError("a layer whose mirror is seen from another medium (host != n1) "
                             "transmits non-ballistically: it must be the only layer")
        if not isinstance(self.base_interreflection, bool):
            raise ValueError(f"base_interreflection must be True or False, got "
                             f"{self.base_interreflection!r}")
        object.__setattr__(self, "layers", layers)
        object.__setattr__(self, "_base", _BaseAlbedo(self.base_albedo))
        object.__setattr__(self, "_tables", {})

    # ------------------------------------------------------------------ structure

    @property
    def host_index(self) -> float:
        """The medium around the layers and of the coating: the mirrors' host, their ``n1``
        (or, for a single layer seen from another medium, that medium: Appendix D)."""
        return self.layers[0].mirror.host

    @property
    def has_coating(self) -> bool:
        """Whether a smooth air / ``n1`` interface covers the layers (``n1 != 1``)."""
        return self.host_index != 1.0

    @property
    def absorbing_base(self) -> bool:
        """Whether the base absorbs everything (``base_albedo=None``)."""
        return self._base.absorbing

    @property
    def base_rgb(self) -> np.ndarray:
        """Linear sRGB albedo of the base (zeros when absorbing)."""
        return self._base.rgb.copy()

    def base_spectrum(self, wavelength_nm) -> np.ndarray:
        """Albedo of the base at ``wavelength_nm`` (zeros when absorbing)."""
        return self._base.spectrum(check_wavelength(wavelength_nm))

    def base_return(self, wavelength_nm=None) -> np.ndarray:
        """``R_down``: the fraction of the light a Lambertian base emits that comes back to it.

        The stack seen from the base, each layer crossed or reflected once per pass::

            R_up(theta) = sum_l (G1_l - t_l) prod_{k below l} t_k^2 + F_c prod_k t_k^2
            R_down = int_0^{pi/2} R_up(theta) sin(2 theta) dtheta

        with ``t_k(theta)`` the layers' integrated transmissivity (eq 28), ``G1_l - t_l`` what
        layer ``l``'s visible microfacets reflect (the simulation's layer: an index-matched
        one lets ``G1`` through and reflects nothing) and ``F_c`` the coating's internal
        reflectance (1 beyond its critical angle; 0 without a coating).

        Parameters
        ----------
        wavelength_nm : array_like, optional
            Wavelengths in nm (default: the 1 nm grid 360..830).

        Returns
        -------
        numpy.ndarray
            ``R_down`` in [0, 1], float64, the shape of the wavelengths.
        """
        wavelength = (colorimetry.xyz_weights()[0] if wavelength_nm is None
                      else check_wavelength(wavelength_nm))
        flat = np.unique(wavelength.ravel())
        theta = self.layers[0].filter.theta_i
        rows = np.broadcast_to(theta[:, None], (theta.size, flat.size))
        columns = np.broadcast_to(flat[None, :], rows.shape)
        up = np.zeros(rows.shape)
        through = np.ones(rows.shape)
        cosine = np.cos(theta)[:, None]
        for index in reversed(range(len(self.layers))):
            visible = ggx_G1_over_cos(cosine, self.layers[index].alpha) * cosine
            t = np.clip(self._transmissivity(index, rows, columns, "numpy"), 0.0, visible)
            up = up + (visible - t) * through
            through = through * t * t
        if self.has_coating:
            n = self.host_index
            sin_air = n * np.sin(theta)
            cos_air = np.sqrt(np.maximum(0.0, 1.0 - sin_air * sin_air))
            internal = np.where(sin_air < 1.0, coating_reflectance(cos_air, n), 1.0)
            up = up + internal[:, None] * through
        weight = np.sin(2.0 * theta)
        returned = np.trapezoid(up * weight[:, None], theta, axis=0) / np.trapezoid(weight, theta)
        return np.interp(wavelength, flat, np.clip(returned, 0.0, 1.0))

    def _brdf_base(self) -> _BaseAlbedo:
        """The base albedo of eq 34: as given, or with its interreflections summed."""
        if not self.base_interreflection or self._base.absorbing:
            return self._base

        def build():
            grid = colorimetry.xyz_weights()[0]
            rho = self._base.spectrum(grid)
            return _BaseAlbedo.tabulated(grid, rho / (1.0 - rho * self.base_return(grid)))
        return self._cached(("base",), build)

    def coating_reflectance(self, wi) -> np.ndarray:
        """Reflectance of the coating's Dirac mirror lobe for ``wi`` (0 without a coating)."""
        wi = check_directions(wi, "wi")
        return coating_reflectance(np.maximum(wi[..., 2], 0.0), self.host_index)

    # ------------------------------------------------------------------ tables

    def _cached(self, key, build):
        tables = self._tables
        if key not in tables:
            if len(tables) >= _TABLE_CACHE_SIZE:
                tables.pop(next(iter(tables)))
            tables[key] = build()
        return tables[key]

    def _transmissivity(self, layer_index: int, theta: np.ndarray, wavelength: np.ndarray,
                        backend: str) -> np.ndarray:
        """``t_k(theta, lambda)`` from the layer's table at the distinct wavelengths."""
        layer = self.layers[layer_index]
        distinct, index = np.unique(wavelength, return_inverse=True)
        table = self._cached(("t", layer_index, backend, distinct.tobytes()),
                             lambda: layer.transmissivity_table(distinct, backend))
        theta, index = np.broadcast_arrays(theta, index.reshape(wavelength.shape))
        return layer._interpolate_rows(table, theta, index)

    def _transmissivity_rgb(self, layer_index: int, theta: np.ndarray, backend: str):
        return self.layers[layer_index].transmissivity_rgb(theta, backend)

    def _lut_grid(self) -> np.ndarray:
        return np.radians(np.arange(0.0, 90.0 + LUT_RESOLUTION_DEG / 2, LUT_RESOLUTION_DEG))

    def _reflectance_lut(self, layer_index: int, backend: str) -> np.ndarray:
        """Unpolarized R over (theta_d grid, 360-830 nm at 1 nm), kept by the layer."""
        layer = self.layers[layer_index]

        def build():
            grid, wavelength = self._lut_grid(), colorimetry.xyz_weights()[0]
            return layer.mirror.reflectance(wavelength[None, :], grid[:, None], "unpolarized",
                                            backend)
        return layer._kept(("reflectance", backend), build)

    def _reflectance_rgb_lut(self, layer_index: int, backend: str, colour_method: str):
        """Linear sRGB of the layer's mirror over the theta_d grid, kept by the layer."""
        layer = self.layers[layer_index]
        return layer._kept(("reflectance_rgb", backend, colour_method),
                           lambda: layer.mirror.rgb(self._lut_grid(), method=colour_method,
                                                    backend=backend))

    @staticmethod
    def _lerp_rows(table: np.ndarray, theta: np.ndarray, step: float) -> tuple:
        position = theta / step
        lower = np.clip(np.floor(position).astype(np.intp), 0, table.shape[0] - 2)
        return lower, (position - lower)

    # ------------------------------------------------------------------ eq 34

    def _layer_reflectance(self, layer_index, cos_d, wavelength, method, backend,
                           colour_method):
        """R of layer ``l`` at the difference angle: spectral (``wavelength``) or RGB."""
        mirror = self.layers[layer_index].mirror
        theta_d = polar_angle(cos_d)
        if method == "single-reflection":
            if wavelength is None:
                return mirror.rgb(theta_d, method=colour_method, backend=backend)
            return yeh_reflectance(mirror.n1, mirror.n2, mirror.d1, mirror.d2, mirror.N,
                                   wavelength, theta_d, "unpolarized", host=mirror.host)
        step = np.radians(LUT_RESOLUTION_DEG)
        if wavelength is None:
            table = self._reflectance_rgb_lut(layer_index, backend, colour_method)
            lower, frac = self._lerp_rows(table, theta_d, step)
            frac = frac[..., None]
            return (1.0 - frac) * table[lower] + frac * table[lower + 1]
        table = self._reflectance_lut(layer_index, backend)
        lower, frac = self._lerp_rows(table, theta_d, step)
        grid = colorimetry.xyz_weights()[0]
        column = np.clip(wavelength - grid[0], 0.0, grid.size - 1.0)
        c0 = np.minimum(np.floor(column).astype(np.intp), grid.size - 2)
        cf = column - c0
        row = (1.0 - frac) * ((1.0 - cf) * table[lower, c0] + cf * table[lower, c0 + 1])
        return row + frac * ((1.0 - cf) * table[lower + 1, c0] + cf * table[lower + 1, c0 + 1])

    def _inner_brdf(self, i, o, wavelength, method, backend, colour_method):
        """The bracket of eq 34 for directions inside ``n1`` (both with z > 0)."""
        spectral = wavelength is not None
        ci, co = i[..., 2], o[..., 2]
        h = half_vector(i, o)
        cos_h, cos_d = h[..., 2], np.clip(np.sum(i * h, axis=-1), 0.0, 1.0)
        theta_i, theta_o = polar_angle(ci), polar_angle(co)
        total = 0.0
        through = 1.0  # prod_{k<l} t_k(i') t_k(o')
        for index, layer in enumerate(self.layers):
            a = layer.alpha
            shape = ggx_lobe(cos_h, ci, co, a)
            r = self._layer_reflectance(index, cos_d, wavelength, method, backend,
                                        colour_method)
            lobe = shape * r if spectral else shape[..., None] * r
            total = total + lobe * through
            if spectral:
                t = (self._transmissivity(index, theta_i, wavelength, backend)
                     * self._transmissivity(index, theta_o, wavelength, backend))
            else:
                t = (self._transmissivity_rgb(index, theta_i, backend)
                     * self._transmissivity_rgb(index, theta_o, backend))
            through = through * t
        if not self._base.absorbing:
            base = self._brdf_base()
            albedo = (base.spectrum(np.broadcast_to(wavelength, np.shape(through)))
                      if spectral else base.rgb)
            total = total + albedo / np.pi * through
        return total

    def _evaluate(self, wi, wo, wavelength, method, backend, colour_method):
        """eq 34 on checked arrays; the result broadcasts over the leading axes."""
        if wavelength is None and colour_method == INTEGRATED:
            return self._integrated_rgb(wi, wo, method, backend)
        n = self.host_index
        shape = np.broadcast_shapes(wi.shape[:-1], wo.shape[:-1],
                                    () if wavelength is None else wavelength.shape)
        wi = np.broadcast_to(wi, (*shape, 3))
        wo = np.broadcast_to(wo, (*shape, 3))
        up = (wi[..., 2] > 0.0) & (wo[..., 2] > 0.0)
        # Below the horizon the value is 0; evaluate a harmless pair there instead.
        safe = np.array([0.0, 0.0, 1.0])
        wi_ok = np.where(up[..., None], wi, safe)
        wo_ok = np.where(up[..., None], wo, safe)
        i, o = refract_in(wi_ok, n), refract_in(wo_ok, n)
        wl = None if wavelength is None else np.broadcast_to(wavelength, shape)
        inner = self._inner_brdf(i, o, wl, method, backend, colour_method)
        scale = np.where(up, coating_scale(wi_ok[..., 2], wo_ok[..., 2], n), 0.0)
        return inner * (scale if wavelength is not None else scale[..., None])

    def _integrated_rgb(self, wi, wo, method, backend):
        """Linear sRGB of the spectral eq 34 on the 1 nm grid, in chunks of pairs (the
        spectra of a chunk are its only temporaries)."""
        shape = np.broadcast_shapes(wi.shape[:-1], wo.shape[:-1])
        wi = np.broadcast_to(wi, (*shape, 3)).reshape(-1, 1, 3)
        wo = np.broadcast_to(wo, (*shape, 3)).reshape(-1, 1, 3)
        grid, weights = colorimetry.xyz_weights()
        xyz = np.empty((wi.shape[0], 3))
        for start in range(0, wi.shape[0], _INTEGRATION_CHUNK):
            chunk = slice(start, start + _INTEGRATION_CHUNK)
            xyz[chunk] = self._evaluate(wi[chunk], wo[chunk], grid, method, backend,
                                        INTEGRATED) @ weights
        return colorimetry.xyz_to_linear_srgb(xyz).reshape(*shape, 3)

    def brdf(self, wi, wo, wavelength_nm=None, method="single-reflection", backend="numpy",
             colour_method=None) -> np.ndarray:
        """The single-reflection BRDF (eq 34), without the coating's Dirac reflection.

        Parameters
        ----------
        wi, wo : array_like, shape (..., 3)
            Unit directions towards the light and the viewer, in air, +z the normal. Pairs with
            either below the horizon give 0.
        wavelength_nm : array_like, optional
            Wavelengths in nm, broadcast against the leading axes of ``wi`` and ``wo``: a
            spectral result. ``None``: linear sRGB, with a trailing axis of 3.
        method : {"single-reflection", "single-reflection-lut"}
            The mirrors' reflectance from Yeh's formula, or linearly interpolated from a table
            per layer over theta_d (0.25 degrees) and wavelength (1 nm; RGB: one colour per
            theta_d).
        backend : {"numpy", "gpu"}
            ``"numpy"``: float64, tables and colours computed in numpy. ``"gpu"``: the float32
            WGSL kernel of ``wgsl/bsdf/layered/model.wgsl`` evaluates eq 34 from float32 tables
            built
            on the GPU (:mod:`wgbragg.bsdf.layered.model_gpu`), with wavelengths in 360-830 nm (its
            tables
            are linear between 1 nm nodes) and, for factored RGB without LUT, a colour method
            of :data:`wgbragg.bsdf.layered.model_gpu.FACTORED_COLOUR_METHODS`.
        colour_method : str, optional
            RGB only (refused with ``wavelength_nm``). ``"integrated"`` (default): the colour
            of the spectral BRDF, integrated on 1 nm nodes (exact). A colour method of
            :meth:`BraggMirror.rgb` (e.g. ``"averaged"``): the *factored* RGB of an RGB
            renderer, the colours of the factors of eq 34 multiplied per channel, each
            layer's reflectance colour by that method.

        Returns
        -------
        numpy.ndarray
            ``f`` in 1/sr: the broadcast shape (spectral), or that (*shape, 3) (RGB).

        Notes
        -----
        Factored RGB is exact for one layer over an absorbing base (a scalar lobe times the
        mirror's colour); otherwise the colour of a product differs from the product of the
        colours by the factors' correlation over wavelength, which is strong between stacked
        mirrors (light reflected by a lower layer went through the gaps of the upper one).
        """
        wi = check_directions(wi, "wi")
        wo = check_directions(wo, "wo")
        backend = check_backend(backend)
        if method not in BRDF_METHODS:
            raise ValueError(f"method must be one of {BRDF_METHODS}, got {method!r}")
        wavelength = _check_wavelength(wavelength_nm, method)
        check_broadcast(**{"wi": wi.shape[:-1], "wo": wo.shape[:-1],
                           "wavelength_nm": () if wavelength is None else wavelength.shape})
        if wavelength is not None and colour_method is not None:
            raise ValueError("colour_method applies to RGB results only: leave it None with "
                             f"wavelength_nm, got {colour_method!r}")
        colour_method = self._colour_method(colour_method, backend)
        if colour_method == HERO:
            raise ValueError("colour_method='hero' draws its wavelengths from a sample's random "
                             "numbers: it is a colour_method of sample() only")
        if backend == "gpu":
            return model_gpu.brdf(self, wi, wo, wavelength, method, colour_method)
        return self._evaluate(wi, wo, wavelength, method, backend, colour_method)

    @staticmethod
    def _colour_method(colour_method, backend):
        if colour_method is None:
            return INTEGRATED

        accepted = (INTEGRATED, HERO, *COLOUR_METHODS)
        if colour_method not in accepted:
            raise ValueError(f"colour_method must be one of {accepted}, got {colour_method!r}")
        return colour_method

    # ------------------------------------------------------------------ eq 35

    def _component_probabilities(self, cos_i_inner: np.ndarray, backend: str) -> np.ndarray:
        """Probability of each continuous component (layers, then the base if Lambertian),
        eq 35 with the wavelength-averaged eq 31, normalised over the components present."""
        theta = polar_angle(cos_i_inner)
        remaining = np.ones(theta.shape)
        probabilities = []
        for layer in self.layers:
            p_trans = np.clip(layer.transmission_probability(theta, None, backend), 0.0, 1.0)
            probabilities.append(remaining * (1.0 - p_trans))
            remaining = remaining * p_trans
        if not self._base.absorbing:
            probabilities.append(remaining * self._brdf_base().mean())
        p = np.stack(probabilities, axis=-1)
        total = p.sum(axis=-1, keepdims=True)
        uniform = np.full(p.shape, 1.0 / p.shape[-1])
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(total > 0.0, p / total, uniform)

    def _inner_pdf(self, i, o, probabilities):
        """Mixture density of ``o`` inside ``n1`` (1/sr), given the component probabilities."""
        h = half_vector(i, o)
        cos_d = np.clip(np.sum(i * h, axis=-1), 0.0, 1.0)
        ci = i[..., 2]
        density = 0.0
        for index, layer in enumerate(self.layers):
            a = layer.alpha
            # VNDF(m = h) / (4 i.h) = G1(i)/cos_i (i.h) D(h) / (4 i.h).
            visible = 0.25 * ggx_G1_over_cos(ci, a) * ggx_D_unchecked(h[..., 2], a)
            density = density + probabilities[..., index] * np.where(cos_d > 0.0, visible, 0.0)
        if not self._base.absorbing:
            density = density + probabilities[..., -1] * np.maximum(o[..., 2], 0.0) / np.pi
        return density

    def _pdf(self, wi, wo, backend):
        n = self.host_index
        shape = np.broadcast_shapes(wi.shape[:-1], wo.shape[:-1])
        wi, wo = np.broadcast_to(wi, (*shape, 3)), np.broadcast_to(wo, (*shape, 3))
        up = (wi[..., 2] > 0.0) & (wo[..., 2] > 0.0)
        safe = np.array([0.0, 0.0, 1.0])
        wi_ok = np.where(up[..., None], wi, safe)
        wo_ok = np.where(up[..., None], wo, safe)
        i, o = refract_in(wi_ok, n), refract_in(wo_ok, n)
        probabilities = self._component_probabilities(i[..., 2], backend)
        inner = self._inner_pdf(i, o, probabilities)
        # d omega' / d omega = cos_o / (n^2 cos_o'): Snell's etendue.
        jacobian = wo_ok[..., 2] / (n * n * o[..., 2])
        continuous = 1.0 - coating_reflectance(wi_ok[..., 2], n)
        return np.where(up, continuous * inner * jacobian, 0.0)

    def pdf(self, wi, wo, backend="numpy") -> np.ndarray:
        """Density (1/sr) with which :meth:`sample` draws ``wo`` from its continuous components.

        It integrates to the probability of not sampling the coating's Dirac reflection, less
        what leaves below the horizon or is totally reflected inside the coating. With
        ``backend="gpu"`` the float32 kernel (:mod:`wgbragg.bsdf.layered.model_gpu`) evaluates it.
        """
        wi = check_directions(wi, "wi")
        wo = check_directions(wo, "wo")
        check_broadcast(wi=wi.shape[:-1], wo=wo.shape[:-1])
        if check_backend(backend) == "gpu":
            return model_gpu.pdf(self, wi, wo)
        return self._pdf(wi, wo, backend)

    def sample(self, wi, u, wavelength_nm=None, method="single-reflection", backend="numpy",
               colour_method=None):
        """Importance-sample an outgoing direction (eq 35, then the chosen lobe).

        With a coating, its Dirac reflection is chosen with its Fresnel probability; else a
        layer or the base by eq 35 (transmission probabilities averaged over wavelength, eq 31
        and 33), then a visible GGX normal of that layer (reflection about it) or a cosine
        direction for the base, refracted out of the coating.

        Parameters
        ----------
        wi : array_like, shape (..., 3)
            Unit direction towards the light (or viewer), in air, upper hemisphere.
        u : array_like, shape (..., 3), or (..., 4) with ``colour_method="hero"``
            Uniform numbers in [0, 1]: ``u[..., 0]`` picks the component, ``u[..., 1:3]`` the
            direction, ``u[..., 3]`` offsets the hero wavelengths. Or a
            :class:`wgbragg.ShiftedPoints` (one point set shifted per group, e.g. per pixel):
            with ``backend="gpu"`` and groups that are the samples' leading axes (``u.shape``
            is the samples' shape plus the trailing axis), the kernel expands it, and the
            host neither makes nor uploads a number per sample (up to the device's largest
            buffer, ``gpu.max_buffer_bytes() / 16`` samples per call; beyond, and for other
            shapes, the host expands it). With ``backend="gpu"``,
            a ``wi`` shared along trailing axes (one view, many samples) is uploaded once,
            and float32 ``u`` is not converted to float64 (contiguous, of the full sample
            shape and width 4, it is uploaded as it is).
        wavelength_nm, method, backend, colour_method
            As for :meth:`brdf`: the weight is spectral or RGB. ``backend="gpu"``: the float32
            kernel draws the sample and computes its weight and pdf (same ``u``, same
            ``wo`` up to float32 rounding). ``colour_method="hero"`` (RGB only, this method
            only): the weight's colour estimated from four hero wavelengths (:data:`HERO`),
            the Dirac reflection's weight staying exactly white.

        Returns
        -------
        wo : numpy.ndarray, shape (..., 3)
            Unit outgoing directions.
        weight : numpy.ndarray
            ``f cos(theta_o) / pdf`` with ``f`` the whole :meth:`brdf` (a one-sample mixture
            estimator), shaped like :meth:`brdf`'s result (``(..., 3)`` with
            ``colour_method="hero"``); 1 for the Dirac reflection; 0 where
            the sampled direction leaves below the horizon or is trapped by total internal
            reflection.
        pdf : numpy.ndarray
            :meth:`pdf` of ``wo``; 0 marks the Dirac reflection (no density: do not weight it
            against light sampling).
        """
        wi, u, wavelength, backend, colour_method = self._sample_arguments(
            wi, u, wavelength_nm, method, backend, colour_method)
        if backend == "gpu":
            return model_gpu.sample(self, wi, u, wavelength, method, colour_method)
        hero = colour_method == HERO
        shape = np.broadcast_shapes(wi.shape[:-1], u.shape[:-1])
        wi, u = np.broadcast_to(wi, (*shape, 3)), np.broadcast_to(u, (*shape, u.shape[-1]))
        wo, dirac, valid = self._sample_directions(wi, u, backend)

        pdf = np.where(valid, self._pdf(wi, wo, backend), 0.0)
        cos_pdf = np.where(valid & (pdf > 0.0), wo[..., 2] / np.where(pdf > 0.0, pdf, 1.0), 0.0)
        if hero:
            hero_nm, scale = colorimetry.hero_wavelengths(u[..., 3])
            f = self._evaluate(wi[..., None, :], wo[..., None, :], hero_nm, method, backend,
                               INTEGRATED)
            xyz = np.einsum("...k,...kc->...c", f * scale, colorimetry.xyz_density(hero_nm))
            weight = colorimetry.xyz_to_linear_srgb(xyz) * cos_pdf[..., None]
            return wo, weight + dirac[..., None] * 1.0, pdf
        f = self._evaluate(wi, wo, wavelength, method, backend, colour_method)
        if wavelength is None:
            weight = f * cos_pdf[..., None] + dirac[..., None] * 1.0
        else:
            weight = f * cos_pdf + dirac * 1.0
        return wo, weight, pdf

    def _sample_arguments(self, wi, u, wavelength_nm, method, backend, colour_method):
        """:meth:`sample`'s arguments checked: ``wi``, ``u`` (a :class:`ShiftedPoints` kept
        as it is for the GPU), the wavelengths, the backend and the colour method."""
        wi = check_directions(wi, "wi")
        backend = check_backend(backend)
        # A shifted point set goes to the kernel as it is; numpy reads its numbers (__array__).
        shifted = isinstance(u, ShiftedPoints) and backend == "gpu"
        if not shifted:
            u = as_float_array("u", u, keep_float32=backend == "gpu")
        if method not in BRDF_METHODS:
            raise ValueError(f"method must be one of {BRDF_METHODS}, got {method!r}")
        wavelength = _check_wavelength(wavelength_nm, method)
        colour_method = self._colour_method(colour_method, backend)
        hero = colour_method == HERO and wavelength is None
        if colour_method == HERO and not hero:
            raise ValueError("colour_method='hero' is an RGB estimate: pass wavelength_nm=None")
        width = 4 if hero else 3
        if u.ndim == 0 or u.shape[-1] != width:
            raise ValueError(f"u must have a trailing axis of length {width}"
                             f"{' (colour_method=' + repr(HERO) + ')' if hero else ''}, got "
                             f"shape {u.shape}")
        # min/max: one pass each, and a NaN fails both.
        if not shifted and not (u.min(initial=0.0) >= 0.0 and u.max(initial=1.0) <= 1.0):
            raise ValueError("u must be in [0, 1]")
        if np.any(wi[..., 2] <= 0.0):
            raise ValueError("wi must lie strictly above the horizon: wi[..., 2] in (0, 1]")
        check_broadcast(**{"wi": wi.shape[:-1], "u": u.shape[:-1],
                           "wavelength_nm": () if wavelength is None else wavelength.shape})
        return wi, u, wavelength, backend, colour_method

    def _sample_directions(self, wi, u, backend):
        """:meth:`sample`'s directions for broadcast ``wi`` and ``u``: ``wo``, where the
        coating's Dirac reflection was drawn, and where a continuous sample is valid (above
        the horizon and out of the coating)."""
        n = self.host_index
        fresnel = coating_reflectance(wi[..., 2], n)
        dirac = u[..., 0] < fresnel
        with np.errstate(invalid="ignore", divide="ignore"):
            pick = np.where(dirac, 0.0, (u[..., 0] - fresnel) / (1.0 - fresnel))
        i = refract_in(wi, n)
        probabilities = self._component_probabilities(i[..., 2], backend)
        component = np.sum(pick[..., None] >= np.cumsum(probabilities, axis=-1)[..., :-1],
                           axis=-1)
        o = np.empty((*wi.shape[:-1], 3))
        for index, layer in enumerate(self.layers):
            chosen = component == index
            if np.any(chosen):
                m = ggx_sample_visible_normal(i[chosen], u[chosen][:, 1:3], layer.alpha)
                o[chosen] = 2.0 * np.sum(i[chosen] * m, axis=-1, keepdims=True) * m - i[chosen]
        if not self._base.absorbing:
            chosen = component == len(self.layers)
            r, phi = np.sqrt(u[chosen][:, 1]), 2.0 * np.pi * u[chosen][:, 2]
            o[chosen] = np.stack([r * np.cos(phi), r * np.sin(phi),
                                  np.sqrt(np.maximum(0.0, 1.0 - r * r))], axis=-1)
        above = o[..., 2] > 0.0
        o = np.where(above[..., None], o, np.array([0.0, 0.0, 1.0]))
        o = o / np.linalg.norm(o, axis=-1, keepdims=True)
        wo, escapes = refract_out(o, n)
        valid = above & escapes & ~dirac
        wo = np.where(dirac[..., None], wi * np.array([-1.0, -1.0, 1.0]), wo)
        return wo, dirac, valid

    def albedo(self, theta_i, wavelength_nm=None, samples=4096, seed=0,
               method="single-reflection", backend="numpy", colour_method=None) -> np.ndarray:
        """Directional albedo ``int f cos dwo`` plus the coating's Dirac reflection.

        Estimated with :meth:`sample` on a scrambled Sobol sequence (deterministic for a seed).

        Parameters
        ----------
        theta_i : array_like
            Angles of incidence in air, radians in [0, pi/2).
        wavelength_nm : array_like, optional
            Wavelengths (spectral result, broadcast against ``theta_i``); ``None``: RGB.
        samples : int
            Directions per angle (a power of 2 is best for Sobol points).
        seed : int
            Scrambling seed.
        method, backend, colour_method
            As for :meth:`sample`; ``colour_method="hero"`` draws 4-D Sobol points (the fourth
            offsets the hero wavelengths).

        Returns
        -------
        numpy.ndarray
            In [0, 1] up to the estimator's noise: the broadcast shape, or + (3,) for RGB.
        """
        from scipy.stats import qmc


        theta = check_angle(theta_i, "theta_i")
        if np.any(theta >= np.pi / 2):
            raise ValueError("theta_i must be in [0, pi/2) radians: at grazing incidence no "
                             "light enters")
        if isinstance(samples, bool) or not isinstance(samples, numbers.Integral) or samples < 1:
            raise ValueError(f"samples must be an integer >= 1, got {samples!r}")
        check_seed(seed)
        wavelength = None if wavelength_nm is None else check_wavelength(wavelength_nm)
        shape = theta.shape if wavelength is None else check_broadcast(
            theta_i=theta.shape, wavelength_nm=wavelength.shape)
        theta = np.broadcast_to(theta, shape)
        dimensions = 4 if colour_method == HERO else 3
        u = qmc.Sobol(dimensions, scramble=True, seed=seed).random(int(samples))
        wi = np.stack([np.sin(theta), np.zeros(shape), np.cos(theta)], axis=-1)
        wl = None if wavelength is None else np.broadcast_to(wavelength, shape)[..., None]
        _, weight, _ = self.sample(wi[..., None, :], u, wl, method, backend, colour_method)
        return weight.mean(axis=-2 if wavelength is None else -1)

    def simulate(self, wi, wo=None, wavelength_nm=None, paths=65536, mode="all",
                 transmission="ballistic", seed=0, return_error=False, max_bounces=64):
        """Monte Carlo simulation of the structure's light transport on the GPU (sec. 4.2).

        The BRDF at ``wo`` by next-event estimation (every path, or ``mode="single"``: eq 34),
        or with ``wo=None`` the exit directions and weights of the paths. Parameters and
        results: :func:`wgbragg.bsdf.layered.simulation.simulate`.
        """
        return simulate(self, wi, wo, wavelength_nm, paths, mode, transmission, seed,
                        return_error, max_bounces)
