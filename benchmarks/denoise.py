"""What denoising (Intel Open Image Denoise, :mod:`wgbragg.render.denoise`) buys the renderer.

For the ``teapot``, ``fig7`` and ``thin_film`` presets, each in its own transport mode, at a
small size, one run measures:

- **error against a reference**: SMAPE (:func:`wgbragg.common.metrics.smape`) of the raw and of
  the denoised image (:meth:`wgbragg.render.Renderer.denoised`) at 4, 16 and 64 spp against a
  high-spp reference of the same preset, rendered from another seed;
- **the effective speed-up**: the spp the raw image needs to be as close to the reference as
  the denoised one is at 16 spp (samples doubling from 4, interpolated log-log between the two
  that bracket it), and the render time that takes against 16 spp plus the denoising;
- **hue**: the mean CIE dE2000 of the displayed images (exposure, tone map, gamut mapping,
  sRGB: what a viewer sees) against the reference's, raw and denoised, and the share of pixels
  where the denoised one is further from the reference than the raw one;
- **denoise time per frame**: :meth:`~wgbragg.render.Renderer.denoised` (feature readback and
  OIDN) at the benchmark's size, and OIDN alone at 256 x 256 and 512 x 512 in its "high" and
  "fast" qualities (its cost does not depend on the content).

It prints a markdown section and writes it into ``docs/benchmarks.md`` between
``<!-- bench_denoise:begin -->`` and ``<!-- bench_denoise:end -->`` (full mode).

Usage::

    python -m benchmarks.denoise            # full run (about half an hour on 2 cores)
    python -m benchmarks.denoise --quick    # tiny sizes (a minute), print only
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import sys
import time
import warnings
from collections.abc import Sequence

import numpy as np

from benchmarks import report
from benchmarks.report import human_ratio, human_time, progress_bar, yes_no
from benchmarks.report import markdown_table as _table

__all__ = ["BEGIN_MARKER", "END_MARKER", "FULL", "PRESETS", "QUICK", "Config", "main",
           "matching_spp", "run_benchmarks"]

MODULE = "benchmarks.denoise"
BEGIN_MARKER, END_MARKER = report.markers("bench_denoise")
PRESETS = ("teapot", "fig7", "thin_film")
MATCHED_SPP = 16
"""The denoised image whose error the raw one is matched against."""
HUE_FROM_SPP = 16
"""The hue check applies from this many samples per pixel."""


@dataclasses.dataclass(frozen=True)
class Config:
    """Sizes of one run: image size, the reference's spp, the spp compared, the most spp the
    raw image may take to match the denoised one, and the sizes OIDN alone is timed at."""

    name: str
    size: tuple[int, int]
    reference_spp: int
    spps: tuple[int, ...]
    match_limit: int
    timing_sizes: tuple[int, ...]
    timing_repeats: int


FULL = Config("full", size=(96, 72), reference_spp=4096, spps=(4, 16, 64), match_limit=2048,
              timing_sizes=(256, 512), timing_repeats=5)
QUICK = Config("quick", size=(24, 18), reference_spp=64, spps=(4, 16), match_limit=32,
               timing_sizes=(32,), timing_repeats=1)


def _displayed_linear(image: np.ndarray, exposure: float) -> np.ndarray:
    """What a viewer sees of a linear image, back in linear sRGB: the display transform's
    bytes decoded."""
    from wgbragg.render import display_transform

    encoded = display_transform(image, exposure) / 255.0
    return np.where(encoded <= 0.04045, encoded / 12.92, ((encoded + 0.055) / 1.055) ** 2.4)


def matching_spp(errors: dict[int, float], target: float) -> tuple[float | None, int, int]:
    """The spp at which the raw error reaches ``target``, interpolated log-log between the two
    measured spp that bracket it: (spp or None if never reached, lower, upper bracket)."""
    spps = sorted(errors)
    if errors[spps[0]] <= target:
        return float(spps[0]), spps[0], spps[0]
    for low, high in itertools.pairwise(spps):
        if errors[high] <= target:
            slope = (math.log(errors[high]) - math.log(errors[low])) / math.log(high / low)
            if slope >= 0.0:
                return float(high), low, high
            spp = low * math.exp((math.log(target) - math.log(errors[low])) / slope)
            return spp, low, high
    return None, spps[-1], spps[-1]


def _measure_preset(name: str, cfg: Config) -> dict:
    from wgbragg.colour.colorimetry import delta_e_2000
    from wgbragg.common.metrics import smape
    from wgbragg.render import Renderer
    from wgbragg.scene import load_preset

    scene = load_preset(name)
    exposure = scene.settings.exposure
    reference = Renderer(scene, size=cfg.size, seed=1_000_003).render(cfg.reference_spp)
    seen_reference = _displayed_linear(reference, exposure)
    renderer = Renderer(scene, size=cfg.size, seed=1)
    renderer.render(1)  # pipelines compiled, tables built: not timed
    renderer.reset()
    raw_errors, render_seconds = {}, {}
    rows = {}
    elapsed, spp = 0.0, 4
    while spp <= max(cfg.match_limit, max(cfg.spps)):
        start = time.perf_counter()
        image = renderer.render(spp - renderer.passes)
        elapsed += time.perf_counter() - start
        render_seconds[spp] = elapsed
        raw_errors[spp] = smape(image, reference)
        if spp in cfg.spps:
            start = time.perf_counter()
            denoised = renderer.denoised()
            denoise_seconds = time.perf_counter() - start
            seen = [_displayed_linear(x, exposure) for x in (image, denoised)]
            delta_e = [delta_e_2000(x, seen_reference) for x in seen]
            rows[spp] = {"raw": raw_errors[spp], "denoised": smape(denoised, reference),
                         "de_raw": float(delta_e[0].mean()),
                         "de_denoised": float(delta_e[1].mean()),
                         "worse_share": float((delta_e[1] > delta_e[0]).mean()),
                         "denoise_s": denoise_seconds}
        spp *= 2
    target = rows[MATCHED_SPP]["denoised"] if MATCHED_SPP in rows else rows[max(rows)]["denoised"]
    matched, low, high = matching_spp(raw_errors, target)
    raw_seconds = None
    if matched is not None:
        # Render time grows linearly with the samples between the two measured.
        raw_seconds = render_seconds[low] + (matched - low) * (
            (render_seconds[high] - render_seconds[low]) / (high - low) if high > low else 0.0)
    matched_spp = MATCHED_SPP if MATCHED_SPP in rows else max(rows)
    return {"mode": renderer.mode, "rows": rows, "target": target, "matched": matched,
            "bracket": (low, high), "raw_seconds": raw_seconds,
            "denoised_seconds": render_seconds[matched_spp] + rows[matched_spp]["denoise_s"],
            "matched_spp": matched_spp}


def _oidn_times(cfg: Config) -> dict:
    """OIDN alone on noisy synthetic images (its cost does not depend on the content)."""
    from wgbragg.render import denoise_image

    rng = np.random.default_rng(0)
    times = {}
    for side in cfg.timing_sizes:
        colour = rng.gamma(1.0, 0.5, (side, side, 3)).astype(np.float32)
        albedo = rng.random((side, side, 3), dtype=np.float32)
        normal = rng.normal(size=(side, side, 3)).astype(np.float32)
        normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
        for quality in ("high", "fast"):
            denoise_image(colour, albedo, normal, quality=quality)  # the filter's set-up
            start = time.perf_counter()
            for _ in range(cfg.timing_repeats):
                denoise_image(colour, albedo, normal, quality=quality)
            times[side, quality] = (time.perf_counter() - start) / cfg.timing_repeats
    return times


def run_benchmarks(cfg: Config, progress: bool = True) -> dict:
    import pyoidn

    meter = report.LoadMeter()
    results = {"presets": {}}
    bar = progress_bar(total=len(PRESETS) + 1, show=progress, desc="denoise")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        for name in PRESETS:
            results["presets"][name] = _measure_preset(name, cfg)
            bar.update()
        results["oidn"] = _oidn_times(cfg)
        bar.update()
    bar.close()
    results["environment"] = report.run_facts()
    results["environment"]["versions"]["OIDN"] = pyoidn.version.oidn_version
    results["environment"]["background_cores"] = meter.background_cores()
    return results


def render_section(results: dict, cfg: Config, command: str) -> str:
    width, height = cfg.size
    lines = report.section_head(
        BEGIN_MARKER, f"Denoising (`python -m {MODULE}`)", command, results["environment"],
        "tiny sizes, a low-spp reference" if cfg.name == "quick" else None)
    lines += [
        f"- {', '.join(PRESETS)} at {width} x {height}, each in its own mode, against a "
        f"{cfg.reference_spp}-spp reference of the same preset from another seed; Intel Open "
        "Image Denoise (OIDN) on the CPU, quality \"high\", guided by the renderer's first-hit "
        "albedo and normal (`Renderer.denoised()`).",
        "",
        "### Error against the reference",
        "",
    ]
    presets = results["presets"]
    lines += _table(["preset", "mode", "spp", "SMAPE raw", "SMAPE denoised", "ratio"], [
        [name, p["mode"], str(spp), f"{row['raw']:.4f}", f"{row['denoised']:.4f}",
         human_ratio(row["raw"] / max(row["denoised"], 1e-12))]
        for name, p in presets.items() for spp, row in p["rows"].items()])
    lines += ["", f"### Effective speed-up (the raw spp that matches denoised {MATCHED_SPP} spp)",
              ""]
    rows = []
    for name, p in presets.items():
        low, high = p["bracket"]
        if p["matched"] is None:
            spp_text, seconds = f"> {high}", report.NOT_MEASURED
            samples = f"> {human_ratio(high / p['matched_spp'])}"
        else:
            spp_text = f"{p['matched']:.0f} ({low}-{high})" if high > low else str(low)
            samples = human_ratio(p["matched"] / p["matched_spp"])
            seconds = human_ratio(p["raw_seconds"] / p["denoised_seconds"])
        rows.append([name, f"{p['target']:.4f}", spp_text, samples, seconds])
    lines += _table(["preset", f"SMAPE denoised at {MATCHED_SPP} spp", "raw spp to match",
                     "samples saved", "time saved (render + denoise)"], rows)
    lines += [
        "",
        "Raw spp double from 4 (at most "
        f"{cfg.match_limit}); the match is interpolated log-log between the two that bracket "
        "it. Time saved: the raw render's time to that spp over the 16-spp render plus its "
        "denoising.",
        "",
        "### Hue: mean dE2000 of the displayed image against the reference's",
        "",
    ]
    hue_rows, misses = [], []
    for name, p in presets.items():
        for spp, row in p["rows"].items():
            lower = row["de_denoised"] < row["de_raw"]
            checked = spp >= HUE_FROM_SPP
            hue_rows.append([name, str(spp), f"{row['de_raw']:.2f}", f"{row['de_denoised']:.2f}",
                             f"{100 * row['worse_share']:.0f} %",
                             yes_no(lower) if checked else f"({yes_no(lower)})"])
            if checked and not lower:
                misses.append(f"{name} at {spp} spp")
    lines += _table(["preset", "spp", "dE2000 raw", "dE2000 denoised",
                     "pixels further when denoised", f"denoised lower (checked from "
                     f"{HUE_FROM_SPP} spp)"], hue_rows)
    lines += [
        "",
        "dE2000 per pixel between the displayed images (exposure, tone map, gamut mapping, "
        "sRGB bytes, decoded to linear), CIELAB of D65; its mean over the image. "
        + ("Denoising lowers it everywhere it is checked." if not misses else
           "Denoising does not lower it for " + ", ".join(misses) + ": there it blurs or "
           "shifts more colour than it removes noise."),
    ]
    timings = [[f"{width} x {height}", "high", human_time(
        float(np.mean([row["denoise_s"] for p in presets.values()
                       for row in p["rows"].values()]))),
        "`Renderer.denoised()`: features read back, OIDN"]]
    for (side, quality), seconds in results["oidn"].items():
        timings.append([f"{side} x {side}", quality, human_time(seconds), "OIDN alone"])
    lines += ["", "### Denoise time per frame", ""]
    lines += _table(["size", "quality", "time", "what"], timings)
    lines += [END_MARKER]
    return "\n".join(lines)


def parse_args(argv: Sequence[str] | None):
    """Parse the command line (``argv`` without the program name)."""
    return report.argument_parser(
        MODULE, "What denoising buys the renderer.",
        "tiny images, a low-spp reference (a minute); writes nothing unless --output"
    ).parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Run, print the section and write it (docs/benchmarks.md in full mode)."""

    def measure(quick: bool, progress: bool, command: str) -> str:
        cfg = QUICK if quick else FULL
        return render_section(run_benchmarks(cfg, progress), cfg, command)

    return report.section_main(argv, MODULE, parse_args, (BEGIN_MARKER, END_MARKER), measure)


if __name__ == "__main__":
    sys.exit(main())
