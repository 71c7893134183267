"""The same workloads on the system's lavapipe and on the current one, side by side.

The driver alone changes wgbragg's speed severalfold, so this benchmark runs its key workloads
on both Vulkan drivers of the machine in one run: the system's own lavapipe (Debian 12: Mesa
22.3.6) and the current one wgbragg uses (fetched into its driver cache, see
:mod:`wgbragg.gpu.driver`). Each measurement runs in a child process whose ``VK_DRIVER_FILES``
names one driver and whose Mesa shader cache starts empty; the drivers alternate from repeat
to repeat and the median of the repeats is kept. It writes its table into
``docs/performance.md`` between the markers ``<!-- bench_drivers:begin -->`` and
``<!-- bench_drivers:end -->``.

Workloads
---------
- the Yeh reflectance kernel (N = 20) and ``BraggMirror.reflectance`` end to end, on the same
  4M points (:mod:`benchmarks.reflectance`);
- the renderer's preview, the ``fig7`` preset at 256 x 256 and 1 spp a frame, readback
  included (as :mod:`benchmarks.render` measures it);
- the path tracer's time per sample on the Mitsuba peer's three scenes
  (:mod:`benchmarks.mitsuba_peer`, wgbragg's side only: Mitsuba does not use Vulkan);
- a 1.3M-triangle mesh: set-up, its first 256 x 256 pass (which compiles the render kernel:
  every child starts with an empty Mesa shader cache) and the later passes
  (:mod:`benchmarks.render`'s large mesh).

Usage::

    python -m benchmarks.drivers               # full run, rewrites docs/performance.md
    python -m benchmarks.drivers --quick       # tiny sizes, print only
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Sequence
from pathlib import Path

from benchmarks import report
from benchmarks.report import NOT_MEASURED, progress_bar
from benchmarks.report import markdown_table as _table

__all__ = ["BEGIN_MARKER", "END_MARKER", "FULL", "QUICK", "Config", "main", "run_benchmarks"]

MODULE = "benchmarks.drivers"
BEGIN_MARKER, END_MARKER = report.markers("bench_drivers")
DEFAULT_OUTPUT = report.REPO_ROOT / "docs" / "performance.md"
CHILD_TIMEOUT_S = 1800.0


@dataclasses.dataclass(frozen=True)
class Config:
    """Sizes of one run: the reflectance grid side (2048: 4.2M points), the preview size and
    frames, the path tracer's image side and samples per pixel, the large mesh's icosphere
    subdivisions (8: 1.3M triangles) and image side, and the repeats per driver."""

    name: str
    reflectance_side: int
    preview_size: int
    preview_frames: int
    path_size: int
    path_spp: int
    subdivisions: int
    mesh_size: int
    repeats: int


FULL = Config("full", reflectance_side=2048, preview_size=256, preview_frames=30,
              path_size=128, path_spp=64, subdivisions=8, mesh_size=256, repeats=3)
QUICK = Config("quick", reflectance_side=64, preview_size=16, preview_frames=2, path_size=16,
               path_spp=2, subdivisions=2, mesh_size=16, repeats=1)
WORKLOADS = ("mesh", "reflectance", "preview", "path")
"""In the order a child runs them: the mesh first, so that its first pass compiles."""


# --------------------------------------------------------------------------- the workloads


def _reflectance(cfg: Config) -> dict[str, float]:
    from benchmarks import reflectance

    kernel, end_to_end = reflectance.target_rates(20, cfg.reflectance_side)
    return {"yeh_kernel": kernel, "yeh_end_to_end": end_to_end}


def _preview(cfg: Config) -> dict[str, float]:
    from wgbragg.render import Renderer
    from wgbragg.scene import load_preset

    preview = Renderer(load_preset("fig7"), size=(cfg.preview_size,) * 2, mode="rgb")
    preview.render(1)
    start = time.perf_counter()
    for _ in range(cfg.preview_frames):
        preview.render(1)  # returns the image: a readback per frame, as a window needs
    return {"preview_fps": cfg.preview_frames / (time.perf_counter() - start)}


def _path(cfg: Config) -> dict[str, float]:
    from benchmarks import mitsuba_peer
    from wgbragg.render import Renderer
    from wgbragg.scene import load_scene

    values = {}
    with tempfile.TemporaryDirectory() as folder:
        for name in mitsuba_peer.SCENES:
            scene = load_scene(mitsuba_peer.scene_file(name, Path(folder)))
            renderer = Renderer(scene, size=(cfg.path_size,) * 2, mode="rgb",
                                max_bounces=mitsuba_peer.MAX_BOUNCES, seed=1)
            renderer.render(spp=min(4, cfg.path_spp))
            renderer.reset()
            start = time.perf_counter()
            renderer.render(spp=cfg.path_spp)
            seconds = time.perf_counter() - start
            values[f"path_{name}"] = seconds / (cfg.path_spp * cfg.path_size**2)
    return values


def _mesh(cfg: Config) -> dict[str, float]:
    from benchmarks import render

    return render.large_mesh_times(cfg.subdivisions, cfg.mesh_size)


_WORKLOAD_FUNCTIONS = {"reflectance": _reflectance, "preview": _preview, "path": _path,
                       "mesh": _mesh}


def child_main(cfg: Config) -> int:
    """Measure every workload on the driver this process was given; print one JSON line."""
    values = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        for workload in WORKLOADS:
            values.update(_WORKLOAD_FUNCTIONS[workload](cfg))
    from wgbragg import gpu

    print(json.dumps({"driver": gpu.adapter_info()["driver"], "values": values}))
    return 0


# --------------------------------------------------------------------------- the drivers


def drivers() -> dict[str, str | None]:
    """``VK_DRIVER_FILES`` of the system's lavapipe and of the current one (None: absent)."""
    from wgbragg.gpu.driver import CURRENT_MESA, cached_driver, system_lavapipe

    system = system_lavapipe()
    cached, _ = cached_driver()
    if system is not None and system[1] is not None and system[1][:2] >= CURRENT_MESA:
        return {"system": str(system[0]), "current": str(system[0])}
    return {"system": None if system is None else str(system[0]),
            "current": None if cached is None else str(cached.manifest)}


def _run_child(driver_files: str, cfg: Config) -> dict:
    environ = {k: v for k, v in os.environ.items()
               if k not in ("VK_ICD_FILENAMES", "WGBRAGG_ADAPTER", "WGBRAGG_DRIVER_FILES")}
    environ["VK_DRIVER_FILES"] = driver_files
    command = [sys.executable, "-m", MODULE, "--child", "--config", cfg.name]
    # An empty shader cache: the first mesh pass then measures the driver's compile, which a
    # warm Mesa cache (~/.cache/mesa_shader_cache) would hide on one driver and not the other.
    with tempfile.TemporaryDirectory(prefix="mesa-shader-cache-") as shader_cache:
        environ["MESA_SHADER_CACHE_DIR"] = shader_cache
        done = subprocess.run(command, capture_output=True, text=True, env=environ,
                              cwd=report.REPO_ROOT, timeout=CHILD_TIMEOUT_S, check=False)
    lines = done.stdout.strip().splitlines()
    if done.returncode != 0 or not lines:
        tail = (done.stderr.strip().splitlines() or ["no output"])[-1]
        return {"error": f"exit {done.returncode}: {tail}"}
    return json.loads(lines[-1])


def run_benchmarks(cfg: Config, progress: bool = True) -> dict:
    """Every workload on both drivers, one child process per driver and repeat, the drivers
alternating; medians of ``cfg.repeats``."""
    meter = report.LoadMeter()
    found = drivers()
    samples: dict[str, dict[str, list[float]]] = {name: {} for name in found}
    names: dict[str, str] = {}
    errors: list[str] = []
    present = [name for name, files in found.items() if files is not None]
    bar = progress_bar(total=cfg.repeats * len(present), show=progress, desc="drivers")
    for repeat in range(cfg.repeats):
        for name in present if repeat % 2 == 0 else present[::-1]:
            outcome = _run_child(found[name], cfg)
            bar.update()
            if "error" in outcome:
                errors.append(f"{name}: {outcome['error']}")
                continue
            names[name] = outcome["driver"]
            for key, value in outcome["values"].items():
                samples[name].setdefault(key, []).append(value)
    bar.close()
    medians = {name: {key: statistics.median(values) for key, values in by_key.items()}
               for name, by_key in samples.items()}
    environment = report.run_facts()
    environment["background_cores"] = meter.background_cores()
    return {"drivers": names, "missing": [n for n in found if found[n] is None],
            "medians": medians, "errors": errors, "environment": environment}


# --------------------------------------------------------------------------- the section

# key, label (formatted with the Config), unit, higher is better
ROWS = (
    ("yeh_kernel", "Yeh reflectance kernel, N = 20, {reflectance_side}² points", "M/s", True),
    ("yeh_end_to_end", "`BraggMirror.reflectance` end to end, same points", "M/s", True),
    ("preview_fps", "Renderer preview, `fig7`, {preview_size}², 1 spp a frame", "frames/s",
     True),
    ("path_sphere", "Path tracer per sample: Mitsuba peer's sphere, {path_size}²", "ns", False),
    ("path_sphere-exr", "Path tracer per sample: sphere under an EXR sky", "ns", False),
    ("path_teapot", "Path tracer per sample: teapot", "ns", False),
    ("mesh_setup_s", "Icosphere of {triangles} triangles: BVH build and upload", "s", False),
    ("mesh_first_pass_s", "Same mesh: first {mesh_size}² pass, empty shader cache (compiles)",
     "s", False),
    ("mesh_pass_s", "Same mesh: a later pass", "s", False),
)
_SCALE = {"M/s": 1e-6, "frames/s": 1.0, "ns": 1e9, "s": 1.0}


def _cell(value: float | None, unit: str) -> str:
    if value is None:
        return NOT_MEASURED
    return f"{value * _SCALE[unit]:.3g} {unit}"


def render_section(results: dict, cfg: Config, command: str) -> str:
    """The markdown section: one row per measurement, both drivers and the speed-up."""
    quick = "tiny sizes, one repeat" if cfg.name == "quick" else None
    out = report.section_head(BEGIN_MARKER, f"Drivers (`python -m {MODULE}`)", command,
                              results["environment"], quick)
    names = results["drivers"]
    out += [f"- System driver: {names.get('system', 'none on this machine')}",
            f"- Current driver: {names.get('current', 'none: nothing fetched')}",
            f"- Each value is the median of {cfg.repeats} runs per driver, each in a fresh "
            "process with an empty Mesa shader cache, the drivers alternating; the speed-up "
            "is how many times faster the current driver is (above 1: faster).", ""]
    rows = []
    medians = results["medians"]
    for key, label, unit, higher in ROWS:
        old = medians.get("system", {}).get(key)
        new = medians.get("current", {}).get(key)
        if old is None and new is None:
            continue
        speedup = NOT_MEASURED
        if old and new:
            speedup = report.human_ratio(new / old if higher else old / new)
        triangles = f"{20 * 4**cfg.subdivisions:,}"
        rows.append([label.format(**dataclasses.asdict(cfg), triangles=triangles),
                     _cell(old, unit), _cell(new, unit), speedup])
    out += _table(["what", "system driver", "current driver", "speed-up"], rows)
    for error in results["errors"]:
        out += ["", f"- Not measured: {error}"]
    out += ["", END_MARKER]
    return "\n".join(out)


# --------------------------------------------------------------------------- the command


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = report.argument_parser(MODULE, "The same workloads on both lavapipe drivers.",
                                    "tiny sizes, one repeat, print only")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--config", choices=("full", "quick"), default="full",
                        help=argparse.SUPPRESS)
    return parser.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmark (or, with ``--child``, one workload on this process's driver)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parse_args(argv)
    if args.child:
        return child_main(QUICK if args.config == "quick" else FULL)
    report.console_header(MODULE)
    cfg = QUICK if args.quick else FULL
    results = run_benchmarks(cfg, progress=not args.no_progress)
    section = render_section(results, cfg, report.command_line(MODULE, argv))
    output = args.output if args.output is not None else (
        None if args.quick or args.no_write else DEFAULT_OUTPUT)
    report.publish(section, output, BEGIN_MARKER, END_MARKER)
    return 0


if __name__ == "__main__":
    sys.exit(main())
