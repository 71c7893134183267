"""Render pipelines (vertex + fragment), cached like compute pipelines.

:func:`render_pipeline` compiles a WGSL entry file (:func:`~wgbragg.gpu.shaders.load_shader`,
its ``//! if`` blocks resolved by the override constants) into a :class:`RenderKernel`, cached
by source, entry points, constants and output state. Bind group layouts are read from the
source's declarations, one per ``@group``, every binding visible to both stages:

- ``var<storage, read>`` buffers and ``var<uniform>`` structs,
- ``texture_2d<f32>`` textures (``rgba32float``, read with ``textureLoad``),
- ``texture_depth_2d_array`` textures and ``sampler_comparison`` samplers (shadow maps).

Vertices are pulled from storage buffers by ``@builtin(vertex_index)`` and
``@builtin(instance_index)``: pipelines take no vertex buffers.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping, Sequence
from typing import Any

import wgpu

from wgbragg.gpu.bindings import declared_bindings, layout_entry
from wgbragg.gpu.device import get_device
from wgbragg.gpu.shaders import ShaderCompileError, load_shader, shader_error
from wgbragg.gpu.specialise import BlockError, specialise

__all__ = ["RenderKernel", "render_pipeline"]

_STAGES = wgpu.ShaderStage.VERTEX | wgpu.ShaderStage.FRAGMENT

_cache: dict[tuple, RenderKernel] = {}


def _layouts(code: str) -> list[list[dict[str, Any]]]:
    """Layout entries of each bind group the source declares, in group order."""
    groups: dict[int, list] = {}
    for declared in declared_bindings(code):
        if declared.kind == "read_write":
            raise ValueError("render pipelines read storage buffers only (var<storage, read>)")
        groups.setdefault(declared.group, []).append(
            layout_entry(declared.binding, declared.kind, _STAGES))
    if sorted(groups) != list(range(len(groups))):
        raise ValueError(f"bind groups must be numbered 0..n-1, got {sorted(groups)}")
    return [groups[g] for g in sorted(groups)]


@dataclasses.dataclass(frozen=True)
class RenderKernel:
    """A compiled render pipeline: made by :func:`render_pipeline`.

    Attributes
    ----------
    pipeline : wgpu.GPURenderPipeline
    layouts : list of wgpu.GPUBindGroupLayout
        One per bind group, in group order.
    name, vertex, fragment : str
    """

    pipeline: Any
    layouts: list
    name: str
    vertex: str
    fragment: str | None

    def bind_group(self, group: int, resources: Sequence[Any]) -> Any:
        """A bind group of ``group`` binding ``resources`` in binding order: buffers (or
        objects with a ``resource`` buffer, such as :class:`wgbragg.gpu.DeviceArray`,
        whose textures are bound by a view), texture views and samplers."""
        entries = []
        for i, item in enumerate(resources):
            resource = getattr(item, "resource", item)
            if isinstance(resource, wgpu.GPUBuffer):
                resource = {"buffer": resource, "offset": 0, "size": resource.size}
            elif isinstance(resource, wgpu.GPUTexture):
                resource = resource.create_view()
            entries.append({"binding": i, "resource": resource})
        return get_device().create_bind_group(layout=self.layouts[group], entries=entries)


def render_pipeline(
    name: str | os.PathLike,
    vertex: str,
    fragment: str | None,
    constants: Mapping[str, float | int | bool] | None = None,
    *,
    targets: Sequence[str] = (),
    depth_format: str | None = "depth32float",
    depth_compare: str = "greater",
    depth_write: bool = True,
    samples: int = 1,
    cull_mode: str = "none",
) -> RenderKernel:
    """Compile (or fetch from the cache) a render pipeline of a WGSL file.

    Parameters
    ----------
    name : str or os.PathLike
        Entry file under the shader folder.
    vertex, fragment : str
        Entry points; ``fragment`` None for a depth-only pipeline.
    constants : mapping, optional
        Values of the source's ``override`` declarations (both stages), which also resolve
        its ``//! if`` blocks.
    targets : sequence of str
        Colour attachment formats, in ``@location`` order.
    depth_format, depth_compare, depth_write
        The depth attachment (None: none), its comparison and whether it is written.
    samples : int
        Multisampling of every attachment (1 or 4).
    cull_mode : {"none", "back", "front"}

    Raises
    ------
    ShaderCompileError
        If composition, compilation or pipeline creation fails.
    """
    source = load_shader(name)
    constants = dict(constants or {})
    key = (source.code, vertex, fragment, tuple(sorted(constants.items())), tuple(targets),
           depth_format, depth_compare, depth_write, samples, cull_mode)
    kernel = _cache.get(key)
    if kernel is not None:
        return kernel
    try:
        code = specialise(source.code, constants)
    except BlockError as exc:
        raise ShaderCompileError(*source.locate(exc.line), str(exc)) from None
    device = get_device()
    values = {k: float(v) for k, v in constants.items()}
    try:
        layouts = [device.create_bind_group_layout(entries=entries)
                   for entries in _layouts(code)]
    except ValueError as exc:
        raise ShaderCompileError(source.name, 1, str(exc)) from None
    try:
        module = device.create_shader_module(label=source.name, code=code)
        depth = None if depth_format is None else {
            "format": depth_format, "depth_write_enabled": depth_write,
            "depth_compare": depth_compare}
        pipeline = device.create_render_pipeline(
            label=f"{source.name}:{vertex}/{fragment}",
            layout=device.create_pipeline_layout(bind_group_layouts=layouts),
            vertex={"module": module, "entry_point": vertex, "buffers": [],
                    "constants": values},
            primitive={"topology": wgpu.PrimitiveTopology.triangle_list,
                       "cull_mode": cull_mode},
            depth_stencil=depth,
            multisample={"count": samples},
            fragment=None if fragment is None else {
                "module": module, "entry_point": fragment, "constants": values,
                "targets": [{"format": f} for f in targets]},
        )
    except wgpu.GPUError as exc:
        raise shader_error(dataclasses.replace(source, code=code), exc,
                           f"{vertex}/{fragment}") from None
    kernel = RenderKernel(pipeline, layouts, source.name, vertex, fragment)
    _cache[key] = kernel
    return kernel
