"""Running a per-point optics kernel over broadcast ``(wavelength_nm, theta)`` inputs: the
shared plumbing of :mod:`wgbragg.optics.yeh_gpu` and :mod:`wgbragg.optics.thin_film_gpu`.

The host forms each point's geometry and phases in float64 (the modules'
``point_inputs``: normal components without cancellation, layer phases reduced to a
fraction of a turn) and the kernel evaluates the physics from them in float32: one float32
evaluation path for every optics kernel (``docs/design.md``, "Float32 numerics").

Pipelines are specialised with WGSL ``override`` constants for what a call needs (the
polarisation, reflectance or transmittance, and for Bragg mirrors whether the host medium
equals ``n1``, which compiles the complex amplitude of Appendix D out).

What a call costs besides the kernel (``docs/performance.md``, "End to end"): the host's
forming of the inputs, their upload, and the copy of the results into the output. So that
it stays below the kernel's own time, :func:`evaluate_pointwise`

- forms everything that depends on the angle alone (``s``, ``cos theta``, the layers'
  optical paths: sines, cosines and square roots) once per distinct angle of the broadcast,
  not once per point: per angle of a broadcast ``theta``, and per run of a flat ``theta``
  that holds a grid (:func:`grid_view`), leaving per point only a product, a rounding and
  a subtraction per phase;
- forms the points in cache-sized units (:data:`UNIT_POINTS`), each straight into the rows
  of a :class:`~wgbragg.gpu.streams.Stream` block, while the device computes the block
  before (buffers reused across blocks and calls);
- takes float32 wavelengths and angles as they are (no float64 copy of the inputs: each
  value is widened exactly where it is used) and writes the results straight into the
  output, float64 (or a caller's ``out``).

The inputs each point reads are bit for bit those of ``point_inputs``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from wgbragg import gpu
from wgbragg.common.blocks import (
    block_part,
    block_ranges,
    block_shape,
    check_out,
    full_rank,
    parallel_map,
)
from wgbragg.gpu.streams import Stream, Streamed, shares_cores

__all__ = ["PARALLEL_MIN_POINTS", "POLARIZATION_CODE", "QUANTITIES", "UNIT_POINTS",
           "WORKGROUP_SIZE", "PointForm",
           "evaluate_pointwise", "form_points", "grid_view", "reduced_turns"]

WORKGROUP_SIZE = 256
"""Workgroup size of the reflectance kernels, the fastest on lavapipe (``docs/performance.md``,
"Reflectance")."""

POLARIZATION_CODE = {"s": 0, "p": 1, "unpolarized": 2}
"""``POLARIZATION`` override constant of the kernels, by polarisation name."""

QUANTITIES = ("reflectance", "transmittance")
"""What a pointwise kernel writes: its ``TRANSMITTANCE`` override constant picks the second."""

UNIT_POINTS = 1 << 14
"""Points the host forms at a time: their float64 temporaries (128 KiB each) and rows (256
KiB) stay in a core's L2 cache, where a whole block's (8 MiB) would stream through memory.
On the 2-core benchmark machine (1 MiB of L2 a core) a Bragg mirror's points took 4.1 ns
each in units of 2^14, 10 ns in units of 2^15 (and 2^16, 2^17)."""

PARALLEL_MIN_POINTS = 1 << 17
"""Blocks of fewer points are formed on the calling thread alone: handing units to the host's
threads costs up to a millisecond on 2 busy cores, more than forming them. On a CPU adapter
every block is (:func:`~wgbragg.gpu.streams.shares_cores`): there the forming, held back by
the GIL between numpy's loops of 2^14 points, took as long on 2 threads as on one."""

_GRID_MIN_POINTS = 1 << 12
"""Flat inputs of fewer points are formed as they are (:func:`grid_view` is not worth it)."""


def reduced_turns(cycles) -> np.ndarray:
    """float64 phases in turns reduced to ``[-1/2, 1/2]``: exact, so a float32 copy carries
    the rounding of a fraction of a turn however many turns the layer holds."""
    cycles = np.asarray(cycles, np.float64)
    return cycles - np.round(cycles)


@dataclasses.dataclass(frozen=True)
class PointForm:
    """What a pointwise optics kernel reads per point, and how the host forms it.

    The kernel's first input holds 4 float32 words a point: ``s``, ``cos theta``, then the
    phases ``path / lambda`` reduced to ``[-1/2, 1/2]`` turn (one per path), then ``1 /
    lambda`` where a word is left (``inverse_column``). Its second input holds ``1 / lambda``
    (Bragg mirrors: two paths fill the row), or a dispersive base's ``(n, k)`` per point, or a
    placeholder every point shares.

    Attributes
    ----------
    angle_terms : callable
        ``angle_terms(theta)`` of float64 angles (radians, in ``[0, pi/2]``, any shape):
        ``(s, cos_theta, paths)``, the float32 ``s`` and ``cos theta`` and a tuple of float64
        optical paths (nm), all of ``theta``'s shape.
    inverse_column : bool
        ``1 / lambda`` is the rows' fourth word (one path), not a buffer of its own.
    base : callable, optional
        A dispersive base: its complex index at float64 wavelengths (nm), whose ``(n, k)`` the
        second input holds per point; None: the second input is a shared placeholder (with
        ``inverse_column``).
    """

    angle_terms: Callable[[np.ndarray], tuple]
    inverse_column: bool
    base: Callable[[np.ndarray], np.ndarray] | None = None

    def streams(self) -> list:
        """The kernel's two inputs: :class:`~wgbragg.gpu.streams.Streamed` rows, or the shared
        placeholder."""
        if not self.inverse_column:
            return [Streamed((4,)), Streamed(())]
        if self.base is not None:
            return [Streamed((4,)), Streamed((2,))]
        return [Streamed((4,)), np.zeros((1, 2), np.float32)]

    def angle_terms_of(self, angle: np.ndarray) -> tuple[np.ndarray, ...]:
        """``(geometry, *paths)`` of (float32 or float64) angles, widened and clipped to
        ``pi/2`` in float64 (float32's pi/2 lies above it): ``geometry`` holds the float32
        pair ``(s, cos theta)`` of each angle as one 8-byte word (``uint64``, the rows' first
        two words), so that a unit copies both in one pass."""
        theta = np.minimum(np.asarray(angle, np.float64), np.pi / 2)
        s, cos_theta, paths = self.angle_terms(theta)
        pairs = np.empty((*theta.shape, 2), np.float32)
        pairs[..., 0], pairs[..., 1] = s, cos_theta
        return (pairs.view(np.uint64)[..., 0], *paths)

    def wavelength_terms(self, wavelength: np.ndarray) -> tuple[np.ndarray, ...]:
        """``(1 / lambda, *base)`` of (float32 or float64) wavelengths: ``1 / lambda`` in
        float64 (the phases' factor), and for a dispersive base its float32 ``n`` and ``k``."""
        inverse = np.divide(1.0, wavelength, dtype=np.float64)
        if self.base is None:
            return (inverse,)
        index = np.asarray(self.base(np.asarray(wavelength, np.float64)), np.complex128)
        return inverse, index.real.astype(np.float32), index.imag.astype(np.float32)

    def fill(self, hosts: list[np.ndarray], offset: int, shape: tuple[int, ...],
             wavelength_terms: tuple[np.ndarray, ...],
             angle_terms: tuple[np.ndarray, ...]) -> None:
        """Form the points of one unit into rows ``offset ..`` of the host arrays ``hosts``.

        Parameters
        ----------
        hosts : list of numpy.ndarray
            The streamed inputs' host rows (:meth:`~wgbragg.gpu.streams.Stream.inputs`).
        offset : int
            First row of the unit.
        shape : tuple of int
            The unit's shape; the terms broadcast to it.
        wavelength_terms, angle_terms : tuple of numpy.ndarray
            :meth:`wavelength_terms` and :meth:`angle_terms_of` of the unit's wavelengths and
            angles.
        """
        count = math.prod(shape)
        rows = hosts[0][offset:offset + count].reshape(*shape, 4)
        inverse, *base = wavelength_terms
        geometry, *paths = angle_terms
        np.copyto(rows.view(np.uint64)[..., 0], geometry)
        cycles = np.empty(shape)
        whole = np.empty(shape)
        for j, path in enumerate(paths):
            np.multiply(path, inverse, out=cycles)
            np.rint(cycles, out=whole)  # = np.round: halves to even
            np.subtract(cycles, whole, out=rows[..., 2 + j], casting="same_kind")
        if not self.inverse_column:
            np.copyto(hosts[1][offset:offset + count].reshape(shape), inverse,
                      casting="same_kind")
            return
        np.copyto(rows[..., 3], inverse, casting="same_kind")
        if base:
            pairs = hosts[1][offset:offset + count].reshape(*shape, 2)
            np.copyto(pairs[..., 0], base[0])
            np.copyto(pairs[..., 1], base[1])


def form_points(form: PointForm, wavelength_nm, theta) -> tuple[list[np.ndarray], tuple]:
    """The kernel's per-point inputs of every point at once (for tests and kernel
    benchmarks: a call streams them instead), formed as :func:`evaluate_pointwise` forms them.

    Returns
    -------
    inputs : list of numpy.ndarray
        The streamed inputs of :meth:`PointForm.streams`, one row a point in C order.
    shape : tuple of int
        The broadcast shape.
    """
    wavelength, angle = np.asarray(wavelength_nm), np.asarray(theta)
    shape = np.broadcast_shapes(wavelength.shape, angle.shape)
    size = math.prod(shape)
    hosts = [np.empty((size, *spec.row_shape), spec.dtype) for spec in form.streams()
             if isinstance(spec, Streamed)]
    if size:
        form.fill(hosts, 0, shape, form.wavelength_terms(wavelength), form.angle_terms_of(angle))
    return hosts, shape


def _first_index(flat: np.ndarray, test: Callable[[np.ndarray], np.ndarray], start: int) -> int:
    """First index ``>= start`` where ``test`` of ``flat`` holds, or ``flat.size``; read in
    units, so that an early hit costs little."""
    for first in range(start, flat.size, UNIT_POINTS):
        hits = np.flatnonzero(test(flat[first:first + UNIT_POINTS]))
        if hits.size:
            return first + int(hits[0])
    return flat.size


def _constant_rows(rows: np.ndarray) -> bool:
    """Whether each row of ``rows`` (2-D, no NaN) holds one value: its least and greatest
    values agree (two reductions, no temporary of the array's size)."""
    return bool(np.array_equal(rows.min(axis=1), rows.max(axis=1)))


def _equal_rows(rows: np.ndarray) -> bool:
    """Whether every row of ``rows`` (2-D, no NaN) equals the first: the columns' least and
    greatest values are the first row's."""
    return bool(np.array_equal(rows.min(axis=0), rows[0])
                and np.array_equal(rows.max(axis=0), rows[0]))


def grid_view(wavelength: np.ndarray, angle: np.ndarray, shape: tuple[int, ...]):
    """Flat inputs that hold a grid, as the broadcast of their axes.

    A flat ``theta`` of the broadcast's size whose values come in runs of one length ``L``
    (a raveled ``meshgrid`` with the angle slowest, as ``np.meshgrid(theta, wavelength,
    indexing="ij")`` gives), or that repeats with a period ``P`` (the angle fastest), is the
    same function of the flat index as a ``(size / L, 1)`` or ``(1, P)`` array broadcast to
    ``(size / L, L)`` or ``(size / P, P)``. In that form the per-angle work is done once per
    angle instead of once per point, and where the wavelengths repeat alike (the other axis
    of the same grid) the per-wavelength work once per wavelength. Anything else is returned
    as it is.

    Parameters
    ----------
    wavelength, angle : numpy.ndarray
        The validated inputs.
    shape : tuple of int
        Their broadcast shape.

    Returns
    -------
    wavelength, angle : numpy.ndarray
        Views, broadcasting to ``grid_shape``; in C order the same values at the same flat
        indices as the inputs broadcast to ``shape``.
    grid_shape : tuple of int
    """
    size = math.prod(shape)
    unchanged = wavelength, angle, shape
    if (size < _GRID_MIN_POINTS or angle.size != size or not angle.flags.c_contiguous
            or not (wavelength.size == 1 or (wavelength.size == size
                                             and wavelength.flags.c_contiguous))):
        return unchanged
    flat = angle.reshape(-1)
    flat_wavelength = wavelength.reshape(-1)
    run = _first_index(flat, lambda part: part != flat[0], 1)
    if 1 < run < size and size % run == 0:
        rows = flat.reshape(-1, run)
        if _constant_rows(rows):
            return (*_wavelength_rows(flat_wavelength, run, across=False), rows[:, :1],
                    (size // run, run))
    period = _first_index(flat, lambda part: part == flat[0], 1)
    if 1 < period < size and size % period == 0:
        rows = flat.reshape(-1, period)
        if _equal_rows(rows):
            return (*_wavelength_rows(flat_wavelength, period, across=True), rows[:1],
                    (size // period, period))
    return unchanged


def _wavelength_rows(flat: np.ndarray, width: int, across: bool) -> tuple[np.ndarray]:
    """The flat wavelengths as rows of ``width`` beside a grid's angles: one row for all where
    every row repeats the first (``across=False``: the angles vary along the columns' rows),
    one value per row where each row is constant (``across=True``), else every row."""
    if flat.size == 1:
        return (flat.reshape(1, 1),)
    rows = flat.reshape(-1, width)
    if not across and _equal_rows(rows):
        return (rows[:1],)
    if across and _constant_rows(rows):
        return (rows[:, :1],)
    return (rows,)


def evaluate_pointwise(shader: str, constants: dict, params: np.ndarray, form: PointForm,
                       wavelength: np.ndarray, angle: np.ndarray, out=None) -> np.ndarray:
    """Run entry point ``shader`` once per point of the broadcast ``(wavelength, angle)``.

    Any number of points: they are formed a unit at a time into blocks streamed through the
    device (:class:`~wgbragg.gpu.streams.Stream`), so host memory is the result plus a few
    blocks.

    Parameters
    ----------
    shader : str
        Entry point, relative to the shader folder.
    constants : dict
        Override constants.
    params : numpy.ndarray
        The uniform.
    form : PointForm
        What the kernel reads per point.
    wavelength, angle : numpy.ndarray
        Validated wavelengths (nm) and angles (radians), float32 or float64, broadcasting
        together.
    out : numpy.ndarray, optional
        Where the result goes (:func:`~wgbragg.common.blocks.check_out`: C-contiguous,
        float64 or float32, of the broadcast shape).

    Returns
    -------
    numpy.ndarray
        ``out``, or a new float64 array of the broadcast shape.
    """
    shape = np.broadcast_shapes(wavelength.shape, angle.shape)
    out = check_out(out, shape)
    size = math.prod(shape)
    if size == 0:
        return out
    kernel = gpu.compute_pipeline(shader, constants=constants)
    wavelength, angle, grid_shape = grid_view(wavelength, angle, shape)
    # Each axis's terms once for the whole call where it holds fewer values than the points
    # (a broadcast or a grid's axis), else a unit's at a time.
    whole_w = form.wavelength_terms(wavelength) if wavelength.size * 4 <= size else None
    whole_a = form.angle_terms_of(angle) if angle.size * 4 <= size else None
    views = full_rank([wavelength, angle], len(grid_shape))
    w_views = None if whole_w is None else full_rank(whole_w, len(grid_shape))
    a_views = None if whole_a is None else full_rank(whole_a, len(grid_shape))
    results = out.reshape(-1)

    def terms(index, whole_views, view, of):
        if whole_views is not None:
            return tuple(block_part(v, index) for v in whole_views)
        return of(block_part(view, index))

    shared = shares_cores()
    with Stream(kernel, form.streams(), [((), np.float32)], params, count=size) as stream:
        units = block_ranges(grid_shape, min(UNIT_POINTS, stream.rows))
        for first, block in _blocks(units, stream.rows):
            hosts = stream.inputs()

            def fill(unit, hosts=hosts, first=first):
                index, start, _ = unit
                form.fill(hosts, start - first, block_shape(grid_shape, index),
                          terms(index, w_views, views[0], form.wavelength_terms),
                          terms(index, a_views, views[1], form.angle_terms_of))

            count = block[-1][2] - first
            parallel_map(fill, block, None if count >= PARALLEL_MIN_POINTS and not shared else 1)
            stream.submit(count, [results[first:first + count]])
    return out


def _blocks(units, rows: int):
    """``(first point, units)`` of each block: consecutive units of :func:`block_ranges`,
    together at most ``rows`` points."""
    block: list = []
    for unit in units:
        if block and unit[2] - block[0][1] > rows:
            yield block[0][1], block
            block = []
        block.append(unit)
    if block:
        yield block[0][1], block
