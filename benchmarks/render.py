"""Throughput of the GPU renderer.

Measures, in one run on the same device:

- **samples per second** of every built-in preset (:data:`wgbragg.scene.model.PRESETS`) at 512 x 512
  in RGB and in spectral mode, and the GPU memory each scene holds
  (:attr:`wgbragg.Renderer.gpu_bytes`);
- **time to SMAPE 0.05**: for the ``teapot`` preset, wall-clock time until the running image is
  within SMAPE 0.05 (:func:`wgbragg.common.metrics.smape`) of a high-spp reference of the same mode,
  in RGB and in spectral mode (samples doubling from 1 spp; the SMAPE checks not counted), and
  the SMAPE between the two references (the RGB model's colour error);
- **what a scene costs by what it holds**: one sphere of a near-smooth single Bragg layer
  (alpha = 0.01, no coating, absorbing base) against one of three layers under a coating over a
  Lambertian base: the pipelines are specialised per configuration;
- **the interactive preview**: frames per second at 256 x 256 and 1 sample per pixel, each
  frame read back (what a window shows), for the single-layer ``fig7`` preset (target >= 10
  on lavapipe, 2 cores);
- **scale**: a mesh of about 1.3 million triangles (an icosphere written to a PLY file): time
  from the scene to a ready renderer (mesh loading, world transform, BVH build, uploads;
  target <= 10 s for the BVH), its BVH build alone, its first 256 x 256 pass and a later one
  (:func:`large_mesh_times`). The first pass is apart because lavapipe compiles a kernel
  with LLVM at its first dispatch, not when the pipeline is made: seconds on Mesa 25, unless
  Mesa's shader cache on disk holds it from an earlier process (docs/performance.md, "The
  large mesh on two drivers").

It prints a markdown section and writes it into ``docs/benchmarks.md`` between
``<!-- bench_render:begin -->`` and ``<!-- bench_render:end -->`` (full mode).

Usage::

    python -m benchmarks.render                # full run (a few minutes)
    python -m benchmarks.render --quick        # tiny sizes (seconds), print only
"""

from __future__ import annotations

import dataclasses
import statistics
import sys
import tempfile
import time
import warnings
from collections.abc import Sequence
from pathlib import Path

from benchmarks import report
from benchmarks.report import human_time, progress_bar, yes_no
from benchmarks.report import markdown_table as _table

__all__ = ["BEGIN_MARKER", "END_MARKER", "FULL", "QUICK", "Config", "large_mesh_times", "main",
           "run_benchmarks"]

MODULE = "benchmarks.render"
BEGIN_MARKER, END_MARKER = report.markers("bench_render")
TARGET_FPS = 10.0
TARGET_BVH_S = 10.0
LATER_PASSES = 3
"""Passes after the large mesh's first, whose median is its pass time."""

# Two spheres that differ only in what their material holds.
_SPHERE_SCENE = """
[settings]
size = [64, 64]
[camera]
position = [0.0, 0.0, 4.0]
look_at = [0.0, 0.0, 0.0]
fov_deg = 35.0
[environment]
type = "sky"
{materials}
[[objects]]
shape = "{shape}"
{path}
material = "m"
"""
_SMOOTH = """
[materials.m]
type = "layered-bragg"
[[materials.m.layers]]
n1 = 1.0
n2 = 1.5
d1_nm = 250.0
d2_nm = 250.0
N = 10
alpha = 0.01
"""
_THREE_COATED = """
[materials.m]
type = "layered-bragg"
base_albedo = 0.3
""" + "".join(f"""
[[materials.m.layers]]
n1 = 1.35
n2 = 1.6
period_nm = {period}
delta = 0.5
N = 8
alpha = {alpha}
""" for period, alpha in ((180.0, 0.05), (220.0, 0.1), (260.0, 0.2)))
_LAMBERTIAN = """
[materials.m]
type = "lambertian"
albedo = 0.7
"""


@dataclasses.dataclass(frozen=True)
class Config:
    """Sizes of one run: preset image size and passes, convergence image size and reference
    spp, preview size and frames, the mesh's icosphere subdivisions (8: 1.3 M triangles) and
    the size of its one pass."""

    name: str
    size: int
    passes: int
    convergence_size: int
    reference_spp: int
    preview_size: int
    preview_frames: int
    subdivisions: int
    mesh_size: int


FULL = Config("full", size=512, passes=4, convergence_size=96, reference_spp=2048,
              preview_size=256, preview_frames=30, subdivisions=8, mesh_size=256)
QUICK = Config("quick", size=24, passes=1, convergence_size=8, reference_spp=16,
               preview_size=16, preview_frames=2, subdivisions=3, mesh_size=16)
TARGET_SMAPE = 0.05
MODES = ("rgb", "spectral")


def _scene_file(folder: Path, name: str, materials: str, shape: str = "sphere",
                path: str = "") -> Path:
    file = folder / f"{name}.toml"
    file.write_text(_SPHERE_SCENE.format(materials=materials, shape=shape, path=path),
                    encoding="utf-8")
    return file


def _throughput(renderer, passes: int) -> float:
    """Samples per second of ``passes`` passes, after one untimed pass."""
    renderer.render(1)
    start = time.perf_counter()
    renderer.render(passes)
    return renderer.width * renderer.height * passes / (time.perf_counter() - start)


def _time_to_smape(make_renderer, reference, limit_spp: int) -> tuple[float, int, float]:
    """Render time until ``smape(image, reference) <= TARGET_SMAPE``, the spp then, and the
    SMAPE reached (the last one tried if ``limit_spp`` came first)."""
    from wgbragg.common.metrics import smape

    renderer = make_renderer(seed=12345)
    elapsed, step = 0.0, 1
    while True:
        start = time.perf_counter()
        image = renderer.render(step)
        elapsed += time.perf_counter() - start
        error = smape(image, reference)
        if error <= TARGET_SMAPE or renderer.passes >= limit_spp:
            return elapsed, renderer.passes, error
        step = min(renderer.passes, limit_spp - renderer.passes)


def large_mesh_times(subdivisions: int, size: int) -> dict[str, float]:
    """Time the large-mesh scene: an icosphere of ``20 * 4**subdivisions`` triangles, written
    to a PLY file and loaded as a Lambertian mesh, rendered at ``size`` x ``size``.

    The first pass is timed apart from the later ones: lavapipe compiles the render kernel
    with LLVM at its first dispatch (about 2 s on Mesa 25.0 and 0.6 s on Mesa 22.3 with an
    empty cache), which the later frames of a renderer do not pay. Mesa keeps compiled
    kernels in its shader cache on disk (``MESA_SHADER_CACHE_DIR``), so the first pass of a
    later process may skip it: which one it measured depends on that cache.

    Parameters
    ----------
    subdivisions : int
        The icosphere's subdivisions (8: 1,310,720 triangles).
    size : int
        Image side in pixels.

    Returns
    -------
    dict
        ``bvh_s`` (the BVH build alone), ``mesh_setup_s`` (scene to a ready renderer: PLY
        loading, world transform, BVH, uploads), ``mesh_first_pass_s`` (one pass, kernel
        compilation included), ``mesh_pass_s`` (the median of :data:`LATER_PASSES` passes
        after it), ``mesh_triangles`` and ``mesh_gpu_bytes``, in seconds and counts.
    """
    import trimesh

    from wgbragg.render.bvh import build_bvh
    from wgbragg.render.renderer import Renderer
    from wgbragg.scene import load_scene
    from wgbragg.scene.meshes import sphere_mesh

    times = {}
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        mesh = sphere_mesh(subdivisions)
        path = folder / "sphere.ply"
        trimesh.Trimesh(mesh.vertices, mesh.faces, process=False).export(path)
        start = time.perf_counter()
        build_bvh(mesh.vertices, mesh.faces)
        times["bvh_s"] = time.perf_counter() - start
        scene = load_scene(_scene_file(folder, "mesh", _LAMBERTIAN, "mesh",
                                       f'path = "{path.name}"'))
        start = time.perf_counter()
        renderer = Renderer(scene, size=(size, size))
        times["mesh_setup_s"] = time.perf_counter() - start
        passes = []
        for _ in range(1 + LATER_PASSES):
            start = time.perf_counter()
            renderer.render(1)
            passes.append(time.perf_counter() - start)
    times["mesh_first_pass_s"] = passes[0]
    times["mesh_pass_s"] = statistics.median(passes[1:])
    times["mesh_triangles"] = float(renderer.triangles)
    times["mesh_gpu_bytes"] = float(renderer.gpu_bytes)
    return times


def run_benchmarks(cfg: Config, progress: bool = True) -> dict:
    from wgbragg.common.metrics import smape
    from wgbragg.render.renderer import Renderer
    from wgbragg.scene import PRESETS, load_preset, load_scene

    meter = report.LoadMeter()
    results = {"presets": {}, "configurations": {}, "convergence": {}}
    size = (cfg.size, cfg.size)
    bar = progress_bar(total=len(PRESETS) + 6, show=progress, desc="renderer")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        for name in PRESETS:
            rates = []
            for mode in MODES:
                renderer = Renderer(load_preset(name), size=size, mode=mode)
                rates.append(_throughput(renderer, cfg.passes))
            geometry = renderer.world_geometry()
            shapes = (f"{renderer.triangles:,} / {len(geometry.sphere_material)} / "
                      f"{len(geometry.parallelogram_material)}")
            results["presets"][name] = (*rates, renderer.gpu_bytes, shapes)
            bar.update()

        teapot = load_preset("teapot")
        references = {}
        for mode in MODES:
            def make_renderer(seed, mode=mode):
                return Renderer(teapot, size=(cfg.convergence_size,) * 2, seed=seed, mode=mode)

            references[mode] = make_renderer(seed=0).render(cfg.reference_spp)
            results["convergence"][mode] = _time_to_smape(make_renderer, references[mode],
                                                          cfg.reference_spp // 4)
            bar.update()
        results["references_smape"] = smape(references["rgb"], references["spectral"])
        with tempfile.TemporaryDirectory() as folder:
            folder = Path(folder)
            for label, materials in (("one near-smooth layer, absorbing base", _SMOOTH),
                                     ("three layers, coated, Lambertian base", _THREE_COATED),
                                     ("Lambertian (no Bragg code)", _LAMBERTIAN)):
                scene = load_scene(_scene_file(folder, label.split()[0], materials))
                renderer = Renderer(scene, size=size)
                results["configurations"][label] = _throughput(renderer, cfg.passes)
            bar.update()

            preview = Renderer(load_preset("fig7"), size=(cfg.preview_size,) * 2, mode="rgb")
            preview.render(1)
            start = time.perf_counter()
            for _ in range(cfg.preview_frames):
                preview.render(1)  # returns the image: a readback per frame, as a window needs
            results["fps"] = cfg.preview_frames / (time.perf_counter() - start)
            bar.update()

            results.update(large_mesh_times(cfg.subdivisions, cfg.mesh_size))
            bar.update()
    bar.close()
    results["environment"] = report.run_facts()
    results["environment"]["background_cores"] = meter.background_cores()
    return results


def _rate(samples_per_s: float) -> str:
    return f"{samples_per_s / 1e6:.3g} M/s"


def render_section(results: dict, cfg: Config, command: str) -> str:
    lines = report.section_head(
        BEGIN_MARKER, f"Renderer throughput (`python -m {MODULE}`)", command,
        results["environment"], "tiny sizes" if cfg.name == "quick" else None)
    lines += [
        f"- Presets at {cfg.size} x {cfg.size}, {cfg.passes} timed passes after one untimed "
        "(pipelines compiled, tables built); the other tables RGB mode.",
        "",
        "### Presets",
        "",
    ]
    lines += _table(["preset", "triangles / spheres / planes", "samples/s, RGB",
                     "samples/s, spectral", "spectral / RGB", "GPU memory (spectral)"], [
        [name, shapes, _rate(rgb), _rate(spectral), f"{spectral / rgb:.2f}",
         f"{memory / 1e6:.2f} MB"]
        for name, (rgb, spectral, memory, shapes) in results["presets"].items()])
    c = cfg.convergence_size
    lines += ["", f"### Time to SMAPE {TARGET_SMAPE:g} (teapot, {c} x {c})", ""]
    lines += _table(["mode", "time", "spp", "SMAPE reached"], [
        [mode, human_time(seconds) if error <= TARGET_SMAPE
         else f"not reached in {human_time(seconds)}", str(spp), f"{error:.4f}"]
        for mode, (seconds, spp, error) in results["convergence"].items()])
    rgb_s, spectral_s = (results["convergence"][m][0] for m in MODES)
    lines += [
        "",
        f"Each against a {cfg.reference_spp}-spp reference of its own mode, rendered from "
        "another seed; spp double from 1 (at most a quarter of the reference's). Spectral "
        f"mode takes {spectral_s / rgb_s:.2f} x the time of RGB mode. The two references "
        f"differ by SMAPE {results['references_smape']:.4f}: RGB mode's factored colours "
        "against the spectral integral (and the references' noise).",
    ]
    lines += ["", "### A sphere, by what its material holds", ""]
    base = results["configurations"]
    first = next(iter(base.values()))
    lines += _table(["material", "samples/s", "relative"], [
        [label, _rate(rate), f"{rate / first:.2f}"] for label, rate in base.items()])
    triangles, memory = int(results["mesh_triangles"]), results["mesh_gpu_bytes"]
    lines += ["", "### Targets", ""]
    lines += _table(["target", "measured", "met"], [
        [f"preview >= {TARGET_FPS:g} frames/s at {cfg.preview_size} x {cfg.preview_size}, 1 spp, "
         "single-layer material (fig7, RGB mode)", f"{results['fps']:.1f} frames/s",
         yes_no(results["fps"] >= TARGET_FPS)],
        [f"BVH of a {triangles:,}-triangle mesh in <= {TARGET_BVH_S:g} s",
         human_time(results["bvh_s"]), yes_no(results["bvh_s"] <= TARGET_BVH_S)],
    ])
    lines += [
        "",
        f"The same mesh as a scene: ready to render in {human_time(results['mesh_setup_s'])} "
        "(PLY loading with trimesh, world transform, BVH, uploads), one "
        f"{cfg.mesh_size} x {cfg.mesh_size} pass in {human_time(results['mesh_pass_s'])} "
        f"(median of {LATER_PASSES}; the first took {human_time(results['mesh_first_pass_s'])}, "
        "the render kernel's compilation included unless Mesa's shader cache held it), "
        f"{memory / 1e6:.1f} MB on the GPU.",
        END_MARKER,
    ]
    return "\n".join(lines)


def parse_args(argv: Sequence[str] | None):
    """Parse the command line (``argv`` without the program name)."""
    return report.argument_parser(
        MODULE, "Throughput of the GPU renderer.",
        "tiny images (seconds); writes nothing unless --output").parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Run, print the section and write it (docs/benchmarks.md in full mode)."""

    def measure(quick: bool, progress: bool, command: str) -> str:
        cfg = QUICK if quick else FULL
        return render_section(run_benchmarks(cfg, progress), cfg, command)

    return report.section_main(argv, MODULE, parse_args, (BEGIN_MARKER, END_MARKER), measure)


if __name__ == "__main__":
    sys.exit(main())
