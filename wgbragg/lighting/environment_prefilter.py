"""Prefiltered environments for image-based lighting: the split-sum radiance and the lobe
moments of Kneiphof et al. 2019, baked per roughness into small equirectangular maps.

:func:`prefilter_environment` bakes one map per level (a GGX roughness or ``"cosine"``), on the
GPU in float32 or with the float64 numpy twin; :class:`PrefilteredEnvironment` looks levels up
and packs them for the renderer. Directions follow :mod:`wgbragg.lighting.environment_map`;
radiance is in the source's unit. The prefiltered quantities, resolutions and windows:
``docs/physics.md``, "Prefiltered environments"; the GPU's blocks and the loop budget:
``docs/design.md``, "The loop budget" and "What the kernels are given".
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Sequence

import numpy as np
from tqdm import tqdm

from wgbragg import gpu
from wgbragg.bsdf.microfacet import ggx_D, ggx_G1
from wgbragg.common.validation import as_float_array, check_backend, check_integer
from wgbragg.lighting.environment_map import LUMINANCE_WEIGHTS, EnvironmentMap
from wgbragg.lighting.procedural_environment import ProceduralEnvironment

__all__ = [
    "ALPHA_MAX",
    "ALPHA_MIN",
    "COSINE",
    "MAX_ITERATIONS",
    "PARAMS_DTYPE",
    "SIMD_LANES",
    "TRUNCATION",
    "PrefilteredEnvironment",
    "block_iterations",
    "level_sizes",
    "prefilter_environment",
    "resample_environment",
    "window_angle",
]

COSINE = "cosine"
"""The level name of the cosine (Lambertian) kernel."""
ALPHA_MIN = 0.01
"""Smallest roughness prefiltered: its lobe already spans only about 1.5 input texels."""
ALPHA_MAX = 1.0
"""Largest roughness prefiltered."""
TRUNCATION = 1e-4
"""``D(h) / D(n)`` at the edge of a GGX window (see :func:`window_angle`)."""
MAX_ITERATIONS = 60_000
"""Loop turns the invocations of one output row may run per dispatch: column iterations plus
one per input row, fewer where the device's loop budget asks (:func:`block_iterations`).
Without a budget it bounds a dispatch's time. It holds per SIMD group because a group never
spans two output rows (:data:`SIMD_LANES`)."""


def block_iterations() -> int:
    """:data:`MAX_ITERATIONS` on this device: the loop budget (:func:`wgbragg.gpu.loop_budget`)
    less room for the exit pass of each loop, which the count leaves out (at most one per
    input row, and input heights are at most 2048), where that is smaller."""
    budget = gpu.loop_budget()
    if budget is None:
        return MAX_ITERATIONS
    return max(1, min(MAX_ITERATIONS, budget - _LARGEST_HEIGHT))

SIMD_LANES = 16
"""Invocations of an output row are padded to a multiple of this: llvmpipe's SIMD groups (8
lanes with AVX2, 16 with 512-bit vectors) then each lie in one output row. A group spanning
two rows would run both rows' loops in lockstep, up to twice :data:`MAX_ITERATIONS` turns."""

PARAMS_DTYPE = gpu.struct_dtype([
    ("in_width", "u32"), ("in_height", "u32"), ("out_width", "u32"), ("out_height", "u32"),
    ("out_stride", "u32"), ("row_begin", "u32"), ("row_end", "u32"), ("cosine", "u32"),
    ("finish", "u32"), ("alpha", "f32"), ("q_max", "f32"),
])
"""Layout of ``PrefilterParams`` in ``wgsl/lighting/environment_prefilter.wgsl``."""

_ROW_DTYPE = gpu.struct_dtype([
    ("sin_theta", "f32"), ("cos_theta", "f32"), ("first", "u32"), ("end", "u32"),
])
"""``OutputRow`` of ``wgsl/lighting/environment_prefilter.wgsl``."""
_COLUMN_DTYPE = gpu.struct_dtype([
    ("sin_phi", "f32"), ("cos_phi", "f32"), ("centre", "u32"), ("_pad", "u32"),
])
"""``OutputColumn`` of ``wgsl/lighting/environment_prefilter.wgsl``."""

_LARGEST_WIDTH = 4096
_LARGEST_HEIGHT = 2048
# Regular subsamples per axis for a procedural gradient; at least this many for the texels a
# disc touches, and at least this many across the disc's angular radius.
_GRADIENT_SUBSAMPLES = 4
_DISC_SUBSAMPLES = 16
_DISC_SUBSAMPLES_PER_RADIUS = 32
_DISC_SUBSAMPLES_MAX = 512
# The window's edge is computed in float64; texels within this many radians of it count.
_WINDOW_SLACK = 1e-9
# Kernel evaluations per numpy chunk: bounds each temporary to ~25 MB.
_NUMPY_CHUNK = 1 << 20
# Output texels per WGSL workgroup; a multiple of SIMD_LANES, so that groups of lanes start at
# the padded output rows' starts.
_WORKGROUP_SIZE = 64


# --------------------------------------------------------------------------- levels


def _check_level(value, name: str):
    if isinstance(value, str):
        if value == COSINE:
            return COSINE
    elif isinstance(value, numbers.Real) and not isinstance(value, bool):
        alpha = float(value)
        if ALPHA_MIN <= alpha <= ALPHA_MAX:
            return alpha
    raise ValueError(f"{name} must be a GGX roughness in [{ALPHA_MIN:g}, {ALPHA_MAX:g}] or "
                     f"{COSINE!r}, got {value!r}")


def _check_levels(levels) -> tuple:
    if isinstance(levels, str | bytes) or not isinstance(levels, Sequence):
        raise ValueError(f"levels must be a sequence of roughnesses in [{ALPHA_MIN:g}, "
                         f"{ALPHA_MAX:g}] or {COSINE!r}, got {levels!r}")
    if len(levels) == 0:
        raise ValueError("levels must hold at least one level")
    return tuple(_check_level(v, f"levels[{i}]") for i, v in enumerate(levels))


def level_sizes(level) -> tuple[tuple[int, int], tuple[int, int]]:
    """Input and output resolutions of a level (``docs/physics.md``,
    "Prefiltered environments").

    Parameters
    ----------
    level : float or str
        GGX roughness in [0.01, 1], or ``"cosine"``.

    Returns
    -------
    ((W_in, H_in), (W_out, H_out)) : tuple of tuple of int
        Texels across and down the input and output equirectangular maps.

    Raises
    ------
    ValueError
        If ``level`` is neither.

    Examples
    --------
    >>> level_sizes(0.05), level_sizes("cosine")
    (((256, 128), (128, 64)), ((64, 32), (32, 16)))
    """
    level = _check_level(level, "level")
    if level == COSINE:
        width = 64
    else:
        width = min(512, max(64, 2 ** math.ceil(math.log2(4.0 * math.pi / level))))
    out = max(32, width // 2)
    return (width, width // 2), (out, out // 2)


def window_angle(level) -> float:
    """Largest angle between ``r`` and ``l`` that a level's kernel sums, in radians.

    Parameters
    ----------
    level : float or str
        GGX roughness in [0.01, 1], or ``"cosine"``.

    Returns
    -------
    float
        ``min(pi/2, 2 atan(10 alpha))``: there the half vector is ``atan(10 alpha)`` from
        ``r``, where ``D(h) / D(n)`` is about :data:`TRUNCATION`; ``pi/2`` for ``"cosine"``.

    Raises
    ------
    ValueError
        If ``level`` is neither a roughness in range nor ``"cosine"``.
    """
    level = _check_level(level, "level")
    if level == COSINE:
        return 0.5 * math.pi
    return min(0.5 * math.pi, 2.0 * math.atan(10.0 * level))


def _check_sizes(sizes) -> tuple[tuple[int, int], tuple[int, int]]:
    message = (f"sizes must be ((W_in, H_in), (W_out, H_out)) with widths in [2, "
               f"{_LARGEST_WIDTH}] and heights in [1, {_LARGEST_HEIGHT}], got {sizes!r}")
    try:
        (w_in, h_in), (w_out, h_out) = sizes
    except (TypeError, ValueError):
        raise ValueError(message) from None
    values = (w_in, h_in, w_out, h_out)
    if any(isinstance(v, bool) or not isinstance(v, numbers.Integral) for v in values):
        raise ValueError(message)
    if not (2 <= w_in <= _LARGEST_WIDTH and 2 <= w_out <= _LARGEST_WIDTH
            and 1 <= h_in <= _LARGEST_HEIGHT and 1 <= h_out <= _LARGEST_HEIGHT):
        raise ValueError(message)
    return (int(w_in), int(h_in)), (int(w_out), int(h_out))


# --------------------------------------------------------------------------- grids


def _directions(sin_theta, cos_theta, sin_phi, cos_phi) -> np.ndarray:
    """(rows, columns, 3) directions of the convention, ``(sin theta sin phi, cos theta,
    -sin theta cos phi)`` with ``phi = 2 pi u``, from per-row and per-column values."""
    s = sin_theta[:, None]
    return np.stack(np.broadcast_arrays(s * sin_phi, cos_theta[:, None], -s * cos_phi),
                    axis=-1)


@dataclasses.dataclass(frozen=True)
class _Grid:
    """Texel centres and solid angles of a width x height equirectangular map."""

    width: int
    height: int

    @property
    def theta(self) -> np.ndarray:
        return np.pi * (np.arange(self.height) + 0.5) / self.height

    @property
    def phi(self) -> np.ndarray:
        """2 pi u of the column centres."""
        return 2.0 * np.pi * (np.arange(self.width) + 0.5) / self.width

    @property
    def half_edges_sin2(self) -> np.ndarray:
        """sin^2(theta / 2) at the row edges: 0 at +y, 1 at -y; (1 - cos theta) / 2."""
        return np.sin(0.5 * np.pi * np.arange(self.height + 1) / self.height) ** 2

    @property
    def solid_angle(self) -> np.ndarray:
        """Per row, in sr: (2 pi / W)(cos theta_y - cos theta_(y+1)), as a product (accurate
        for the thin polar rows)."""
        half_edges = 0.5 * np.pi * np.arange(self.height + 1) / self.height
        band = np.sin(half_edges[:-1] + half_edges[1:]) * np.sin(0.5 * np.pi / self.height)
        return (4.0 * np.pi / self.width) * band

    def centres(self) -> np.ndarray:
        theta, phi = self.theta, self.phi
        return _directions(np.sin(theta), np.cos(theta), np.sin(phi), np.cos(phi))


# --------------------------------------------------------------------------- resampling


def _check_source(source):
    if not isinstance(source, EnvironmentMap | ProceduralEnvironment):
        raise ValueError("source must be a wgbragg.lighting.environment_map.EnvironmentMap or a "
                         "wgbragg.lighting.procedural_environment.ProceduralEnvironment (see "
                         f"ProceduralEnvironment.from_scene), got {type(source).__name__}")
    return source


def _overlaps(target_edges: np.ndarray, source_edges: np.ndarray) -> np.ndarray:
    """(targets, sources) lengths shared by the intervals between increasing edges."""
    low = np.maximum(target_edges[:-1, None], source_edges[None, :-1])
    high = np.minimum(target_edges[1:, None], source_edges[None, 1:])
    return np.maximum(high - low, 0.0)


def _resample_map(environment: EnvironmentMap, width: int, height: int) -> np.ndarray:
    """Exact solid-angle average of the piecewise constant map over each new texel: the map
    is separable in (sin^2(theta / 2), phi), the measure being their product."""
    source = _Grid(environment.width, environment.height)
    target = _Grid(width, height)
    rows = _overlaps(target.half_edges_sin2, source.half_edges_sin2)
    rows /= np.diff(target.half_edges_sin2)[:, None]
    columns = _overlaps(np.arange(width + 1) / width,
                        np.arange(environment.width + 1) / environment.width) * width
    # (H, Hs) @ (Hs, Ws, 3) then over Ws: each texel is a convex combination of the source's.
    across = (rows @ environment.radiance.reshape(environment.height, -1)).reshape(
        height, environment.width, 3)
    resampled = np.einsum("ykc,xk->yxc", across, columns)
    return resampled * environment.intensity


def _subsample_directions(grid: _Grid, rows: np.ndarray, columns: np.ndarray,
                          n: int) -> np.ndarray:
    """(texels, n * n, 3) directions at the equal-area midpoints of n x n subtexels."""
    z_edges = grid.half_edges_sin2
    fraction = (np.arange(n) + 0.5) / n
    z = z_edges[rows][:, None] + fraction[None, :] * (z_edges[rows + 1] - z_edges[rows])[:, None]
    phi = 2.0 * np.pi * (columns[:, None] + fraction[None, :]) / grid.width
    sin_theta = 2.0 * np.sqrt(z * (1.0 - z))
    cos_theta = 1.0 - 2.0 * z
    s = sin_theta[:, :, None]
    directions = np.stack(np.broadcast_arrays(
        s * np.sin(phi)[:, None, :], cos_theta[:, :, None], -s * np.cos(phi)[:, None, :]),
        axis=-1)
    return directions.reshape(len(rows), n * n, 3)


def _rasterize(environment: ProceduralEnvironment, width: int, height: int) -> np.ndarray:
    grid = _Grid(width, height)
    out = np.empty((height, width, 3))
    columns = np.arange(width)
    n = _GRADIENT_SUBSAMPLES
    # Some rows at a time: each holds width * 16 directions.
    step = max(1, (1 << 18) // (width * n * n))
    for y in range(0, height, step):
        rows = np.repeat(np.arange(y, min(y + step, height)), width)
        d = _subsample_directions(grid, rows, np.tile(columns, len(rows) // width), n)
        gradient = environment.radiance(d, disc=False).mean(axis=1)
        out[y:y + step] = gradient.reshape(-1, width, 3)
    if environment.has_disc:
        out += _disc_coverage(environment, grid)[:, :, None] * environment.disc_radiance
    return out


def _disc_coverage(environment: ProceduralEnvironment, grid: _Grid) -> np.ndarray:
    """(H, W) fraction of each texel's solid angle inside the disc, measured by supersampling
    and scaled so that the covered solid angle is exactly the disc's."""
    radius = math.acos(min(1.0, environment.disc_cos))
    # Any point of a texel lies within half a row plus half a column of its centre.
    reach = 0.5 * np.pi / grid.height + np.pi / grid.width
    distance = np.arccos(np.clip(grid.centres() @ environment.disc_direction, -1.0, 1.0))
    rows, columns = np.nonzero(distance <= radius + reach)
    coverage = np.zeros((grid.height, grid.width))
    if rows.size == 0:
        return coverage
    extent = max(np.pi / grid.height, 2.0 * np.pi / grid.width)
    n = min(_DISC_SUBSAMPLES_MAX, max(
        _DISC_SUBSAMPLES, math.ceil(_DISC_SUBSAMPLES_PER_RADIUS * extent / max(radius, 1e-12))))
    step = max(1, (1 << 20) // (n * n))
    for start in range(0, rows.size, step):
        r, c = rows[start:start + step], columns[start:start + step]
        d = _subsample_directions(grid, r, c, n)
        coverage[r, c] = np.mean(d @ environment.disc_direction >= environment.disc_cos, axis=1)
    covered = np.sum(coverage * grid.solid_angle[:, None])
    if covered > 0.0:
        coverage *= environment.disc_solid_angle / covered
    return coverage


def resample_environment(source, width: int, height: int) -> np.ndarray:
    """A source's radiance averaged over the texels of a ``width x height`` equirectangular map.

    Parameters
    ----------
    source : EnvironmentMap or ProceduralEnvironment
        An image is averaged exactly (its texels as piecewise constant radiance, weighted
        by solid angle, ``intensity`` applied); a procedural environment is rasterised with regular
        subsamples and its disc's energy kept exact (``docs/physics.md``,
        "Prefiltered environments").
    width, height : int
        Texels across (``phi``) and down (``theta``), in [2, 4096] and [1, 2048].

    Returns
    -------
    numpy.ndarray, shape (height, width, 3), float64
        Linear sRGB radiance, row 0 at the top (+y).

    Raises
    ------
    ValueError
        If ``source`` is of another type, or a size is out of range.
    """
    _check_source(source)
    width = check_integer("width", width, 2, _LARGEST_WIDTH)
    height = check_integer("height", height, 1, _LARGEST_HEIGHT)
    if isinstance(source, EnvironmentMap):
        return _resample_map(source, width, height)
    return _rasterize(source, width, height)


# --------------------------------------------------------------------------- plan


@dataclasses.dataclass(frozen=True)
class _Plan:
    """What a level sums: its grids, window and, per output row, the input rows (``first`` to
    ``end``) and per input row the columns (``spans``: -1 none, else ``n`` columns either
    side of the one holding ``r``'s azimuth, all of them once ``2 n + 1 >= W_in``)."""

    level: object
    source: _Grid
    target: _Grid
    q_max: float
    first: np.ndarray
    end: np.ndarray
    spans: np.ndarray
    centre: np.ndarray

    @classmethod
    def make(cls, level, sizes) -> _Plan:
        (w_in, h_in), (w_out, h_out) = sizes
        source, target = _Grid(w_in, h_in), _Grid(w_out, h_out)
        angle = window_angle(level)
        q_max = 1.0 if level == COSINE else 2.0 * math.sin(0.5 * angle) ** 2
        theta_r, theta_c = target.theta[:, None], source.theta[None, :]
        # The largest azimuth offset at which a row centre's ring stays inside the window.
        with np.errstate(divide="ignore", invalid="ignore"):
            cos_offset = ((math.cos(angle) - np.cos(theta_c) * np.cos(theta_r))
                          / (np.sin(theta_c) * np.sin(theta_r)))
        offset = np.arccos(np.clip(cos_offset, -1.0, 1.0))
        reached = np.abs(theta_c - theta_r) <= angle + _WINDOW_SLACK
        step = 2.0 * np.pi / w_in
        # A column centre lies within one column of r's column plus the offset.
        spans = np.floor((offset + _WINDOW_SLACK) / step).astype(np.int64) + 1
        spans = np.where(reached, np.minimum(spans, w_in // 2), -1)
        any_row = reached.any(axis=1)
        first = np.where(any_row, np.argmax(reached, axis=1), 0)
        end = np.where(any_row, h_in - np.argmax(reached[:, ::-1], axis=1), 0)
        # The input column holding the output column's centre, (x + 1/2) / W_out of a turn.
        centre = ((2 * np.arange(w_out) + 1) * w_in) // (2 * w_out)
        return cls(level, source, target, q_max, first, end, spans.astype(np.int32), centre)

    def blocks(self, most: int = MAX_ITERATIONS) -> list[tuple[int, int]]:
        """Input rows split so that no output row iterates more than ``most`` times in a
        block (the GPU bake's :func:`block_iterations`): per input row, its column loop and
        one turn of the row loop. The GPU bake pads output rows to SIMD_LANES invocations, so
        this bounds every SIMD group."""
        w_in = self.source.width
        cost = np.where(self.spans >= 0, np.minimum(2 * self.spans + 1, w_in) + 1, 0)
        blocks, begin = [], 0
        total = np.zeros(self.target.height, np.int64)
        for row in range(self.source.height):
            if np.any(total + cost[:, row] > most) and row > begin:
                blocks.append((begin, row))
                begin, total = row, np.zeros_like(total)
            total += cost[:, row]
        blocks.append((begin, self.source.height))
        return blocks


# --------------------------------------------------------------------------- bakes


def _kernel(level, q: np.ndarray) -> np.ndarray:
    """K(r, l) as a function of q = 1 - r.l in [0, 2], window not applied."""
    cos = 1.0 - q
    if level == COSINE:
        return cos
    # r.h = sqrt((1 + r.l) / 2) = sqrt(1 - q / 2).
    return ggx_D(np.sqrt(1.0 - 0.5 * q), level) * ggx_G1(np.clip(cos, -1.0, 1.0), level)


def _finish(r, sums) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Normalised radiance, mean and second moments from the sums (..., 16) laid out as
    the kernel's: (radiance sum, K sum), (m sum, w sum), (xx, yy, zz, 0), (xy, yz, zx, 0)."""
    k, y = sums[..., 3:4], sums[..., 7:8]
    with np.errstate(divide="ignore", invalid="ignore"):
        radiance = np.where(k > 0.0, sums[..., 0:3] / k, 0.0)
        mean = np.where(y > 0.0, sums[..., 4:7] / y, r)
        diagonal = np.where(y > 0.0, sums[..., 8:11] / y, r * r)
        off = np.where(y > 0.0, sums[..., 12:15] / y, r * np.roll(r, -1, axis=-1))
    return radiance, mean, np.concatenate([diagonal, off], axis=-1)


def _bake_numpy(plan: _Plan, radiance: np.ndarray):
    source, target = plan.source, plan.target
    l_all = source.centres()
    luminance = radiance @ LUMINANCE_WEIGHTS
    omega = source.solid_angle
    r_all = target.centres()
    sums = np.zeros((target.height, target.width, 16))
    for y_out in range(target.height):
        f, e = int(plan.first[y_out]), int(plan.end[y_out])
        if f >= e:
            continue
        l, weight = l_all[f:e], omega[f:e, None]
        light, lum = radiance[f:e], luminance[f:e]
        chunk = max(1, _NUMPY_CHUNK // l[..., 0].size)
        for x in range(0, target.width, chunk):
            r = r_all[y_out, x:x + chunk]
            difference = r[:, None, None, :] - l[None]
            q = 0.5 * np.sum(difference * difference, axis=-1)
            k = np.where(q <= plan.q_max, _kernel(plan.level, q), 0.0) * weight
            w = k * lum
            out = sums[y_out, x:x + chunk]
            out[:, 0:3] = np.einsum("nyx,yxc->nc", k, light)
            out[:, 3] = k.sum(axis=(1, 2))
            out[:, 4:7] = np.einsum("nyx,yxc->nc", w, l)
            out[:, 7] = w.sum(axis=(1, 2))
            out[:, 8:11] = np.einsum("nyx,yxc->nc", w, l * l)
            out[:, 12:15] = np.einsum("nyx,yxc->nc", w, l * np.roll(l, -1, axis=-1))
    return _finish(r_all, sums)


def _gpu_inputs(plan: _Plan, radiance: np.ndarray) -> list[np.ndarray]:
    source, target = plan.source, plan.target
    theta, phi = source.theta, source.phi
    rows = np.zeros((source.height, 4), np.float32)
    rows[:, 0], rows[:, 1], rows[:, 2] = np.sin(theta), np.cos(theta), source.solid_angle
    columns = np.column_stack([np.sin(phi), np.cos(phi)]).astype(np.float32)
    with np.errstate(over="ignore"):
        texels = np.concatenate([radiance, (radiance @ LUMINANCE_WEIGHTS)[..., None]], axis=-1)
        texels = texels.reshape(-1, 4).astype(np.float32)
    if not np.isfinite(texels).all():
        raise ValueError("source radiance is beyond the float32 range of the GPU backend")
    out_rows = np.zeros(target.height, _ROW_DTYPE)
    out_rows["sin_theta"], out_rows["cos_theta"] = np.sin(target.theta), np.cos(target.theta)
    out_rows["first"], out_rows["end"] = plan.first, plan.end
    out_columns = np.zeros(target.width, _COLUMN_DTYPE)
    out_columns["sin_phi"], out_columns["cos_phi"] = np.sin(target.phi), np.cos(target.phi)
    out_columns["centre"] = plan.centre
    return [rows, columns, texels, out_rows, out_columns, plan.spans.reshape(-1)]


def _bake_gpu(plan: _Plan, radiance: np.ndarray):
    source, target = plan.source, plan.target
    kernel = gpu.compute_pipeline("lighting/environment_prefilter.wgsl",
                                  constants={"WORKGROUP_SIZE": _WORKGROUP_SIZE})
    inputs = [gpu.DeviceArray.upload(a) for a in _gpu_inputs(plan, radiance)]
    stride = -(-target.width // SIMD_LANES) * SIMD_LANES
    count = stride * target.height
    sums = gpu.DeviceArray.empty((count * 4, 4), np.float32)
    result = gpu.DeviceArray.empty((count * 4, 4), np.float32)
    blocks = plan.blocks(block_iterations())
    dispatches = []
    for index, (begin, end) in enumerate(blocks):
        params = np.zeros((), PARAMS_DTYPE)
        params["in_width"], params["in_height"] = source.width, source.height
        params["out_width"], params["out_height"] = target.width, target.height
        params["out_stride"] = stride
        params["row_begin"], params["row_end"] = begin, end
        params["cosine"] = plan.level == COSINE
        params["finish"] = index == len(blocks) - 1
        params["alpha"] = 0.0 if plan.level == COSINE else plan.level
        params["q_max"] = plan.q_max
        dispatches.append(kernel.bind(inputs, [sums, result], params, count=count))
    (out,) = gpu.submit(dispatches, read=[result])
    out = out.astype(np.float64).reshape(target.height, stride, 16)[:, :target.width]
    return out[..., 0:3], out[..., 4:7], np.concatenate([out[..., 8:11], out[..., 12:15]], -1)


def prefilter_environment(source, levels, backend: str = "gpu", sizes=None,
                          progress: bool | None = None) -> PrefilteredEnvironment:
    """Prefilter an environment for image-based lighting, one map per level.

    Parameters
    ----------
    source : EnvironmentMap or ProceduralEnvironment
        The environment (a scene's procedural one through
        :meth:`ProceduralEnvironment.from_scene`).
    levels : sequence of float or str
        GGX roughnesses in [0.01, 1] or ``"cosine"``, in any order; duplicates are kept
        (and baked once).
    backend : {"gpu", "numpy"}
        float32 on the GPU, or the float64 numpy twin (slow at full resolution).
    sizes : ((int, int), (int, int)), optional
        ``((W_in, H_in), (W_out, H_out))`` for every level instead of :func:`level_sizes`
        (widths in [2, 4096], heights in [1, 2048]), e.g. to keep the numpy twin cheap.
    progress : bool or None
        Show a tqdm bar counting levels; ``None`` shows it for more than one level.

    Returns
    -------
    PrefilteredEnvironment

    Raises
    ------
    ValueError
        If ``source`` is of another type, a level is out of range or unknown, ``backend`` is
        unknown, ``sizes`` is malformed or out of range, or (GPU) the radiance overflows
        float32.
    """
    source = _check_source(source)
    levels = _check_levels(levels)
    backend = check_backend(backend)
    if sizes is not None:
        sizes = _check_sizes(sizes)
    if progress is None:
        progress = len(levels) > 1
    bake = _bake_gpu if backend == "gpu" else _bake_numpy
    inputs: dict[tuple[int, int], np.ndarray] = {}
    baked: dict[object, tuple] = {}
    for level in tqdm(levels, desc="prefilter", unit="level", disable=not progress):
        if level in baked:
            continue
        level_size = sizes or level_sizes(level)
        size = level_size[0]
        if size not in inputs:
            inputs[size] = resample_environment(source, *size)
        baked[level] = bake(_Plan.make(level, level_size), inputs[size])
    radiance, mean, second = zip(*(baked[level] for level in levels), strict=True)
    return PrefilteredEnvironment(levels, radiance, mean, second)


# --------------------------------------------------------------------------- result


def _azimuth_polar(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The image coordinates ``u`` and ``v`` in [0, 1] of unit directions
    (:mod:`wgbragg.lighting.environment_map`: ``u = atan2(x, -z) / (2 pi)`` wrapped, as
    ``1/2 - atan2(x, z) / (2 pi)``, and 1/2 at the poles)."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    u = np.where((x == 0.0) & (z == 0.0), 0.5, 0.5 - np.arctan2(x, z) / (2.0 * np.pi))
    return u, np.arctan2(np.hypot(x, z), y) / np.pi


class PrefilteredEnvironment:
    """Prefiltered levels of an environment, made by :func:`prefilter_environment`.

    Parameters
    ----------
    levels : sequence of float or str
        The level of each map: a GGX roughness or ``"cosine"``.
    radiance, mean, second : sequence of array_like
        Per level, shapes (H, W, 3), (H, W, 3) and (H, W, 6) (``xx, yy, zz, xy, yz, zx``),
        finite, in the module's equirectangular convention; H >= 1, W >= 2.

    Attributes
    ----------
    levels : tuple
    radiance, mean, second : tuple of numpy.ndarray
        Read-only float64 copies.

    Raises
    ------
    ValueError
        If a level is out of range, the sequences differ in length, or an array has a wrong
        shape or a non-finite value.
    """

    def __init__(self, levels, radiance, mean, second):
        self.levels = _check_levels(levels)
        n = len(self.levels)
        arrays = {}
        for name, value, channels in (("radiance", radiance, 3), ("mean", mean, 3),
                                      ("second", second, 6)):
            if len(value) != n:
                raise ValueError(f"{name} must hold one array per level ({n}), got {len(value)}")
            checked = []
            for k, array in enumerate(value):
                array = as_float_array(f"{name}[{k}]", array).copy()
                if array.ndim != 3 or array.shape[2] != channels or array.shape[0] < 1 or (
                        array.shape[1] < 2):
                    raise ValueError(f"{name}[{k}] must have shape (H >= 1, W >= 2, "
                                     f"{channels}), got {array.shape}")
                if not np.isfinite(array).all():
                    raise ValueError(f"{name}[{k}] must be finite")
                array.flags.writeable = False
                checked.append(array)
            arrays[name] = tuple(checked)
        for k in range(n):
            shapes = {arrays[name][k].shape[:2] for name in arrays}
            if len(shapes) != 1:
                raise ValueError(f"radiance[{k}], mean[{k}] and second[{k}] must share one "
                                 f"(H, W), got {sorted(shapes)}")
        self.radiance = arrays["radiance"]
        self.mean = arrays["mean"]
        self.second = arrays["second"]

    def lookup(self, level: int, directions) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A level's values at ``directions``, bilinear between texel centres: the float64
        twin of ``prefiltered_lookup`` in ``wgsl/lighting/environment_prefilter_lookup.wgsl``.

        Parameters
        ----------
        level : int
            Index into :attr:`levels`.
        directions : array_like, shape (..., 3)
            Unit vectors (norm within 1e-5 of 1).

        Returns
        -------
        radiance, mean, second : numpy.ndarray, shapes (..., 3), (..., 3), (..., 6)
            Interpolated with wrapping in ``phi`` (across the seam) and clamping in
            ``theta`` (above the first row's centres and below the last's, constant in
            ``theta``).

        Raises
        ------
        ValueError
            If ``level`` is not an index of :attr:`levels` or ``directions`` are not unit
            vectors with a trailing axis of 3.
        """
        if isinstance(level, bool) or not isinstance(level, numbers.Integral) or not (
                0 <= level < len(self.levels)):
            raise ValueError(f"level must be an integer in [0, {len(self.levels)}), got "
                             f"{level!r}")
        d = as_float_array("directions", directions)
        if d.ndim == 0 or d.shape[-1] != 3:
            raise ValueError(f"directions must have a trailing axis of length 3, got shape "
                             f"{d.shape}")
        if not np.all(np.abs(np.linalg.norm(d, axis=-1) - 1.0) <= 1e-5):
            raise ValueError("directions must be unit vectors (norm within 1e-05 of 1)")
        table = np.concatenate([self.radiance[level], self.mean[level], self.second[level]],
                               axis=-1)
        height, width = table.shape[:2]
        azimuth, polar = _azimuth_polar(d)
        u = azimuth * width - 0.5
        v = np.clip(polar * height - 0.5, 0.0, height - 1.0)
        column = np.floor(u)
        fx = (u - column)[..., None]
        x0 = column.astype(np.intp) % width
        x1 = (x0 + 1) % width
        y0 = np.minimum(v.astype(np.intp), max(height, 2) - 2)
        fy = (v - y0)[..., None]
        y1 = np.minimum(y0 + 1, height - 1)
        top = table[y0, x0] + fx * (table[y0, x1] - table[y0, x0])
        bottom = table[y1, x0] + fx * (table[y1, x1] - table[y1, x0])
        value = top + fy * (bottom - top)
        return value[..., 0:3], value[..., 3:6], value[..., 6:12]

    def packed(self) -> tuple[np.ndarray, np.ndarray]:
        """The levels as the two tables ``wgsl/lighting/environment_prefilter_lookup.wgsl`` reads.

        Returns
        -------
        records : numpy.ndarray, shape (levels, 4), uint32
            Bound as ``prefiltered_levels: array<PrefilteredLevel>``: per level ``(W, H,
            first, 0)``, ``first`` the index of its texel (0, 0) among all levels' texels.
        texels : numpy.ndarray, shape (4 * texels, 4), float32
            Bound as ``prefiltered_texels: array<vec4<f32>>``: texel ``(x, y)`` of a level
            (row 0 at the top) is ``texels[4 (first + y W + x) + k]`` for ``k`` = 0..3:
            ``(radiance.rgb, 0)``, ``(mean.xyz, 0)``, ``(xx, yy, zz, 0)``, ``(xy, yz, zx, 0)``.

        Raises
        ------
        ValueError
            If a value overflows float32.
        """
        records = np.zeros((len(self.levels), 4), np.uint32)
        blocks, first = [], 0
        for k in range(len(self.levels)):
            height, width = self.radiance[k].shape[:2]
            records[k, :3] = width, height, first
            block = np.zeros((height * width, 4, 4))
            block[:, 0, :3] = self.radiance[k].reshape(-1, 3)
            block[:, 1, :3] = self.mean[k].reshape(-1, 3)
            block[:, 2, :3] = self.second[k][..., :3].reshape(-1, 3)
            block[:, 3, :3] = self.second[k][..., 3:].reshape(-1, 3)
            blocks.append(block.reshape(-1, 4))
            first += height * width
        with np.errstate(over="ignore"):
            texels = np.concatenate(blocks).astype(np.float32)
        if not np.isfinite(texels).all():
            raise ValueError("a prefiltered value is out of the float32 range of the packed "
                             "layout")
        return records, texels
