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
clamped in ``v`` above the first row's centres and below the last's), while importance
sampling follows the texels' luminance: the sampling density is piecewise constant per texel
(``docs/physics.md``, "Environment maps"), and :meth:`EnvironmentMap.pdf` is
exactly the density :meth:`EnvironmentMap.sample` draws from, which keeps the estimators that
combine them unbiased.
"""

from __future__ import annotations

import numpy as np

from wgbragg.common.validation import as_float, as_float_array, check_directions

__all__ = ["FLOOR_FRACTION", "LUMINANCE_WEIGHTS", "EnvironmentMap"]

LUMINANCE_WEIGHTS = np.array([0.2126, 0.7152, 0.0722])
"""Luminance of linear sRGB (Rec. 709 primaries, D65)."""
FLOOR_FRACTION = 1e-3
"""Sampling floor added to every texel's luminance, as a fraction of the mean luminance."""

# The kernel clamps u below 1 the same way, so that u = 1 (e.g. 1 - 1e-9 rounded to float32)
# still falls inside the last CDF step.
_BELOW_ONE = np.nextafter(1.0, 0.0)


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
        mean = np.sum(relative * solid_angle[:, None]) / (4.0 * np.pi)
        floor = FLOOR_FRACTION * mean if mean > 0.0 else 1.0
        cumulative = np.cumsum((relative + floor) * solid_angle[:, None], axis=1)
        marginal = np.cumsum(cumulative[:, -1])
        total = marginal[-1]
        # Dividing by the last partial sum makes each CDF end at exactly 1.
        self._marginal = marginal / total
        self._conditional = cumulative / cumulative[:, -1:]
        # Per unit of absolute luminance; infinite for a subnormal peak, which packed() refuses.
        with np.errstate(over="ignore", divide="ignore"):
            self._pdf_scale = 1.0 / (total * peak) if peak > 0.0 else 1.0 / total
        self._pdf_floor = floor / total
        self._density = (relative + floor) / total

    def direction_to_texel(self, directions) -> tuple[np.ndarray, np.ndarray]:
        """The texel holding each direction: the one whose luminance :meth:`pdf` uses.

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
        texel (:meth:`direction_to_texel`), proportional to its luminance plus a floor.

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
        numpy.ndarray, shape (2 + H + H * W, 4), float32
            Bound as ``environment_texels: array<vec4<f32>>``; with ``theta_y = pi y / H``:

            - row 0: ``(W, H, intensity, 0)``;
            - row 1: ``(pdf_scale, pdf_floor, 0, 0)``: the density of a texel of luminance
              ``L`` is ``pdf_scale * L + pdf_floor`` (1/sr);
            - row ``2 + y`` for ``y`` in ``[0, H)``: ``(marginal CDF at the end of row y,
              sin^2(theta_y / 2), (cos theta_y - cos theta_(y+1)) / 2,
              cos^2(theta_(y+1) / 2))``;
            - row ``2 + H + y * W + x``: ``(r, g, b, conditional CDF at the end of texel x
              within row y)``, ``(r, g, b)`` being :attr:`radiance` (without ``intensity``).

            Both CDFs are non-decreasing and end at exactly 1.0.

        Raises
        ------
        ValueError
            If a value overflows float32 (radiance beyond 3.4e38, or a density beyond it for
            a map whose radiance is almost 0 everywhere).
        """
        header = [
            [self.width, self.height, self.intensity, 0.0],
            [self._pdf_scale, self._pdf_floor, 0.0, 0.0],
        ]
        rows = np.column_stack([self._marginal, self._rows])
        texels = np.column_stack([self.radiance.reshape(-1, 3), self._conditional.reshape(-1)])
        with np.errstate(over="ignore"):
            packed = np.concatenate([header, rows, texels]).astype(np.float32)
        if not np.isfinite(packed).all():
            raise ValueError("radiance is out of the float32 range of the packed layout")
        return packed

    def _texel(self, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # u = 1 (the seam approached from the right edge) wraps to column 0.
        column = np.floor(u * self.width).astype(np.intp) % self.width
        row = np.minimum(np.floor(v * self.height).astype(np.intp), self.height - 1)
        return column, row


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
