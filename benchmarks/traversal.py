"""The path tracer's BVH traversal, A/B: the working tree against a git revision, interleaved.

Each variant is a source tree: ``work`` (this checkout) or a git revision, unpacked with ``git
archive`` into a temporary folder and imported from there (``PYTHONPATH``), so a variant is
everything its commit holds: shaders, BVH layout and packing. Every measurement is a fresh
process of one variant; the variants alternate, their order reversing each round, so that
other processes' load on the shared cores falls on both alike.

A process renders each scene at ``size`` x ``size``, RGB, ``max_bounces = 8`` (as
:mod:`benchmarks.mitsuba_peer`): one untimed pass of ``pass_spp`` (the kernel's compile),
then ``passes`` timed passes, and reports the least wall and CPU time per sample of a pass (the
pass least disturbed by other processes; CPU time is the process's: lavapipe's threads and
Python's), and the camera rays' closest hits
(``Renderer.primary_hits``) so that the variants' hits can be compared.

Scenes: ``teapot`` (:mod:`benchmarks.mitsuba_peer`'s: 4,034 triangles on an exact plane, a
point light, an area light and a dim sky) and ``icosphere`` (a 20,480-triangle sphere mesh
on the same scene's plane under a uniform sky: camera rays, bounces and sky shadow rays
through a deeper tree) and ``sphere`` (:mod:`benchmarks.mitsuba_peer`'s: an exact sphere on
an exact plane, no BVH, for what a path costs besides traversal).

Usage::

    python -m benchmarks.traversal --base HEAD~1            # A = HEAD~1, B = the working tree
    python -m benchmarks.traversal --base abc123 --rounds 8
    python -m benchmarks.traversal --quick                  # tiny sizes, both variants `work`
"""

from __future__ import annotations

import dataclasses
import json
import os
import statistics
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from benchmarks import report
from benchmarks.mitsuba_peer import scene_file
from benchmarks.report import human_ratio, human_time, progress_bar

__all__ = ["BEGIN_MARKER", "END_MARKER", "FULL", "QUICK", "SCENES", "Config", "main",
           "run_ab", "write_scenes"]

MODULE = "benchmarks.traversal"
BEGIN_MARKER, END_MARKER = report.markers("bench_traversal")
SCENES = ("teapot", "icosphere", "sphere")
WORK = "work"
"""The variant that is this checkout's working tree."""
WORKER_TIMEOUT_S = 1800.0


@dataclasses.dataclass(frozen=True)
class Config:
    """Sizes of one run: image side, samples per pass, timed passes a process, rounds (one
    process per variant a round)."""

    name: str
    size: int
    pass_spp: int
    passes: int
    rounds: int


FULL = Config("full", size=128, pass_spp=4, passes=8, rounds=6)
QUICK = Config("quick", size=16, pass_spp=1, passes=1, rounds=1)

_ICOSPHERE = """
[camera]
position = [0.0, 1.5, 5.0]
look_at = [0.0, 0.8, 0.0]
fov_deg = 40.0

[environment]
type = "uniform"
radiance = 1.0

[materials.ball]
type = "lambertian"
albedo = 0.8

[materials.floor]
type = "lambertian"
albedo = 0.5

[[objects]]
shape = "mesh"
path = "icosphere.ply"
material = "ball"
translate = [0.0, 1.0, 0.0]

[[objects]]
shape = "plane"
material = "floor"
scale = 6.0
"""

# Run in each variant's tree (its own wgbragg): only APIs every variant has.
_WORKER = r"""
import json, sys, time, warnings
import numpy as np
from wgbragg.render import Renderer
from wgbragg.scene import load_scene
size, spp, passes = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
out = {}
for path in sys.argv[4:]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        r = Renderer(load_scene(path), size=(size, size), mode="rgb", max_bounces=8, seed=3)
    r.render(spp=spp)
    wall, cpu = [], []
    for _ in range(passes):
        w0, c0 = time.perf_counter(), time.process_time()
        r.render(spp=spp)
        wall.append(time.perf_counter() - w0)
        cpu.append(time.process_time() - c0)
    t, face = r.primary_hits()
    n = spp * size * size
    out[path] = {"wall": min(wall) / n, "cpu": min(cpu) / n,
                 "t": np.where(np.isfinite(t), t, -1.0).ravel().tolist(),
                 "face": face.ravel().tolist()}
print("RESULT " + json.dumps(out))
"""


# Variants that differ in their WGSL only: one process, each pass's shaders read from the
# variant's folder, the variants' passes alternating (their order reversed each round).
_SHADER_WORKER = r"""
import json, sys, time, warnings
import numpy as np
import wgbragg.gpu.shaders as shaders
from pathlib import Path
from wgbragg.render import Renderer
from wgbragg.scene import load_scene
size, spp, rounds = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
split = sys.argv.index("--")
paths, folders = sys.argv[4:split], [Path(f) for f in sys.argv[split + 1:]]
def use(folder):
    shaders.shader_dir = lambda: folder
out = [[{} for _ in range(rounds)] for _ in folders]
for path in paths:
    renderers = []
    for k, folder in enumerate(folders):
        use(folder)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            r = Renderer(load_scene(path), size=(size, size), mode="rgb", max_bounces=8,
                         seed=3)
        r.render(spp=spp)
        t, face = r.primary_hits()
        renderers.append((r, np.where(np.isfinite(t), t, -1.0).ravel().tolist(),
                          face.ravel().tolist()))
    n = spp * size * size
    for i in range(rounds):
        order = range(len(folders)) if i % 2 == 0 else reversed(range(len(folders)))
        for k in order:
            use(folders[k])
            r, t, face = renderers[k]
            w0, c0 = time.perf_counter(), time.process_time()
            r.render(spp=spp)
            out[k][i][path] = {"wall": (time.perf_counter() - w0) / n,
                               "cpu": (time.process_time() - c0) / n, "t": t, "face": face}
print("RESULT " + json.dumps(out))
"""


def write_scenes(folder: Path) -> dict[str, Path]:
    """The benchmark's scene files, written into ``folder``."""
    import trimesh

    from wgbragg.scene.meshes import sphere_mesh

    mesh = sphere_mesh(5)
    # meshes.py is +z up, scenes +y up: (x, y, z) -> (x, z, -y).
    vertices = mesh.vertices[:, [0, 2, 1]] * [1.0, 1.0, -1.0]
    trimesh.Trimesh(vertices, mesh.faces, process=False).export(folder / "icosphere.ply")
    (folder / "icosphere.toml").write_text(_ICOSPHERE, encoding="utf-8")
    return {"teapot": scene_file("teapot", folder), "icosphere": folder / "icosphere.toml",
            "sphere": scene_file("sphere", folder)}


def _tree(variant: str, folder: Path) -> Path:
    """The source tree of ``variant``: the checkout for ``work``, a folder as it is (a copy
    of the tree with an edit), else the revision unpacked."""
    if variant == WORK:
        return report.REPO_ROOT
    if Path(variant).is_dir():
        return Path(variant).resolve()
    target = folder / f"tree-{len(list(folder.glob('tree-*')))}"
    target.mkdir()
    archive = subprocess.run(["git", "archive", variant], cwd=report.REPO_ROOT,
                             capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(target)], input=archive, check=True)
    return target


def _measure(tree: Path, scenes: dict[str, Path], cfg: Config) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(tree)
    completed = subprocess.run(
        [sys.executable, "-c", _WORKER, str(cfg.size), str(cfg.pass_spp), str(cfg.passes),
         *map(str, scenes.values())],
        capture_output=True, text=True, env=env, cwd=tree, timeout=WORKER_TIMEOUT_S, check=False)
    lines = [line for line in completed.stdout.splitlines() if line.startswith("RESULT ")]
    if completed.returncode != 0 or not lines:
        raise RuntimeError(f"traversal worker failed in {tree}:\n{completed.stderr[-2000:]}")
    raw = json.loads(lines[-1][len("RESULT "):])
    return {name: raw[str(path)] for name, path in scenes.items()}


def _measure_shaders(folders: Sequence[Path], scenes: dict[str, Path], cfg: Config,
                     rounds: int) -> list[list[dict]]:
    completed = subprocess.run(
        [sys.executable, "-c", _SHADER_WORKER, str(cfg.size), str(cfg.pass_spp), str(rounds),
         *map(str, scenes.values()), "--", *map(str, folders)],
        capture_output=True, text=True, cwd=report.REPO_ROOT, timeout=WORKER_TIMEOUT_S,
        check=False)
    lines = [line for line in completed.stdout.splitlines() if line.startswith("RESULT ")]
    if completed.returncode != 0 or not lines:
        raise RuntimeError(f"traversal worker failed:\n{completed.stderr[-2000:]}")
    raw = json.loads(lines[-1][len("RESULT "):])
    return [[{name: by_round[str(path)] for name, path in scenes.items()}
             for by_round in by_variant] for by_variant in raw]


def run_shaders_ab(base: Path, candidate: Path, cfg: Config, rounds: int) -> dict:
    """A/B of two WGSL folders under this checkout's Python, in one process: ``rounds``
    passes each, alternating (see the module docstring)."""
    meter = report.LoadMeter()
    with tempfile.TemporaryDirectory() as folder:
        scenes = write_scenes(Path(folder))
        runs = _measure_shaders([base, candidate], scenes, cfg, rounds)
    env = report.run_facts()
    env["background_cores"] = meter.background_cores()
    return {"runs": {f"wgsl:{base}": runs[0], f"wgsl:{candidate}": runs[1]},
            "base": f"wgsl:{base}", "candidate": f"wgsl:{candidate}", "environment": env}


def run_ab(base: str, cfg: Config, progress: bool = True,
           candidate: str = WORK) -> dict:
    """Measure ``base`` (A) and ``candidate`` (B) alternately, ``cfg.rounds`` processes each."""
    meter = report.LoadMeter()
    runs = {base: [], candidate: []} if base != candidate else {base: []}
    order = [base, candidate]
    bar = progress_bar(total=2 * cfg.rounds, show=progress, desc="traversal A/B")
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        scenes = write_scenes(folder)
        trees = {variant: _tree(variant, folder) for variant in runs}
        for round_ in range(cfg.rounds):
            for variant in (order if round_ % 2 == 0 else order[::-1]):
                runs.setdefault(variant, []).append(_measure(trees[variant], scenes, cfg))
                bar.update()
    bar.close()
    if base == candidate:
        # Both sides are the same tree: alternate its processes between A and B.
        both = runs[base]
        runs = {"A": both[0::2], "B": both[1::2] or both[:1]}
        base, candidate = "A", "B"
    env = report.run_facts()
    env["background_cores"] = meter.background_cores()
    return {"runs": runs, "base": base, "candidate": candidate, "environment": env}


def _revision(variant: str) -> str:
    if variant in (WORK, "A", "B"):
        return "the working tree"
    if variant.startswith("wgsl:"):
        return f"the shaders in `{variant[5:]}`, this checkout's Python"
    if Path(variant).is_dir():
        return f"the tree in `{variant}`"
    found = subprocess.run(["git", "rev-parse", "--short", variant], cwd=report.REPO_ROOT,
                           capture_output=True, text=True, check=False).stdout.strip()
    return f"`{variant}` ({found})" if found and found != variant else f"`{variant}`"


def analyse(results: dict) -> dict:
    """Per scene: each side's median and range of wall and CPU time per sample, the B / A
    ratios of the rounds, and how many camera rays' closest hits differ between the sides."""
    a_runs, b_runs = results["runs"][results["base"]], results["runs"][results["candidate"]]
    rounds = min(len(a_runs), len(b_runs))
    out = {}
    for name in SCENES:
        row = {}
        for key in ("wall", "cpu"):
            a = [run[name][key] for run in a_runs]
            b = [run[name][key] for run in b_runs]
            ratios = [b[k] / a[k] for k in range(rounds)]
            row[key] = (statistics.median(a), statistics.median(b), statistics.median(ratios),
                        min(ratios), max(ratios))
        face_a, face_b = np.array(a_runs[0][name]["face"]), np.array(b_runs[0][name]["face"])
        t_a, t_b = np.array(a_runs[0][name]["t"]), np.array(b_runs[0][name]["t"])
        row["faces_differ"] = int((face_a != face_b).sum())
        row["t_differ"] = int((t_a != t_b).sum())
        row["pixels"] = len(face_a)
        out[name] = row
    return out


def render_section(results: dict, cfg: Config, command: str) -> str:
    analysis = analyse(results)
    lines = report.section_head(BEGIN_MARKER, f"BVH traversal, A/B (`python -m {MODULE}`)",
                                command, results["environment"],
                                "tiny sizes" if cfg.name == "quick" else None)
    lines += [
        f"- A: {_revision(results['base'])}; B: {_revision(results['candidate'])}.",
        f"- Scenes: {', '.join(f'`{s}`' for s in SCENES)} (the module docstring describes "
        f"them), {cfg.size} x {cfg.size}, RGB, `max_bounces = 8`; a process per variant and "
        f"round, {cfg.rounds} rounds, the order reversed each round; in each, an untimed pass "
        f"of {cfg.pass_spp} spp, then the least of {cfg.passes} timed passes of "
        f"{cfg.pass_spp} spp.",
        "",
        "### Time per sample",
        "",
    ]
    rows = []
    for name, row in analysis.items():
        for key, label in (("cpu", "CPU time / sample"), ("wall", "wall time / sample")):
            a, b, ratio, low, high = row[key]
            rows.append([name, label, human_time(a), human_time(b),
                         f"{human_ratio(ratio)} [{human_ratio(low)}-{human_ratio(high)}]"])
        rows[-1].append(f"{row['faces_differ']} / {row['t_differ']} of {row['pixels']}")
        rows[-2].append("")
    lines += report.markdown_table(
        ["scene", "what", "A (median)", "B (median)", "B / A: median of rounds [min-max]",
         "camera rays: face / distance differs"], rows)
    lines += [
        "",
        "B / A below 1: B is faster. Ratios are taken within a round (the two processes "
        "adjacent in time), so the machine's load changes them less than it changes the "
        "medians.",
        END_MARKER,
    ]
    return "\n".join(lines)


def parse_args(argv: Sequence[str] | None):
    """Parse the command line (``argv`` without the program name)."""
    parser = report.argument_parser(MODULE, "A/B of the BVH traversal, interleaved processes.",
                                    "tiny sizes, both sides the working tree; writes nothing "
                                    "unless --output")
    parser.add_argument("--base", default=None,
                        help="git revision of A (default HEAD; `work` for the working tree)")
    parser.add_argument("--candidate", default=WORK,
                        help="git revision or source folder of B (default: the working tree)")
    parser.add_argument("--rounds", type=int, default=None, help="processes per variant")
    parser.add_argument("--shaders", nargs=2, type=Path, metavar=("A", "B"), default=None,
                        help="instead: two wgsl/ folders timed in one process, pass by pass")
    return parser.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Run, print the section and write it (docs/benchmarks.md in full mode)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parse_args(argv)

    def measure(quick: bool, progress: bool, command: str) -> str:
        cfg = QUICK if quick else FULL
        if args.rounds:
            cfg = dataclasses.replace(cfg, rounds=args.rounds)
        if args.shaders:
            rounds = args.rounds or 4 * cfg.rounds
            results = run_shaders_ab(*args.shaders, cfg, rounds)
            return render_section(results, dataclasses.replace(cfg, rounds=rounds), command)
        base = args.base or (WORK if quick else "HEAD")
        return render_section(run_ab(base, cfg, progress, args.candidate), cfg, command)

    return report.section_main(argv, MODULE, parse_args, (BEGIN_MARKER, END_MARKER), measure)


if __name__ == "__main__":
    sys.exit(main())
