"""The shape of the code base: what import-linter (``make lint``) cannot see.

Layers and forbidden imports are import-linter contracts in ``pyproject.toml``; these tests check
the rest of the architecture rules: no function-level imports of our own modules, no private
names imported across modules, twins that share a stem, a twin test for every kernel entry
point, and a repository that stands alone.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "wgbragg"
SHADERS = ROOT / "wgsl"
MODULES = sorted(PACKAGE.rglob("*.py"))

LAZY_IMPORTS_ALLOWED = {PACKAGE / "app" / "cli.py", PACKAGE / "app" / "sweep_cli.py",
                        PACKAGE / "app" / "design_cli.py", PACKAGE / "app" / "info_cli.py",
                        PACKAGE / "app" / "export_cli.py"}
"""Modules that import our own modules inside functions: the CLI, whose commands import what
they run when they run."""

HELPER_SHADERS = {"gpu/harness.wgsl", "gpu/numerics.wgsl", "gpu/complex.wgsl", "optics/layer.wgsl"}
"""WGSL libraries of float32 helpers with no numpy twin."""

ENTRY_POINT_TWIN_TESTS = {
    "optics/yeh_reflectance.wgsl":
        "test_optics_gpu.py::test_mirror_matches_float64_on_a_dense_grid",
    "optics/thin_film_reflectance.wgsl":
        "test_optics_gpu.py::test_thin_film_matches_float64_pointwise",
    "optics/landmarks_eval.wgsl": "test_colour_landmarks_gpu.py::test_landmarks_match_numpy",
    "colour/reference_bragg.wgsl": "test_colour_reference.py::test_reference_gpu_matches_numpy",
    "colour/reference_film.wgsl": "test_colour_reference.py::test_reference_gpu_matches_numpy",
    "colour/landmark_methods_bragg.wgsl":
        "test_colour_landmarks_gpu.py::test_matches_numpy_on_the_issue_grid",
    "colour/grid_bragg.wgsl": "test_colour_grid.py::test_gpu_matches_numpy_on_the_issue_grid",
    "colour/thin_film_eval.wgsl": "test_thin_film_colour_gpu.py::test_fourier_gpu_matches_numpy",
    "bsdf/transmission_filter_bake.wgsl": "test_transmission_filter.py::test_gpu_matches_numpy",
    "bsdf/rough_layer_phases.wgsl":
        "test_rough_layer.py::test_gpu_table_of_a_resonant_mirror_matches_numpy",
    "bsdf/rough_layer_transmittance.wgsl": "test_rough_layer.py::test_gpu_table_matches_numpy",
    "bsdf/rough_layer_transmissivity.wgsl":
        "test_rough_layer.py::test_gpu_table_matches_numpy_on_any_grid",
    "bsdf/layered/model_eval.wgsl": "test_layered_gpu.py::test_brdf_spectral",
    "bsdf/layered/simulation.wgsl":
        "test_layered_simulation.py::test_single_ballistic_reproduces_the_model_without_variance",
    "lighting/environment_prefilter.wgsl": "test_environment_prefilter.py::test_gpu_matches_numpy",
    "render/renderer.wgsl": "test_render_ibl.py::test_the_gpu_shades_a_plane_as_its_float64_twin",
    "design/population_bragg.wgsl": "test_design.py::test_population_gpu_matches_numpy",
    "design/population_film.wgsl": "test_design.py::test_population_gpu_matches_numpy",
    "design/population_colour_bragg.wgsl":
        "test_design.py::test_population_colour_gpu_matches_numpy",
    "design/stack_population.wgsl":
        "test_design_stack_gpu.py::test_stack_kernel_matches_the_transfer_matrix_solver",
    # The loop-budget probe has no float64 twin: its test checks the iterations it counts
    # against the counts it was asked for.
    "gpu/loops_probe.wgsl": "test_gpu_harness.py::test_loop_budget_is_what_the_probe_kernel_shows",
}
"""Each compute entry point and the test that compares it with its float64 numpy twin."""


def _module_name(path: Path) -> str:
    return ".".join(path.relative_to(ROOT).with_suffix("").parts)


def _function_imports(tree: ast.AST):
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            for inner in ast.walk(node):
                if isinstance(inner, (ast.Import, ast.ImportFrom)):
                    yield inner


def _own(node) -> bool:
    if isinstance(node, ast.ImportFrom):
        return node.level > 0 or (node.module or "").split(".")[0] == "wgbragg"
    return any(alias.name.split(".")[0] == "wgbragg" for alias in node.names)


def test_the_package_top_holds_only_its_entry_files():
    top = sorted(p.name for p in PACKAGE.iterdir() if p.is_file())
    assert top == ["__init__.py", "_version.py"]


@pytest.mark.parametrize("path", MODULES, ids=_module_name)
def test_no_function_level_import_of_our_own_modules(path):
    if path in LAZY_IMPORTS_ALLOWED:
        return
    tree = ast.parse(path.read_text(encoding="utf-8"))
    lazy = [node.lineno for node in _function_imports(tree) if _own(node)]
    assert not lazy, f"{path.name}: function-level imports of wgbragg at lines {lazy}"


@pytest.mark.parametrize("path", MODULES, ids=_module_name)
def test_no_private_name_imported_across_modules(path):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    private = [
        f"{node.module}.{alias.name}"
        for node in ast.walk(tree) if isinstance(node, ast.ImportFrom) and _own(node)
        for alias in node.names
        if alias.name.startswith("_") and not alias.name.startswith("__")
    ]
    modules = [
        alias.name for node in ast.walk(tree) if isinstance(node, ast.Import) and _own(node)
        for alias in node.names if any(part.startswith("_") for part in alias.name.split(".")[1:])
    ]
    assert not private + modules


def test_relative_imports_are_not_used():
    relative = [_module_name(p) for p in MODULES
                if any(isinstance(n, ast.ImportFrom) and n.level
                       for n in ast.walk(ast.parse(p.read_text(encoding="utf-8"))))]
    assert not relative


def test_wgsl_mirrors_the_package_and_twins_share_a_stem():
    """Every WGSL library or entry point sits in the folder of its layer and starts with the
    stem of a Python module there (``optics/yeh_reflectance.wgsl`` beside ``optics/yeh.py``)."""
    orphans = []
    for shader in sorted(SHADERS.rglob("*.wgsl")):
        name = shader.relative_to(SHADERS).as_posix()
        if name in HELPER_SHADERS:
            continue
        folder = PACKAGE / shader.parent.relative_to(SHADERS)
        stems = [p.stem for p in folder.glob("*.py") if p.stem != "__init__"]
        if not any(shader.stem == s or shader.stem.startswith(s + "_") for s in stems):
            orphans.append(name)
    assert not orphans


def test_every_compute_entry_point_has_a_twin_test():
    entry_points = sorted(
        shader.relative_to(SHADERS).as_posix() for shader in SHADERS.rglob("*.wgsl")
        if re.search(r"^@compute", shader.read_text(encoding="utf-8"), re.MULTILINE)
    )
    assert entry_points == sorted(ENTRY_POINT_TWIN_TESTS)
    for shader, test in ENTRY_POINT_TWIN_TESTS.items():
        file, function = test.split("::")
        source = (ROOT / "tests" / file).read_text(encoding="utf-8")
        assert re.search(rf"^def {function}\(", source, re.MULTILINE), (shader, test)


def test_test_kernels_live_with_the_tests():
    assert not list(SHADERS.rglob("*test*"))
    assert sorted((ROOT / "tests" / "kernels").glob("*.wgsl"))


def test_the_repository_stands_alone():
    """Nothing cites the notes and papers kept outside the repository."""
    outside = "shared" + "/"
    suffixes = {".py", ".wgsl", ".md", ".toml", ".txt", ".cfg", ".sh", ""}
    citing = []
    for path in ROOT.rglob("*"):
        parts = path.relative_to(ROOT).parts
        if (not path.is_file() or path.suffix not in suffixes
                or parts[0].startswith(".") or parts[0] in ("build", "dist", "out")):
            continue
        if outside in path.read_text(encoding="utf-8", errors="replace"):
            citing.append(path.relative_to(ROOT).as_posix())
    assert not citing
