"""Bounded work: elementwise functions of broadcast inputs, evaluated a block at a time.

A broadcasting elementwise function of arrays that broadcast to ``shape`` builds, if called
once, temporaries of the whole broadcast: a Bragg mirror's numpy reflectance takes about 360
bytes a point, so 1e7 points ask for 3.6 GB and 1e8 for more than most machines hold.
:func:`blockwise` calls it on blocks of at most ``block`` elements of the broadcast instead
and writes each block's result into one preallocated output, so that its peak memory is

    the output (``size x itemsize``, e.g. 8 bytes a point in float64)
    + the function's temporaries for one block (O(``block``), independent of ``size``)

besides the caller's inputs, which are never broadcast in full: a block's inputs are views
of them. Results are bit-identical to the unblocked call for functions that are elementwise
(each output element depends only on the input elements it is broadcast from; numpy's
ufuncs then compute each element the same way whatever the block).

Blocks are hyper-rectangles of the broadcast shape ``(n_0, ..., n_{d-1})`` in C order: the
trailing axes whole, a range along one axis ``k`` and single indices before it, so each block
is also one contiguous range of flat indices, and each input keeps its broadcast structure
(an angle array of shape ``(1, M)`` stays ``(1, m)``: per-angle work done once per block
column, as in the unblocked call). :func:`block_ranges` lists them;
:func:`flat_block` gives the broadcast values of any flat index range as 1-D arrays (what a
GPU upload of a range of points needs), also without materialising the broadcast.
"""

from __future__ import annotations

import math
import os
import threading
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor

import numpy as np

__all__ = ["DEFAULT_BLOCK", "MAX_HOST_THREADS", "block_part", "block_ranges", "block_shape",
           "blockwise", "check_out", "flat_block", "full_rank", "host_threads", "parallel_map"]

DEFAULT_BLOCK = 1 << 16
"""Elements of the broadcast per block of :func:`blockwise`: 65,536, so that a function with
a few dozen float64 / complex128 temporaries a point stays within some tens of MB, while a
block still takes milliseconds and the Python overhead per block (microseconds) is noise."""


MAX_HOST_THREADS = 8
"""Most threads :func:`parallel_map` runs: numpy's loops release the GIL, so blocks of a few
ten thousand elements scale over a few cores; more threads only add their overhead."""

_executor: ThreadPoolExecutor | None = None
_executor_workers = 0
_executor_lock = threading.Lock()


def host_threads() -> int:
    """Threads :func:`parallel_map` uses: the cores this process may run on (at most
    :data:`MAX_HOST_THREADS`), or ``WGBRAGG_HOST_THREADS`` where set (1: the calling thread
    alone)."""
    setting = os.environ.get("WGBRAGG_HOST_THREADS", "").strip()
    if setting:
        try:
            return max(1, int(setting))
        except ValueError:
            raise ValueError(f"WGBRAGG_HOST_THREADS must be an integer >= 1, got "
                             f"{setting!r}") from None
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return max(1, min(MAX_HOST_THREADS, cores or 1))


def parallel_map(function: Callable, items: Iterable, threads: int | None = None) -> list:
    """``[function(item) for item in items]``, spread over :func:`host_threads` threads.

    For functions that spend their time in numpy loops on disjoint outputs (blocks of an
    array), which release the GIL: the host's share of a GPU call (forming its inputs) then
    takes the cores that the device leaves idle. Exceptions propagate; results keep the
    items' order.

    Parameters
    ----------
    function : callable
    items : iterable
    threads : int, optional
        At most this many threads (default :func:`host_threads`); 1 runs them here, in order.

    Returns
    -------
    list
    """
    items = list(items)
    threads = min(len(items), host_threads() if threads is None else max(1, int(threads)))
    if threads <= 1:
        return [function(item) for item in items]
    global _executor, _executor_workers
    with _executor_lock:
        if _executor is None or _executor_workers < threads:
            if _executor is not None:
                _executor.shutdown(wait=False)
            _executor = ThreadPoolExecutor(max_workers=threads,
                                           thread_name_prefix="wgbragg-host")
            _executor_workers = threads
        executor = _executor
    # One contiguous run of items a thread: each keeps its part of the output in its cache.
    runs = [items[k * len(items) // threads:(k + 1) * len(items) // threads]
            for k in range(threads)]
    futures = [executor.submit(lambda run: [function(item) for item in run], run)
               for run in runs]
    return [result for future in futures for result in future.result()]


def _check_block(block) -> int:
    if isinstance(block, bool) or not isinstance(block, int | np.integer) or block < 1:
        raise ValueError(f"block must be an integer >= 1 (elements per block), got {block!r}")
    return int(block)


def block_ranges(shape: Sequence[int], block: int = DEFAULT_BLOCK
                 ) -> Iterator[tuple[tuple[slice, ...], int, int]]:
    """The blocks of an array of ``shape``, in C order, each of at most ``block`` elements.

    Parameters
    ----------
    shape : sequence of int
        The broadcast shape.
    block : int
        Most elements a block holds (>= 1).

    Yields
    ------
    index : tuple of slice
        The block's part of the array: ``array[index]`` keeps every axis (single indices as
        slices of length 1; trailing axes not named are whole).
    start, stop : int
        The same elements as flat (C-order) indices ``start .. stop - 1``.

    Notes
    -----
    Axis ``k`` is the first whose trailing product ``n_{k+1} ... n_{d-1}`` is at most
    ``block``; a block holds ``block // that product`` indices along it (the last block of a
    run fewer). No block is yielded for an empty shape (size 0); a 0-d shape is one block.

    Examples
    --------
    >>> [(start, stop) for _, start, stop in block_ranges((3, 4), 8)]
    [(0, 8), (8, 12)]
    >>> [index for index, _, _ in block_ranges((2, 3), 2)][:2]
    [(slice(0, 1, None), slice(0, 2, None)), (slice(0, 1, None), slice(2, 3, None))]
    """
    block = _check_block(block)
    shape = tuple(int(n) for n in shape)
    if math.prod(shape) == 0:
        return
    if not shape:
        yield (), 0, 1
        return
    trailing = [math.prod(shape[axis + 1:]) for axis in range(len(shape))]
    axis = next(a for a, inner in enumerate(trailing) if inner <= block)
    inner = trailing[axis]
    step = block // inner
    length = shape[axis]
    for lead in np.ndindex(*shape[:axis]):
        base = int(np.ravel_multi_index(lead, shape[:axis])) * length if axis else 0
        for first in range(0, length, step):
            last = min(first + step, length)
            index = (*(slice(i, i + 1) for i in lead), slice(first, last))
            yield index, (base + first) * inner, (base + last) * inner


def full_rank(arrays: Sequence, ndim: int) -> list[np.ndarray]:
    """``arrays`` as views with ``ndim`` axes (leading axes of length 1 added), for
    :func:`block_part`."""
    views = []
    for array in arrays:
        array = np.asarray(array)
        views.append(array.reshape((1,) * (ndim - array.ndim) + array.shape))
    return views


def block_part(view: np.ndarray, index: tuple[slice, ...]) -> np.ndarray:
    """The part of ``view`` (full rank, :func:`full_rank`) that broadcasts to the block
    ``index`` of :func:`block_ranges`: a view, its axes of length 1 kept as they are (an
    input broadcast along an axis stays broadcast in every block)."""
    return view[tuple(slice(0, 1) if view.shape[axis] == 1 else part
                      for axis, part in enumerate(index))]


def block_shape(shape: Sequence[int], index: tuple[slice, ...]) -> tuple[int, ...]:
    """The shape of the block ``index`` of :func:`block_ranges` in an array of ``shape``."""
    return (*(part.stop - part.start for part in index), *shape[len(index):])


def blockwise(function: Callable[..., np.ndarray | tuple], *arrays,
              block: int = DEFAULT_BLOCK, dtype=None, out=None):
    """``function(*arrays)`` evaluated a block of the broadcast at a time, into one output.

    Parameters
    ----------
    function : callable
        Elementwise in its array arguments: ``function(*parts)`` takes the blocks' parts of
        ``arrays`` (views, broadcastable against each other, never written) and returns an
        array broadcastable to their broadcast shape, or a tuple of such arrays.
    *arrays : array_like
        Inputs broadcast against each other, numpy-style (scalars included).
    block : int
        Most elements of the broadcast per call of ``function`` (default
        :data:`DEFAULT_BLOCK`).
    dtype : numpy.dtype, optional
        The output's dtype (every output's, for a tuple); default: that of the first block's
        result.
    out : numpy.ndarray or tuple of numpy.ndarray, optional
        Preallocated output(s) of the broadcast shape, written in place and returned.

    Returns
    -------
    numpy.ndarray or tuple of numpy.ndarray
        Of the broadcast shape: equal, bit for bit, to ``function(*arrays)`` broadcast to
        it, for an elementwise ``function``.

    Raises
    ------
    ValueError
        If the arrays do not broadcast together, ``block`` is not an integer >= 1, or
        ``out`` does not have the broadcast shape.

    Notes
    -----
    Peak memory: the output(s), allocated once (after the first block, unless ``out`` is
    given), plus ``function``'s temporaries for one block of at most ``block`` elements;
    the inputs are never broadcast in full. An input of size 0 makes an empty output; then
    ``function`` is called once on the empty inputs, only if ``dtype`` is not given.

    Examples
    --------
    >>> wavelength = np.linspace(400.0, 700.0, 5)[:, None]
    >>> theta = np.linspace(0.0, 1.0, 3)[None, :]
    >>> blockwise(lambda w, t: w * np.cos(t), wavelength, theta, block=4).shape
    (5, 3)
    """
    block = _check_block(block)
    inputs = [np.asarray(array) for array in arrays]
    shape = np.broadcast_shapes(*(array.shape for array in inputs))
    views = full_rank(inputs, len(shape))
    outputs = None if out is None else _outputs(out, shape)
    single = out is not None and not isinstance(out, tuple)
    for index, _, _ in block_ranges(shape, block):
        result = function(*(block_part(view, index) for view in views))
        parts = result if isinstance(result, tuple) else (result,)
        if outputs is None:
            single = not isinstance(result, tuple)
            outputs = tuple(np.empty(shape, np.asarray(part).dtype if dtype is None else dtype)
                            for part in parts)
        if len(parts) != len(outputs):
            raise ValueError(f"function returned {len(parts)} arrays, expected {len(outputs)}")
        for target, part in zip(outputs, parts, strict=True):
            target[index] = part
    if outputs is None:  # size 0
        if dtype is None:
            result = function(*views)
            single = not isinstance(result, tuple)
            parts = result if isinstance(result, tuple) else (result,)
            outputs = tuple(np.empty(shape, np.asarray(part).dtype) for part in parts)
        else:
            outputs = (np.empty(shape, dtype),)
            single = True
    return outputs[0] if single else outputs


def _outputs(out, shape: tuple[int, ...]) -> tuple[np.ndarray, ...]:
    outputs = out if isinstance(out, tuple) else (out,)
    for array in outputs:
        if not isinstance(array, np.ndarray) or array.shape != shape:
            got = array.shape if isinstance(array, np.ndarray) else type(array).__name__
            raise ValueError(f"out must be a numpy array of the broadcast shape {shape}, "
                             f"got {got}")
    return outputs


def check_out(out, shape: tuple[int, ...], dtypes=(np.float64, np.float32),
              name: str = "out") -> np.ndarray:
    """A caller's preallocated output, checked, or a new float64 array of ``shape``.

    Parameters
    ----------
    out : numpy.ndarray or None
        None for a new array; else a writeable C-contiguous array of ``shape`` and one of
        ``dtypes``, which the results are written into (and which is returned).
    shape : tuple of int
        The shape of the result.
    dtypes : sequence of numpy.dtype
        Accepted dtypes; the first is that of a new array.
    name : str
        The parameter's name, for errors.

    Returns
    -------
    numpy.ndarray

    Raises
    ------
    ValueError
        Naming ``name``, for anything but such an array.
    """
    dtypes = tuple(np.dtype(d) for d in dtypes)
    if out is None:
        return np.empty(shape, dtypes[0])
    if not isinstance(out, np.ndarray):
        raise ValueError(f"{name} must be a numpy array, got {type(out).__name__}")
    problems = []
    if out.shape != tuple(shape):
        problems.append(f"shape {out.shape} (expected the broadcast shape {tuple(shape)})")
    if out.dtype not in dtypes:
        problems.append(f"dtype {out.dtype} (expected "
                        f"{' or '.join(str(d) for d in dtypes)})")
    if not out.flags.c_contiguous:
        problems.append("a layout that is not C-contiguous")
    if not out.flags.writeable:
        problems.append("a read-only buffer")
    if problems:
        raise ValueError(f"{name} has {', '.join(problems)}")
    return out


def flat_block(arrays: Sequence, start: int, stop: int) -> list[np.ndarray]:
    """The broadcast values of ``arrays`` at flat (C-order) indices ``start .. stop - 1``.

    Parameters
    ----------
    arrays : sequence of array_like
        Inputs broadcast against each other.
    start, stop : int
        ``0 <= start <= stop <= size`` of the broadcast.

    Returns
    -------
    list of numpy.ndarray
        One 1-D array of length ``stop - start`` per input, in order (read-only where an
        input of one element is broadcast): what ``np.broadcast_to(a, shape).ravel()[start:
        stop]`` would give, without materialising the broadcast (memory O(``(stop - start) x
        ndim``), the flat indices unravelled).

    Raises
    ------
    ValueError
        If the arrays do not broadcast together or the range is outside the broadcast.

    Examples
    --------
    >>> w, t = flat_block([np.array([[1.0], [2.0]]), np.array([10.0, 20.0, 30.0])], 2, 5)
    >>> w.tolist(), t.tolist()
    ([1.0, 2.0, 2.0], [30.0, 10.0, 20.0])
    """
    inputs = [np.asarray(array) for array in arrays]
    shape = np.broadcast_shapes(*(array.shape for array in inputs))
    size = math.prod(shape)
    if not 0 <= start <= stop <= size:
        raise ValueError(f"flat range {start}..{stop} is outside 0..{size} (shape {shape})")
    if not shape:
        return [array.reshape(1)[start:stop] for array in inputs]
    multi = np.unravel_index(np.arange(start, stop, dtype=np.intp), shape)
    views = full_rank(inputs, len(shape))
    # An input of size 1 is indexed by integers only: a scalar, broadcast to the range.
    return [np.broadcast_to(view[tuple(0 if view.shape[axis] == 1 else multi[axis]
                                       for axis in range(len(shape)))], (stop - start,))
            for view in views]
