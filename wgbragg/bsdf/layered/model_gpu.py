"""Dispatch of the float32 single-reflection kernels (``wgsl/bsdf/layered/model_eval.wgsl``):
the GPU twins of :meth:`LayeredBragg.brdf` (eq 34), :meth:`LayeredBragg.sample` (eq 35) and
:meth:`LayeredBragg.pdf`, reached through ``backend="gpu"``.

This module builds the buffers of ``wgsl/bsdf/layered/model.wgsl`` once per structure and kind
and runs one invocation per pair ``(wi, wo)`` or sample ``(wi, u)``. The buffers, the
pipelines' specialisation, the wavelength tables, the loop budget and the RGB modes:
``docs/design.md``, "What the kernels are given".
"""

from __future__ import annotations

import dataclasses

import numpy as np

from wgbragg import gpu
from wgbragg.bsdf.layered.coating import HERO, INTEGRATED
from wgbragg.colour import colorimetry
from wgbragg.colour.landmark_methods_gpu import GPU_LANDMARK_METHODS, check_mirror, cmf_table
from wgbragg.common.sampling import ShiftedPoints
from wgbragg.optics import yeh_gpu

__all__ = [
    "FACTORED_COLOUR_METHODS",
    "LAYER_DTYPE",
    "OPERATIONS",
    "PARAMS_DTYPE",
    "WAVELENGTH_BLOCK_ITERATIONS",
    "WAVELENGTH_RANGE_NM",
    "benchmark",
    "brdf",
    "max_integrated_layers",
    "pdf",
    "sample",
    "wavelengths_per_invocation",
]

WORKGROUP_SIZE = 64

WAVELENGTH_RANGE_NM = colorimetry.WAVELENGTH_RANGE_NM
"""Wavelengths the GPU tables cover (nm, 1 nm apart): the colorimetry's nodes."""

FACTORED_COLOUR_METHODS = {**GPU_LANDMARK_METHODS, "reference": 3}
"""``colour_method`` values whose layer colours the kernel computes in place (factored RGB
without LUT), with their ``COLOUR_METHOD`` codes."""

OPERATIONS = {"brdf": "evaluate", "sample": "sample", "pdf": "density"}
"""Entry point of each operation in ``bsdf/layered/model_eval.wgsl``."""

LAYER_DTYPE = gpu.struct_dtype([
    ("n1", "f32"), ("n2", "f32"), ("d1_nm", "f32"), ("d2_nm", "f32"), ("host", "f32"),
    ("periods", "u32"), ("bulk", "u32"), ("_pad", "u32"),
    ("alpha", "f32"), ("rows", "u32"), ("rows_per_radian", "f32"),
    ("transmissivity", "u32"), ("transmissivity_mean", "u32"), ("transmissivity_rgb", "u32"),
    ("reflectance", "u32"), ("reflectance_rgb", "u32"),
    ("transmissivity_elsewhere", "u32"), ("_pad0", "u32"), ("_pad1", "u32"), ("_pad2", "u32"),
])
"""``RoughLayer`` of bsdf/layered/model.wgsl: 20 four-byte words (no padding in storage either)."""

PARAMS_DTYPE = gpu.struct_dtype([
    ("base_rgb", "vec3<f32>"), ("host", "f32"), ("base_mean", "f32"), ("first_layer", "u32"),
    ("base_spectrum", "u32"), ("lut_rows", "u32"), ("lut_rows_per_radian", "f32"),
    ("_pad0", "u32"), ("_pad1", "u32"), ("_pad2", "u32"),
    ("count", "u32"), ("wavelength_stride", "u32"), ("incoming_repeat", "u32"),
    ("operand_repeat", "u32"),
])
"""``Params`` of bsdf/layered/model_eval.wgsl: a ``LayeredStructure`` (48 bytes), then the batch."""

VISIBLE_NODES = 471
"""Nodes of the 1 nm wavelength axis, 360..830 nm (``VISIBLE_NODES`` of
``wgsl/bsdf/layered/model.wgsl``, checked by ``tests/test_wgsl_layouts.py``)."""

WAVELENGTH_BLOCK_ITERATIONS = 32768
"""Loop iterations one invocation spends on a multiplexed wavelength axis at most, fewer
where the device's loop budget asks (:func:`wgbragg.gpu.planned_loop_iterations`): longer
axes are split over dispatches, which bounds a dispatch's time also without a budget."""


def max_integrated_layers() -> int:
    """Most layers of a structure whose RGB the kernel integrates over the 471 nodes in one
    invocation (``colour_method="integrated"``, or ``"reference"`` without LUT) on this
    device: each node costs ``layers + 2`` loop iterations (:func:`wavelengths_per_invocation`)
    of the :func:`wgbragg.gpu.planned_loop_iterations` an invocation plans for; 67 under Mesa
    22's loop budget, 2224 without a budget."""
    return gpu.planned_loop_iterations() // VISIBLE_NODES - 2


def wavelengths_per_invocation(layers: int) -> int:
    """Most multiplexed wavelengths one invocation evaluates, for ``layers`` rough layers.

    An invocation plans for :data:`WAVELENGTH_BLOCK_ITERATIONS` loop iterations, or for
    :func:`wgbragg.gpu.planned_loop_iterations` where the device's loop budget allows fewer,
    and each wavelength takes one of the wavelength loop and ``layers + 1`` of the layer loop
    (its exit test counts; a single layer is unrolled), as Mesa 22's cuts confirm
    (``docs/performance.md``, "Layered structures").

    Parameters
    ----------
    layers : int
        Rough layers of the structure, >= 1.

    Returns
    -------
    int
    """
    iterations = min(WAVELENGTH_BLOCK_ITERATIONS, gpu.planned_loop_iterations())
    return max(1, iterations // (layers + 2))

# What a kernel reads besides the transmission probabilities: the spectral tables (spectral
# and integrated RGB results), the factored RGB tables, or nothing more (the density).
_SPECTRAL, _FACTORED, _DENSITY = "spectral", "factored", "density"


@dataclasses.dataclass(frozen=True)
class _Variant:
    """Buffers of one structure for one kind of table, and its structure-level constants."""

    layers: np.ndarray
    tables: np.ndarray
    node_colours: np.ndarray
    params: np.ndarray
    constants: dict
    _device: dict = dataclasses.field(default_factory=dict, repr=False, compare=False)

    def transmissivity_quads(self) -> np.ndarray:
        """The layers' transmissivity tables as cell corners, from ``tables``, after one
        unused quad (a buffer is never empty); that quad alone without
        ``TRANSMISSIVITY_QUADS``. Built here, not with the variant: the renderer, which
        reads ``tables``, never needs them."""
        quads = [np.zeros((1, 4), np.float32)]
        if self.constants["TRANSMISSIVITY_QUADS"]:
            for record in self.layers:
                start, rows = int(record["transmissivity"]), int(record["rows"])
                table = self.tables[start:start + rows * VISIBLE_NODES]
                quads.append(gpu.bilinear_quads(table.reshape(rows, VISIBLE_NODES)))
        return np.concatenate(quads)

    def device_tables(self) -> tuple[gpu.DeviceArray, ...]:
        """``tables``, ``node_colours`` and the transmissivity quads on the device, uploaded
        on first use: they are read-only and larger than a call's own inputs (2.7 MB of
        quads per layer spectral, against 1.2 MB of ``u`` for 80 000 samples)."""
        if "tables" not in self._device:
            self._device["tables"] = (
                gpu.DeviceArray.upload(self.tables, what="layer tables"),
                gpu.DeviceArray.upload(self.node_colours, what="node colours"),
                gpu.DeviceArray.upload(self.transmissivity_quads(),
                                       what="transmissivity quads"))
        return self._device["tables"]


def _kind(operation: str, wavelength, colour_method: str) -> str:
    if operation == "pdf":
        return _DENSITY
    spectral = wavelength is not None or colour_method in (INTEGRATED, HERO)
    return _SPECTRAL if spectral else _FACTORED


def gpu_variant(structure, kind: str, lut: bool, colour_method: str) -> _Variant:
    lut = lut and kind != _DENSITY
    key = ("gpu", kind, lut, colour_method if kind == _FACTORED and lut else None)
    return structure._cached(key, lambda: _build(structure, kind, lut, colour_method))


def _rgb_weights() -> np.ndarray:
    """The D65-weighted XYZ weights of the 1 nm nodes in linear sRGB, shape (471, 3)."""
    grid, weights = colorimetry.xyz_weights()
    if grid.size != VISIBLE_NODES or grid[0] != WAVELENGTH_RANGE_NM[0]:
        raise RuntimeError("bsdf/layered/model.wgsl assumes the 1 nm grid 360..830 nm")
    return weights @ colorimetry.XYZ_TO_LINEAR_SRGB.T


def _header() -> list[np.ndarray]:
    """The tables' fixed start: the CMF block, XYZ -> linear sRGB, the 1 nm XYZ weights in
    linear sRGB, the hero wavelengths' inverse CDF (its offsets are the WGSL constants
    ``SRGB_MATRIX``, ``RGB_WEIGHTS`` and ``HERO_INVERSE_CDF``, and its length
    ``colorimetry.HERO_SEGMENTS + 1``: ``tests/test_wgsl_layouts.py``,
    ``tests/test_layered_hero.py``)."""
    matrix = np.zeros((3, 4), np.float32)
    matrix[:, :3] = colorimetry.XYZ_TO_LINEAR_SRGB
    return [cmf_table().ravel(), matrix.ravel(), _rgb_weights().astype(np.float32).ravel(),
            colorimetry.hero_inverse_cdf()]


class _Blocks:
    """The ``tables`` buffer being built: float32 blocks, each appended at a known offset."""

    def __init__(self, blocks: list[np.ndarray]):
        self.blocks = blocks
        self.size = sum(block.size for block in blocks)

    def append(self, table) -> int:
        """Append ``table`` (flattened, float32) and return its offset in floats."""
        offset = self.size
        self.blocks.append(np.ascontiguousarray(table, np.float32).ravel())
        self.size += self.blocks[-1].size
        return offset


def _build(structure, kind: str, lut: bool, colour_method: str) -> _Variant:
    blocks = _Blocks(_header())
    records = _layer_records(structure, kind, lut, colour_method, blocks)
    params, node_colours = _params(structure, kind, blocks)
    quads = _transmissivity_quads(records, kind)
    tables = np.concatenate(blocks.blocks)
    for array in (tables, node_colours, records, params):
        array.setflags(write=False)
    return _Variant(records, tables, node_colours, params,
                    _structure_constants(structure, records, quads))


def _layer_records(structure, kind: str, lut: bool, colour_method: str,
                   blocks: _Blocks) -> np.ndarray:
    """The ``RoughLayer`` records, their tables appended to ``blocks``."""
    records = np.zeros(len(structure.layers), LAYER_DTYPE)
    for index, layer in enumerate(structure.layers):
        record = records[index]  # a view: structured scalars write through
        m = layer.mirror
        mirror = yeh_gpu.bragg_params(m.n1, m.n2, m.d1, m.d2, m.N, m.host)
        for name in ("n1", "n2", "d1_nm", "d2_nm", "host", "periods", "bulk"):
            record[name] = mirror[name]
        visible = layer._visible_table("gpu")
        theta_i = layer.filter.theta_i
        record["alpha"] = layer.alpha
        record["rows"] = theta_i.size
        record["rows_per_radian"] = 1.0 / (theta_i[1] - theta_i[0])
        record["transmissivity_mean"] = blocks.append(visible.mean(axis=1))
        if kind == _SPECTRAL:
            record["transmissivity"] = blocks.append(visible)
            if lut:
                record["reflectance"] = blocks.append(structure._reflectance_lut(index, "gpu"))
        elif kind == _FACTORED:
            weights = colorimetry.xyz_weights()[1]
            record["transmissivity_rgb"] = blocks.append(
                colorimetry.xyz_to_linear_srgb(visible @ weights))
            if lut:
                record["reflectance_rgb"] = blocks.append(
                    structure._reflectance_rgb_lut(index, "gpu", colour_method))
    return records


def _params(structure, kind: str, blocks: _Blocks) -> tuple[np.ndarray, np.ndarray]:
    """The structure's part of ``Params`` and the ``node_colours`` buffer; a spectral base
    albedo is appended to ``blocks``."""
    params = np.zeros((), PARAMS_DTYPE)
    base = structure._brdf_base()
    params["base_rgb"] = base.rgb
    params["host"] = structure.host_index
    params["base_mean"] = 0.0 if structure.absorbing_base else base.mean()
    lut_grid = structure._lut_grid()
    params["lut_rows"] = lut_grid.size
    params["lut_rows_per_radian"] = 1.0 / (lut_grid[1] - lut_grid[0])
    # Per 1 nm node, the rgb weights and the base's albedo in one vec4 (the hero colour reads
    # both at each of a sample's wavelengths: two vec4 loads for eight scalar ones).
    node_colours = np.zeros((VISIBLE_NODES, 4), np.float32)
    node_colours[:, :3] = _rgb_weights()
    if kind == _SPECTRAL and not structure.absorbing_base:
        albedo = base.spectrum(colorimetry.xyz_weights()[0])
        params["base_spectrum"] = blocks.append(albedo)
        node_colours[:, 3] = albedo
    return params, node_colours


def _transmissivity_quads(records: np.ndarray, kind: str) -> bool:
    """Whether the kernel reads the transmissivity tables as cell corners; if so, each
    record's offset into them is set."""
    # bsdf/layered/model_eval.wgsl reads the transmissivity tables as cell corners (one load per
    # lookup, not four) where they fit the budget: at 4x a table's size they need 2.7 MB per
    # layer at the filters' default resolution.
    cells = (records["rows"].astype(np.int64) - 1) * (VISIBLE_NODES - 1)
    quads = kind == _SPECTRAL and gpu.bilinear_quads_fit(1 + int(cells.sum()))
    if quads:
        records["transmissivity_elsewhere"] = 1 + np.concatenate([[0], np.cumsum(cells)[:-1]])
    return quads


def _structure_constants(structure, records: np.ndarray, quads: bool) -> dict:
    """The override constants that depend on the structure alone."""
    host_matched = all(np.float32(r["host"]) == np.float32(r["n1"]) for r in records)
    return {
        "LAYERS": len(structure.layers),
        "COATING": structure.has_coating,
        "BASE": int(not structure.absorbing_base),
        "HOST_MATCHED": host_matched,
        "MATCHED_LAYERS": host_matched and all(
            not r["bulk"] and np.float32(r["n2"]) >= np.float32(r["n1"]) for r in records),
        "WORKGROUP_SIZE": WORKGROUP_SIZE,
        "TRANSMISSIVITY_QUADS": quads,
    }


def _constants(variant: _Variant, kind: str, lut: bool, colour_method: str,
               wavelengths: int) -> dict:
    """Override constants of a request: only those its code paths read, so that requests
    differing elsewhere share a pipeline."""
    constants = {name: variant.constants[name]
                 for name in ("LAYERS", "COATING", "BASE", "HOST_MATCHED", "WORKGROUP_SIZE")}
    if kind == _DENSITY:
        return constants
    constants["LUT"] = lut
    constants["WAVELENGTHS"] = wavelengths
    constants["INTEGRATED"] = kind == _SPECTRAL
    constants["HERO"] = kind == _SPECTRAL and wavelengths == 0 and colour_method == HERO
    if kind == _SPECTRAL:
        constants["TRANSMISSIVITY_QUADS"] = variant.constants["TRANSMISSIVITY_QUADS"]
    if kind == _FACTORED and not lut:
        constants["COLOUR_METHOD"] = FACTORED_COLOUR_METHODS[colour_method]
        if colour_method in GPU_LANDMARK_METHODS:
            constants["MATCHED_LAYERS"] = variant.constants["MATCHED_LAYERS"]
    return constants


def _check_request(structure, wavelength, method: str, colour_method: str) -> None:
    layers = len(structure.layers)
    nodes_in_kernel = wavelength is None and (
        colour_method == INTEGRATED
        or (colour_method == "reference" and method != "single-reflection-lut"))
    most = max_integrated_layers() if nodes_in_kernel else layers
    if layers > most:
        raise ValueError(
            f"layers: backend='gpu' sums colour_method={colour_method!r} over "
            f"{VISIBLE_NODES} wavelengths in one invocation for 1 to {most} layers (the "
            f"device's loop budget), got {layers}: pass wavelength_nm and integrate, or use "
            "backend='numpy'")
    if wavelength is not None:
        low, high = WAVELENGTH_RANGE_NM
        if not np.all((wavelength >= low) & (wavelength <= high)):
            raise ValueError(f"backend='gpu' tabulates the model over {low:g}-{high:g} nm: "
                             "wavelength_nm must lie in that range (use backend='numpy' "
                             "outside it)")
        return
    if colour_method in (INTEGRATED, HERO) or method == "single-reflection-lut":
        return
    if colour_method not in FACTORED_COLOUR_METHODS:
        raise ValueError(
            f"backend='gpu' computes factored layer colours in the kernel with colour_method "
            f"in {tuple(FACTORED_COLOUR_METHODS)}, got {colour_method!r}: use one of them, or "
            "method='single-reflection-lut', which tabulates any colour method")
    if colour_method in GPU_LANDMARK_METHODS:
        for layer in structure.layers:
            check_mirror(layer.mirror, colour_method)


@dataclasses.dataclass(frozen=True)
class _Batch:
    """How a broadcast request maps onto invocations: ``count`` invocations over the leading
    shape ``invocations`` (the request's shape with a multiplexed axis kept as 1), each with
    ``wavelengths`` wavelengths (0: RGB) from ``wavelength`` (flat, ``stride`` per invocation)."""

    shape: tuple
    invocations: tuple
    count: int
    wavelengths: int
    wavelength: np.ndarray
    stride: int


def _multiplexed(direction_shape: tuple, wavelength) -> bool:
    """Whether the request's trailing axis holds wavelengths along which the directions do
    not vary."""
    shape = np.broadcast_shapes(direction_shape, wavelength.shape)
    padded = (1,) * (len(shape) - len(direction_shape)) + tuple(direction_shape)
    return len(shape) > 0 and padded[-1] == 1 and shape[-1] > 1


def _wavelength_parts(structure, direction_shape: tuple, wavelength) -> list:
    """``wavelength`` split along a multiplexed axis into parts that an invocation evaluates
    within its share of loop iterations (:func:`wavelengths_per_invocation`)."""
    if wavelength is None or not _multiplexed(direction_shape, wavelength):
        return [wavelength]
    step = wavelengths_per_invocation(len(structure.layers))
    return [wavelength[..., start:start + step]
            for start in range(0, wavelength.shape[-1], step)]


def _batch(direction_shape: tuple, wavelength) -> _Batch:
    if wavelength is None:
        count = int(np.prod(direction_shape, dtype=np.int64))
        return _Batch(direction_shape, direction_shape, count, 0, np.zeros(1, np.float32), 0)
    shape = np.broadcast_shapes(direction_shape, wavelength.shape)
    multiplexed = _multiplexed(direction_shape, wavelength)
    invocations = (*shape[:-1], 1) if multiplexed else shape
    per_invocation = shape[-1] if multiplexed else 1
    count = int(np.prod(invocations, dtype=np.int64))
    wl_padded = (1,) * (len(shape) - wavelength.ndim) + wavelength.shape
    if multiplexed and all(n == 1 for n in wl_padded[:-1]):
        # The same wavelengths for every invocation: upload them once.
        flat = np.ascontiguousarray(wavelength.reshape(-1), np.float32)
        stride = 0
    else:
        flat = np.ascontiguousarray(np.broadcast_to(wavelength, shape), np.float32).ravel()
        stride = per_invocation
    return _Batch(shape, invocations, count, per_invocation, flat, stride)


def _vec4(array, shape) -> np.ndarray:
    # Cast before broadcasting: a direction shared by many samples is converted once.
    array = np.asarray(array, np.float32)
    if array.shape == (*shape, 4) and array.flags.c_contiguous:
        return array.reshape(-1, 4)
    out = np.empty((*shape, 4), np.float32)
    out[..., :array.shape[-1]] = array
    if array.shape[-1] == 3:
        out[..., 3] = 0.0
    return out.reshape(-1, 4)


def _shared_vec4(array, shape) -> tuple[np.ndarray, int]:
    """``array`` (leading shape broadcast to ``shape``, one trailing axis) as vec4 rows without
    its trailing broadcast axes, and how many consecutive invocations share each row: a view
    direction shared by all of a pixel's samples is uploaded once, not once per sample."""
    leading = array.shape[:-1]
    padded = (1,) * (len(shape) - len(leading)) + leading
    kept = len(shape)
    while kept > 0 and padded[kept - 1] == 1:
        kept -= 1
    repeat = int(np.prod(shape[kept:], dtype=np.int64))
    compact = np.reshape(array, (*padded, array.shape[-1]))[(..., *(0,) * (len(shape) - kept),
                                                              slice(None))]
    return _vec4(compact, shape[:kept]), max(repeat, 1)


def _operand(second, invocations, sample: bool) -> tuple[np.ndarray, int, bool]:
    """The operand's vec4 rows (u32 words), ``operand_repeat``, and whether they are a
    shifted point set: a ``sample``'s :class:`ShiftedPoints` whose groups are the leading axes
    of ``invocations`` (a pixel's samples) goes as its points then its shifts, a few kB instead
    of 16 bytes per sample; any other operand as :func:`_shared_vec4`."""
    if isinstance(second, ShiftedPoints):
        if not sample or tuple(second.shape[:-1]) != tuple(invocations):
            second = second.values(np.float32)
        else:
            count, dims = second.points.shape
            rows = np.zeros((count + second.shifts.size // dims, 4), np.uint32)
            rows[:count, :dims] = second.points
            rows[count:, :dims] = second.shifts.reshape(-1, dims)
            return rows, count, True
    rows, repeat = _shared_vec4(second, invocations)
    return rows.view(np.uint32), repeat, False


def _setup(structure, operation: str, first, second, wavelength, batch: _Batch, method: str,
           colour_method: str):
    kind = _kind(operation, wavelength, colour_method)
    lut = method == "single-reflection-lut" and kind != _DENSITY
    variant = gpu_variant(structure, kind, lut, colour_method)
    params = variant.params.copy()
    params["count"], params["wavelength_stride"] = batch.count, batch.stride
    channels = 1 if operation == "pdf" else (batch.wavelengths or 3)
    directions = batch.count if operation == "sample" else 1
    incoming, params["incoming_repeat"] = _shared_vec4(first, batch.invocations)
    operand, params["operand_repeat"], shifted = _operand(second, batch.invocations,
                                                          operation == "sample")
    constants = _constants(variant, kind, lut, colour_method, batch.wavelengths)
    if operation == "sample":
        constants["SHIFTED_OPERAND"] = shifted
    kernel = gpu.compute_pipeline("bsdf/layered/model_eval.wgsl", OPERATIONS[operation], constants)
    inputs = [incoming, operand, batch.wavelength, variant.layers, *variant.device_tables()]
    outputs = [(batch.count * channels, np.float32), ((directions, 4), np.float32),
               (1, np.uint32)]
    return kernel, inputs, outputs, params


def _run(structure, operation, first, second, wavelength, batch, method, colour_method):
    if batch.count == 0:
        return np.zeros(0, np.float32), np.zeros((0, 4), np.float32)
    # Per invocation: two vec4 directions, its wavelengths (unless shared) and its values.
    channels = 1 if operation == "pdf" else (batch.wavelengths or 3)
    per_invocation = 4 * max(4, channels, batch.stride)
    step = max(1, gpu.max_buffer_bytes() // per_invocation)
    if batch.count <= step:
        return _dispatch(structure, operation, first, second, wavelength, batch, method,
                         colour_method)
    # More than the device's largest buffer holds: dispatch consecutive invocations apart
    # (a ShiftedPoints expanded here: beyond max_buffer_bytes / 16 samples per call).
    first, second = _vec4(first, batch.invocations), _vec4(second, batch.invocations)
    values, drawn = [], []
    for start in range(0, batch.count, step):
        stop = min(start + step, batch.count)
        part = dataclasses.replace(
            batch, invocations=(stop - start,), count=stop - start,
            wavelength=(batch.wavelength[start * batch.stride:stop * batch.stride]
                        if batch.stride else batch.wavelength))
        value, drawn_part = _dispatch(structure, operation, first[start:stop],
                                      second[start:stop], wavelength, part, method,
                                      colour_method)
        values.append(value)
        drawn.append(drawn_part)
    return np.concatenate(values), np.concatenate(drawn)


def _dispatch(structure, operation, first, second, wavelength, batch, method, colour_method):
    kernel, inputs, outputs, params = _setup(structure, operation, first, second, wavelength,
                                             batch, method, colour_method)
    value, drawn, cut = kernel.run(inputs, outputs, params, count=batch.count)
    thickest = max(layer.mirror.n1 * layer.mirror.d1 + layer.mirror.n2 * layer.mirror.d2
                   for layer in structure.layers)
    colour = f", colour_method={colour_method!r}" if batch.wavelengths == 0 else ""
    gpu.check_loops(cut, f"LayeredBragg.{operation} on {len(structure.layers)} layers with "
                         f"periods up to n1 d1 + n2 d2 = {thickest:g} nm{colour}")
    return value, drawn


def _values(value: np.ndarray, batch: _Batch) -> np.ndarray:
    value = value.astype(np.float64)
    if batch.wavelengths == 0:
        return value.reshape((*batch.shape, 3))
    return value.reshape(batch.shape)


def brdf(structure, wi, wo, wavelength, method: str, colour_method: str) -> np.ndarray:
    """Eq 34 by the float32 kernel; arguments as :meth:`LayeredBragg.brdf`, checked.

    Parameters
    ----------
    structure : LayeredBragg
    wi, wo : numpy.ndarray, shape (..., 3)
        Unit directions in air.
    wavelength : numpy.ndarray or None
        Wavelengths in nm, in 360-830; ``None`` for linear sRGB.
    method : {"single-reflection", "single-reflection-lut"}
    colour_method : str
        RGB: "integrated" (or "hero", :func:`sample` only); or factored, by a method of
        :data:`FACTORED_COLOUR_METHODS` (any colour method with the LUT).

    Returns
    -------
    numpy.ndarray
        float64 ``f`` in 1/sr, shaped as :meth:`LayeredBragg.brdf`'s result.
    """
    _check_request(structure, wavelength, method, colour_method)
    shape = np.broadcast_shapes(wi.shape[:-1], wo.shape[:-1])
    values = []
    for part in _wavelength_parts(structure, shape, wavelength):
        batch = _batch(shape, part)
        value, _ = _run(structure, "brdf", wi, wo, part, batch, method, colour_method)
        values.append(_values(value, batch))
    return values[0] if len(values) == 1 else np.concatenate(values, axis=-1)


def pdf(structure, wi, wo) -> np.ndarray:
    """:meth:`LayeredBragg.pdf` by the float32 kernel (1/sr), for checked unit directions."""
    batch = _batch(np.broadcast_shapes(wi.shape[:-1], wo.shape[:-1]), None)
    value, _ = _run(structure, "pdf", wi, wo, None, batch, "single-reflection", INTEGRATED)
    return value.astype(np.float64).reshape(batch.shape)


def sample(structure, wi, u, wavelength, method: str, colour_method: str):
    """Eq 35 and the chosen lobe by the float32 kernel; as :meth:`LayeredBragg.sample`.

    Parameters
    ----------
    structure : LayeredBragg
    wi : numpy.ndarray, shape (..., 3)
        Unit directions in air with ``z > 0``.
    u : numpy.ndarray, shape (..., 3), or (..., 4) with ``colour_method="hero"``
        Uniform numbers in [0, 1]; or :class:`ShiftedPoints`, whose groups, when they are the
        samples' leading shape, the kernel expands itself.
    wavelength, method, colour_method
        As for :func:`brdf`.

    Returns
    -------
    wo, weight, pdf : numpy.ndarray
        float64, shaped as :meth:`LayeredBragg.sample`'s results.
    """
    _check_request(structure, wavelength, method, colour_method)
    sample_shape = np.broadcast_shapes(wi.shape[:-1], u.shape[:-1])
    weights = []
    for part in _wavelength_parts(structure, sample_shape, wavelength):
        batch = _batch(sample_shape, part)
        # Every part draws the same directions from (wi, u): keep the first part's.
        value, drawn_part = _run(structure, "sample", wi, u, part, batch, method, colour_method)
        if not weights:
            drawn = _reduce(drawn_part.astype(np.float64).reshape((*batch.invocations, 4)),
                            sample_shape)
        weights.append(_values(value, batch))
    weight = weights[0] if len(weights) == 1 else np.concatenate(weights, axis=-1)
    return drawn[..., :3], weight, drawn[..., 3]


def _reduce(array: np.ndarray, shape: tuple) -> np.ndarray:
    """``array`` (leading shape broadcast from ``shape``, one trailing axis) back on ``shape``:
    along the axes that broadcasting added or stretched, the values repeat, so take the first."""
    extra = array.ndim - 1 - len(shape)
    index = (0,) * extra + tuple(slice(0, 1) if n == 1 else slice(None) for n in shape)
    return array[index].reshape((*shape, array.shape[-1]))


def benchmark(structure, operation: str, wi, second, wavelength=None,
              method: str = "single-reflection", colour_method: str = INTEGRATED,
              repeats: int = 5) -> float:
    """Median GPU seconds of one dispatch (buffers uploaded once), as the operations above.

    Parameters
    ----------
    structure : LayeredBragg
    operation : {"brdf", "sample", "pdf"}
    wi : array_like, shape (..., 3)
        Unit directions in air.
    second : array_like, shape (..., 3)
        ``wo`` (brdf, pdf) or ``u`` (sample; shape (..., 4) with ``colour_method="hero"``;
        or :class:`ShiftedPoints` of 3 or 4 numbers per point, expanded in the kernel).
    wavelength : array_like, optional
        nm, in 360-830; ``None``: RGB.
    method, colour_method
        As for :meth:`LayeredBragg.brdf`.
    repeats : int
        Timed dispatches.

    Returns
    -------
    float
        Seconds; ``count / seconds`` is the evaluation rate (pairs or samples per second).

    Raises
    ------
    ValueError
        As the operations, and for a multiplexed wavelength axis longer than
        :func:`wavelengths_per_invocation` (which the operations split over dispatches).
    """
    if operation not in OPERATIONS:
        raise ValueError(f"operation must be one of {tuple(OPERATIONS)}, got {operation!r}")
    wi = np.asarray(wi, np.float64)
    if not isinstance(second, ShiftedPoints):
        second = np.asarray(second, np.float64)
    wavelength = None if wavelength is None else np.asarray(wavelength, np.float64)
    _check_request(structure, wavelength, method, colour_method)
    if isinstance(second, ShiftedPoints) and (operation != "sample"
                                              or second.shape[-1] not in (3, 4)):
        raise ValueError("second: a ShiftedPoints is the u of operation='sample', 3 or 4 "
                         f"numbers per point; got operation={operation!r}, u shape "
                         f"{second.shape}")
    if colour_method == HERO and (operation != "sample" or second.shape[-1:] != (4,)):
        raise ValueError("colour_method='hero' is timed for operation='sample' with u of "
                         f"trailing length 4; got operation={operation!r}, u shape "
                         f"{second.shape}")
    shape = np.broadcast_shapes(wi.shape[:-1], second.shape[:-1])
    wavelength = None if operation == "pdf" else wavelength
    if len(_wavelength_parts(structure, shape, wavelength)) > 1:
        raise ValueError(
            f"wavelength: one dispatch evaluates 1 to "
            f"{wavelengths_per_invocation(len(structure.layers))} multiplexed wavelengths for "
            f"{len(structure.layers)} layers (an invocation's share of loop iterations), got "
            f"{np.broadcast_shapes(shape, wavelength.shape)[-1]}")
    batch = _batch(shape, wavelength)
    if batch.count == 0:
        return 0.0
    kernel, inputs, outputs, params = _setup(structure, operation, wi, second, wavelength,
                                             batch, method, colour_method)
    return kernel.benchmark(inputs, outputs, params, repeats=repeats, count=batch.count)
