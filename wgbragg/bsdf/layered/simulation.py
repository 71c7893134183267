"""Position-free Monte Carlo simulation of a layered Bragg structure, on the GPU.

The reference light transport of Fourneau, Pacanowski & Barla 2024 (sec. 4.2; Guo, Hasan &
Zhao 2018): a random walk through a :class:`~wgbragg.bsdf.layered.model.LayeredBragg` that
ignores lateral positions and lets a path reflect any number of times. It validates the
single-reflection model (eq 34). :func:`simulate` estimates the BRDF by next-event estimation
(``wo`` given) or returns the paths' exit directions and weights (``wo=None``).

The walk, the estimators and the wavelengths a path carries: ``docs/physics.md``, section 12;
the loop budget: ``docs/design.md``, "The loop budget".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wgbragg import gpu
from wgbragg.bsdf.layered.coating import coating_scale, refract_in
from wgbragg.colour import colorimetry
from wgbragg.common.validation import (
    check_broadcast,
    check_directions,
    check_integer,
    check_wavelength,
)
from wgbragg.optics import yeh_gpu

__all__ = ["MAX_WAVELENGTHS", "MODES", "PATH_WAVELENGTHS", "TRANSMISSIONS", "bounce_limit",
           "max_layers", "simulate", "walk_iterations"]

MODES = ("all", "single")
"""``mode=``: every path, or the paths that reflect once (eq 34)."""

TRANSMISSIONS = ("ballistic", "naive")
"""``transmission=``: the integrated transmissivity tables (eqs 28, 31, 33), or a visible
normal sampled at every layer crossing."""

MAX_WAVELENGTHS = 64
"""Most wavelengths of a spectral BRDF estimate (``wo`` given)."""

PATH_WAVELENGTHS = 4
"""Wavelengths a path carries: RGB hero wavelengths, or a group of the given ones."""

_WORKGROUP_SIZE = 64
# Most paths an invocation runs (fewer when their walks may be long): next-event estimation
# reduces them in the invocation, so more paths write fewer statistics.
_PATHS_PER_INVOCATION = 64
_PARTICLES_PER_INVOCATION = 16
# Invocations of one dispatch; more queries, or more paths, go in several dispatches.
_MAX_INVOCATIONS = 2**22

_LAYER_DTYPE = gpu.struct_dtype([
    *((name, "u32" if name in ("periods", "bulk", "_pad") else "f32")
      for name in yeh_gpu.BRAGG_MIRROR_DTYPE.names),
    ("alpha", "f32"), ("table", "u32"), ("rows", "u32"), ("row_step", "f32"),
])
_PARAMS_DTYPE = gpu.struct_dtype([
    ("queries", "u32"), ("first_query", "u32"), ("groups", "u32"), ("batches", "u32"),
    ("paths", "u32"), ("seed", "u32"),
    ("host", "f32"), ("max_reflections", "u32"), ("columns", "u32"),
    ("per_invocation", "u32"), ("first_batch", "u32"), ("_pad", "u32"),
])


def walk_iterations(layers: int, max_bounces: int) -> int:
    """Loop iterations that one walk may take in the kernel, at most (the loop budget's plan).

    A walk makes up to ``max_bounces + 1`` reflections, each after crossing up to ``layers``
    layers, and each crossing or reflection loops over the layers above for next-event
    estimation and over four wavelengths for Yeh's formula: ``12 + 4 layers`` iterations,
    a bound fitted with a margin to lavapipe's longest walks (``docs/performance.md``,
    "Layered structures").

    Parameters
    ----------
    layers : int
        Rough layers of the structure, >= 1.
    max_bounces : int
        As :func:`simulate`'s.

    Returns
    -------
    int
    """
    return (max_bounces + 1) * (layers + 1) * (12 + 4 * layers)


def bounce_limit(layers: int) -> int:
    """Largest ``max_bounces`` of :func:`simulate` for a structure of ``layers`` rough layers
    on this device: one walk then fits in the iterations an invocation plans for
    (:func:`wgbragg.gpu.planned_loop_iterations`, :func:`walk_iterations`); 0 when not even
    one reflection does (from :func:`max_layers` + 1 layers on).

    Parameters
    ----------
    layers : int
        >= 1.

    Returns
    -------
    int
        Under Mesa 22's loop budget 233 for 4 layers, 81 for 8, below the default 64 from 10
        layers on; without a budget 7488 for 4 layers (a bound on a dispatch's time).
    """
    return max(0, gpu.planned_loop_iterations() // walk_iterations(layers, 0) - 1)


def max_layers() -> int:
    """Most rough layers a structure may have for :func:`simulate` on this device: those
    whose walks may still reflect once (:func:`bounce_limit`); 62 under Mesa 22's loop budget,
    360 without a budget."""
    # walk_iterations(n, 1) grows with n (at least as n): the largest n whose walk fits.
    planned, layers = gpu.planned_loop_iterations(), 0
    while layers < planned and walk_iterations(layers + 1, 1) <= planned:
        layers += 1
    return layers


def _check_wavelengths(wavelength_nm) -> np.ndarray | None:
    if wavelength_nm is None:
        return None
    wavelength = check_wavelength(wavelength_nm)
    if wavelength.ndim != 1 or not 1 <= wavelength.size <= MAX_WAVELENGTHS:
        raise ValueError(f"wavelength_nm must be 1-D with 1 to {MAX_WAVELENGTHS} values, got "
                         f"shape {wavelength.shape}")
    low, high = colorimetry.WAVELENGTH_RANGE_NM
    if not np.all((wavelength >= low) & (wavelength <= high)):
        raise ValueError(f"wavelength_nm must be in [{low:g}, {high:g}] nm")
    return wavelength


def _spectrum_rows(structure, wavelength: np.ndarray | None) -> np.ndarray:
    """The ``spectrum`` buffer: sRGB density and albedo on the 1 nm grid, or the padded
    wavelengths and their albedo."""
    if wavelength is None:
        grid, weights = colorimetry.xyz_weights()
        rgb = colorimetry.xyz_to_linear_srgb(weights / colorimetry.WAVELENGTH_STEP_NM)
        rows = np.column_stack([rgb, structure.base_spectrum(grid)])
    else:
        rows = np.zeros((wavelength.size, 4))
        rows[:, 0], rows[:, 3] = wavelength, structure.base_spectrum(wavelength)
    return rows.astype(np.float32)


def _padded(wavelength: np.ndarray) -> np.ndarray:
    """Whole groups of PATH_WAVELENGTHS, the last filled with its last wavelength."""
    lanes = -(-wavelength.size // PATH_WAVELENGTHS) * PATH_WAVELENGTHS
    return np.concatenate([wavelength, np.full(lanes - wavelength.size, wavelength[-1])])


def _layers(structure, wavelength, ballistic: bool):
    """Per-layer parameters, their transmissivity tables for ballistic transmission
    (concatenated, kept in the structure's table cache) and whether the tables are cell
    corners (RGB, where they fit :func:`gpu.bilinear_quads_fit`)."""
    records = np.zeros(len(structure.layers), _LAYER_DTYPE)
    for index, layer in enumerate(structure.layers):
        m = layer.mirror
        mirror = yeh_gpu.bragg_params(m.n1, m.n2, m.d1, m.d2, m.N, m.host)
        for name in yeh_gpu.BRAGG_MIRROR_DTYPE.names:
            records[index][name] = mirror[name]
        records[index]["alpha"] = layer.alpha
    if not ballistic:
        return records, np.zeros((1, 4), np.float32), False
    columns = colorimetry.xyz_weights()[0].size if wavelength is None else wavelength.size
    rows = np.array([layer.filter.theta_i.size for layer in structure.layers], np.int64)
    # One load per lookup (llvmpipe bounds-checks every load): RGB tables as the corners of
    # their cells, at 4x their size where that fits; spectral rows in groups of four
    # wavelengths, a path's. Else the plain RGB tables, four floats per vec4.
    quads = wavelength is None and gpu.bilinear_quads_fit(int(((rows - 1) * (columns - 1)).sum()))

    def vec4_rows(table: np.ndarray) -> np.ndarray:
        return gpu.bilinear_quads(table) if quads else np.asarray(table, np.float32).ravel()

    def build():
        tables = np.concatenate([vec4_rows(layer.transmissivity_table(wavelength, "gpu"))
                                 for layer in structure.layers])
        if not quads:
            tables = np.concatenate([tables, np.zeros(-tables.size % 4, np.float32)])
        return tables.reshape(-1, 4)

    key = ("simulation", None if wavelength is None else wavelength.tobytes())
    # Kept on the device, as the model's (model_gpu._Variant.device_tables): read-only,
    # and no call needs them on the host.
    tables = structure._cached(key, lambda: gpu.DeviceArray.upload(build(), what="layer tables"))
    if quads:
        sizes = (rows - 1) * (columns - 1)  # vec4s
    elif wavelength is None:
        sizes = rows * columns  # floats
    else:
        sizes = rows * columns // 4  # vec4s
    records["table"] = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    records["rows"] = rows
    for index, layer in enumerate(structure.layers):
        grid = layer.filter.theta_i
        records[index]["row_step"] = grid[1] - grid[0]
    return records, tables, quads


def _combine(counts, means, squares):
    """Chan et al.'s pairwise combination of Welford statistics: ``counts`` (b,) paths of
    ``b`` batches with means and sums of squared deviations ``(q, b, c)``, to the total
    count and ``(q, c)`` mean and sum of squared deviations."""
    total = counts.sum()
    mean = np.einsum("b,qbc->qc", counts, means) / total
    spread = squares.sum(axis=1) + np.einsum("b,qbc->qc", counts, (means - mean[:, None]) ** 2)
    return total, mean, spread


def simulate(structure, wi, wo=None, wavelength_nm=None, paths=65536, mode="all",
             transmission="ballistic", seed=0, return_error=False, max_bounces=64):
    """Monte Carlo simulation of light transport in a layered Bragg structure (sec. 4.2).

    Parameters
    ----------
    structure : LayeredBragg
    wi : array_like, shape (..., 3)
        Unit directions towards the light, in air, strictly above the horizon.
    wo : array_like, shape (..., 3), optional
        Unit directions towards the viewer, broadcast against ``wi``: estimate the BRDF
        there (0 where ``wo`` is at or below the horizon). ``None``: return the paths.
    wavelength_nm : array_like, optional
        1-D wavelengths in [360, 830] nm, 1 to :data:`MAX_WAVELENGTHS` with ``wo`` and 1 to
        :data:`PATH_WAVELENGTHS` without: a spectral result with a trailing axis over them.
        ``None``: linear sRGB (D65).
    paths : int
        Paths per ``wi`` (or per pair), >= 1 (>= 2 with ``return_error``).
    mode : {"all", "single"}
        Every path, or only those that reflect once (eq 34).
    transmission : {"ballistic", "naive"}
        Layer crossings from the integrated transmissivity tables (eq 28, 31, 33), or by
        sampling a visible normal at each crossing.
    seed : int
        In [0, 2**32): the result is deterministic for a seed.
    return_error : bool
        With ``wo``: also return the standard error of the estimate.
    max_bounces : int
        Most reflections of a path, 1 to :func:`bounce_limit` of the structure's number of
        layers (the device's loop budget: 233 for 4 layers under Mesa 22's); longer paths are
        cut off.

    Returns
    -------
    f : numpy.ndarray
        With ``wo``: the BRDF in 1/sr, shape ``broadcast(wi, wo)[:-1] + (K,)`` (spectral) or
        ``+ (3,)`` (RGB), without the coating's Dirac reflection.
    error : numpy.ndarray
        With ``return_error``: its standard error, same shape.
    directions, weights : numpy.ndarray
        With ``wo=None``: shapes ``wi.shape[:-1] + (paths, 3)`` and
        ``wi.shape[:-1] + (paths, K or 3)``: the exit direction of each path in air and its
        weight, ``E[weights g(directions)] = int f g cos dwo`` including the coating's Dirac
        reflection; absorbed paths have weight 0 and direction 0.

    Raises
    ------
    ValueError
        For a parameter out of its range or of the wrong shape, named in the message.
    wgbragg.gpu.LoopBudgetError
        (a ValueError) Should the device end a walk early all the same (the kernel reports
        it).

    Notes
    -----
    The estimators are described in ``docs/physics.md``, section 12.
    Statistics are accumulated in float32 over the paths of a GPU invocation (Welford's
    update; up to 64, fewer for long walks) and combined in float64.

    Examples
    --------
    >>> from wgbragg import BraggMirror, LayeredBragg, RoughBraggLayer
    >>> m = BraggMirror(n1=1.0, n2=1.5, d1=250.0, d2=250.0, N=10)
    >>> s = LayeredBragg([RoughBraggLayer(m, alpha=0.1)], base_albedo=0.5)
    >>> wi, wo = [0.0, 0.0, 1.0], [0.5, 0.0, 0.75 ** 0.5]
    >>> f, error = s.simulate(wi, wo, [450.0, 550.0], paths=4096,
    ...                       return_error=True)  # doctest: +SKIP
    >>> directions, weights = s.simulate(wi, paths=4096)  # doctest: +SKIP
    """
    wi, wo, wavelength, paths, seed, max_bounces, shape = _checked(
        structure, wi, wo, wavelength_nm, paths, mode, transmission, seed, return_error,
        max_bounces)
    ballistic = transmission == "ballistic"
    next_event = wo is not None
    lanes, channels = _lanes(wavelength, next_event)
    if 0 in shape:  # no query: what the same call on one more query would give, empty
        return _empty(shape, paths, channels, next_event, return_error)
    layers = len(structure.layers)
    groups = 1 if lanes is None else lanes.size // PATH_WAVELENGTHS
    n = structure.host_index
    records, tables, quads = _layers(structure, lanes, ballistic)
    kernel = _pipeline(structure, mode, ballistic, next_event, lanes, quads)
    # bounce_limit guarantees that one walk fits.
    per_invocation = min(_PATHS_PER_INVOCATION if next_event else _PARTICLES_PER_INVOCATION,
                         gpu.planned_loop_iterations() // walk_iterations(layers, max_bounces))
    walks = _Walks(paths, channels, groups, per_invocation, -(-paths // per_invocation),
                   next_event)

    wi_flat, wo_flat, up, queries = _queries(wi, wo, n)
    params = np.zeros((), _PARAMS_DTYPE)
    params["groups"], params["paths"] = groups, paths
    params["seed"], params["host"] = seed, n
    params["max_reflections"] = max_bounces - 1 if next_event else max_bounces
    params["columns"] = colorimetry.xyz_weights()[0].size if lanes is None else lanes.size
    params["per_invocation"] = per_invocation
    inputs = [None, records, tables, _spectrum_rows(structure, lanes),
              colorimetry.hero_inverse_cdf() if lanes is None else np.zeros(1, np.float32)]
    results = _run(kernel, queries, inputs, params, walks,
                   f"simulate on {layers} layers with max_bounces={max_bounces}")

    if not next_event:
        return _particles(results, shape, paths, channels)
    return _brdf(results, wi_flat, wo_flat, up, n, shape, walks, return_error)


def _checked(structure, wi, wo, wavelength_nm, paths, mode, transmission, seed, return_error,
             max_bounces):
    """:func:`simulate`'s arguments checked: ``wi``, ``wo`` (broadcast, or None), the
    wavelengths (or None), ``paths``, ``seed``, ``max_bounces`` and the queries' shape."""
    # Duck-typed: the model (wgbragg.bsdf.layered.model) sits above this module.
    if not all(hasattr(structure, name) for name in ("layers", "base_return", "host_index")):
        raise ValueError("structure must be a LayeredBragg (layers, base_return, host_index), "
                         f"got {type(structure).__name__}")
    wi = check_directions(wi, "wi")
    if np.any(wi[..., 2] <= 0.0):
        raise ValueError("wi must lie strictly above the horizon: wi[..., 2] in (0, 1]")
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    if transmission not in TRANSMISSIONS:
        raise ValueError(f"transmission must be one of {TRANSMISSIONS}, got {transmission!r}")
    wavelength = _check_wavelengths(wavelength_nm)
    paths = check_integer("paths", paths, 1, 2**31 - 1)
    seed = check_integer("seed", seed, 0, 2**32 - 1)
    layers = len(structure.layers)
    most_bounces = bounce_limit(layers)
    if most_bounces < 1:
        raise ValueError(f"structure: the GPU walk takes 1 to {max_layers()} rough layers "
                         f"(the device's loop budget), got {layers}")
    max_bounces = check_integer("max_bounces", max_bounces, 1, most_bounces)
    if not isinstance(return_error, bool):
        raise ValueError(f"return_error must be a bool, got {return_error!r}")
    if return_error and (wo is None or paths < 2):
        raise ValueError("return_error needs wo and paths >= 2")
    if wo is not None:
        wo = check_directions(wo, "wo")
        shape = check_broadcast(wi=wi.shape[:-1], wo=wo.shape[:-1])
        wi, wo = np.broadcast_to(wi, (*shape, 3)), np.broadcast_to(wo, (*shape, 3))
    else:
        shape = wi.shape[:-1]
    return wi, wo, wavelength, paths, seed, max_bounces, shape


def _lanes(wavelength, next_event: bool):
    """The wavelengths paths carry (padded to whole groups; None for RGB) and the number of
    channels of the result."""
    if wavelength is None:
        return None, 3
    lanes, channels = _padded(wavelength), wavelength.size
    if not next_event and channels > PATH_WAVELENGTHS:
        raise ValueError(f"wavelength_nm: with wo=None a path carries at most "
                         f"{PATH_WAVELENGTHS} wavelengths, got {channels} (call again "
                         "with the same seed for more: the paths share random numbers)")
    return lanes, channels


def _empty(shape, paths: int, channels: int, next_event: bool, return_error: bool):
    """:func:`simulate`'s result for no query."""
    if not next_event:
        return np.zeros((*shape, paths, 3)), np.zeros((*shape, paths, channels))
    empty = np.zeros((*shape, channels))
    return (empty, empty.copy()) if return_error else empty


def _pipeline(structure, mode: str, ballistic: bool, next_event: bool, lanes, quads: bool):
    """The walk kernel specialised for the structure and the call."""
    return gpu.compute_pipeline("bsdf/layered/simulation.wgsl", constants={
        "WORKGROUP_SIZE": _WORKGROUP_SIZE,
        "LAYERS": len(structure.layers),
        "COATING": structure.has_coating,
        "LAMBERTIAN": not structure.absorbing_base,
        "BALLISTIC": ballistic,
        "SINGLE": mode == "single",
        "NEXT_EVENT": next_event,
        "RGB": lanes is None,
        "QUADS": quads,
        # Layers share their host (LayeredBragg); Appendix D where it is not their n1.
        "HOST_MATCHED": all(layer.ballistic for layer in structure.layers),
    })


def _queries(wi, wo, n: float):
    """Flat ``wi`` and ``wo`` (+z where ``wo`` is None or below the horizon), whether ``wo``
    is above it, and the ``queries`` buffer: ``wi`` and both directions refracted in."""
    wi_flat = wi.reshape(-1, 3)
    up = np.ones(wi_flat.shape[0], bool)
    wo_flat = np.tile([0.0, 0.0, 1.0], (wi_flat.shape[0], 1))
    if wo is not None:
        up = wo.reshape(-1, 3)[:, 2] > 0.0
        wo_flat = np.where(up[:, None], wo.reshape(-1, 3), wo_flat)
    # Refracted here in float64: in float32, 1 - sin^2 rounds a grazing cosine to 0.
    queries = np.zeros((wi_flat.shape[0], 3, 4), np.float32)
    queries[:, 0, :3] = wi_flat
    queries[:, 1, :3], queries[:, 2, :3] = refract_in(wi_flat, n), refract_in(wo_flat, n)
    return wi_flat, wo_flat, up, queries


@dataclass(frozen=True)
class _Walks:
    """How a call's paths are laid out: ``batches`` invocations of up to ``per_invocation``
    paths per query and wavelength group."""

    paths: int
    channels: int
    groups: int
    per_invocation: int
    batches: int
    next_event: bool


def _dispatch_sizes(walks: _Walks) -> tuple[int, int]:
    """Batches and queries per dispatch."""
    if walks.next_event:
        # Invocations write a mean and an m2 (vec4) each: a query's batches may need several
        # dispatches, or a dispatch may hold several queries.
        batch_step = min(walks.batches, max(1, _MAX_INVOCATIONS // walks.groups))
        chunk = max(1, _MAX_INVOCATIONS // (walks.groups * batch_step))
        return batch_step, chunk
    limit = int(gpu.get_device().limits["max-storage-buffer-binding-size"])
    if 16 * (walks.paths + 1) > limit:
        raise ValueError(f"paths={walks.paths} take more than {limit} bytes of weights per wi: "
                         "use fewer (and another seed for more)")
    return walks.batches, (limit - 16) // (16 * walks.paths)


def _run(kernel, queries, inputs, params, walks: _Walks, what: str) -> list:
    """Every dispatch: per chunk of queries, the particles ``(values, directions)`` or the
    combined statistics ``(count, mean, spread)``."""
    batch_step, chunk = _dispatch_sizes(walks)
    next_event, groups, batches = walks.next_event, walks.groups, walks.batches
    paths, channels = walks.paths, walks.channels
    counts = np.minimum(walks.per_invocation,
                        paths - walks.per_invocation * np.arange(batches))
    results = []
    for start in range(0, len(queries), chunk):
        part = queries[start:start + chunk]
        params["queries"], params["first_query"] = len(part), start
        inputs[0] = part.reshape(-1, 4)
        pieces = []
        for first_batch in range(0, batches, batch_step):
            step = min(batch_step, batches - first_batch)
            params["batches"], params["first_batch"] = step, first_batch
            rows = 2 * len(part) * groups * step if next_event else len(part) * paths
            outputs = [((rows, 4), np.float32),
                       ((1 if next_event else rows + 1, 4), np.float32)]
            count = len(part) * groups * step if next_event else len(part) * batches
            values, directions = kernel.run(inputs, outputs, params, count=count)
            gpu.check_loops(directions[-1:, 3], what)
            if not next_event:
                pieces.append((values, directions[:-1]))
                continue
            values = values.astype(np.float64).reshape(len(part), groups, step, 2, 4)
            values = values.transpose(0, 2, 3, 1, 4).reshape(len(part), step, 2, 4 * groups)
            pieces.append(_combine(counts[first_batch:first_batch + step],
                                   values[..., 0, :channels], values[..., 1, :channels]))
        results.append(pieces[0] if not next_event else _combine(
            np.array([piece[0] for piece in pieces]),
            np.stack([piece[1] for piece in pieces], axis=1),
            np.stack([piece[2] for piece in pieces], axis=1)))
    return results


def _particles(results, shape, paths: int, channels: int):
    """The paths' exit directions and weights, in the queries' shape."""
    directions = np.concatenate([d for _, d in results])[:, :3].astype(np.float64)
    weights = np.concatenate([v for v, _ in results])[:, :channels].astype(np.float64)
    return (directions.reshape(*shape, paths, 3), weights.reshape(*shape, paths, channels))


def _brdf(results, wi_flat, wo_flat, up, n: float, shape, walks: _Walks, return_error: bool):
    """The BRDF estimate from the paths' statistics, scaled by the coating's transmittances
    and the compression of solid angle, with its standard error if asked."""
    paths, channels = walks.paths, walks.channels
    mean = np.concatenate([piece[1] for piece in results])
    spread = np.concatenate([piece[2] for piece in results])
    scale = np.where(up, coating_scale(wi_flat[:, 2], wo_flat[:, 2], n), 0.0)[:, None]
    estimate = (mean * scale).reshape(*shape, channels)
    if not return_error:
        return estimate
    error = np.sqrt(spread / ((paths - 1) * paths)) * scale
    return estimate, error.reshape(*shape, channels)
