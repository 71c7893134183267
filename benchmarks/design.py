"""Inverse design (:mod:`wgbragg.design`): parameter recovery, colour design and the jewel
beetle, measured side by side in one run.

- **Parameter recovery**: random Bragg mirrors (n1 = 1 fixed; n2, d1, d2, N free) and films
  over glass or gold (n_film, d free); spectra from ``tmm`` (float64, s and p averaged) at
  400-750 nm every 5 nm and 3 angles (0, 30, 60 degrees), plus 1 % noise (normal, sigma 0.01
  in R). Success: N exact and every continuous parameter within 2 standard errors or 1 % of the
  truth. Success rate and median time of :func:`~wgbragg.design.fit_spectrum` with the GPU
  global stage, with the float64 numpy one, and with CMA-ES instead of differential evolution.
- **tmm + scipy baseline**: the same algorithm with ``tmm`` evaluating each spectrum
  (``tmm`` and the numpy twin agree to rounding, so the same searches succeed equally): its time
  is the number of spectra our fits evaluated times tmm's measured time per spectrum
  (extrapolated, not run: one fit would take hours on 2 cores).
- **Colour design**: targets that are the colours (0, 30, 60 degrees) of random mirrors;
  share reaching dE2000 <= 1 and median time of :func:`~wgbragg.design.design_colour`, with
  each search colour method ("averaged", the default, and "grid") on the same targets.
- **Search colour methods**: one population of random mirrors coloured at 0, 30 and 60
  degrees by each method on the GPU (one dispatch) and by the float64 "averaged" twin: time
  per population, and dE2000 to the reference colour.
- **Robust design**: the same colour travels designed plainly and with ``robust=`` (the
  objective averaged over fixed quasi-random draws of a per-parameter thickness error), both
  designs then evaluated on the same 300 fresh pseudo-random draws: mean dE2000 to the target,
  nominal dE2000, time.
- **Jewel beetle**: the green area of Table 3 (host air) recovered from its own noisy spectrum.

Usage::

    python -m benchmarks.design                 # full run: docs/benchmarks.md
    python -m benchmarks.design --quick         # tiny sizes, print only
"""

from __future__ import annotations

import dataclasses
import sys
import time
from collections.abc import Sequence

import numpy as np

from benchmarks import report
from benchmarks.report import human_time, markdown_table

MODULE = "benchmarks.design"
BEGIN_MARKER, END_MARKER = report.markers("bench_design")

ANGLES_DEG = (0.0, 30.0, 60.0)
WAVELENGTH_NM = np.arange(400.0, 751.0, 5.0)
NOISE = 0.01


@dataclasses.dataclass(frozen=True)
class Config:
    name: str
    mirrors: int
    films: int
    numpy_fits: int
    cma_fits: int
    colours: int
    population_colours: int
    generations: int
    beetle: bool
    robust_targets: int
    robust_samples: int


QUICK = Config("quick", mirrors=1, films=1, numpy_fits=1, cma_fits=1, colours=1,
               population_colours=4, generations=10, beetle=False, robust_targets=1,
               robust_samples=4)
FULL = Config("full", mirrors=16, films=8, numpy_fits=6, cma_fits=8, colours=50,
              population_colours=200, generations=150, beetle=True, robust_targets=4,
              robust_samples=32)

ROBUST_SIGMA_NM = 3.0
FRESH_DRAWS = 300


def tmm_spectrum(structure, wavelength_nm, angles_rad) -> np.ndarray:
    """Unpolarized R ``(W, A)`` of a BraggMirror or ThinFilm by ``tmm.coh_tmm``."""
    import tmm

    from wgbragg import BraggMirror

    out = np.empty((len(wavelength_nm), len(angles_rad)))
    for i, wl in enumerate(wavelength_nm):
        if isinstance(structure, BraggMirror):
            n = [structure.host, *[structure.n1, structure.n2] * structure.N, structure.n1]
            d = [np.inf, *[structure.d1, structure.d2] * structure.N, np.inf]
        else:
            base = complex(structure.base_index(np.array([wl]))[0])
            n = [structure.host, structure.n_film, base]
            d = [np.inf, structure.d, np.inf]
        for j, a in enumerate(angles_rad):
            out[i, j] = 0.5 * (tmm.coh_tmm("s", n, d, a, wl)["R"]
                               + tmm.coh_tmm("p", n, d, a, wl)["R"])
    return out


def random_cases(config: Config, seed: int = 0):
    """(label, truth, fixed, bounds) of the recovery cases."""
    from wgbragg import BraggMirror, ThinFilm

    rng = np.random.default_rng(seed)
    cases = []
    for _ in range(config.mirrors):
        truth = BraggMirror(1.0, rng.uniform(1.3, 2.0), rng.uniform(60, 250),
                            rng.uniform(60, 250), int(rng.integers(3, 16)))
        cases.append(("mirror", truth, {"n1": 1.0}, {"N": (1, 30)}))
    for k in range(config.films):
        if k % 2:
            truth = ThinFilm(rng.uniform(1.3, 2.2), rng.uniform(100, 800), base="Au")
            cases.append(("film on Au", truth, {"base": "Au"}, None))
        else:
            truth = ThinFilm(rng.uniform(1.3, 2.2), rng.uniform(100, 800), n_base=1.5)
            cases.append(("film on glass", truth, {"n_base": 1.5}, None))
    return cases


def succeeded(result, truth) -> bool:
    """N exact and each continuous free parameter within 2 standard errors or 1 %."""
    for name in result.free:
        value, true = result.parameters[name], float(getattr(truth, name))
        if name == "N":
            if value != true:
                return False
            continue
        error = result.standard_errors[name]
        if abs(value - true) > max(2 * error, 0.01 * abs(true)):
            return False
    return True


@dataclasses.dataclass
class Results:
    config: Config
    environment: dict
    recovery: dict  # search -> list of (label, success, seconds, spectra, tmm seconds/spectrum)
    tmm_agreement: float
    colour: dict  # search colour method -> list of (delta_e, seconds)
    search_colours: dict  # "averaged (GPU)" etc. -> (seconds, dE2000 to the reference (P*A,))
    beetle: dict | None
    robust: list  # per target: {"plain"|"robust": (nominal dE, fresh mean dE, seconds)}


def run_benchmarks(config: Config, progress: bool) -> Results:
    from wgbragg.design import design_colour, fit_spectrum
    from wgbragg.design.families import parameter_space
    from wgbragg.design.population import population_reflectance

    meter = report.LoadMeter()
    environment = report.run_facts()
    theta = np.radians(ANGLES_DEG)
    rng = np.random.default_rng(1)
    cases = random_cases(config)
    spectra, tmm_seconds = [], []
    for _, t, _, _ in cases:
        spectrum, seconds = report.timed(lambda t=t: tmm_spectrum(t, WAVELENGTH_NM, theta))
        spectra.append(spectrum)
        tmm_seconds.append(seconds)
    noisy = [s + NOISE * rng.standard_normal(s.shape) for s in spectra]
    # tmm against the numpy twin, and tmm's time per spectrum (W x A points, s and p).
    label, truth, fixed, bounds = cases[0]
    space = parameter_space("bragg", fixed=fixed)
    ours = population_reflectance(
        "bragg", space.members(space.vector(truth)[None]),
        np.repeat(WAVELENGTH_NM, 3), np.tile(theta, WAVELENGTH_NM.size))
    agreement = float(np.max(np.abs(ours.reshape(-1, 3) - spectra[0])))

    runs = {"gpu": [], "numpy": [], "cma": []}
    bar = report.progress_bar(total=len(cases) + config.numpy_fits + config.cma_fits,
                              show=progress, desc="fits", unit="fit")
    for i, (label, truth, fixed, bounds) in enumerate(cases):
        for key, kwargs, limit in (("gpu", {}, len(cases)),
                                   ("numpy", {"backend": "numpy"}, config.numpy_fits),
                                   ("cma", {"method": "cma"}, config.cma_fits)):
            if i >= limit:
                continue
            family = "bragg" if label == "mirror" else "film"
            result = fit_spectrum(family, WAVELENGTH_NM[:, None], theta, noisy[i], bounds,
                                  fixed, seed=i, generations=config.generations, **kwargs)
            runs[key].append((label, succeeded(result, truth), result.seconds,
                              result.evaluations + result.polish_evaluations,
                              tmm_seconds[i]))
            bar.update(1)
    bar.close()

    colour = {"averaged": [], "grid": []}
    from wgbragg import BraggMirror

    for k in range(config.colours):
        truth = BraggMirror(1.0, rng.uniform(1.3, 2.0), rng.uniform(60, 250),
                            rng.uniform(60, 250), int(rng.integers(3, 13)))
        for method, rows in colour.items():
            start = time.perf_counter()
            found = design_colour(truth.xyz(theta), theta, "bragg", fixed={"n1": 1.0},
                                  bounds={"N": (1, 15)}, space="xyz", seed=k,
                                  generations=max(10, config.generations // 3), method=method)
            rows.append((found[0].delta_e, time.perf_counter() - start))
    search_colours = run_search_colours(config, theta, np.random.default_rng(3))

    robust = run_robust(config, theta, np.random.default_rng(2))  # own draws: rng unchanged
    beetle = None
    if config.beetle:
        from wgbragg.app.scatterogram import JEWEL_BEETLE_AREAS

        p = JEWEL_BEETLE_AREAS["green"]
        d1 = p["delta"] * p["period_nm"]
        truth = BraggMirror(p["n1"], p["n2"], d1, p["period_nm"] - d1, p["N"], host=1.0)
        measured = tmm_spectrum(truth, WAVELENGTH_NM, theta)
        measured = measured + NOISE * rng.standard_normal(measured.shape)
        result = fit_spectrum("bragg", WAVELENGTH_NM[:, None], theta, measured,
                              bounds={"n1": (1.3, 1.8), "n2": (1.3, 1.9), "d1": (40, 200),
                                      "d2": (40, 200), "N": (2, 20)}, fixed={"host": 1.0},
                              seed=0, generations=config.generations)
        beetle = {"truth": truth, "result": result, "success": succeeded(result, truth)}
    environment["background_cores"] = meter.background_cores()
    return Results(config, environment, runs, agreement, colour, search_colours, beetle,
                   robust)


def run_search_colours(config: Config, theta, rng) -> dict:
    """One population of random mirrors (N in [1, 15]) coloured by each search colour method:
    seconds per population (the GPU's second call, its pipeline built) and dE2000 to the
    reference colour at each (member, angle)."""
    from wgbragg import BraggMirror
    from wgbragg.colour.colorimetry import xyz_to_lab
    from wgbragg.design import population, population_gpu
    from wgbragg.design.colour_targets import delta_e, grid_xyz_weights
    from wgbragg.design.families import parameter_space

    space = parameter_space("bragg", bounds={"N": (1, 15)}, fixed={"n1": 1.0})
    size = config.population_colours
    members = space.members(space.lower + rng.random((size, space.size))
                            * (space.upper - space.lower))
    reference = np.stack([
        BraggMirror(*(members[k][p] for k in ("n1", "n2", "d1", "d2")), int(members["N"][p]),
                    host=members["host"][p]).xyz(theta, method="reference")
        for p in range(size)])
    nodes, weights = grid_xyz_weights()
    wl, th = np.tile(nodes, theta.size), np.repeat(theta, nodes.size)

    def grid_gpu():
        spectra = population_gpu.population_reflectance("bragg", members, wl, th)
        return spectra.reshape(size, theta.size, nodes.size) @ weights

    out = {}
    for name, colour in (("averaged, GPU population kernel",
                          lambda: population_gpu.population_xyz(members, theta)),
                         ("grid (2 nm), GPU population kernel", grid_gpu),
                         ("averaged, float64 numpy twin",
                          lambda: population.population_xyz(members, theta))):
        if "GPU" in name:
            colour()  # builds the pipeline
        xyz, seconds = report.timed(colour)
        out[name] = (seconds, delta_e(xyz_to_lab(np.maximum(xyz, 0.0)),
                                      xyz_to_lab(reference)).ravel())
    return out


def run_robust(config: Config, theta, rng) -> list:
    """Plain and robust designs of random mirrors' colour travels, each measured on the same
    fresh draws (mean dE2000 to the target) and at its nominal colour."""
    from wgbragg import BraggMirror
    from wgbragg.design import design_colour
    from wgbragg.design.colour_design import perturbed_delta_e
    from wgbragg.design.tolerance import perturbations

    out = []
    fresh = perturbations("bragg", FRESH_DRAWS, ROBUST_SIGMA_NM, 0.0, seed=12345)
    for k in range(config.robust_targets):
        truth = BraggMirror(1.0, rng.uniform(1.3, 2.0), rng.uniform(60, 250),
                            rng.uniform(60, 250), int(rng.integers(3, 13)))
        target = truth.xyz(theta)
        row = {}
        for name, robust in (("plain", None), ("robust", {
                "sigma_thickness_nm": ROBUST_SIGMA_NM, "samples": config.robust_samples})):
            start = time.perf_counter()
            best = design_colour(target, theta, "bragg", fixed={"n1": 1.0},
                                 bounds={"N": (1, 15)}, space="xyz", seed=k,
                                 generations=max(10, config.generations // 3), robust=robust)[0]
            seconds = time.perf_counter() - start
            spread = perturbed_delta_e(best.structure, target, theta, fresh, space="xyz",
                                       backend="gpu")
            row[name] = (best.delta_e, float(spread.mean()), seconds)
        out.append(row)
    return out


def _rate(rows) -> str:
    if not rows:
        return report.NOT_MEASURED
    return f"{sum(r[1] for r in rows)}/{len(rows)}"


def render_section(results: Results, command: str) -> str:
    cfg = results.config
    out = report.section_head(BEGIN_MARKER, f"Inverse design (`python -m {MODULE}`)", command,
                              results.environment,
                              "tiny sizes, 10 generations" if cfg.name == "quick" else None)
    out += [
        f"- Spectra: `tmm` (float64, unpolarized), {WAVELENGTH_NM[0]:g}-{WAVELENGTH_NM[-1]:g} "
        f"nm every 5 nm at {', '.join(f'{a:g}' for a in ANGLES_DEG)}°, noise "
        f"{report.SIGMA} = {NOISE} in R. "
        "Mirrors: n1 = 1 fixed, n2 in [1.3, 2], d1, d2 in [60, 250] nm, N in [3, 15] (searched "
        "in [1, 30]); films: n_film in [1.3, 2.2], d in [100, 800] nm over glass (1.5) or Au.",
        f"- Success: N exact and every continuous parameter within 2 standard errors or 1 %. "
        f"{cfg.generations} generations at most, default population.",
        f"- tmm against the numpy twin on the first mirror: max |ΔR| = "
        f"{results.tmm_agreement:.1e}.",
        "",
        "### Parameter recovery",
        "",
    ]
    rows = []
    for key, name in (("gpu", "DE, GPU global stage"), ("numpy", "DE, numpy global stage"),
                      ("cma", "CMA-ES, GPU global stage")):
        runs = results.recovery[key]
        for label in ("mirror", "film on glass", "film on Au"):
            subset = [r for r in runs if r[0] == label]
            if not subset:
                continue
            rows.append([name, label, _rate(subset),
                         human_time(float(np.median([r[2] for r in subset]))),
                         f"{np.median([r[3] for r in subset]):,.0f}"])
    out += markdown_table(["search", "structures", "success", "median time",
                           "median spectra evaluated"], rows)
    gpu = results.recovery["gpu"]
    numpy_runs = results.recovery["numpy"]
    paired = gpu[:len(numpy_runs)]
    tmm_times = [r[3] * r[4] for r in gpu]  # spectra evaluated x tmm's time per spectrum
    out += ["", "### Against the float64 numpy search and the tmm + scipy baseline", "",
            *markdown_table(
                ["global stage", "median time per fit", "median ratio to the GPU (same fits)"],
                [["GPU (float32 population kernel)",
                  human_time(float(np.median([r[2] for r in gpu]))), "1"],
                 ["numpy (float64 twin)",
                  human_time(float(np.median([r[2] for r in numpy_runs]))),
                  f"{np.median([n[2] / g[2] for n, g in zip(numpy_runs, paired, strict=True)]):.1f}"
                  f"{report.TIMES}"],
                 ["tmm + scipy (extrapolated: spectra evaluated x tmm's time per spectrum, "
                  f"median {human_time(float(np.median([r[4] for r in gpu])))})",
                  human_time(float(np.median(tmm_times))),
                  f"{np.median([t / g[2] for t, g in zip(tmm_times, gpu, strict=True)]):,.0f}"
                  f"{report.TIMES}"]]),
            ""]
    rows = []
    for method, runs in results.colour.items():
        de = np.array([c[0] for c in runs])
        rows.append([f"{len(de)} colour travels of random mirrors (0/30/60°)", f'"{method}"',
                     f"{np.mean(de <= 1.0):.0%}", f"{np.median(de):.2f}",
                     human_time(float(np.median([c[1] for c in runs])))])
    out += ["### Colour design", "",
            *markdown_table(["targets", "search colour", "dE2000 <= 1", "median dE2000",
                             "median time"], rows), ""]
    size = cfg.population_colours
    rows = []
    for name, (seconds, de) in results.search_colours.items():
        rows.append([name, human_time(seconds), human_time(seconds / (size * len(ANGLES_DEG))),
                     f"{de.mean():.3f}", f"{np.percentile(de, 95):.3f}", f"{de.max():.3f}"])
    out += ["### Search colour methods", "",
            f"One population of {size} random mirrors (n1 = 1, n2 in [1.3, 2], d1, d2 in "
            f"[60, 250] nm, N in [1, 15]) at {', '.join(f'{a:g}' for a in ANGLES_DEG)}°; "
            "dE2000 to the reference colour (exact R every nm) over all members and angles.", "",
            *markdown_table(["colour", "time per population", "per colour",
                             "mean dE2000", "p95", "max"], rows), ""]
    rows = []
    for k, row in enumerate(results.robust):
        for name in ("plain", "robust"):
            nominal, fresh, seconds = row[name]
            rows.append([str(k + 1), name, f"{nominal:.2f}", f"{fresh:.3f}", human_time(seconds)])
    plain = np.array([row["plain"][1] for row in results.robust])
    sturdy = np.array([row["robust"][1] for row in results.robust])
    out += ["### Robust design", "",
            f"Colour travels of random mirrors (0/30/60°); `robust=` averages the objective "
            f"over {cfg.robust_samples} fixed quasi-random draws of a per-parameter thickness "
            f"error ({report.SIGMA} = {ROBUST_SIGMA_NM:g} nm); both designs are then measured "
            f"on the same {FRESH_DRAWS} fresh pseudo-random draws (colour by the search's "
            "\"averaged\" on the GPU).", "",
            *markdown_table(["target", "design", "nominal dE2000",
                             f"mean dE2000 over {FRESH_DRAWS} fresh draws", "time"], rows),
            "", f"Robust design better on the fresh draws for {int(np.sum(sturdy < plain))} of "
            f"{len(plain)} targets; mean over targets {sturdy.mean():.3f} against "
            f"{plain.mean():.3f}.", ""]
    if results.beetle is not None:
        truth, result = results.beetle["truth"], results.beetle["result"]
        rows = []
        for name in result.free:
            error = result.standard_errors.get(name)
            rows.append([name, f"{float(getattr(truth, name)):g}",
                         f"{result.parameters[name]:.4g}",
                         report.NOT_MEASURED if error is None else f"{error:.2g}"])
        out += ["### Jewel beetle (green area, Table 3, seen from air)", "",
                *markdown_table(["parameter", "Table 3", "fitted", "std error"], rows),
                "", f"Recovered: {report.yes_no(results.beetle['success'])}, in "
                f"{human_time(result.seconds)}; RMS residual {result.rms:.4f}.", ""]
    out.append(END_MARKER)
    return "\n".join(out)


def parse_args(argv: Sequence[str] | None):
    return report.argument_parser(
        MODULE, "Inverse design: parameter recovery, colour design, the jewel beetle.",
        "tiny sizes; writes nothing unless --output").parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmark, print the section and write it where asked; returns the status."""

    def measure(quick: bool, progress: bool, command: str) -> str:
        return render_section(run_benchmarks(QUICK if quick else FULL, progress), command)

    return report.section_main(argv, MODULE, parse_args, (BEGIN_MARKER, END_MARKER), measure)


if __name__ == "__main__":
    sys.exit(main())
