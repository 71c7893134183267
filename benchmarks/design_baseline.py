"""Fitting measured spectra with wgbragg against a ``tmm`` + scipy baseline, both run, side by
side in one run.

The cases and their noisy spectra are those of :mod:`benchmarks.design` (the same random
structures, the same noise draws): for each, :func:`~wgbragg.design.fit_spectrum` with the GPU
global stage, then the baseline a ``tmm`` user would write with scipy: the same global search
(scrambled Sobol screen, then ``scipy.optimize.differential_evolution`` with integer N, the same
population, generations and seed), each member's spectrum from ``tmm.coh_tmm`` (s and p, every
wavelength and angle), then ``scipy.optimize.least_squares`` of the continuous parameters with
``tmm`` residuals from the best point at N - 1, N and N + 1, standard errors from its Jacobian.
Success has the same definition: N exact and every continuous parameter within 2 standard
errors or 1 % of the truth. A baseline mirror fit takes about 17 minutes on 2 cores, hence a
few cases only.

Usage::

    python -m benchmarks.design_baseline            # full run: docs/benchmarks.md
    python -m benchmarks.design_baseline --quick    # one film, tiny search, print only
"""

from __future__ import annotations

import dataclasses
import sys
import time
from collections.abc import Sequence
from types import SimpleNamespace

import numpy as np

from benchmarks import design, report
from benchmarks.report import human_time, markdown_table

MODULE = "benchmarks.design_baseline"
BEGIN_MARKER, END_MARKER = report.markers("bench_design_baseline")


@dataclasses.dataclass(frozen=True)
class Config:
    name: str
    cases: tuple[int, ...]  # indices into benchmarks.design's full case list
    generations: int
    population: int | None
    wavelength_step: int  # every k-th wavelength of benchmarks.design.WAVELENGTH_NM


QUICK = Config("quick", cases=(16,), generations=2, population=4, wavelength_step=10)
FULL = Config("full", cases=(0, 1, 16), generations=design.FULL.generations, population=None,
              wavelength_step=1)


def tmm_fit(label, measured, wavelength, theta, fixed, bounds, *, generations, population,
            seed, progress):
    """The baseline: the same global search with ``tmm`` spectra, then a ``tmm``
    ``least_squares`` polish; returns an object :func:`benchmarks.design.succeeded` reads."""
    from scipy.optimize import least_squares

    from wgbragg.design.families import parameter_space
    from wgbragg.design.search import global_search

    space = parameter_space("bragg" if label == "mirror" else "film", bounds, fixed)
    counter = [0]

    def spectra(x):
        x = np.atleast_2d(x)
        counter[0] += len(x)
        return np.array([design.tmm_spectrum(space.structure(v), wavelength, theta).ravel()
                         for v in x])

    data = np.asarray(measured, np.float64).ravel()
    best, archive, _ = global_search(
        space, lambda x: np.mean((spectra(x) - data) ** 2, axis=1), population=population,
        generations=generations, seed=seed, progress=progress, description="tmm + scipy")
    free = ~space.integer
    lo, hi = space.lower[free], space.upper[free]
    starts = [best]
    if space.integer.any():
        for step in (-1, 1):
            neighbour = best.copy()
            neighbour[space.integer] = np.clip(best[space.integer] + step,
                                               space.lower[space.integer],
                                               space.upper[space.integer])
            if not np.array_equal(neighbour, best):
                starts.append(neighbour)
    polished = []
    for start in starts:
        def residual(u, start=start):
            v = start.copy()
            v[free] = u
            return spectra(v)[0] - data
        fit = least_squares(residual, np.clip(start[free], lo, hi), bounds=(lo, hi),
                            x_scale=hi - lo, method="trf", max_nfev=200)
        x = start.copy()
        x[free] = fit.x
        polished.append((float(np.sqrt(np.mean(fit.fun ** 2))), x, fit))
    rms, x, fit = min(polished, key=lambda p: p[0])
    dof = max(data.size - int(free.sum()), 1)
    covariance = np.linalg.pinv(fit.jac.T @ fit.jac) * float(fit.fun @ fit.fun) / dof
    names = [n for n, f in zip(space.names, free, strict=True) if f]
    errors = dict(zip(names, np.sqrt(np.abs(np.diag(covariance))).tolist(), strict=True))
    return SimpleNamespace(free=space.names, standard_errors=errors, rms=rms,
                           parameters=dict(zip(space.names, (float(v) for v in x),
                                               strict=True)),
                           spectra=counter[0], evaluations=archive.evaluations)


def run_benchmarks(config: Config, progress: bool) -> dict:
    from wgbragg.design import fit_spectrum

    meter = report.LoadMeter()
    environment = report.run_facts()
    theta = np.radians(design.ANGLES_DEG)
    cases = design.random_cases(design.FULL)
    # The noise of benchmarks.design: one (W, A) normal draw per case, in case order.
    rng = np.random.default_rng(1)
    noise = [design.NOISE * rng.standard_normal((design.WAVELENGTH_NM.size, theta.size))
             for _ in cases]
    keep = slice(None, None, config.wavelength_step)
    wavelength = design.WAVELENGTH_NM[keep]
    rows = []
    for index in config.cases:
        label, truth, fixed, bounds = cases[index]
        measured = (design.tmm_spectrum(truth, design.WAVELENGTH_NM, theta)
                    + noise[index])[keep]
        family = "bragg" if label == "mirror" else "film"
        ours = fit_spectrum(family, wavelength[:, None], theta, measured, bounds, fixed,
                            seed=index, generations=config.generations,
                            population=config.population)
        start = time.perf_counter()
        baseline = tmm_fit(label, measured, wavelength, theta, fixed, bounds,
                           generations=config.generations, population=config.population,
                           seed=index, progress=progress)
        baseline_seconds = time.perf_counter() - start
        rows.append({"label": label, "truth": truth,
                     "ours": (design.succeeded(ours, truth), ours.seconds,
                              ours.evaluations + ours.polish_evaluations),
                     "baseline": (design.succeeded(baseline, truth), baseline_seconds,
                                  baseline.spectra)})
    environment["background_cores"] = meter.background_cores()
    return {"config": config, "environment": environment, "rows": rows,
            "wavelengths": wavelength.size}


def render_section(results: dict, command: str) -> str:
    cfg = results["config"]
    out = report.section_head(
        BEGIN_MARKER, f"Fitting spectra against tmm + scipy (`python -m {MODULE}`)", command,
        results["environment"],
        "one film, population 4, 2 generations, 8 wavelengths" if cfg.name == "quick" else None)
    out += [
        f"- Cases {', '.join(str(i + 1) for i in cfg.cases)} of `benchmarks.design` (same "
        f"structures, same noisy `tmm` spectra: {results['wavelengths']} wavelengths x "
        f"{len(design.ANGLES_DEG)} angles, unpolarized); {cfg.generations} generations, "
        f"{'default' if cfg.population is None else cfg.population} population, the same seed "
        "for both.",
        "- wgbragg: `fit_spectrum` with the GPU global stage and its float64 polish. Baseline: "
        "the same Sobol screen and `differential_evolution` with each spectrum from "
        "`tmm.coh_tmm` (s and p), then `least_squares` with `tmm` residuals at N - 1, N, N + 1.",
        "- Success: N exact and every continuous parameter within 2 standard errors or 1 %.",
        "",
    ]
    table = []
    for k, row in zip(cfg.cases, results["rows"], strict=True):
        ok, seconds, spectra = row["ours"]
        base_ok, base_seconds, base_spectra = row["baseline"]
        table.append([f"{k + 1} ({row['label']})", report.yes_no(ok), human_time(seconds),
                      f"{spectra:,}", report.yes_no(base_ok), human_time(base_seconds),
                      f"{base_spectra:,}", f"{base_seconds / seconds:,.0f}{report.TIMES}"])
    out += markdown_table(["case", "wgbragg recovered", "wgbragg time", "spectra",
                           "tmm + scipy recovered", "tmm + scipy time", "spectra",
                           "time ratio"], table)
    ours_ok = sum(r["ours"][0] for r in results["rows"])
    base_ok = sum(r["baseline"][0] for r in results["rows"])
    ratios = [r["baseline"][1] / r["ours"][1] for r in results["rows"]]
    out += ["", f"Recovered: wgbragg {ours_ok}/{len(ratios)}, tmm + scipy {base_ok}/"
            f"{len(ratios)}; median time ratio {np.median(ratios):,.0f}{report.TIMES}.",
            END_MARKER]
    return "\n".join(out)


def parse_args(argv: Sequence[str] | None):
    return report.argument_parser(
        MODULE, "Fitting spectra: wgbragg against a tmm + scipy baseline, both run.",
        "one film with a tiny search; writes nothing unless --output").parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmark, print the section and write it where asked; returns the status."""

    def measure(quick: bool, progress: bool, command: str) -> str:
        return render_section(run_benchmarks(QUICK if quick else FULL, progress), command)

    return report.section_main(argv, MODULE, parse_args, (BEGIN_MARKER, END_MARKER), measure)


if __name__ == "__main__":
    sys.exit(main())
