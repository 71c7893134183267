"""Rough Bragg layers: ballistic transmission through a distribution of tilted Bragg mirrors.

A rough Bragg layer (Fourneau, Pacanowski & Barla 2024, sec. 4.1-4.2) transmits light
undeviated, with its mirror's transmittance filtered over the difference angle by the
roughness alone (eq 28). With the filter baked once per ``alpha``, a layer's table over
(theta_i, wavelength) is one matrix product, computed on the GPU by
``wgsl/bsdf/rough_layer_transmissivity.wgsl``. Angles are in ``n1``, radians; wavelengths in
nm. Details: ``docs/physics.md``, section 10.
"""

from __future__ import annotations

import dataclasses
import functools
import weakref

import numpy as np

from wgbragg import gpu
from wgbragg.bsdf import filter_cache
from wgbragg.bsdf.materials import BraggMirror
from wgbragg.bsdf.microfacet import ggx_G1
from wgbragg.bsdf.transmission_filter import TransmissionFilter, check_filter_alpha
from wgbragg.colour import colorimetry
from wgbragg.common.validation import check_angle, check_backend, check_broadcast, check_wavelength
from wgbragg.optics import pointwise_gpu, yeh_gpu
from wgbragg.optics.yeh import cell_coefficients, yeh_reflectance

__all__ = ["RoughBraggLayer"]

# The product pass (bsdf/rough_layer_transmissivity.wgsl): filter rows per workgroup (ROWS),
# wavelengths per invocation (SPAN), WORKGROUP_SIZE; the fastest blocks on lavapipe
# (docs/performance.md, "Rough Bragg layers"). Eight invocations keep the padding of the
# wavelength blocks small: 96 per workgroup, 480 for the 471 of 1 nm. ROWS and SPAN are
# written out in the kernel, so tests/test_wgsl_layouts.py checks them instead of passing them
# as override constants.
_WORKGROUP_SIZE = 8
_ROWS_PER_GROUP = 16
_WAVELENGTHS_PER_LANE = 12
_PARAMS_DTYPE = gpu.struct_dtype([
    ("rows", "u32"), ("quads", "u32"), ("wavelengths", "u32"), ("blocks", "u32"),
])
# id(filter) -> its weights (texture), difference angles and their cells' ends on the GPU,
# dropped with the filter.
_filters_on_gpu: dict[int, tuple[gpu.DeviceArray, ...]] = {}


def _filter_on_gpu(filt: TransmissionFilter) -> tuple[gpu.DeviceArray, ...]:
    """The filter's float32 weights, zero-padded to whole quads of difference angles, as a
    (rows, quads, 4) texture, its theta_d and the ends of their cells (:func:`cell_edges`) as
    buffers: uploaded once per filter, so that a layer with another mirror uploads only its
    parameters."""
    key = id(filt)
    arrays = _filters_on_gpu.get(key)
    if arrays is None:
        rows, angles = filt.weights.shape
        quads = -(-angles // 4)
        weights = np.zeros((rows, 4 * quads), np.float32)
        weights[:, :angles] = filt.weights
        lower, upper = cell_edges(filt.theta_d)
        arrays = (gpu.DeviceArray.upload(weights.reshape(rows, quads, 4), texture=True),
                  gpu.DeviceArray.upload(filt.theta_d.astype(np.float32)),
                  gpu.DeviceArray.upload(np.append(lower, upper[-1]).astype(np.float32)))
        _filters_on_gpu[key] = arrays
        weakref.finalize(filt, _filters_on_gpu.pop, key, None)
    return arrays


def _visible_wavelengths() -> np.ndarray:
    return colorimetry.xyz_weights()[0]


# Cell means of T (_cell_transmittance): the phase window widens from 0 to the whole cell as
# the cell's span of T's features, width sqrt(1 + |C|^2 / sin^2 K Lambda) / pi, goes from
# _RESOLVED to _UNRESOLVED (a smoothstep): below, T is resolved by the Gauss-Legendre nodes
# and its point values keep their accuracy (N = 10: 2.5e-5 of the dense reference, 5e-4 with
# the whole cell).
_RESOLVED = 0.1
_UNRESOLVED = 0.5


def cell_edges(theta_d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper ends of the cells of the difference angles ``theta_d`` (increasing,
    inside (0, pi/2)): midpoints between neighbours, ``theta_d[0] / 2`` and
    ``(theta_d[-1] + pi / 2) / 2`` at the ends (off the grazing angle, where the Bloch phase of
    a matched mirror is undefined)."""
    theta_d = np.asarray(theta_d, np.float64)
    middle = 0.5 * (theta_d[1:] + theta_d[:-1])
    return (np.concatenate([[0.5 * theta_d[0]], middle]),
            np.concatenate([middle, [0.5 * (theta_d[-1] + 0.5 * np.pi)]]))


def _smoothstep(z, lo, hi):
    t = np.clip((z - lo) / (hi - lo), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _window_transmittance(a, b, psi0, width):
    """Mean of ``T = b / (b + a sin^2 psi)`` over ``psi`` in ``psi0 +- width / 2`` (width > 0).

    ``int dpsi / (b + a sin^2 psi) = atan(k tan psi) / sqrt(b (a + b))``, ``k^2 = (a + b) / b``:
    whole periods of pi add ``pi`` to the arc tangent, the rest ``r`` adds the angle between
    ``(cos u, k sin u)`` and ``(cos v, k sin v)``, ``v = u + r``, in [0, pi)."""
    whole = np.floor(width / np.pi)
    rest = width - whole * np.pi
    u = psi0 - 0.5 * width
    v = u + rest
    ab = a + b
    angle = np.arctan2(np.sqrt(b * ab) * np.sin(rest),
                       b * np.cos(u) * np.cos(v) + ab * np.sin(u) * np.sin(v))
    return np.sqrt(b / ab) * (whole * np.pi + angle) / width


def _cell_transmittance(m: BraggMirror, wavelength: np.ndarray, theta_d: np.ndarray):
    """Unpolarized ``1 - R`` of a matched mirror (``host == n1``, with an n2 layer) averaged
    over the cell of each node ``theta_d`` (:func:`cell_edges`), float64.

    In a pass band ``T = sin^2 phi / (sin^2 phi + |C|^2 sin^2 psi)``, ``phi = K Lambda``, and
    across a cell the fast phase ``psi = N phi`` moves by ``N |phi(hi) - phi(lo)|`` while
    ``phi`` and ``|C|`` barely change: for N of hundreds, T runs through many periods per cell
    and its point value at the node aliases (t off by up to 0.1 at N = 1000). The node's value
    is the exact mean of T over a window of ``psi`` centred on the node, with ``phi`` and
    ``|C|`` frozen at the node (:func:`_window_transmittance`): the whole span of the cell
    where it holds unresolved features (tending to ``1 - R_avg``, the phase-averaged
    reflectance, for many periods), no window (the point value) where T is resolved, a
    smoothstep between. The window stays inside ``psi >= pi / 2`` and within ``psi0`` of the
    node's phase ``psi0 = N min(phi, pi - phi)``: next to a band edge (``phi -> 0`` or pi)
    ``sin^2 phi`` changes as fast as ``psi`` and the frozen form does not hold. Inside gaps
    (``sin^2 phi <= 0``) T does not oscillate: point values. The float32 twin is
    ``wgsl/bsdf/rough_layer_transmittance.wgsl``.
    """
    lower, upper = cell_edges(theta_d)
    # Neighbouring cells share an end: the phases at each end once (bsdf/rough_layer_phases.wgsl).
    ends = np.append(lower, upper[-1])
    N = m.N
    total = 0.0
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        for polarization in ("s", "p"):
            _, C, x, sin2 = cell_coefficients(m.n1, m.n2, m.d1, m.d2, wavelength,
                                              m.n1 * np.sin(theta_d), polarization)
            _, _, x_end, sin2_end = cell_coefficients(m.n1, m.n2, m.d1, m.d2, wavelength,
                                                      m.n1 * np.sin(ends), polarization)
            phase = np.arctan2(np.sqrt(np.maximum(sin2_end, 0.0)), x_end)
            span = N * np.abs(phase[..., 1:] - phase[..., :-1])
            a = np.abs(C) ** 2
            b = np.maximum(sin2, 0.0)
            psi0 = N * np.arctan2(np.sqrt(b), np.abs(x))
            features = span * np.sqrt((a + b) / b) / np.pi
            width = span * _smoothstep(features, _RESOLVED, _UNRESOLVED)
            width = np.minimum(width, np.maximum(np.minimum(psi0, 2.0 * psi0 - np.pi), 0.0))
            width = np.where(np.isfinite(width), width, 0.0)
            point = 1.0 - yeh_reflectance(m.n1, m.n2, m.d1, m.d2, N, wavelength, theta_d,
                                          polarization)
            window = _window_transmittance(a, b, psi0, np.where(width > 0.0, width, 1.0))
            total = total + 0.5 * np.where((sin2 > 0.0) & (width > 0.0),
                                           np.clip(window, 0.0, 1.0), point)
    return total


@dataclasses.dataclass(frozen=True)
class RoughBraggLayer:
    """A GGX-rough layer of Bragg mirrors (sec. 4.1), seen from its host ``n1``.

    Parameters
    ----------
    mirror : BraggMirror
        The mirror of every microfacet, embedded in ``n1`` (``host == n1``: the transmission is
        ballistic, eq 22). A mirror seen from another medium (``host != n1``, Appendix D, such
        as the jewel beetle's cuticle in air) is accepted for the paper's sec. 5 use: its
        transmissivity is eq 28 with ``T = 1 - R`` from the host, the energy that crosses the
        layer, whose directions are then no longer ballistic (see :attr:`ballistic`).
    alpha : float
        GGX roughness in [0.01, 1].
    transmission_filter : TransmissionFilter, optional
        The filter of ``alpha``; by default the cached one at 0.25 degrees and 1000 azimuth
        samples (:func:`wgbragg.bsdf.filter_cache.transmission_filter`, baked on the GPU on
        first use).

    Raises
    ------
    ValueError
        If ``mirror`` is not a BraggMirror, ``alpha`` is out of range, or
        the filter was baked for another ``alpha``.
    """

    mirror: BraggMirror
    alpha: float
    transmission_filter: TransmissionFilter | None = dataclasses.field(
        default=None, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not isinstance(self.mirror, BraggMirror):
            raise ValueError(f"mirror must be a BraggMirror, got {type(self.mirror).__name__}")
        object.__setattr__(self, "alpha", check_filter_alpha(self.alpha))
        given = self.transmission_filter
        if given is not None:
            if not isinstance(given, TransmissionFilter):
                raise ValueError("transmission_filter must be a TransmissionFilter, got "
                                 f"{type(given).__name__}")
            if not np.isclose(given.alpha, self.alpha, rtol=1e-6, atol=0.0):
                raise ValueError(f"transmission_filter was baked for alpha={given.alpha}, "
                                 f"the layer has alpha={self.alpha}")

    @property
    def ballistic(self) -> bool:
        """Whether transmitted light keeps its direction (the mirror sits in its own ``n1``)."""
        return self.mirror.host == self.mirror.n1

    @functools.cached_property
    def filter(self) -> TransmissionFilter:
        """The transmission filter F_alpha in use (baked or loaded on first access)."""
        if self.transmission_filter is not None:
            return self.transmission_filter

        return filter_cache.transmission_filter(self.alpha)

    # ------------------------------------------------------------------ eq 28

    @property
    def _cell_means(self) -> bool:
        """Whether T is averaged over the cells of theta_d (:func:`_cell_transmittance`): a
        ballistic layer whose mirror has an n2 layer."""
        m = self.mirror
        return self.ballistic and not (m.n1 == m.n2 or m.d2 == 0.0)

    def _transmittance(self, wavelength_nm: np.ndarray) -> np.ndarray:
        """``1 - R`` at (..., the filter's theta_d), unpolarized, float64: for a ballistic
        layer the mean over each node's cell (:func:`_cell_transmittance`), else point values."""
        m = self.mirror
        theta_d = self.filter.theta_d
        wavelength = wavelength_nm[..., None]
        if self._cell_means:
            return _cell_transmittance(m, wavelength, theta_d)
        return 1.0 - yeh_reflectance(m.n1, m.n2, m.d1, m.d2, m.N, wavelength,
                                     theta_d, "unpolarized", host=m.host)

    def transmissivity_table(self, wavelength_nm=None, backend="gpu") -> np.ndarray:
        """``f_t(theta_i) cos(theta_i)`` (eq 28) at every filter row and wavelength.

        Parameters
        ----------
        wavelength_nm : array_like, optional
            1-D wavelengths in nm (default: 360, 361, ..., 830).
        backend : {"gpu", "numpy"}
            ``"gpu"``: float32, the transmittances (``wgsl/bsdf/rough_layer_transmittance.wgsl``),
            then
            their product with the filter (``wgsl/bsdf/rough_layer_transmissivity.wgsl``), in one
            submission; ``"numpy"``: float64.

        Returns
        -------
        numpy.ndarray
            Shape ``(len(filter.theta_i), len(wavelength_nm))``, in [0, G1(theta_i)].
        """
        wavelength = self._table_wavelengths(wavelength_nm)
        backend = check_backend(backend)
        if backend == "numpy":
            return self.filter.integrate(self._transmittance(wavelength)).T
        return self._table_gpu(wavelength)

    def _kept(self, key, build) -> np.ndarray:
        """``build()`` (an array, made read-only), kept per layer under ``key`` (in the
        instance dict, as the cached ``filter``). What depends on the layer alone lives here,
        so that structures which share the layer share it: a renderer rebuilds only the
        edited layer's tables."""
        tables = self.__dict__.setdefault("_tables", {})
        if key not in tables:
            table = build()
            table.setflags(write=False)
            tables[key] = table
        return tables[key]

    def _visible_table(self, backend: str) -> np.ndarray:
        """The 1 nm table, kept per layer and backend: RGB, probabilities and weights all
        start from it."""
        return self._kept(("visible", backend), lambda: self.transmissivity_table(None, backend))

    def _table_wavelengths(self, wavelength_nm) -> np.ndarray:
        if wavelength_nm is None:
            return _visible_wavelengths()
        wavelength = check_wavelength(wavelength_nm)
        if wavelength.ndim != 1:
            raise ValueError(f"wavelength_nm must be 1-D, got shape {wavelength.shape}")
        return wavelength

    def _table_gpu(self, wavelength: np.ndarray) -> np.ndarray:
        passes = self._gpu_passes(wavelength)
        (table,) = gpu.submit(passes, read=passes[-1].outputs)
        return table.reshape(self.filter.theta_i.size, wavelength.size).astype(np.float64)

    def _gpu_passes(self, wavelength: np.ndarray) -> list[gpu.Dispatch]:
        """The two GPU passes, chained on the device: T = 1 - R on the (theta_d, wavelength)
        grid (``bsdf/rough_layer_transmittance.wgsl``), then its product with the filter's weights
        (``bsdf/rough_layer_transmissivity.wgsl``)."""
        m = self.mirror
        weights, theta_d, ends = _filter_on_gpu(self.filter)
        rows, quads = weights.shape[:2]
        n = wavelength.size
        mirror = yeh_gpu.bragg_params(m.n1, m.n2, m.d1, m.d2, m.N, m.host)
        wavelength = gpu.DeviceArray.upload(wavelength.astype(np.float32))
        cell_means = self._cell_means
        passes = []
        if cell_means:
            passes.append(gpu.compute_pipeline(
                "bsdf/rough_layer_phases.wgsl",
                constants={"WORKGROUP_SIZE": pointwise_gpu.WORKGROUP_SIZE},
            ).bind([wavelength, ends], [((ends.shape[0] * n, 2), np.float32)], mirror))
        phases = passes[0].outputs[0] if cell_means else np.zeros((1, 2), np.float32)
        transmittance = gpu.compute_pipeline(
            "bsdf/rough_layer_transmittance.wgsl",
            constants={"WORKGROUP_SIZE": pointwise_gpu.WORKGROUP_SIZE,
                       "HOST_MATCHED": self.ballistic, "CELL_MEANS": cell_means},
        ).bind([wavelength, theta_d, phases], [(4 * quads * n, np.float32)], mirror)
        params = np.zeros((), _PARAMS_DTYPE)
        params["rows"], params["quads"], params["wavelengths"] = rows, quads, n
        params["blocks"] = -(-n // (_WAVELENGTHS_PER_LANE * _WORKGROUP_SIZE))
        groups = -(-rows // _ROWS_PER_GROUP) * int(params["blocks"])
        product = gpu.compute_pipeline(
            "bsdf/rough_layer_transmissivity.wgsl", constants={"WORKGROUP_SIZE": _WORKGROUP_SIZE},
        ).bind([weights, transmittance.outputs[0]], [(rows * n, np.float32)], params,
               count=groups * _WORKGROUP_SIZE)
        return [*passes, transmittance, product]

    def benchmark_table(self, wavelength_nm=None, repeats: int = 10) -> tuple[float, float]:
        """Median GPU seconds of :meth:`transmissivity_table`'s passes, chained in one
        submission as it runs them, inputs uploaded once: the transmittances (with the Bloch
        phases at the cells' ends where T is averaged over cells), then the filter product."""
        *transmittance, product = gpu.benchmark(
            self._gpu_passes(self._table_wavelengths(wavelength_nm)), repeats)
        return sum(transmittance), product

    def transmissivity(self, theta_i, wavelength_nm, backend="numpy") -> np.ndarray:
        """Integrated transmissivity ``f_t(theta_i) cos(theta_i)`` (eq 28).

        Parameters
        ----------
        theta_i : array_like
            Angles of incidence in ``n1``, radians in [0, pi/2].
        wavelength_nm : array_like
            Wavelengths in nm; broadcast against ``theta_i``.
        backend : {"numpy", "gpu"}
            Both interpolate the filter linearly in ``theta_i``; ``"gpu"`` integrates in
            float32 (:meth:`transmissivity_table` at the distinct wavelengths).

        Returns
        -------
        numpy.ndarray
            The broadcast shape, in [0, G1(theta_i)] (a smooth, index-matched mirror gives
            exactly ``G1``: what the microfacets do not shadow).
        """
        theta = check_angle(theta_i, "theta_i")
        wavelength = check_wavelength(wavelength_nm)
        check_broadcast(theta_i=theta.shape, wavelength_nm=wavelength.shape)
        theta, wavelength = np.broadcast_arrays(theta, wavelength)
        if check_backend(backend) == "numpy":
            rows = self.filter.interpolate(theta)
            return np.sum(rows * self._transmittance(wavelength), axis=-1)
        distinct, index = np.unique(wavelength, return_inverse=True)
        table = self._table_gpu(distinct)
        return self._interpolate_rows(table, theta, index.reshape(theta.shape))

    def _interpolate_rows(self, table: np.ndarray, theta: np.ndarray, column) -> np.ndarray:
        """Linear interpolation along theta_i of ``table[:, column]`` (rows on the filter grid)."""
        grid = self.filter.theta_i
        position = theta / (grid[1] - grid[0])
        lower = np.clip(np.floor(position).astype(np.intp), 0, grid.size - 2)
        fraction = position - lower
        return (1.0 - fraction) * table[lower, column] + fraction * table[lower + 1, column]

    def transmissivity_rgb(self, theta_i, backend="numpy") -> np.ndarray:
        """Linear sRGB (D65) of the transmissivity spectrum, white where ``T = 1``.

        Parameters
        ----------
        theta_i : array_like
            Angles of incidence in ``n1``, radians in [0, pi/2].
        backend : {"numpy", "gpu"}
            Where the spectral table (1 nm, 360-830 nm) is integrated.

        Returns
        -------
        numpy.ndarray
            Shape ``theta_i.shape + (3,)``: ``f_t cos`` weighted by the CIE 1931 CMFs under
            D65, as :meth:`BraggMirror.rgb` weights R (``G1 (1, 1, 1)`` for ``T = 1``).
        """
        theta = check_angle(theta_i, "theta_i")
        xyz = self._visible_table(check_backend(backend)) @ colorimetry.xyz_weights()[1]
        table = colorimetry.xyz_to_linear_srgb(xyz)
        return np.stack([self._interpolate_rows(table, theta, c) for c in range(3)], axis=-1)

    # ------------------------------------------------------------------ eqs 30-33

    def absorption(self, theta_i) -> np.ndarray:
        """Eq 30: ``A = 1 - G1(theta_i)``, what the layer neither reflects nor transmits once.

        Parameters
        ----------
        theta_i : array_like
            Angles of incidence in ``n1``, radians in [0, pi/2].
        """
        theta = check_angle(theta_i, "theta_i")
        return 1.0 - ggx_G1(np.cos(theta), self.alpha)

    def _averaged_transmissivity(self, theta: np.ndarray, backend) -> np.ndarray:
        """``<f_t cos>_lambda`` over the 1 nm visible grid (eq 33's denominator)."""
        table = self._visible_table(check_backend(backend)).mean(axis=1)[:, None]
        return self._interpolate_rows(table, theta, 0)

    def transmission_probability(self, theta_i, wavelength_nm=None,
                                 backend="numpy") -> np.ndarray:
        """Eq 31: ``p = 2 f_t cos / (1 + G1)``, the chance a path is transmitted.

        Parameters
        ----------
        theta_i : array_like
            Angles of incidence in ``n1``, radians in [0, pi/2].
        wavelength_nm : array_like, optional
            Per wavelength (broadcast); ``None``: the wavelength-multiplexed probability, with
            ``f_t cos`` averaged over 360-830 nm (eq 33).
        backend : {"numpy", "gpu"}

        Returns
        -------
        numpy.ndarray
            In [0, 1].
        """
        theta = check_angle(theta_i, "theta_i")
        if wavelength_nm is None:
            transmitted = self._averaged_transmissivity(theta, backend)
        else:
            transmitted = self.transmissivity(theta, wavelength_nm, backend)
        return 2.0 * transmitted / (1.0 + ggx_G1(np.cos(theta), self.alpha))

    def transmission_weight(self, theta_i, wavelength_nm=None, backend="numpy") -> np.ndarray:
        """Weight of a transmission sampled with :meth:`transmission_probability`.

        Eq 32 for ``wavelength_nm=None`` (``(1 + G1) / 2``, wavelength-independent, for a
        path that carries one wavelength); eq 33 otherwise, ``(1 + G1) / 2`` times
        ``f_t cos / <f_t cos>_lambda`` for a wavelength-multiplexed path sampled with the
        averaged probability. Either way, weight x probability is ``f_t cos``.

        Parameters
        ----------
        theta_i : array_like
            Angles of incidence in ``n1``, radians in [0, pi/2].
        wavelength_nm : array_like, optional
            Wavelengths (nm) carried by a multiplexed path, broadcast against ``theta_i``.
        backend : {"numpy", "gpu"}
        """
        theta = check_angle(theta_i, "theta_i")
        check_backend(backend)  # before the early return: a typo is refused either way
        base = 0.5 * (1.0 + ggx_G1(np.cos(theta), self.alpha))
        if wavelength_nm is None:
            return base
        averaged = self._averaged_transmissivity(theta, backend)
        transmitted = self.transmissivity(theta, wavelength_nm, backend)
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.where(averaged > 0.0, transmitted / averaged, 0.0)
        return base * ratio
