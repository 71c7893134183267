"""Per-invocation inputs made a block of rows at a time (:class:`Rows`): what lets a pointwise
kernel's :meth:`wgbragg.gpu.pipelines.Kernel.run` take any element count in bounded memory
("Any element count: pointwise kernels" in :mod:`wgbragg.gpu.pipelines`)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from wgbragg.gpu.layouts import check_dtype

__all__ = ["Rows"]


@dataclasses.dataclass(frozen=True)
class Rows:
    """A per-invocation input of a pointwise :meth:`Kernel.run`, made a block of rows at a
    time.

    Row ``i`` is what invocation ``i`` reads (``array<T>`` element ``i``; a trailing
    ``row_shape`` for vector or struct elements, e.g. ``(8,)`` float32 for two ``vec4``).
    :meth:`Kernel.run` calls ``make(start, stop)`` for the rows of each block, in order, and
    uploads them; the rows of the whole count never exist at once (see "Any element count:
    pointwise kernels" in the module docstring).

    Attributes
    ----------
    make : callable
        ``make(start, stop)`` returns rows ``start .. stop - 1``: shape
        ``(stop - start, *row_shape)``, dtype ``dtype`` (not cast: convert explicitly).
    row_shape : tuple of int
        Shape of one row beyond the first axis.
    dtype : numpy.dtype
        One the harness allows (see the module docstring).
    """

    make: Callable[[int, int], np.ndarray]
    row_shape: tuple[int, ...] = ()
    dtype: Any = np.float32

    def __post_init__(self):
        object.__setattr__(self, "row_shape", tuple(int(n) for n in self.row_shape))
        object.__setattr__(self, "dtype", check_dtype(self.dtype, "Rows"))

    @classmethod
    def of(cls, array: np.ndarray) -> Rows:
        """The rows of an array already on the host (its first axis)."""
        array = np.asarray(array)
        if array.ndim == 0:
            raise ValueError("Rows.of takes an array with a first axis (one row an invocation)")
        return cls(lambda start, stop: array[start:stop], array.shape[1:], array.dtype)

    @property
    def row_bytes(self) -> int:
        """Bytes of one row."""
        return math.prod(self.row_shape) * self.dtype.itemsize

    def block(self, start: int, stop: int, what: str = "Rows") -> np.ndarray:
        """Rows ``start .. stop - 1`` from :attr:`make`, checked."""
        data = np.asarray(self.make(start, stop))
        want = (stop - start, *self.row_shape)
        if data.shape != want:
            raise ValueError(f"{what}: make({start}, {stop}) returned shape {data.shape}, "
                             f"expected {want}")
        if data.dtype.newbyteorder("=") != self.dtype.newbyteorder("="):
            raise TypeError(f"{what}: make({start}, {stop}) returned dtype {data.dtype}, "
                            f"expected {self.dtype}; convert explicitly")
        return data
