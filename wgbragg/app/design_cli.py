"""The ``wgbragg fit`` and ``wgbragg design`` commands (inverse design, :mod:`wgbragg.design`).

``wgbragg fit SPECTRUM.csv --family bragg|film --theta-deg 0,30,60`` fits a structure to a
measured spectrum; ``wgbragg design --target "#d4af37@0" --target "#2e8b57@60" --family bragg``
designs one for target colours over angle. Both print a table and write a report PNG and a
scene TOML whose material is the structure (``wgbragg render OUT.toml`` renders it), and with
``--export FILE`` the same scene as glTF 2.0 or MaterialX.

Building the parser imports nothing heavy; each command imports what it runs when it runs.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from wgbragg.app import export_cli
from wgbragg.common.atomic import check_output_path

__all__ = ["add_design_commands", "parse_assignments", "parse_target"]

FAMILY_NAMES = ("bragg", "film")
SPACES = ("srgb", "linear-srgb", "xyz", "lab")


def parse_assignments(flag: str, text: str, ranges: bool) -> dict:
    """``"n2=1.2:2.0,N=2:20"`` (ranges; a film's ``base=Au:Cu`` lists metals to choose
    among) or ``"n1=1.0,base=Au"`` as a dict."""
    out: dict = {}
    for item in filter(None, (part.strip() for part in (text or "").split(","))):
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or not name:
            raise ValueError(f"{flag}: expected NAME={'LOW:HIGH' if ranges else 'VALUE'}, "
                             f"got {item!r}")
        if ranges and name == "base":  # a film's base: metals to choose among
            out[name] = [v.strip() for v in value.split(":") if v.strip()]
        elif ranges:
            low, colon, high = value.partition(":")
            try:
                out[name] = (float(low), float(high))
            except ValueError:
                raise ValueError(f"{flag}: {name} needs LOW:HIGH numbers, got {value!r}") from None
            if not colon:
                raise ValueError(f"{flag}: {name} needs LOW:HIGH, got {value!r}")
        else:
            try:
                out[name] = float(value)
            except ValueError:
                out[name] = value.strip()
    return out


def parse_target(text: str, space: str):
    """``"#d4af37@0"`` or ``"0.2,0.5,0.1@30"`` as (colour, angle in degrees)."""
    colour, sep, degrees = text.rpartition("@")
    if not sep:
        raise ValueError(f"--target: expected COLOUR@DEGREES, e.g. '#d4af37@0', got {text!r}")
    try:
        angle = float(degrees)
    except ValueError:
        raise ValueError(f"--target: the angle after @ must be degrees, got {degrees!r}") from None
    if not (math.isfinite(angle) and 0.0 <= angle <= 90.0):
        raise ValueError(f"--target: the angle must be in [0, 90] degrees, got {degrees!r}")
    if colour.strip().startswith("#"):
        return colour.strip(), angle
    try:
        values = [float(v) for v in colour.split(",")]
    except ValueError:
        raise ValueError(f"--target: a colour is '#rrggbb' or three numbers in {space}, got "
                         f"{colour!r}") from None
    if len(values) != 3:
        raise ValueError(f"--target: three numbers per colour, got {colour!r}")
    return values, angle


def _theta_list(text: str) -> np.ndarray:
    try:
        degrees = np.array([float(v) for v in text.split(",") if v.strip()])
    except ValueError:
        raise ValueError(f"--theta-deg: comma-separated degrees, got {text!r}") from None
    if degrees.size == 0 or np.any(~np.isfinite(degrees)) or np.any((degrees < 0) |
                                                                      (degrees > 90)):
        raise ValueError(f"--theta-deg: angles in [0, 90] degrees, got {text!r}")
    return degrees


def _outputs(args) -> tuple[Path, Path]:
    """The report and scene paths, after checking the options used only after the search."""
    if not (math.isfinite(args.alpha) and 0.01 <= args.alpha <= 1.0):
        raise ValueError(f"--alpha must be in [0.01, 1], got {args.alpha:g}")
    for flag, value in (("--sigma-thickness-nm", args.sigma_thickness_nm),
                        ("--sigma-index", args.sigma_index)):
        if not (math.isfinite(value) and value >= 0):
            raise ValueError(f"{flag} must be a finite number >= 0, got {value:g}")
    if not 1 <= args.samples <= 10**6:
        raise ValueError(f"--samples must be in [1, 1000000], got {args.samples}")
    export_cli.check_export(args.export)
    png = check_output_path(f"{args.output}.png", "--output", ".png")
    toml = check_output_path(f"{args.output}.toml", "--output", ".toml")
    return png, toml


def _add_search_arguments(parser) -> None:
    parser.add_argument("--family", choices=FAMILY_NAMES, required=True,
                        help="bragg: BraggMirror (n1, n2, d1, d2, N, host); film: ThinFilm "
                             "(n_film, d, n_base, k_base, host, base)")
    parser.add_argument("--bounds", default="", metavar="NAME=LOW:HIGH,...",
                        help="search bounds, e.g. 'n2=1.2:2.0,N=2:20'; a film's base as "
                             "metals to choose among: 'base=Au:Cu:Ag'")
    parser.add_argument("--fixed", default="", metavar="NAME=VALUE,...",
                        help="fixed parameters, e.g. 'n1=1.0' or 'base=Au'")
    parser.add_argument("--backend", choices=("gpu", "numpy"), default="gpu",
                        help="evaluator of the global search")
    parser.add_argument("--max-seconds", type=float, default=None,
                        help="time budget of the search")
    parser.add_argument("--seed", type=int, default=None, help="seed of the search")
    parser.add_argument("--generations", type=int, default=None,
                        help="most generations of the search (default: the API's)")
    parser.add_argument("--alpha", type=float, default=0.1,
                        help="GGX roughness of the material written to the TOML")
    parser.add_argument("--sigma-thickness-nm", type=float, default=2.0,
                        help="thickness error of the tolerance histogram, nm")
    parser.add_argument("--sigma-index", type=float, default=0.0,
                        help="index error of the tolerance histogram")
    parser.add_argument("--samples", type=int, default=500,
                        help="Monte Carlo samples of the tolerance histogram")
    parser.add_argument("--per-layer", action="store_true",
                        help="independent errors in each layer of a mirror (transfer "
                             "matrices on the GPU) instead of all layers of a kind together, "
                             "in the tolerance histogram and (design) --robust")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--export", default=None, metavar="FILE",
                        help="also write the result's scene as glTF 2.0 (.glb, .gltf) or "
                             "MaterialX (.mtlx), as 'wgbragg export' does")


def add_design_commands(commands, command) -> None:
    """Add ``fit`` and ``design`` to the subparsers ``commands``; ``command(commands, name,
    text)`` makes a subparser (the CLI's own help style)."""
    fit = command(commands, "fit", "fit a Bragg mirror or thin film to a measured spectrum "
                                   "(CSV: wavelength_nm, then one reflectance column per angle)")
    fit.add_argument("spectrum", metavar="SPECTRUM.csv", help="the measured spectrum")
    fit.add_argument("--theta-deg", default=None,
                     help="angles of the columns in degrees, e.g. 0,30,60 (default: the CSV "
                          "header's)")
    fit.add_argument("--polarization", choices=("unpolarized", "s", "p"), default="unpolarized",
                     help="polarization of the measurement")
    fit.add_argument("--method", choices=("de", "cma"), default="de",
                     help="global search: differential evolution or CMA-ES")
    _add_search_arguments(fit)
    fit.add_argument("-o", "--output", default="out/fit",
                     help="prefix of the report PNG and the scene TOML")
    fit.set_defaults(run=run_fit)
    design = command(commands, "design", "design a Bragg mirror or thin film whose colour over "
                                         "angle matches targets")
    design.add_argument("--target", action="append", required=True, metavar="COLOUR@DEG",
                        help="a target colour at an angle: '#d4af37@0', or three numbers in "
                             "--space: '0.2,0.5,0.1@30'; repeat for a colour travel")
    design.add_argument("--space", choices=SPACES, default="srgb",
                        help="space of numeric targets (xyz and lab: D65, Y = 1 white)")
    design.add_argument("--objective", choices=("mean", "max"), default="mean",
                        help="dE2000 over the angles")
    design.add_argument("--colour-method", choices=("averaged", "grid"), default=None,
                        help="colour method of the global search: averaged (mirrors, the "
                             "default) or grid (R every 2 nm; films, the default)")
    design.add_argument("--candidates", type=int, default=5,
                        help="most candidates (Pareto set of dE2000 against N or thickness)")
    design.add_argument("--robust", type=int, default=None, metavar="DRAWS",
                        help="design for robustness: average the objective over DRAWS fixed "
                             "draws of the --sigma-thickness-nm / --sigma-index errors "
                             "(a power of 2, e.g. 16)")
    _add_search_arguments(design)
    design.add_argument("-o", "--output", default="out/design",
                        help="prefix of the report PNG and the scene TOML")
    design.set_defaults(run=run_design)


def run_fit(args) -> int:
    """``wgbragg fit``."""
    from wgbragg.app.design_report import save_fit_report
    from wgbragg.design import fit_spectrum, tolerance
    from wgbragg.design.files import read_spectrum_csv

    png, toml = _outputs(args)
    bounds = parse_assignments("--bounds", args.bounds, True)
    fixed = parse_assignments("--fixed", args.fixed, False)
    spectrum = read_spectrum_csv(args.spectrum)
    if args.theta_deg is not None:
        degrees = _theta_list(args.theta_deg)
    elif spectrum.theta_deg is not None:
        degrees = spectrum.theta_deg
    else:
        raise ValueError("--theta-deg is required when the CSV header does not name the angles")
    if degrees.size != spectrum.reflectance.shape[1]:
        raise ValueError(f"--theta-deg gives {degrees.size} angles but {args.spectrum} has "
                         f"{spectrum.reflectance.shape[1]} reflectance columns")
    theta = np.radians(degrees)
    result = fit_spectrum(args.family, spectrum.wavelength_nm[:, None], theta,
                          spectrum.reflectance, bounds, fixed, args.polarization,
                          backend=args.backend, method=args.method,
                          max_seconds=args.max_seconds, seed=args.seed,
                          **_generations(args),
                          progress=not args.no_progress)
    spread = tolerance(result.structure, args.sigma_thickness_nm, args.sigma_index,
                       args.samples, theta, per_layer=args.per_layer, backend=args.backend,
                       seed=args.seed)
    print(f"fit of {args.spectrum}: RMS residual {result.rms:.4g}, "
          f"{result.evaluations} structures searched in {result.seconds:.1f} s"
          + (" (stopped by --max-seconds)" if result.stopped_by_time else ""))
    print(f"{'parameter':<10} {'value':>14} {'std error':>12}")
    for name, value in result.parameters.items():
        error = result.standard_errors.get(name)
        shown = f"{value:14.6g}" if isinstance(value, float | int) else f"{value!s:>14}"
        note = f"{error:12.3g}" if error is not None else \
            ("    (integer)" if name in result.free else
             "     (chosen)" if name in bounds else "      (fixed)")
        print(f"{name:<10} {shown} {note}")
    if len(result.optima) > 1:
        print(f"{len(result.optima)} distinct optima fit about as well (the data do not single "
              "out one structure):")
        for optimum in result.optima:
            print(f"  RMS {optimum.rms:.4g}: {optimum.structure!r}")
    _write(result.structure, args, toml)
    save_fit_report(result, spectrum.wavelength_nm, theta, spectrum.reflectance, png, spread)
    print(f"tolerance (sigma {args.sigma_thickness_nm:g} nm, {args.sigma_index:g}): median "
          f"dE2000 {spread.percentiles[50]:.2f}, 90% {spread.percentiles[90]:.2f}")
    print(f"wrote {png} and {toml}")
    return 0


def _generations(args) -> dict:
    return {} if args.generations is None else {"generations": args.generations}


def _write(structure, args, toml) -> None:
    from wgbragg.design.files import write_scene_toml

    write_scene_toml(structure, toml, alpha=args.alpha)
    if args.export is not None:
        export_cli.write_structure(structure, args.export, args.alpha)


def run_design(args) -> int:
    """``wgbragg design``."""
    from wgbragg.app.design_report import save_design_report
    from wgbragg.design import design_colour, tolerance
    from wgbragg.design.colour_targets import parse_targets

    png, toml = _outputs(args)
    bounds = parse_assignments("--bounds", args.bounds, True)
    fixed = parse_assignments("--fixed", args.fixed, False)
    parsed = [parse_target(t, args.space) for t in args.target]
    colours = [c for c, _ in parsed]
    theta = np.radians([a for _, a in parsed])
    space = "srgb" if all(isinstance(c, str) for c in colours) else args.space
    if any(isinstance(c, str) for c in colours) and space != "srgb":
        raise ValueError("--target: do not mix hex colours with numeric ones in another --space")
    if args.robust is not None and not 1 <= args.robust <= 4096:
        raise ValueError(f"--robust must be in [1, 4096] draws, got {args.robust}")
    robust = None if args.robust is None else {
        "sigma_thickness_nm": args.sigma_thickness_nm, "sigma_index": args.sigma_index,
        "samples": args.robust, "per_layer": args.per_layer}
    candidates = design_colour(colours, theta, args.family, bounds, fixed, space,
                               objective=args.objective, method=args.colour_method,
                               candidates=args.candidates,
                               backend=args.backend, max_seconds=args.max_seconds,
                               seed=args.seed, progress=not args.no_progress, robust=robust,
                               **_generations(args))
    spread = tolerance(candidates[0].structure, args.sigma_thickness_nm, args.sigma_index,
                       args.samples, theta, per_layer=args.per_layer, backend=args.backend,
                       seed=args.seed)
    robust_column = "" if robust is None else f" {'robust dE':>9}"
    print(f"{'#':>2} {'dE2000':>7} {candidates[0].method + ' dE':>13}{robust_column} "
          f"{'complexity':>10}  structure")
    for i, c in enumerate(candidates, start=1):
        mean = "" if robust is None else f" {c.robust_delta_e:9.2f}"
        print(f"{i:>2} {c.delta_e:7.2f} {c.delta_e_method:13.2f}{mean} {c.complexity:10.4g}  "
              f"{c.structure!r}")
    _write(candidates[0].structure, args, toml)
    save_design_report(candidates, theta, parse_targets(colours, len(colours), space), png,
                       spread)
    print(f"tolerance of #1 (sigma {args.sigma_thickness_nm:g} nm, {args.sigma_index:g}): "
          f"median dE2000 {spread.percentiles[50]:.2f}, 90% {spread.percentiles[90]:.2f}")
    print(f"wrote {png} and {toml}")
    return 0
