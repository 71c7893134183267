"""The real-time rasterizer (:class:`wgbragg.render.Rasterizer`): its error against converged path
traces of every preset, and its frame rates against the targets.

One run measures:

- **accuracy** per preset: the rasterized image (``temporal_frames`` averaged) against the
  path tracer's converged image (Monte Carlo lighting, the reference) and against the path
  tracer's filtered-lighting image (``ibl="split-sum"``: the same shading, so what remains is
  the rasterizer's own approximations, shadow maps and area lights as points). SMAPE
  (:func:`wgbragg.smape`) and the mean CIE dE2000 of the displayed images (what a viewer
  sees), and the share of pixels whose visible primitive is ``primary_hits()``'s;
- **frame rates** of the teapot at 256 x 256 and 512 x 512: a resting view (one frame after
  another) and an orbit (a camera update before each frame), each frame read back as
  display-ready 8-bit pixels (:meth:`~wgbragg.render.Rasterizer.frame_srgb`), against the
  issue's targets (>= 60 frames/s at 256^2, >= 30 at 512^2); the path tracer's one-sample
  passes at the same sizes beside them.

It prints a markdown section and writes it into ``docs/benchmarks.md`` between
``<!-- bench_rasterizer:begin -->`` and ``<!-- bench_rasterizer:end -->`` (full mode).

Usage::

    python -m benchmarks.rasterizer            # full run (about 10 minutes on 2 cores)
    python -m benchmarks.rasterizer --quick    # tiny sizes (a minute), print only
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time
import warnings
from collections.abc import Sequence

import numpy as np

from benchmarks import report
from benchmarks.report import markdown_table as _table
from benchmarks.report import progress_bar, yes_no

__all__ = ["BEGIN_MARKER", "END_MARKER", "FULL", "PRESETS", "QUICK", "Config", "main",
           "run_benchmarks"]

MODULE = "benchmarks.rasterizer"
BEGIN_MARKER, END_MARKER = report.markers("bench_rasterizer")
PRESETS = ("teapot", "fig1", "fig7", "fig10", "fig11", "fig12", "thin_film", "furnace")
TARGETS = {256: 60.0, 512: 30.0}
"""Frames per second the rasterized teapot must reach at each side (lavapipe, 2 cores)."""


@dataclasses.dataclass(frozen=True)
class Config:
    """Sizes of one run: the presets, the accuracy images, the reference's and the filtered
    path trace's spp, the sides timed and the frames timed at each."""

    name: str
    presets: tuple[str, ...]
    size: tuple[int, int]
    reference_spp: int
    filtered_spp: int
    sides: tuple[int, ...]
    frames: int


FULL = Config("full", PRESETS, (128, 96), 512, 64, (256, 512), 40)
QUICK = Config("quick", ("teapot", "fig11"), (48, 36), 8, 4, (64,), 2)


def _displayed_linear(image: np.ndarray, exposure: float) -> np.ndarray:
    """What a viewer sees of a linear image, back in linear sRGB."""
    from wgbragg.render import display_transform
    from wgbragg.render.display import decode_srgb

    return decode_srgb(display_transform(image, exposure) / 255.0)


def _errors(image: np.ndarray, reference: np.ndarray, exposure: float) -> tuple[float, float]:
    from wgbragg import smape
    from wgbragg.colour.colorimetry import delta_e_2000

    delta_e = delta_e_2000(_displayed_linear(image, exposure),
                           _displayed_linear(reference, exposure))
    return smape(image, reference), float(delta_e.mean())


def _accuracy(name: str, cfg: Config) -> dict:
    from wgbragg import Rasterizer, Renderer
    from wgbragg.scene import load_preset

    scene = load_preset(name)
    raster = Rasterizer(scene, size=cfg.size)
    while not raster.converged:
        image = raster.frame()
    _, primitive = raster.visibility()
    tracer = Renderer(scene, size=cfg.size, mode="rgb")
    _, traced_primitive = tracer.primary_hits()
    reference = tracer.render(cfg.reference_spp)
    filtered = Renderer(scene, size=cfg.size, mode="rgb", ibl="split-sum").render(
        cfg.filtered_spp)
    exposure = scene.settings.exposure
    return {"reference": _errors(image, reference, exposure),
            "filtered": _errors(image, filtered, exposure),
            "filtered_vs_reference": _errors(filtered, reference, exposure),
            "visible": float((primitive == traced_primitive).mean())}


def _rate(step, frames: int) -> float:
    """Frames per second of ``step()``, after one untimed call."""
    step()
    start = time.perf_counter()
    for _ in range(frames):
        step()
    return frames / (time.perf_counter() - start)


def _frame_rates(side: int, frames: int) -> dict:
    from wgbragg import Rasterizer, Renderer
    from wgbragg.scene import load_preset

    scene = load_preset("teapot")
    raster = Rasterizer(scene, size=(side, side), temporal_frames=256)
    rest = _rate(raster.frame_srgb, frames)
    cameras = []
    for k in range(frames + 1):
        angle = 2.0 * math.pi * k / (frames + 1)
        cameras.append(dataclasses.replace(
            scene, camera=dataclasses.replace(
                scene.camera, position=(2.0 * math.sin(angle), 0.9, 2.0 * math.cos(angle)))))
    orbit_scenes = iter(cameras)

    def orbit():
        raster.update(next(orbit_scenes))
        raster.frame_srgb()

    orbit_rate = _rate(orbit, frames)
    tracer = Renderer(scene, size=(side, side), ibl="split-sum", max_bounces=1)
    traced = _rate(lambda: tracer.render(1), max(2, frames // 4))
    return {"rest": rest, "orbit": orbit_rate, "traced": traced}


def run_benchmarks(cfg: Config, progress: bool = True) -> dict:
    meter = report.LoadMeter()
    results = {"accuracy": {}, "rates": {}}
    bar = progress_bar(total=len(cfg.presets) + len(cfg.sides), show=progress,
                       desc="rasterizer")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        for side in cfg.sides:
            results["rates"][side] = _frame_rates(side, cfg.frames)
            bar.update()
        for name in cfg.presets:
            results["accuracy"][name] = _accuracy(name, cfg)
            bar.update()
    bar.close()
    results["environment"] = report.run_facts()
    results["environment"]["background_cores"] = meter.background_cores()
    return results


def render_section(results: dict, cfg: Config, command: str) -> str:
    width, height = cfg.size
    lines = report.section_head(
        BEGIN_MARKER, f"Rasterizer: frame rates and accuracy (`python -m {MODULE}`)", command,
        results["environment"], "tiny sizes, a low-spp reference" if cfg.name == "quick" else None)
    lines += [
        "- Frames: the teapot preset, `Rasterizer.frame_srgb()` (draw, temporal average, "
        "display transform, 8-bit readback); *rest* draws frame after frame, *orbit* moves the "
        "camera by `update()` before each. The path tracer's column is one sample per pixel "
        "of the same view under filtered lighting (`ibl=\"split-sum\"`, one bounce).",
        "",
        "### Frame rates (frames/s)",
        "",
    ]
    rows = []
    for side, rate in results["rates"].items():
        target = TARGETS.get(side)
        rows.append([f"{side} x {side}", f"{rate['rest']:.1f}", f"{rate['orbit']:.1f}",
                     f"{rate['traced']:.1f}", "-" if target is None else f">= {target:g}",
                     "-" if target is None else yes_no(rate["orbit"] >= target)])
    lines += _table(["size", "rasterized, rest", "rasterized, orbit",
                     "path traced, 1 spp", "target (orbit)", "met"], rows)
    lines += [
        "",
        f"### Accuracy at {width} x {height}",
        "",
        f"Against the path tracer's {cfg.reference_spp}-spp image (Monte Carlo lighting, the "
        f"reference) and its {cfg.filtered_spp}-spp filtered-lighting image (the same "
        "shading as the rasterizer's: what is left is the shadow maps, area lights as "
        "points and antialiasing). SMAPE of the linear images; mean dE2000 of the displayed "
        "ones; *visible*: pixels whose primitive is `primary_hits()`'s.",
        "",
    ]
    rows = []
    for name, found in results["accuracy"].items():
        reference, filtered, alone = (found[k] for k in ("reference", "filtered",
                                                         "filtered_vs_reference"))
        rows.append([name, f"{reference[0]:.3f}", f"{reference[1]:.2f}",
                     f"{filtered[0]:.3f}", f"{filtered[1]:.2f}", f"{alone[0]:.3f}",
                     f"{alone[1]:.2f}", f"{100 * found['visible']:.2f} %"])
    lines += _table(["preset", "SMAPE vs reference", "dE2000 vs reference",
                     "SMAPE vs filtered path trace", "dE2000 vs filtered",
                     "filtered path trace vs reference: SMAPE", "dE2000", "visible"], rows)
    lines += [END_MARKER]
    return "\n".join(lines)


def parse_args(argv: Sequence[str] | None):
    """Parse the command line (``argv`` without the program name)."""
    return report.argument_parser(
        MODULE, "The rasterizer's frame rates and accuracy.",
        "tiny sizes, a low-spp reference (a minute); writes nothing unless --output"
    ).parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Run, print the section and write it (docs/benchmarks.md in full mode)."""

    def measure(quick: bool, progress: bool, command: str) -> str:
        cfg = QUICK if quick else FULL
        return render_section(run_benchmarks(cfg, progress), cfg, command)

    return report.section_main(argv, MODULE, parse_args, (BEGIN_MARKER, END_MARKER), measure)


if __name__ == "__main__":
    sys.exit(main())
