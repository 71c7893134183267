"""Equirectangular environment maps: radiance lookup and importance sampling.

Float64 numpy twin of ``wgsl/lighting/environment_map.wgsl``, which reads
:meth:`EnvironmentMap.packed`.

Convention, stated once: the standard equirectangular (latitude-longitude) orientation, the
one of Mitsuba 3's ``envmap`` and of a panorama viewed from inside it. +y is up. A direction
``d`` has the image coordinates

    ``u = atan2(d_x, -d_z) / (2 pi)`` wrapped to ``[0, 1)``, ``v = acos(d_y) / pi``,

``u`` across the image from its left edge and ``v`` down from its top row; conversely
``d = (sin theta sin phi, cos theta, -sin theta cos phi)`` with ``phi = 2 pi u`` and
``theta = pi v``. Texel column ``x`` in ``[0, W)`` covers ``u`` in ``[x / W, (x + 1) / W]``
and row ``y`` in ``[0, H)`` covers ``v`` in ``[y / H, (y + 1) / H]``, row 0 at +y. So the
left and right edges look along -z (the seam, which belongs to column 0), ``u = 1/4`` along
+x, the image centre along +z and ``u = 3/4`` along -x: looking at the centre, the image's
right is the viewer's right (+y up, right-handed). At the poles (``d_x = d_z = 0``) ``u`` is
taken as 1/2. Angles are in radians, densities per steradian, radiance in the map's unit
(linear sRGB).

Radiance lookups are bilinear between texel centres (wrapping in ``u`` across the seam,
clamped in ``v`` above the first row's centres and below the last's). Importance sampling
follows that bilinear radiance's luminance: the sampling density is piecewise constant per
texel, proportional to the mean over the texel's solid angle of the luminance
:meth:`EnvironmentMap.radiance_at` returns there (:attr:`EnvironmentMap.sampling_luminance`,
``docs/physics.md``, "Environment maps") plus a floor, and :meth:`EnvironmentMap.pdf` is
exactly the density :meth:`EnvironmentMap.sample` draws from, which keeps the estimators that
combine them unbiased.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from wgbragg.common.exr import read_exr
from wgbragg.common.hdr import read_hdr
from wgbragg.common.validation import as_float, as_float_array, check_directions

__all__ = ["FLOOR_FRACTION", "LUMINANCE_WEIGHTS", "PANORAMA_SUFFIXES", "EnvironmentMap",
           "read_panorama", "rotate_panorama"]

LUMINANCE_WEIGHTS = np.array([0.2126, 0.7152, 0.0722])
"""Luminance of linear sRGB (Rec. 709 primaries, D65)."""
FLOOR_FRACTION = 1e-3
"""Sampling floor added to every texel's sampling luminance, as a fraction of its mean over
the sphere."""

# The kernel clamps u below 1 the same way, so that u = 1 (e.g. 1 - 1e-9 rounded to float32)
# still falls inside the last CDF step.
_BELOW_ONE = np.nextafter(1.0, 0.0)

PANORAMA_SUFFIXES = (".exr", ".hdr")
"""File types of an ``"exr"`` environment: OpenEXR, or Radiance RGBE."""


def read_panorama(path, rotate_deg: float = 0.0) -> np.ndarray:
    """The linear RGB image of an OpenEXR (``.exr``) or Radiance RGBE (``.hdr``) panorama,
    turned by ``rotate_deg`` about +y (:func:`rotate_panorama`).

    Raises
    ------
    ValueError
        One line naming the file, for another suffix or a file that cannot be read.
    """
    suffix = Path(path).suffix.lower()
    if suffix == ".exr":
        image = read_exr(path)
    elif suffix == ".hdr":
        image = read_hdr(path)
    else:
        raise ValueError(f"{path}: an environment panorama must be one of {PANORAMA_SUFFIXES}")
    return rotate_panorama(image, rotate_deg)


def rotate_panorama(image, rotate_deg: float) -> np.ndarray:
    """An equirectangular image turned by ``rotate_deg`` degrees about +y.

    What was seen at azimuth ``phi`` (from +z towards +x) is seen at ``phi + rotate_deg``,
    as a procedural environment's sun turns (:mod:`wgbragg.lighting.procedural_environment`):
    column ``x`` takes the old image at ``u + rotate_deg / 360``, linearly interpolated
    between column centres and wrapping across the seam. A whole number of columns
    (``rotate_deg * W / 360`` an integer) is an exact shift.
    """
    image = np.asarray(image)
    rotate_deg = float(rotate_deg)
    if not np.isfinite(rotate_deg):
        raise ValueError(f"rotate_deg must be finite, got {rotate_deg}")
    width = image.shape[1]
    shift = (rotate_deg / 360.0 * width) % width
    whole = int(np.floor(shift))
    fraction = shift - whole
    if fraction < 1e-9 or fraction > 1.0 - 1e-9:
        return np.roll(image, -round(shift) % width, axis=1)
    first = np.roll(image, -whole, axis=1).astype(np.float64)
    second = np.roll(image, -whole - 1, axis=1).astype(np.float64)
    return ((1.0 - fraction) * first + fraction * second).astype(image.dtype)


class EnvironmentMap:
    """An equirectangular map of radiance arriving from every direction.

    Parameters
    ----------
    radiance : array_like, shape (H, W, 3)
        Linear sRGB radiance (e.g. from :func:`wgbragg.common.exr.read_exr`), finite and >= 0,
        ``H >= 1`` rows, ``W >= 2`` columns, in the module's convention (an equirectangular
        image as Mitsuba 3 and panorama viewers read it, row 0 at the top).
    intensity : float
        Finite scale >= 0 applied to the returned radiance (its product with the largest
        radiance must be finite in float64); sampling ignores it.

    Attributes
    ----------
    radiance : numpy.ndarray, shape (H, W, 3)
        Read-only float64 copy of ``radiance`` (without ``intensity``).
    intensity : float
    height, width : int
        ``H`` and ``W``.
    sampling_luminance : numpy.ndarray, shape (H, W)
        Read-only: per texel, the mean over its solid angle of the luminance (Rec. 709
        weights, :data:`LUMINANCE_WEIGHTS`) of the bilinear radiance :meth:`radiance_at`
        returns there, without ``intensity``; the sampling density is proportional to it plus
        a floor. Each is a combination of the luminance of the texel's 3 x 3 neighbourhood
        (``docs/physics.md``, "Environment maps"): weights 1/8, 3/4, 1/8 across columns
        (wrapping at the seam) and, across rows, solid-angle weights that tend to the same away
        from the poles (the first row has none above, the last none below).

    Raises
    ------
    ValueError
        If ``radiance`` has another shape or a negative or non-finite value, or ``intensity``
        is negative, not finite, or so large that the scaled radiance would overflow.

    Examples
    --------
    >>> environment = EnvironmentMap(np.ones((8, 16, 3)))
    >>> float(environment.pdf([0.0, 1.0, 0.0]) * 4 * np.pi)
    1.0
    """

    def __init__(self, radiance, intensity: float = 1.0):
        radiance = as_float_array("radiance", radiance)
        if radiance.ndim != 3 or radiance.shape[2] != 3:
            raise ValueError(f"radiance must have shape (H, W, 3), got {radiance.shape}")
        if radiance.shape[0] < 1 or radiance.shape[1] < 2:
            raise ValueError(f"radiance needs H >= 1 rows and W >= 2 columns, got {radiance.shape}")
        if not np.all(np.isfinite(radiance) & (radiance >= 0.0)):
            raise ValueError("radiance must be finite and >= 0")
        intensity = as_float("intensity", intensity)
        peak_radiance = float(radiance.max())
        # Python floats overflow to inf without a warning: radiance_at stays finite.
        if not (0.0 <= intensity < np.inf and intensity * peak_radiance < np.inf):
            raise ValueError(f"intensity must be finite and >= 0, and intensity times the "
                             f"largest radiance ({peak_radiance:g}) must not overflow float64, "
                             f"got {intensity}")
        radiance.flags.writeable = False
        self.radiance = radiance
        self.intensity = intensity
        self.height, self.width = radiance.shape[:2]

        half_edges = 0.5 * np.pi * np.arange(self.height + 1) / self.height  # theta / 2
        # (cos theta_y - cos theta_(y+1)) / 2 as a product, accurate for the thin polar rows.
        band = np.sin(half_edges[:-1] + half_edges[1:]) * np.sin(0.5 * np.pi / self.height)
        # Per row: sin^2(theta_y / 2), the band, cos^2(theta_(y+1) / 2); a direction's
        # sin^2(theta / 2) and cos^2(theta / 2) are each measured from the nearer pole.
        self._rows = np.stack(
            [np.sin(half_edges[:-1]) ** 2, band, np.cos(half_edges[1:]) ** 2], axis=-1
        )
        solid_angle = (4.0 * np.pi / self.width) * band
        with np.errstate(over="ignore"):
            # A convex combination of finite channels, unless rounding tips it over.
            luminance = np.minimum(radiance @ LUMINANCE_WEIGHTS, np.finfo(np.float64).max)
        peak = float(luminance.max())
        # The densities do not depend on the radiance's scale. From the luminance relative to
        # its peak, a map of subnormal radiance keeps its floor (which would underflow to 0,
        # and its CDFs to 0 / 0) and a huge one cannot overflow its integral.
        relative = luminance / peak if peak > 0.0 else luminance
        sampling = _cell_means(relative, _row_weights(self.height))
        with np.errstate(over="ignore"):
            self.sampling_luminance = np.minimum(sampling * peak, np.finfo(np.float64).max)
        self.sampling_luminance.flags.writeable = False
        mean = np.sum(sampling * solid_angle[:, None]) / (4.0 * np.pi)
        floor = FLOOR_FRACTION * mean if mean > 0.0 else 1.0
        cumulative = np.cumsum((sampling + floor) * solid_angle[:, None], axis=1)
        marginal = np.cumsum(cumulative[:, -1])
        total = marginal[-1]
        # Dividing by the last partial sum makes each CDF end at exactly 1.
        self._marginal = marginal / total
        self._conditional = cumulative / cumulative[:, -1:]
        self._density = (sampling + floor) / total

    def direction_to_texel(self, directions) -> tuple[np.ndarray, np.ndarray]:
        """The texel holding each direction: the one whose density :meth:`pdf` returns.

        Parameters
        ----------
        directions : array_like, shape (..., 3)
            Unit vectors (norm within 1e-5 of 1).

        Returns
        -------
        x, y : numpy.ndarray of int, shape (...)
            Column ``floor(u W)`` in ``[0, W)`` and row ``floor(v H)`` in ``[0, H)``. The seam
            ``u = 0`` (-z) is column 0, the pole -y row ``H - 1``.

        Raises
        ------
        ValueError
            If ``directions`` are not unit vectors with a trailing axis of 3.
        """
        u, v = _image_coordinates(check_directions(directions, "directions"))
        return self._texel(u, v)

    def radiance_at(self, directions) -> np.ndarray:
        """Radiance arriving from ``directions``, bilinear between texel centres, times
        ``intensity``.

        Texel ``(x, y)`` holds the radiance at its centre ``u = (x + 1/2) / W``,
        ``v = (y + 1/2) / H``. A direction blends the four centres around it, wrapping in
        ``u`` (the last column's neighbour is column 0) and clamping in ``v`` (above the
        first row's centres and below the last's only ``u`` is interpolated).

        Parameters
        ----------
        directions : array_like, shape (..., 3)
            Unit vectors pointing towards the environment.

        Returns
        -------
        numpy.ndarray, shape (..., 3)
            Linear sRGB radiance, float64.
        """
        u, v = _image_coordinates(check_directions(directions, "directions"))
        s = u * self.width - 0.5  # in [-1/2, W - 1/2]
        column = np.floor(s)
        fx = (s - column)[..., None]
        x0 = column.astype(np.intp) % self.width
        x1 = (x0 + 1) % self.width
        t = np.clip(v * self.height - 0.5, 0.0, self.height - 1.0)
        y0 = np.minimum(t.astype(np.intp), max(self.height, 2) - 2)
        fy = (t - y0)[..., None]
        y1 = np.minimum(y0 + 1, self.height - 1)
        r = self.radiance
        top = r[y0, x0] + fx * (r[y0, x1] - r[y0, x0])
        bottom = r[y1, x0] + fx * (r[y1, x1] - r[y1, x0])
        return (top + fy * (bottom - top)) * self.intensity

    def pdf(self, directions) -> np.ndarray:
        """Density of :meth:`sample` per steradian at ``directions``: constant over each
        texel (:meth:`direction_to_texel`), proportional to its :attr:`sampling_luminance`
        plus a floor (:data:`FLOOR_FRACTION` of that luminance's mean over the sphere, or 1
        for a black map, which is then sampled uniformly).

        Parameters
        ----------
        directions : array_like, shape (..., 3)
            Unit vectors.

        Returns
        -------
        numpy.ndarray, shape (...)
            Positive densities in 1/sr; their integral over the sphere is 1.
        """
        x, y = self.direction_to_texel(directions)
        return self._density[y, x]

    def sample(self, u) -> np.ndarray:
        """Draw directions with density :meth:`pdf`.

        Parameters
        ----------
        u : array_like, shape (..., 2)
            Uniform numbers in [0, 1); ``u[..., 0]`` picks the row, ``u[..., 1]`` the column.
            1 is accepted and treated as the largest float64 below it.

        Returns
        -------
        numpy.ndarray, shape (..., 3)
            Unit directions.

        Raises
        ------
        ValueError
            If ``u`` lacks a trailing axis of 2 or lies outside [0, 1].
        """
        u = as_float_array("u", u)
        if u.ndim == 0 or u.shape[-1] != 2:
            raise ValueError(f"u must have a trailing axis of length 2, got shape {u.shape}")
        if not np.all((u >= 0.0) & (u <= 1.0)):
            raise ValueError("u must be in [0, 1]")
        u = np.minimum(u, _BELOW_ONE)
        top = np.zeros(u.shape[:-1], dtype=np.intp)
        y, v = _invert(self._marginal[None, :], top, u[..., 0])
        x, w = _invert(self._conditional, y, u[..., 1])
        sin2_top, band, cos2_bottom = np.moveaxis(self._rows[y], -1, 0)
        # Uniform in cos theta = 1 - 2 sin^2(theta / 2) across the row.
        sin2_half = sin2_top + v * band
        cos2_half = cos2_bottom + (1.0 - v) * band
        sin_theta = 2.0 * np.sqrt(sin2_half * cos2_half)
        # Uniform in u across the column. With the angle from the image centre (+z),
        # phi - pi = 2 pi (u - 1/2) in [-pi, pi], sin phi = -sin(phi - pi) and likewise cos.
        from_centre = 2.0 * np.pi * ((x + w) / self.width - 0.5)
        return np.stack(
            [-sin_theta * np.sin(from_centre), cos2_half - sin2_half,
             sin_theta * np.cos(from_centre)],
            axis=-1,
        )

    def packed(self) -> np.ndarray:
        """The map as the float32 table that ``wgsl/lighting/environment_map.wgsl`` reads.

        Returns
        -------
        numpy.ndarray, shape (1 + H + H * W + ceil(H * W / 4), 4), float32
            Bound as ``environment_texels: array<vec4<f32>>``; with ``theta_y = pi y / H``:

            - row 0: ``(W, H, intensity, 0)``;
            - row ``1 + y`` for ``y`` in ``[0, H)``: ``(marginal CDF at the end of row y,
              sin^2(theta_y / 2), (cos theta_y - cos theta_(y+1)) / 2,
              cos^2(theta_(y+1) / 2))``;
            - row ``1 + H + y * W + x``: ``(r, g, b, conditional CDF at the end of texel x
              within row y)``, ``(r, g, b)`` being :attr:`radiance` (without ``intensity``);
            - row ``1 + H + H * W + i // 4``, component ``i % 4``, with ``i = y * W + x``:
              the density :meth:`pdf` of texel ``(x, y)`` in 1/sr (the last row padded with
              zeros).

            Both CDFs are non-decreasing and end at exactly 1.0.

        Raises
        ------
        ValueError
            If a radiance overflows float32 (beyond 3.4e38).
        """
        header = [[self.width, self.height, self.intensity, 0.0]]
        rows = np.column_stack([self._marginal, self._rows])
        texels = np.column_stack([self.radiance.reshape(-1, 3), self._conditional.reshape(-1)])
        densities = np.zeros(-(-self._density.size // 4) * 4)
        densities[:self._density.size] = self._density.reshape(-1)
        with np.errstate(over="ignore"):
            packed = np.concatenate(
                [header, rows, texels, densities.reshape(-1, 4)]
            ).astype(np.float32)
        if not np.isfinite(packed).all():
            raise ValueError("radiance is out of the float32 range of the packed layout")
        return packed

    def _texel(self, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # u = 1 (the seam approached from the right edge) wraps to column 0.
        column = np.floor(u * self.width).astype(np.intp) % self.width
        row = np.minimum(np.floor(v * self.height).astype(np.intp), self.height - 1)
        return column, row


def _row_weights(height: int) -> np.ndarray:
    """Weights of rows ``y - 1``, ``y`` and ``y + 1`` in the mean over row ``y``'s solid angle
    of the bilinear lookup, which is linear in ``theta`` between row centres and constant
    above the first row's centres and below the last's.

    Parameters
    ----------
    height : int
        ``H >= 1``.

    Returns
    -------
    numpy.ndarray, shape (H, 3)
        Non-negative rows summing to 1 (up to rounding). The first row has no weight above
        and the last none below: those halves of them see only their own row. Away from the
        poles the weights tend to (1/8, 3/4, 1/8), the mean of the lookup over ``v``.
    """
    step = np.pi / height
    centres = step * (np.arange(height) + 0.5)
    # Gauss-Legendre on each half-row, s in [0, 1] from the row's centre line to its edge,
    # where the neighbour's weight is s / 2: 8 nodes integrate s / 2 * sin(theta) over a
    # half-row of at most pi / 2 to rounding, positive terms only (no cancellation).
    nodes, weights = np.polynomial.legendre.leggauss(8)
    s, weights = 0.5 * (nodes + 1.0), 0.5 * weights
    half = 0.5 * step
    above = (weights * s / 2.0 * np.sin(centres[:, None] - half * s)).sum(axis=1) * half
    below = (weights * s / 2.0 * np.sin(centres[:, None] + half * s)).sum(axis=1) * half
    # cos theta_y - cos theta_(y+1), as a product (accurate for the thin polar rows).
    band = 2.0 * np.sin(centres) * np.sin(half)
    above, below = above / band, below / band
    above[0] = below[-1] = 0.0
    return np.stack([above, 1.0 - above - below, below], axis=-1)


def _cell_means(luminance: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Mean over each texel's solid angle of the bilinear interpolation of ``luminance``
    (H, W) between texel centres, given :func:`_row_weights` ``rows``. Written as the texel's
    value plus weighted differences, it is exact for a constant map and cannot overflow."""
    across = 0.75 * luminance + 0.125 * (np.roll(luminance, 1, axis=1)
                                         + np.roll(luminance, -1, axis=1))
    y = np.arange(luminance.shape[0])
    up, down = np.maximum(y - 1, 0), np.minimum(y + 1, luminance.shape[0] - 1)
    return (across + rows[:, :1] * (across[up] - across)
            + rows[:, 2:] * (across[down] - across))


def _image_coordinates(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(u, v)`` of unit directions, both in [0, 1]: ``u = atan2(x, -z) / (2 pi)``, computed
    as ``1/2 - atan2(x, z) / (2 pi)`` (the same angle, wrapped to [0, 1] and accurate near the
    image centre), 1/2 at the poles; ``v = acos(y) / pi``, accurate near the poles."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    pole = (x == 0.0) & (z == 0.0)
    u = np.where(pole, 0.5, 0.5 - np.arctan2(x, z) / (2.0 * np.pi))
    v = np.arctan2(np.hypot(x, z), y) / np.pi
    return u, v


def _invert(cdf: np.ndarray, row: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Index of the first entry of ``cdf[row]`` above ``u`` (by bisection, as the kernel) and
    where ``u`` lies within that step, in [0, 1]; needs ``u < cdf[row, -1]``."""
    n = cdf.shape[1]
    low = np.zeros(u.shape, dtype=np.intp)
    high = np.full(u.shape, n - 1, dtype=np.intp)
    for _ in range((n - 1).bit_length()):
        middle = (low + high) // 2
        above = cdf[row, middle] > u
        high = np.where(above, middle, high)
        low = np.where(above, low, middle + 1)
    end = cdf[row, low]
    start = np.where(low > 0, cdf[row, low - 1], 0.0)
    return low, np.clip((u - start) / (end - start), 0.0, 1.0)
