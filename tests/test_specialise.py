"""Specialisation blocks (``//! if`` / ``//! else`` / ``//! endif``, wgbragg/gpu/specialise.py):
which lines each set of override constants keeps, and the errors of malformed blocks."""

from __future__ import annotations

import re

import pytest

from wgbragg import gpu
from wgbragg.gpu.specialise import BlockError, specialise

HEADER = (
    "override LAYERED: bool = false;\n"
    "override IBL: u32 = 0u;\n"
    "override EXPRESSION: u32 = 2u * 3u;\n"
    "const IBL_KNEIPHOF: u32 = 2u;\n"
)


def kept(body: str, **constants) -> list[str]:
    """The non-empty body lines that ``constants`` keep, directives excluded."""
    code = specialise(HEADER + body, constants)
    lines = code.split("\n")
    assert len(lines) == len((HEADER + body).split("\n")), "line numbers moved"
    return [line.strip() for line in lines[HEADER.count("\n"):]
            if line.strip() and not line.strip().startswith("//!")]


BLOCK = """\
a
//! if LAYERED
b
//! if IBL == IBL_KNEIPHOF || IBL == 1
c
//! else
d
//! endif
//! else
e
//! endif
f
"""


@pytest.mark.parametrize(("constants", "expected"), [
    ({}, ["a", "e", "f"]),  # defaults from the declarations
    ({"LAYERED": True}, ["a", "b", "d", "f"]),
    ({"LAYERED": True, "IBL": 2}, ["a", "b", "c", "f"]),
    ({"LAYERED": 1, "IBL": 1}, ["a", "b", "c", "f"]),
    ({"LAYERED": False, "IBL": 2}, ["a", "e", "f"]),
])
def test_nested_blocks_keep_the_branches_taken(constants, expected):
    assert kept(BLOCK, **constants) == expected


@pytest.mark.parametrize(("condition", "constants", "holds"), [
    ("!LAYERED", {}, True),
    ("!LAYERED", {"LAYERED": True}, False),
    ("LAYERED && IBL != 0", {"LAYERED": True, "IBL": 0}, False),
    ("LAYERED && IBL != 0u", {"LAYERED": True, "IBL": 2}, True),
    ("LAYERED || IBL == 2", {"IBL": 2}, True),
    ("LAYERED == true", {"LAYERED": True}, True),
    ("LAYERED != false", {}, False),
])
def test_conditions(condition, constants, holds):
    assert kept(f"//! if {condition}\nx\n//! endif\n", **constants) == (["x"] if holds else [])


@pytest.mark.parametrize(("body", "line", "message"), [
    ("//! if LAYERED\nx\n", 5, "without `//! endif`"),
    ("x\n//! endif\n", 6, "without `//! if`"),
    ("//! else\n", 5, "without `//! if`"),
    ("//! if LAYERED\n//! else\n//! else\n//! endif\n", 7, "second `//! else`"),
    ("//! if LAYERED\n//! endif LAYERED\n", 6, "takes no condition"),
    ("//! if\n//! endif\n", 5, "needs a condition"),
    ("//! if SPECTRAL\n//! endif\n", 5, "'SPECTRAL' is not an override"),
    ("//! if EXPRESSION == 6\n//! endif\n", 5, "its default is not an integer"),
    # Every atom is read, the ones that cannot change the outcome too.
    ("//! if !LAYERED || SPECTRAL\n//! endif\n", 5, "'SPECTRAL' is not an override"),
    ("//! if LAYERED && IBL == NOWHERE\n//! endif\n", 5, "'NOWHERE' is neither"),
    ("//! if !LAYERED ||\n//! endif\n", 5, "cannot read ''"),
    ("//! if LAYERED\n//! elif IBL == 2\n//! endif\n", 6, "unknown directive `//! elif`"),
    ("//! ifLAYERED\n", 5, "unknown directive `//! ifLAYERED`"),
    ("//! if !IBL == 2\n//! endif\n", 5, "cannot read '!IBL == 2'"),
    ("//! if LAYERED == trueu\n//! endif\n", 5, "'trueu' is neither"),
    ("//! if IBL == NOWHERE\n//! endif\n", 5, "'NOWHERE' is neither"),
    ("//! if IBL < 2\n//! endif\n", 5, "cannot read 'IBL < 2'"),
])
def test_malformed_blocks_are_located(body, line, message):
    with pytest.raises(BlockError, match=message) as info:
        specialise(HEADER + body, {})
    assert info.value.line == line


def test_a_value_set_by_the_pipeline_replaces_a_default_that_is_an_expression():
    assert kept("//! if EXPRESSION == 6\nx\n//! endif\n", EXPRESSION=6) == ["x"]


def test_a_const_declared_with_two_values_is_not_read():
    code = HEADER + ("fn a() { const K: u32 = 5u; }\nconst K: u32 = 2u;\n"
                     "//! if IBL == K\n//! endif\n")
    with pytest.raises(BlockError, match="'K' is neither"):
        specialise(code, {})


def test_constants_set_by_id():
    code = "@id(7) override FAST: bool = false;\n//! if FAST\nx\n//! endif\n"
    assert "x" in specialise(code, {"7": True}).split("\n")
    assert "x" not in specialise(code, {}).split("\n")


def test_declarations_in_comments_are_not_overrides():
    code = "// override GHOST: bool = true;\n//! if GHOST\n//! endif\n"
    with pytest.raises(BlockError, match="'GHOST' is not an override"):
        specialise(code, {})


def test_directives_inside_block_comments_are_comment_text():
    """WGSL block comments nest; a `//!` line inside one is neither a directive nor an error,
    and a declaration inside one is not an override."""
    body = ("/* disabled:\n//! if LAYERED\n  /* nested */ still inside\n//! bogus\n*/\n"
            "//! if LAYERED\nb\n//! endif\n/* override GHOST: bool = true; */\n"
            "// a line comment /* does not open a block\nc\n")
    assert kept(body) == ["/* disabled:", "/* nested */ still inside", "*/",
                          "/* override GHOST: bool = true; */",
                          "// a line comment /* does not open a block", "c"]
    assert kept(body, LAYERED=True)[-3:] == ["/* override GHOST: bool = true; */",
                                             "// a line comment /* does not open a block", "c"]
    with pytest.raises(BlockError, match="'GHOST' is not an override"):
        specialise(HEADER + body + "//! if GHOST\n//! endif\n", {})


SHIPPED = sorted(path.relative_to(gpu.shader_dir()).as_posix()
                 for path in gpu.shader_dir().rglob("*.wgsl") if "broken" not in path.name)
ENTRY_POINT = re.compile(r"^@(compute|vertex|fragment)\b", re.MULTILINE)


@pytest.mark.parametrize("name", SHIPPED)
def test_every_shipped_shader_specialises_with_its_defaults(name):
    """An entry point specialises on its own; a library whose blocks read the override
    constants of the kernels that include it specialises inside each of them."""
    source = gpu.load_shader(name)
    if ENTRY_POINT.search(source.code) or "//! if" not in source.code:
        assert specialise(source.code, {}).count("\n") == source.code.count("\n")
        return
    includers = [gpu.load_shader(other) for other in SHIPPED
                 if other != name and ENTRY_POINT.search(gpu.load_shader(other).code)
                 and name in {file for file, _ in gpu.load_shader(other).line_map}]
    assert includers, f"{name} has //! if blocks but no entry point includes it"
    for kernel in includers:
        assert specialise(kernel.code, {}).count("\n") == kernel.code.count("\n")


# ------------------------------------------------------------------ through the harness

KERNEL = """\
//! include "gpu/harness.wgsl"
override FAST: bool = false;
@group(0) @binding(0) var<storage, read_write> out: array<f32>;
@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    //! if FAST
    out[gid.x] = 1.0;
    //! else
    out[gid.x] = function_that_does_not_exist();
    //! endif
}
"""


@pytest.fixture
def tmp_shaders(tmp_path, monkeypatch):
    (tmp_path / "gpu").mkdir()
    (tmp_path / "gpu/harness.wgsl").write_text(
        (gpu.shader_dir() / "gpu/harness.wgsl").read_text(encoding="utf-8"), encoding="utf-8")
    monkeypatch.setattr(gpu.shaders, "shader_dir", lambda: tmp_path)  # load_shader's lookup
    return tmp_path


@pytest.mark.gpu
def test_pipelines_compile_only_the_branches_taken(tmp_shaders):
    import numpy as np

    (tmp_shaders / "blocks.wgsl").write_text(KERNEL, encoding="utf-8")
    (out,) = gpu.compute_pipeline("blocks.wgsl", constants={"FAST": True}).run(
        [], [(4, np.float32)])
    np.testing.assert_array_equal(out, 1.0)
    with pytest.raises(gpu.ShaderCompileError, match="function_that_does_not_exist") as info:
        gpu.compute_pipeline("blocks.wgsl", constants={"FAST": False})
    assert (info.value.file, info.value.line) == ("blocks.wgsl", 9)


@pytest.mark.gpu
def test_a_kernel_built_directly_resolves_its_blocks(tmp_shaders):
    import numpy as np

    (tmp_shaders / "blocks.wgsl").write_text(KERNEL, encoding="utf-8")
    kernel = gpu.Kernel(gpu.load_shader("blocks.wgsl"), "main",
                        {"WORKGROUP_SIZE": 64, "FAST": True})
    np.testing.assert_array_equal(kernel.run([], [(4, np.float32)])[0], 1.0)


@pytest.mark.gpu
def test_a_malformed_block_is_a_compile_error_at_its_directive(tmp_shaders):
    (tmp_shaders / "open.wgsl").write_text(KERNEL.replace("    //! endif\n", ""),
                                           encoding="utf-8")
    with pytest.raises(gpu.ShaderCompileError, match="without `//! endif`") as info:
        gpu.compute_pipeline("open.wgsl", constants={"FAST": True})
    assert (info.value.file, info.value.line) == ("open.wgsl", 6)
