"""Values shared by Python and WGSL: struct layouts and constants read from the shader source.

A kernel's uniform or storage struct is written on the host as a numpy structured dtype, and a
WGSL ``const`` (or an ``override``'s default, where some pipelines rely on it) may restate a
Python constant. These tests read the composed WGSL (includes resolved, no device needed) and
check each such pair, so that neither side can change alone. Values that can vary per pipeline
are passed as ``override`` constants instead and need no entry here.
"""

from __future__ import annotations

import inspect
import re
from pathlib import Path

import numpy as np
import pytest

from wgbragg import gpu
from wgbragg.bsdf import rough_layer, transmission_filter
from wgbragg.bsdf.layered import model_gpu, simulation
from wgbragg.colour import colorimetry, grid_gpu, landmark_methods, landmark_methods_gpu, thin_film
from wgbragg.colour import thin_film_gpu as colour_thin_film_gpu
from wgbragg.lighting import environment_map, environment_prefilter, ibl
from wgbragg.optics import landmarks, thin_film_gpu, yeh_gpu
from wgbragg.render import packing_geometry

ENVIRONMENT_MAP = str(Path(__file__).parent / "kernels" / "environment_map_eval.wgsl")
"""A kernel that includes ``lighting/environment_map.wgsl`` (the library has no entry point)."""

_STRUCT = re.compile(r"^struct (\w+) \{(.*?)^\}", re.MULTILINE | re.DOTALL)
_FIELD = re.compile(r"(\w+)\s*:\s*([\w<>]+)")
_DECLARATION = re.compile(r"^(?:const|override) (\w+)\s*:\s*([\w<>]+)\s*=\s*(.*?);",
                          re.MULTILINE | re.DOTALL)
_TYPES = {"f32": (4, 4), "u32": (4, 4), "i32": (4, 4)}
_VECTORS = {2: (8, 8), 3: (16, 12), 4: (16, 16)}
_NUMPY = {"f32": "<f4", "u32": "<u4", "i32": "<i4"}


def _source(shader: str) -> str:
    return gpu.load_shader(shader).code


def _structs(code: str) -> dict[str, list[tuple[str, str]]]:
    return {name: _FIELD.findall(re.sub(r"//[^\n]*", "", body))
            for name, body in _STRUCT.findall(code)}


def _layout(structs, name: str):
    """Leaf fields ``(name, offset, type)`` of struct ``name`` by WGSL's alignment rules
    (nested structs flattened), its alignment and its size."""
    leaves, offset, align = [], 0, 4
    for field, kind in structs[name]:
        if kind in structs:
            inner, field_align, size = _layout(structs, kind)
        else:
            vector = re.fullmatch(r"vec([234])<(\w+)>", kind)
            field_align, size = _VECTORS[int(vector.group(1))] if vector else _TYPES[kind]
            inner = [(field, 0, kind)]
        offset = -(-offset // field_align) * field_align
        leaves += [(leaf, offset + at, leaf_kind) for leaf, at, leaf_kind in inner]
        offset += size
        align = max(align, field_align)
    return leaves, align, -(-offset // align) * align


def _dtype_fields(dtype: np.dtype):
    fields = []
    for name in dtype.names:
        field, offset = dtype.fields[name][:2]
        if field.subdtype is None:
            kind = {v: k for k, v in _NUMPY.items()}[field.str]
        else:
            base, (n,) = field.subdtype
            kind = f"vec{n}<{ {v: k for k, v in _NUMPY.items()}[base.str] }>"
        fields.append((name, offset, kind))
    return fields


STRUCTS = [
    (yeh_gpu.BRAGG_MIRROR_DTYPE, "optics/yeh_reflectance.wgsl", "BraggMirror"),
    (thin_film_gpu.THIN_FILM_DTYPE, "optics/thin_film_reflectance.wgsl", "ThinFilm"),
    (landmark_methods_gpu.PARAMS_DTYPE, "colour/landmark_methods_bragg.wgsl",
     "LandmarkColourParams"),
    (colour_thin_film_gpu.PARAMS_DTYPE, "colour/thin_film_eval.wgsl", "FilmColourParams"),
    (transmission_filter.BAKE_PARAMS_DTYPE, "bsdf/transmission_filter_bake.wgsl", "BakeParams"),
    (rough_layer._PARAMS_DTYPE, "bsdf/rough_layer_transmissivity.wgsl", "TransmissivityParams"),
    (model_gpu.LAYER_DTYPE, "bsdf/layered/model_eval.wgsl", "RoughLayer"),
    (model_gpu.PARAMS_DTYPE, "bsdf/layered/model_eval.wgsl", "Params"),
    (simulation._LAYER_DTYPE, "bsdf/layered/simulation.wgsl", "Layer"),
    (simulation._PARAMS_DTYPE, "bsdf/layered/simulation.wgsl", "SimulationParams"),
    (environment_prefilter.PARAMS_DTYPE, "lighting/environment_prefilter.wgsl",
     "PrefilterParams"),
    (environment_prefilter._ROW_DTYPE, "lighting/environment_prefilter.wgsl", "OutputRow"),
    (environment_prefilter._COLUMN_DTYPE, "lighting/environment_prefilter.wgsl",
     "OutputColumn"),
]


@pytest.mark.parametrize(("dtype", "shader", "struct"), STRUCTS,
                         ids=[f"{shader}:{struct}" for _, shader, struct in STRUCTS])
def test_struct_dtype_matches_the_wgsl_struct(dtype, shader, struct):
    """Same fields (padding aside) at the same offsets with the same types, and the same size
    rounded to 16 bytes as numpy's structs are."""
    leaves, _, size = _layout(_structs(_source(shader)), struct)
    named = [leaf for leaf in leaves if not leaf[0].startswith("_pad")]
    python = [field for field in _dtype_fields(dtype) if not field[0].startswith("_pad")]
    assert python == named
    assert dtype.itemsize == max(16, -(-size // 16) * 16)


def _declarations(shader: str) -> dict[str, tuple[str, str]]:
    return {name: (kind, value.strip())
            for name, kind, value in _DECLARATION.findall(_source(shader))}


def _value(shader: str, name: str):
    """The value of a WGSL ``const`` or ``override`` default: a number, a vector as an array,
    or an expression of integers and earlier constants."""
    declarations = _declarations(shader)
    kind, text = declarations[name]
    vector = re.fullmatch(r"vec\d<\w+>\((.*)\)", text, re.DOTALL)
    if vector:
        return np.array([float(v) for v in vector.group(1).split(",")])
    if text in ("true", "false"):
        return text == "true"
    names = {other: _value(shader, other) for other in re.findall(r"[A-Z_][A-Z0-9_]+", text)}
    expression = re.sub(r"\b(\d+)[ui]\b", r"\1", text)
    value = eval(expression, {"__builtins__": {}}, names)  # our own shaders: literals, + and *
    return int(value) if kind in ("u32", "i32") else float(value)


def _f32(value) -> np.ndarray:
    return np.asarray(value, np.float32)


def _subdivided_default() -> int:
    """``s`` of "subdivided" by default, which the layered model's factored colour uses."""
    return inspect.signature(landmark_methods_gpu.subdivided_xyz).parameters["s"].default


def _environment_header_rows() -> int:
    """Rows before the map's rows: all but its H rows, H W texels and H W densities, 4 a row."""
    height, width = 3, 5
    packed = environment_map.EnvironmentMap(np.ones((height, width, 3))).packed()
    return packed.shape[0] - height - height * width - -(-height * width // 4)


def _hero_inverse_cdf_offset() -> int:
    blocks = model_gpu._header()
    return sum(block.size for block in blocks[:-1])


CONSTANTS = [
    # Landmarks: the searched range and the kinds' codes.
    ("optics/landmarks_eval.wgsl", "OMEGA_LO", _f32(landmarks.VISIBLE_OMEGA[0])),
    ("optics/landmarks_eval.wgsl", "OMEGA_HI", _f32(landmarks.VISIBLE_OMEGA[1])),
    ("optics/landmarks_eval.wgsl", "LAMBDA_LO_NM", colorimetry.WAVELENGTH_RANGE_NM[0]),
    ("optics/landmarks_eval.wgsl", "LAMBDA_HI_NM", colorimetry.WAVELENGTH_RANGE_NM[1]),
    *(("optics/landmarks_eval.wgsl", f"KIND_{kind.upper()}", landmarks.KINDS.index(kind))
      for kind in landmarks.KINDS),
    # Landmark colour methods.
    ("colour/landmark_methods_bragg.wgsl", "PANEL_NM", landmark_methods.PANEL_NM),
    ("colour/landmark_methods_bragg.wgsl", "PANEL_MARGIN", _f32(landmark_methods.PANEL_MARGIN)),
    ("colour/landmark_methods_bragg.wgsl", "PHASE_SNAP", _f32(landmark_methods.PHASE_SNAP)),
    ("colour/landmark_methods_bragg.wgsl", "EXACT_MIN_OSCILLATION_NM",
     _f32(landmark_methods.EXACT_MIN_OSCILLATION_NM)),
    ("colour/landmark_methods_bragg.wgsl", "AVERAGING_MIN_PERIODS",
     landmark_methods.AVERAGING_MIN_PERIODS),
    ("colour/landmark_methods_bragg.wgsl", "PANELS_PER_OSCILLATION",
     landmark_methods.PANELS_PER_OSCILLATION),
    ("colour/landmark_methods_bragg.wgsl", "GAUSS_OFFSET",
     _f32(landmark_methods._GAUSS_NODES[2] - 0.5)),
    ("colour/landmark_methods_bragg.wgsl", "GAUSS_OUTER", _f32(landmark_methods._GAUSS_WEIGHTS[0])),
    ("colour/landmark_methods_bragg.wgsl", "GAUSS_INNER", _f32(landmark_methods._GAUSS_WEIGHTS[1])),
    *(("colour/landmark_methods_bragg.wgsl", f"METHOD_{name.upper()}", code)
      for name, code in landmark_methods_gpu.GPU_LANDMARK_METHODS.items()),
    ("colour/landmark_methods_bragg.wgsl", "CMF_NODES",
     landmark_methods_gpu.cmf_table().shape[0] // 2),
    # The grid quadrature's per-angle modes.
    ("colour/grid_bragg.wgsl", "MODE_EXACT", grid_gpu.MODE_EXACT),
    ("colour/grid_bragg.wgsl", "MODE_AVERAGED", grid_gpu.MODE_AVERAGED),
    ("colour/grid_bragg.wgsl", "MODE_TOTAL", grid_gpu.MODE_TOTAL),
    # Thin-film colour: where the series hands over to exact integration.
    ("colour/thin_film_eval.wgsl", "TAIL_LOW", _f32(thin_film.TAIL_RANGE[0])),
    ("colour/thin_film_eval.wgsl", "TAIL_HIGH", _f32(thin_film.TAIL_RANGE[1])),
    ("colour/thin_film_eval.wgsl", "EXACT_OPD_SHORT_NM", thin_film.EXACT_OPD_RANGE_NM[0]),
    ("colour/thin_film_eval.wgsl", "EXACT_OPD_LONG_NM", thin_film.EXACT_OPD_RANGE_NM[1]),
    # Rough layers: cell means and the product pass's blocks.
    ("bsdf/rough_layer_transmittance.wgsl", "RESOLVED", _f32(rough_layer._RESOLVED)),
    ("bsdf/rough_layer_transmittance.wgsl", "UNRESOLVED", _f32(rough_layer._UNRESOLVED)),
    ("bsdf/rough_layer_transmissivity.wgsl", "ROWS", rough_layer._ROWS_PER_GROUP),
    ("bsdf/rough_layer_transmissivity.wgsl", "SPAN", rough_layer._WAVELENGTHS_PER_LANE),
    # The layered model's tables and codes.
    ("bsdf/layered/model_eval.wgsl", "VISIBLE_NODES", model_gpu.VISIBLE_NODES),
    ("bsdf/layered/model_eval.wgsl", "SRGB_MATRIX", landmark_methods_gpu.cmf_table().size),
    ("bsdf/layered/model_eval.wgsl", "RGB_WEIGHTS", landmark_methods_gpu.cmf_table().size + 12),
    ("bsdf/layered/model_eval.wgsl", "HERO_INVERSE_CDF", _hero_inverse_cdf_offset()),
    ("bsdf/layered/model_eval.wgsl", "COLOUR_REFERENCE",
     model_gpu.FACTORED_COLOUR_METHODS["reference"]),
    ("bsdf/layered/model_eval.wgsl", "SUBDIVISIONS", _subdivided_default()),
    ("bsdf/layered/simulation.wgsl", "FIRST_NM", colorimetry.WAVELENGTH_RANGE_NM[0]),
    # The BVH traversal: its stack and the node texture's rows.
    ("render/renderer_scene.wgsl", "STACK_SIZE", packing_geometry._STACK_SIZE),
    ("render/renderer_scene.wgsl", "NODE_TEXTURE_WIDTH", packing_geometry.NODE_TEXTURE_WIDTH),
    ("render/renderer_scene.wgsl", "SHAPE_TEXTURE_WIDTH", packing_geometry.SHAPE_TEXTURE_WIDTH),
    # Filtered image-based lighting: the microfacet albedo table.
    ("lighting/ibl.wgsl", "IBL_ALBEDO_NODES", ibl.ALBEDO_TABLE_NODES),
    # Environment maps.
    (ENVIRONMENT_MAP, "ENVIRONMENT_ROWS", _environment_header_rows()),
    (ENVIRONMENT_MAP, "ENVIRONMENT_BELOW_ONE", np.nextafter(np.float32(1.0), np.float32(0.0))),
]


ONE_ULP = {"GAUSS_OFFSET": 1}
"""Constants whose WGSL literal is a float32 off the rounding of the Python value: sqrt(0.6) / 2
written to eight digits (0.38729833) is one ulp below it. Kept, so that colours stay as they
are; the comparison allows that ulp and no more."""


@pytest.mark.parametrize(("shader", "name", "expected"), CONSTANTS,
                         ids=[name for _, name, _ in CONSTANTS])
def test_wgsl_constant_matches_python(shader, name, expected):
    """Compared at the WGSL type's precision: a float32 constant as the float32 rounding of
    the Python value."""
    kind = _declarations(shader)[name][0]
    value = _value(shader, name)
    if kind.startswith("vec") or kind == "f32":
        np.testing.assert_array_max_ulp(_f32(value), _f32(expected), ONE_ULP.get(name, 0))
    else:
        assert value == expected


def test_the_product_pass_is_written_out_for_rows_and_span():
    """``ROWS`` and ``SPAN`` of the transmissivity product are written out in the kernel (four
    weight matrices of four rows, one sum per wavelength), not loops: their counts in the
    source are the constants' values."""
    code = (gpu.shader_dir() / "bsdf/rough_layer_transmissivity.wgsl").read_text()
    span = _value("bsdf/rough_layer_transmissivity.wgsl", "SPAN")
    rows = _value("bsdf/rough_layer_transmissivity.wgsl", "ROWS")
    assert len(re.findall(r"var s\d+ = mat4x4<f32>\(\);", code)) == span
    assert 4 * len(re.findall(r"let w\d = weight_rows\(", code)) == rows
