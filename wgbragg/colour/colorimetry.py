"""Colorimetry of reflectance spectra: D65-weighted CIE 1931 XYZ, linear sRGB and CIE dE2000.

The reference quadrature is the 1 nm sum over 360-830 nm (:func:`xyz_weights`), normalised so
that a perfect reflector has ``Y = 1``; all spectral data come from colour-science. Units:
wavelengths in nm; XYZ with ``Y = 1`` for the perfect reflector; linear sRGB with the perfect
reflector at about ``(1, 1, 1)``. The integral and references: ``docs/physics.md``,
"Colorimetry".
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import colour
import numpy as np

from wgbragg.common.validation import check_broadcast

__all__ = [
    "CMFS_NAME",
    "COLOUR_SPACES",
    "HERO_SEGMENTS",
    "HERO_WAVELENGTHS",
    "ILLUMINANT_NAME",
    "WAVELENGTH_RANGE_NM",
    "WAVELENGTH_STEP_NM",
    "XYZ_TO_LINEAR_SRGB",
    "colour_space_chromaticities",
    "cumulative_table",
    "cumulative_xyz",
    "delta_e_2000",
    "hero_inverse_cdf",
    "hero_wavelengths",
    "lab_to_xyz",
    "linear_srgb_to",
    "linear_srgb_to_xyz",
    "spectral_xyz",
    "xyz_density",
    "xyz_to_lab",
    "xyz_to_linear_srgb",
    "xyz_weights",
]

WAVELENGTH_RANGE_NM = (360.0, 830.0)
"""Visible range integrated over, nm: the extent of colour's CIE 1931 2 degree CMF table."""

WAVELENGTH_STEP_NM = 1.0
"""Spacing of the reference quadrature and of the tabulated density, nm."""

HERO_WAVELENGTHS = 4
"""Wavelengths of one hero sample (:func:`hero_wavelengths`): one vec4 on the GPU."""

HERO_SEGMENTS = 512
"""Segments of :func:`hero_inverse_cdf`."""

CMFS_NAME = "CIE 1931 2 Degree Standard Observer"
ILLUMINANT_NAME = "D65"

_RGB_SPACE = colour.RGB_COLOURSPACES["sRGB"]

XYZ_TO_LINEAR_SRGB: np.ndarray = np.array(_RGB_SPACE.matrix_XYZ_to_RGB, dtype=np.float64)
"""XYZ -> linear sRGB (IEC 61966-2-1, from colour); D65 white maps to about (1, 1, 1)."""
XYZ_TO_LINEAR_SRGB.setflags(write=False)

_LINEAR_SRGB_TO_XYZ = np.linalg.inv(XYZ_TO_LINEAR_SRGB)
_LINEAR_SRGB_TO_XYZ.setflags(write=False)

_D65_XY = np.array(colour.CCS_ILLUMINANTS[CMFS_NAME][ILLUMINANT_NAME], dtype=np.float64)

COLOUR_SPACES = ("srgb", "xyz", "acescg")
"""Linear colour spaces an image can be converted to (:func:`linear_srgb_to`): linear sRGB
(Rec. 709 primaries, D65 white), CIE 1931 XYZ (the perfect reflector under D65 at ``Y = 1``)
and ACEScg (ACES AP1 primaries, the ACES white)."""

_ACESCG = colour.RGB_COLOURSPACES["ACEScg"]
# colour-science's default chromatic adaptation for RGB_to_RGB, CAT02: D65 -> the ACES white.
_FROM_LINEAR_SRGB = {
    "srgb": np.eye(3),
    "xyz": _LINEAR_SRGB_TO_XYZ,
    "acescg": np.array(colour.matrix_RGB_to_RGB(_RGB_SPACE, _ACESCG, "CAT02"), np.float64),
}
for _matrix in _FROM_LINEAR_SRGB.values():
    _matrix.setflags(write=False)
_CHROMATICITIES = {
    "srgb": (*np.ravel(_RGB_SPACE.primaries), *_RGB_SPACE.whitepoint),
    # OpenEXR's convention for XYZ data: X, Y, Z as primaries, the white of X = Y = Z.
    "xyz": (1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0 / 3.0, 1.0 / 3.0),
    "acescg": (*np.ravel(_ACESCG.primaries), *_ACESCG.whitepoint),
}


# --------------------------------------------------------------------------- tables


@functools.cache
def _tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(wavelength_nm[471], weights[471, 3], cumulative[471, 3]), read-only."""
    start, end = WAVELENGTH_RANGE_NM
    shape = colour.SpectralShape(start, end, WAVELENGTH_STEP_NM)
    cmfs = colour.MSDS_CMFS[CMFS_NAME].copy().align(shape)
    # colour's D65 table stops at 780 nm; align() interpolates it linearly to 1 nm and holds
    # the 780 nm value beyond, exactly as colour.sd_to_XYZ aligns an illuminant to the CMFs.
    illuminant = colour.SDS_ILLUMINANTS[ILLUMINANT_NAME].copy().align(shape)
    wavelength = np.asarray(shape.wavelengths, dtype=np.float64)
    weighted = np.asarray(cmfs.values, np.float64) * np.asarray(illuminant.values, np.float64)[
        :, None
    ]
    weights = weighted / weighted[:, 1].sum()
    # Trapezoid rule on the density weights / step (cell integrals of the linear interpolant).
    density = weights / WAVELENGTH_STEP_NM
    cells = 0.5 * (density[1:] + density[:-1]) * WAVELENGTH_STEP_NM
    cumulative = np.concatenate([np.zeros((1, 3)), np.cumsum(cells, axis=0)])
    for table in (wavelength, weights, cumulative):
        table.setflags(write=False)
    return wavelength, weights, cumulative


def xyz_weights() -> tuple[np.ndarray, np.ndarray]:
    """Reference quadrature: 1 nm nodes and their D65-weighted XYZ weights.

    Returns
    -------
    wavelength_nm : numpy.ndarray
        Shape ``(471,)``: 360, 361, ..., 830 nm.
    weights : numpy.ndarray
        Shape ``(471, 3)``: ``cmf(lambda) D65(lambda) / sum_lambda ybar(lambda) D65(lambda)``
        (dimensionless, the 1 nm step included), so ``weights.sum(0)`` is the XYZ of the perfect
        reflector, with ``Y = 1`` to rounding. Both arrays are read-only and cached.

    Notes
    -----
    CMFs: colour's ``MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]`` (tabulated at 1 nm over
    360-830 nm). Illuminant: colour's ``SDS_ILLUMINANTS["D65"]`` (5 nm, 300-780 nm) aligned to
    the CMF shape with colour's ``align`` (linear interpolation; beyond 780 nm the 780 nm value
    is held, as ``colour.sd_to_XYZ`` does). ``sum_k R_k weights_k`` equals
    ``colour.sd_to_XYZ(sd, cmfs, D65, method="Integration") / 100`` on the same shape.

    Examples
    --------
    >>> wavelength, weights = xyz_weights()
    >>> wavelength.shape, weights.shape
    ((471,), (471, 3))
    >>> print(f"{weights.sum(0)[1]:.12f}")
    1.000000000000
    """
    wavelength, weights, _ = _tables()
    return wavelength, weights


def _real_array(name: str, value, copy: bool = True) -> np.ndarray:
    """``value`` as a float64 array (a new one, or with ``copy=False`` a float64 array as it
    is, for callers that only read it), refused unless real and finite."""
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} must be a real number or array of real numbers") from error
    if raw.dtype.kind not in "biuf":
        raise ValueError(f"{name} must be a real number or array of real numbers, got {raw.dtype}")
    array = raw.astype(np.float64) if copy else np.asarray(raw, np.float64)
    # NaN propagates into the minimum and the maximum, infinities are one of them: two
    # reductions, no temporary of the array's size.
    if array.size and not (np.isfinite(array.min()) and np.isfinite(array.max())):
        raise ValueError(f"{name} must be finite (no NaN or infinity)")
    return array


def _cell(wavelength: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(index i of the 1 nm cell, fraction t in [0, 1], inside mask) for in-range wavelengths."""
    start, end = WAVELENGTH_RANGE_NM
    inside = (wavelength >= start) & (wavelength <= end)
    position = (np.clip(wavelength, start, end) - start) / WAVELENGTH_STEP_NM
    last = round((end - start) / WAVELENGTH_STEP_NM)
    index = np.minimum(np.floor(position).astype(np.intp), last - 1)
    return index, position - index, inside


def xyz_density(wavelength_nm) -> np.ndarray:
    """The normalised XYZ weight as a continuous density per nm.

    Parameters
    ----------
    wavelength_nm : array_like
        Wavelengths in nm, any shape, finite.

    Returns
    -------
    numpy.ndarray
        Shape ``wavelength_nm.shape + (3,)``, in nm^-1: :func:`xyz_weights` divided by the 1 nm
        step, linearly interpolated between the 1 nm nodes, 0 outside 360-830 nm. Its integral
        over 360-830 nm is the perfect reflector's XYZ (``Y = 1`` up to the trapezoid-versus-sum
        difference, ~2e-6).

    Raises
    ------
    ValueError
        If ``wavelength_nm`` is not real or not finite.

    Examples
    --------
    >>> bool(np.allclose(xyz_density([555.0]), xyz_weights()[1][195]))
    True
    """
    wavelength = _real_array("wavelength_nm", wavelength_nm)
    weights = _tables()[1] / WAVELENGTH_STEP_NM
    index, t, inside = _cell(wavelength)
    t = t[..., None]
    value = (1.0 - t) * weights[index] + t * weights[index + 1]
    return np.where(inside[..., None], value, 0.0)


def cumulative_xyz(wavelength_nm) -> np.ndarray:
    """Integral of :func:`xyz_density` from 360 nm to ``wavelength_nm``.

    Parameters
    ----------
    wavelength_nm : array_like
        Wavelengths in nm, any shape, finite.

    Returns
    -------
    numpy.ndarray
        Shape ``wavelength_nm.shape + (3,)``, dimensionless, nondecreasing in the wavelength:
        0 at and below 360 nm, the perfect reflector's XYZ at and above 830 nm. Exact for the
        piecewise-linear density (trapezoids on the 1 nm table, the quadratic within a cell),
        so the integral of a constant ``w`` over ``[l0, l1]`` is
        ``w * (cumulative_xyz(l1) - cumulative_xyz(l0))``.

    Raises
    ------
    ValueError
        If ``wavelength_nm`` is not real or not finite.

    Examples
    --------
    >>> box = cumulative_xyz(830.0) - cumulative_xyz(360.0)
    >>> bool(abs(box[1] - 1.0) < 1e-5)
    True
    """
    wavelength = _real_array("wavelength_nm", wavelength_nm)
    _, weights, cumulative = _tables()
    density = weights / WAVELENGTH_STEP_NM
    index, t, _ = _cell(wavelength)
    t = t[..., None]
    d0, d1 = density[index], density[index + 1]
    step = WAVELENGTH_STEP_NM
    return cumulative[index] + step * (d0 * t + 0.5 * (d1 - d0) * t * t)


def cumulative_table() -> tuple[np.ndarray, np.ndarray]:
    """:func:`cumulative_xyz` at the 1 nm nodes, for upload to the GPU.

    Returns
    -------
    wavelength_nm : numpy.ndarray
        Shape ``(471,)``, 360-830 nm (read-only).
    cumulative : numpy.ndarray
        Shape ``(471, 3)`` float64 (read-only); ``astype(np.float32)`` for a storage buffer.
        Between nodes the exact value adds the cell's quadratic (see :func:`cumulative_xyz`).
    """
    wavelength, _, cumulative = _tables()
    return wavelength, cumulative


@functools.cache
def hero_inverse_cdf() -> np.ndarray:
    """Wavelengths at equal steps of the cumulative summed XYZ density, for hero sampling.

    Returns
    -------
    numpy.ndarray
        Shape ``(HERO_SEGMENTS + 1,)`` float32, nm, read-only: 360 nm, then the wavelength
        below which ``j / HERO_SEGMENTS`` of ``int (x + y + z)`` lies, ..., 830 nm. A
        wavelength drawn uniformly within segment ``j`` has the constant density
        ``1 / (HERO_SEGMENTS (node[j+1] - node[j]))`` per nm: samples land where the eye is
        sensitive. The GPU kernels read this table (``wgsl/colour/colorimetry_hero.wgsl``).
    """
    grid, cumulative = cumulative_table()
    total = cumulative.sum(axis=1)
    nodes = np.interp(np.linspace(0.0, total[-1], HERO_SEGMENTS + 1), total, grid)
    nodes[0], nodes[-1] = grid[0], grid[-1]
    nodes = nodes.astype(np.float32)
    nodes.setflags(write=False)
    return nodes


def hero_wavelengths(offset) -> tuple[np.ndarray, np.ndarray]:
    """Hero wavelengths (Wilkie et al. 2014) stratified in :func:`hero_inverse_cdf`.

    Parameters
    ----------
    offset : array_like
        Uniform numbers in [0, 1], any shape: one per sample.

    Returns
    -------
    wavelength_nm : numpy.ndarray
        Shape ``offset.shape + (HERO_WAVELENGTHS,)``: wavelength ``k`` at the cumulative
        fraction ``(offset + k) / HERO_WAVELENGTHS``.
    scale : numpy.ndarray
        Same shape, nm: ``1 / (HERO_WAVELENGTHS pdf(wavelength))``, so that
        ``xyz_to_linear_srgb(sum_k v_k scale_k xyz_density(wavelength_k))`` is an unbiased
        estimate of the linear sRGB of a spectrum ``v`` (a spectrum of 1 gives about
        ``(1, 1, 1)``, exactly in expectation). The float64 twin of ``hero_wavelengths`` in
        ``wgsl/colour/colorimetry_hero.wgsl``, which the layered simulation, the renderer's
        spectral mode and
        the single-reflection sampler use.

    Raises
    ------
    ValueError
        If ``offset`` is not real, finite and within [0, 1].

    References
    ----------
    Wilkie, Nawaz, Droske, Weidlich & Hanika, "Hero Wavelength Spectral Sampling", Computer
    Graphics Forum 33(4), 2014.

    Examples
    --------
    >>> wavelength, scale = hero_wavelengths([0.5])
    >>> wavelength.shape
    (1, 4)
    """
    offset = _real_array("offset", offset)
    if not np.all((offset >= 0.0) & (offset <= 1.0)):
        raise ValueError("offset must be in [0, 1]")
    nodes = hero_inverse_cdf().astype(np.float64)
    position = ((offset[..., None] + np.arange(HERO_WAVELENGTHS)) / HERO_WAVELENGTHS
                * HERO_SEGMENTS)
    segment = np.minimum(position.astype(np.intp), HERO_SEGMENTS - 1)
    lower, upper = nodes[segment], nodes[segment + 1]
    wavelength = lower + (position - segment) * (upper - lower)
    return wavelength, (HERO_SEGMENTS / HERO_WAVELENGTHS) * (upper - lower)


# --------------------------------------------------------------------------- colour spaces


def _xyz_array(name: str, value) -> np.ndarray:
    array = _real_array(name, value, copy=False)
    if array.ndim == 0 or array.shape[-1] != 3:
        raise ValueError(f"{name} must have a last axis of length 3, got shape {array.shape}")
    return array


def xyz_to_linear_srgb(xyz) -> np.ndarray:
    """CIE XYZ (perfect reflector ``Y = 1``) to linear (not gamma-encoded) sRGB.

    Parameters
    ----------
    xyz : array_like
        Shape ``(..., 3)``, finite.

    Returns
    -------
    numpy.ndarray
        Shape ``(..., 3)``: ``xyz @ XYZ_TO_LINEAR_SRGB.T``; unclipped (out-of-gamut colours have
        components below 0 or above 1).

    Raises
    ------
    ValueError
        If the last axis is not 3 or a value is not finite.

    Examples
    --------
    >>> rgb = xyz_to_linear_srgb(xyz_weights()[1].sum(0))
    >>> bool(np.all(np.abs(rgb - 1.0) < 2e-3))
    True
    """
    return _times_matrix(_xyz_array("xyz", xyz), XYZ_TO_LINEAR_SRGB)


_MATRIX_ROWS = 1 << 15
"""Colours per product in :func:`_times_matrix`."""


def _times_matrix(colours: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """``colours @ matrix.T`` for colours of shape ``(..., 3)``, a block of colours at a time:
    one product over millions of colours is a BLAS call that OpenBLAS spreads over its
    threads, whose wake-up cost up to 0.4 s for 1e6 colours on 2 cores shared with lavapipe,
    where blocks of :data:`_MATRIX_ROWS` run on the calling thread in about 5 ms."""
    flat = colours.reshape(-1, 3)
    out = np.empty(flat.shape)
    for start in range(0, flat.shape[0], _MATRIX_ROWS):
        np.matmul(flat[start:start + _MATRIX_ROWS], matrix.T, out=out[start:start + _MATRIX_ROWS])
    return out.reshape(colours.shape)


def linear_srgb_to_xyz(rgb) -> np.ndarray:
    """Inverse of :func:`xyz_to_linear_srgb` (the exact matrix inverse), shape ``(..., 3)``."""
    return _times_matrix(_xyz_array("rgb", rgb), _LINEAR_SRGB_TO_XYZ)


def _colour_space(space) -> str:
    if space not in COLOUR_SPACES:
        raise ValueError(f"space must be one of {COLOUR_SPACES}, got {space!r}")
    return space


def linear_srgb_to(rgb, space: str) -> np.ndarray:
    """Linear sRGB in another linear colour space of :data:`COLOUR_SPACES`.

    ``"xyz"`` is :func:`linear_srgb_to_xyz`, the exact inverse of the renderer's XYZ -> sRGB
    matrix: the XYZ of every spectrum, monochromatic light included, is >= 0, and so is a
    spectral render's, at any sample count. ``"acescg"`` is colour-science's
    ``RGB_to_RGB(rgb, "sRGB", "ACEScg")`` on linear values, whose default chromatic
    adaptation is CAT02 (D65 to the ACES white): its gamut holds the sRGB gamut and most
    surface colours, not monochromatic light (see ``docs/physics.md``, "Negative values").

    Parameters
    ----------
    rgb : array_like
        Shape ``(..., 3)``, finite.
    space : {"srgb", "xyz", "acescg"}

    Returns
    -------
    numpy.ndarray
        Shape ``(..., 3)``, float64.

    Raises
    ------
    ValueError
        If ``space`` is not one of :data:`COLOUR_SPACES`, the last axis is not 3 or a value is
        not finite.
    """
    matrix = _FROM_LINEAR_SRGB[_colour_space(space)]
    return _times_matrix(_xyz_array("rgb", rgb), matrix)


def colour_space_chromaticities(space: str) -> tuple[float, ...]:
    """The CIE xy chromaticities of a space of :data:`COLOUR_SPACES`: red, green and blue
    primaries and white, ``(rx, ry, gx, gy, bx, by, wx, wy)``, as OpenEXR's
    ``chromaticities`` header attribute holds them (for ``"xyz"``: X, Y and Z as primaries,
    white ``(1/3, 1/3)``).

    Raises
    ------
    ValueError
        If ``space`` is not one of :data:`COLOUR_SPACES`.
    """
    return tuple(float(v) for v in _CHROMATICITIES[_colour_space(space)])


def delta_e_2000(rgb_a, rgb_b) -> np.ndarray:
    """CIE dE2000 colour difference between two linear sRGB colours.

    Parameters
    ----------
    rgb_a, rgb_b : array_like
        Linear sRGB, shape ``(..., 3)``, broadcastable, finite; the perfect reflector at about
        ``(1, 1, 1)``.

    Returns
    -------
    numpy.ndarray
        Shape ``broadcast(rgb_a, rgb_b).shape[:-1]``; 0 for equal colours, symmetric.

    Raises
    ------
    ValueError
        If a last axis is not 3, a value is not finite, or the shapes do not broadcast.

    Notes
    -----
    Linear sRGB -> XYZ by the exact inverse of :data:`XYZ_TO_LINEAR_SRGB` (so the difference
    of two results of :func:`xyz_to_linear_srgb` is that of their XYZ), XYZ -> CIELAB with
    colour's D65 chromaticity as reference white (``Y_n = 1``), then
    ``colour.delta_E(..., method="CIE 2000")``. As a rule of thumb, 1 is a just-noticeable
    difference.

    Examples
    --------
    >>> float(delta_e_2000([0.2, 0.3, 0.4], [0.2, 0.3, 0.4]))
    0.0
    """
    a = linear_srgb_to_xyz(_xyz_array("rgb_a", rgb_a))
    b = linear_srgb_to_xyz(_xyz_array("rgb_b", rgb_b))
    check_broadcast(rgb_a=a.shape, rgb_b=b.shape)
    a, b = np.broadcast_arrays(a, b)
    return np.asarray(colour.delta_E(xyz_to_lab(a), xyz_to_lab(b), method="CIE 2000"),
                      dtype=np.float64)


def xyz_to_lab(xyz) -> np.ndarray:
    """CIELAB of CIE 1931 XYZ under D65 with the perfect reflector ``Y = 1`` (as the colour
    methods return it), by colour-science with D65's chromaticity as the white: a perfect
    reflector is ``L* = 100``."""
    return np.asarray(colour.XYZ_to_Lab(np.asarray(xyz, np.float64), _D65_XY), np.float64)


def lab_to_xyz(lab) -> np.ndarray:
    """The inverse of :func:`xyz_to_lab`."""
    return np.asarray(colour.Lab_to_XYZ(np.asarray(lab, np.float64), _D65_XY), np.float64)


# --------------------------------------------------------------------------- spectra


def spectral_xyz(
    reflectance_fn: Callable[[np.ndarray], np.ndarray] | np.ndarray,
    wavelength_nm,
    weights,
) -> np.ndarray:
    """Weighted sum ``sum_k R_k w_k`` of a sampled spectrum.

    Parameters
    ----------
    reflectance_fn : callable or array_like
        Either ``R`` itself, shape ``(..., K)``, sampled at ``wavelength_nm``, or a function
        of the wavelengths (shape ``(K,)``) returning that array.
    wavelength_nm : array_like
        Shape ``(K,)``, nm: the nodes, e.g. from :func:`xyz_weights`.
    weights : array_like
        Shape ``(K, 3)``: XYZ weight of each node, e.g. from :func:`xyz_weights`.

    Returns
    -------
    numpy.ndarray
        XYZ, shape ``(..., 3)``.

    Raises
    ------
    ValueError
        If the shapes disagree or a value is not finite.

    Examples
    --------
    >>> wavelength, weights = xyz_weights()
    >>> xyz = spectral_xyz(np.full((2, 471), 0.5), wavelength, weights)
    >>> xyz.shape, bool(np.allclose(xyz[:, 1], 0.5))
    ((2, 3), True)
    """
    wavelength = _real_array("wavelength_nm", wavelength_nm)
    weight = _real_array("weights", weights)
    if wavelength.ndim != 1 or weight.shape != (wavelength.size, 3):
        raise ValueError(
            f"wavelength_nm must have shape (K,) and weights (K, 3), got {wavelength.shape} and "
            f"{weight.shape}"
        )
    values = reflectance_fn(wavelength) if callable(reflectance_fn) else reflectance_fn
    reflectance = _real_array("reflectance_fn", values)
    if reflectance.ndim == 0 or reflectance.shape[-1] != wavelength.size:
        raise ValueError(
            f"reflectance_fn must give shape (..., {wavelength.size}), got {reflectance.shape}"
        )
    return reflectance @ weight
