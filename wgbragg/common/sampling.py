"""Uniform numbers in a form a kernel expands itself: one point set, digitally shifted per group.

:class:`ShiftedPoints` describes a renderer's uniform numbers in a few kilobytes, ``n`` points
shared by every group (a pixel's samples) and one random digital shift per group, instead of
16 bytes per sample uploaded (``docs/design.md``, "What the kernels are given").

Convention, stated once: a number is a 32-bit binary fraction (``uint32`` digits ``b`` stand
for ``b / 2**32``), shifted by XOR, and read as the float32 of its top 23 bits,
``(b >> 9) * 2**-23``: exact in float32 and float64 alike, in ``[0, 1 - 2**-23]``, so the
numpy and GPU backends see identical numbers.
"""

from __future__ import annotations

import warnings

import numpy as np

__all__ = ["MANTISSA_BITS", "ShiftedPoints"]

MANTISSA_BITS = 23
"""Bits of a number kept in its float value: the float32 mantissa, so that the kernel forms it
exactly by a bit cast."""


def _digits(name: str, value, ndim_min: int) -> np.ndarray:
    array = np.asarray(value)
    if array.dtype != np.uint32:
        raise ValueError(f"{name} must hold uint32 digits (32-bit binary fractions), got dtype "
                         f"{array.dtype}")
    if array.ndim < ndim_min:
        raise ValueError(f"{name} must have at least {ndim_min} axes, got shape {array.shape}")
    return array


class ShiftedPoints:
    """Uniform numbers ``u[..., j, k] = points[j, k] XOR shifts[..., k]`` (see the module).

    Parameters
    ----------
    points : array_like of uint32, shape (n, dims)
        The point set every group shares, as 32-bit binary fractions; ``n >= 1``,
        ``dims >= 1``.
    shifts : array_like of uint32, shape (..., dims)
        One digital shift per group.

    Attributes
    ----------
    points, shifts : numpy.ndarray of uint32
        Read-only copies of the arguments.
    shape : tuple
        ``shifts.shape[:-1] + (n, dims)``: the shape of the numbers, as an array's.

    Raises
    ------
    ValueError
        For digits that are not uint32, an empty point set, or ``shifts`` whose last axis is
        not ``dims`` long.

    Examples
    --------
    >>> u = ShiftedPoints.sobol(samples=64, dims=4, groups=(1184,), seed=1)
    >>> u.shape
    (1184, 64, 4)
    >>> float(np.asarray(u).max()) < 1.0
    True
    """

    def __init__(self, points, shifts):
        points = _digits("points", points, 2)
        shifts = _digits("shifts", shifts, 1)
        if points.ndim != 2 or points.shape[0] < 1 or points.shape[1] < 1:
            raise ValueError(f"points must have shape (n, dims) with n, dims >= 1, got "
                             f"{points.shape}")
        if shifts.shape[-1] != points.shape[1]:
            raise ValueError(f"shifts must end in an axis of dims = {points.shape[1]} (one "
                             f"shift per number of a point), got shape {shifts.shape}")
        self.points = np.array(points, copy=True)
        self.shifts = np.array(shifts, copy=True)
        self.points.setflags(write=False)
        self.shifts.setflags(write=False)

    @property
    def shape(self) -> tuple:
        return (*self.shifts.shape[:-1], *self.points.shape)

    @property
    def ndim(self) -> int:
        return len(self.shape)

    def __repr__(self) -> str:
        return f"ShiftedPoints(n={self.points.shape[0]}, dims={self.points.shape[1]}, " \
               f"groups={self.shifts.shape[:-1]})"

    def values(self, dtype=np.float64) -> np.ndarray:
        """The numbers as an array of ``shape`` (float32 or float64, equal values)."""
        if np.dtype(dtype) not in (np.dtype(np.float32), np.dtype(np.float64)):
            raise ValueError(f"dtype must be float32 or float64, got {np.dtype(dtype)}")
        lead = self.shifts.shape[:-1]
        digits = self.shifts.reshape((*lead, 1, self.points.shape[1])) ^ self.points
        digits >>= np.uint32(32 - MANTISSA_BITS)
        return np.ldexp(digits.astype(dtype), -MANTISSA_BITS)

    def __array__(self, dtype=None, copy=None):
        if copy is False:
            raise ValueError("ShiftedPoints makes its numbers on request: copy=False is "
                             "impossible")
        return self.values(np.float64 if dtype is None else dtype)

    @classmethod
    def sobol(cls, samples: int, dims: int, groups: tuple = (), seed=None) -> ShiftedPoints:
        """A scrambled Sobol' set of ``samples`` points (scipy's LMS scramble and digital
        shift), shifted again per group by random digits.

        Parameters
        ----------
        samples : int
            Points per group, >= 1; a power of 2 keeps the balance properties of the set.
        dims : int
            Numbers per point, 1 to 21201 (scipy's Sobol' dimensions).
        groups : tuple of int
            Leading shape, one shift per group (e.g. ``(pixels,)``).
        seed : None, int or numpy.random.Generator
            Seeds the scramble and the shifts (deterministic for an int).

        Returns
        -------
        ShiftedPoints
        """
        from scipy.stats import qmc

        if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) \
                or samples < 1:
            raise ValueError(f"samples must be an integer >= 1, got {samples!r}")
        if isinstance(dims, bool) or not isinstance(dims, (int, np.integer)) \
                or not 1 <= dims <= qmc.Sobol.MAXDIM:
            raise ValueError(f"dims must be an integer in [1, {qmc.Sobol.MAXDIM}], got {dims!r}")
        if not isinstance(groups, tuple) or not all(
                isinstance(g, (int, np.integer)) and not isinstance(g, bool) and g >= 0
                for g in groups):
            raise ValueError(f"groups must be a tuple of sizes >= 0, got {groups!r}")
        rng = np.random.default_rng(seed)
        with warnings.catch_warnings():
            # Counts that are not powers of 2 are fine for a sampler; scipy warns about them.
            warnings.filterwarnings("ignore", message="The balance properties")
            points = qmc.Sobol(dims, scramble=True, seed=rng, bits=32).random(samples)
        digits = (points * 2.0**32).astype(np.uint32)  # exact: multiples of 2**-32 below 1
        shifts = rng.integers(0, 2**32, (*groups, dims), dtype=np.uint32)
        return cls(digits, shifts)
