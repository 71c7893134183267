"""The resource bindings a WGSL source declares, read from its text, and the bind group layout
entries for them: what compute and render pipelines build their explicit layouts from (so that
no declared binding is dropped, as ``layout="auto"`` would drop unused ones)."""

from __future__ import annotations

import dataclasses
import re
from typing import Any

import wgpu

from wgbragg.gpu.shaders import ShaderCompileError, ShaderSource
from wgbragg.gpu.specialise import strip_comments

__all__ = ["KINDS", "Binding", "compute_layout_entries", "convention_kinds", "declared_bindings",
           "layout_entry"]

KINDS = ("read", "read_write", "uniform", "texture", "depth_array", "comparison")
"""Kinds of :class:`Binding`: ``var<storage, read>``, ``var<storage, read_write>``,
``var<uniform>``, ``texture_2d<f32>`` (an ``rgba32float`` texture read with ``textureLoad``),
``texture_depth_2d_array`` and ``sampler_comparison``."""

_DECLARATION_RE = re.compile(
    r"@(group|binding)\s*\(\s*(\d+)\s*\)\s*@(group|binding)\s*\(\s*(\d+)\s*\)\s*var\s*"
    r"(?:<\s*(\w+)\s*(?:,\s*(\w+)\s*)?>\s*\w+\s*:|\w+\s*:\s*(\w+)(?:\s*<\s*(\w+)\s*>)?)")
_HANDLES = {("texture_2d", "f32"): "texture", ("texture_depth_2d_array", None): "depth_array",
            ("sampler_comparison", None): "comparison"}


@dataclasses.dataclass(frozen=True, order=True)
class Binding:
    """One declared binding: its group, its number and its kind (one of :data:`KINDS`, or
    ``"unsupported"``)."""

    group: int
    binding: int
    kind: str


def declared_bindings(code: str) -> list[Binding]:
    """Every ``@group(g) @binding(b) var`` declaration of ``code`` (comments ignored), sorted
    by group and number."""
    found = []
    for m in _DECLARATION_RE.finditer(strip_comments(code)):
        attrs = {m.group(1): int(m.group(2)), m.group(3): int(m.group(4))}
        if m.group(5) is not None:
            space, access = m.group(5), m.group(6) or "read"
            kind = {"storage": access, "uniform": "uniform"}.get(space, "unsupported")
        else:
            kind = _HANDLES.get((m.group(7), m.group(8)), "unsupported")
        found.append(Binding(attrs.get("group", -1), attrs.get("binding", -1),
                             kind if kind in KINDS else "unsupported"))
    return sorted(found)


def layout_entry(binding: int, kind: str, visibility: int) -> dict[str, Any]:
    """The bind group layout entry of a binding of ``kind`` seen by the ``visibility`` stages."""
    entry = {"binding": binding, "visibility": visibility}
    buffers = {"read": wgpu.BufferBindingType.read_only_storage,
               "read_write": wgpu.BufferBindingType.storage,
               "uniform": wgpu.BufferBindingType.uniform}
    if kind in buffers:
        return entry | {"buffer": {"type": buffers[kind]}}
    if kind == "texture":
        return entry | {"texture": {"sample_type": wgpu.TextureSampleType.unfilterable_float,
                                    "view_dimension": "2d"}}
    if kind == "depth_array":
        return entry | {"texture": {"sample_type": wgpu.TextureSampleType.depth,
                                    "view_dimension": "2d-array"}}
    if kind == "comparison":
        return entry | {"sampler": {"type": wgpu.SamplerBindingType.comparison}}
    raise ValueError(f"binding {binding}: unsupported declaration ({kind})")


def convention_kinds(source: ShaderSource) -> str:
    """One letter per binding of a compute kernel's ``source``, checked against the harness's
    convention (:mod:`wgbragg.gpu.pipelines`, "Binding convention"): ``r`` storage read, ``t``
    texture_2d<f32>, ``w`` storage read_write, ``u`` uniform.

    Raises
    ------
    ShaderCompileError
        Where the declarations break the convention, at the first binding's line.
    """
    code = strip_comments(source.code)
    found = [(b.binding, b.group, b.kind) for b in declared_bindings(code)]

    def fail(detail: str) -> ShaderCompileError:
        line = code.count("\n", 0, code.find("@binding")) + 1 if "@binding" in code else 1
        return ShaderCompileError(*source.locate(line), f"binding convention: {detail}")

    if len(found) != len(re.findall(r"@binding\s*\(", code)) or any(
            kind not in ("read", "read_write", "uniform", "texture") for *_, kind in found):
        raise fail(
            "only var<storage, read>, var<storage, read_write> and var<uniform> buffers and "
            "texture_2d<f32> textures"
        )
    if [b for b, _, _ in found] != list(range(len(found))) or any(g != 0 for _, g, _ in found):
        raise fail(f"bindings must be @group(0) @binding(0..n-1), got {found}")
    letters = {"read": "r", "texture": "t", "read_write": "w", "uniform": "u"}
    kinds = "".join(letters.get(k, "?") for *_, k in found)
    if re.fullmatch(r"[rt]*w*u?", kinds) is None:
        raise fail(
            "order must be inputs (read, texture_2d<f32>), outputs (read_write), "
            f"params (uniform); got {found}"
        )
    return kinds


def compute_layout_entries(kinds: str) -> list[dict[str, Any]]:
    """Bind group layout entries for bindings of ``kinds``, one letter each as
    :func:`convention_kinds` gives them."""
    names = {"r": "read", "t": "texture", "w": "read_write", "u": "uniform"}
    return [layout_entry(i, names[k], wgpu.ShaderStage.COMPUTE) for i, k in enumerate(kinds)]
