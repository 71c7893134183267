"""The ``wgbragg`` command line.

``wgbragg info`` shows the adapter and versions; ``wgbragg reflectance`` prints R for one
mirror; ``wgbragg map`` writes a reflectance map (wavelength x angle) as a PNG; ``wgbragg bake``
fills the LUT cache (transmission filters and colour tables, see :mod:`wgbragg.common.luts`),
``wgbragg cache verify|clear`` checks or empties it;
``wgbragg scatterogram`` renders the reflected hemisphere of a rough Bragg layer as a PNG;
``wgbragg render`` path-traces a scene file or a built-in preset to a PNG and optionally an EXR.

The module imports only what building the parser needs (argparse, numpy, the file checks):
each command imports what it runs when it runs, so ``--help`` answers at once, without
colour-science, matplotlib, trimesh, wgpu or scipy (``benchmarks/cli.py`` times it).
"""

from __future__ import annotations

import argparse
import collections
import contextlib
import functools
import signal
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from wgbragg.app import design_cli, export_cli, info_cli, sweep_cli
from wgbragg.common.atomic import check_output_folder, check_output_path
from wgbragg.common.luts import LutWarning

__all__ = ["build_parser", "main"]

DESCRIPTION = ("Structural-colour iridescence (Bragg mirrors, thin films) on any Vulkan device: "
               "reflectance of a mirror, reflectance maps, scatterograms, the LUT cache and a "
               "spectral path tracer. 'wgbragg COMMAND --help' describes each command.")
"""The top-level ``--help`` text (plain text: the module docstring is reStructuredText)."""

DEFAULT_ALPHAS = (0.05, 0.1, 0.2, 0.4)
"""GGX roughnesses whose transmission filters ``wgbragg bake`` bakes by default."""

PRESET_NAMES = ("furnace", "teapot", "fig1", "fig7", "fig10", "fig11", "fig12", "thin_film")
"""The built-in scenes, for the help text: :data:`wgbragg.scene.model.PRESETS` (a test keeps
them equal), named here because importing the scene package loads colour-science."""

SCATTEROGRAM_SIZES = (16, 4096)
"""Smallest and largest side of a scatterogram, for the help text and the check before the
work: :data:`wgbragg.app.scatterogram.SIZE_RANGE` (a test keeps them equal)."""

EXR_COLOUR_SPACES = {"srgb": "lin_rec709_scene", "xyz": "lin_ciexyzd65_scene",
                     "acescg": "lin_ap1_scene"}
"""``render --colour-space`` choices (:data:`wgbragg.colour.colorimetry.COLOUR_SPACES`) and the
``colorInteropID`` each writes into the EXR header (Color Interop Forum names)."""


class _HelpFormatter(argparse.HelpFormatter):
    """Help that states each option's default: ``(default: X)`` after its text, unless the
    text already says it or there is none to state (None, a flag)."""

    def _get_help_string(self, action):
        text = action.help or ""
        default = action.default
        if isinstance(action, argparse.BooleanOptionalAction):
            shown = "on" if default else "off"
        elif (action.nargs == 0 or default is None or default is argparse.SUPPRESS
              or not action.option_strings):
            return text
        elif isinstance(default, list | tuple):
            shown = " ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in default)
        else:
            shown = f"{default:g}" if isinstance(default, float) else str(default)
        if "default" in text:
            return text
        shown = shown.replace("%", "%%")
        return f"{text} (default: {shown})" if text else f"(default: {shown})"


def _command(commands, name: str, text: str):
    """A subcommand described by ``text`` (in the list of commands and atop its own
    ``--help``), whose help states each option's default."""
    return commands.add_parser(name, help=text, description=text, formatter_class=_HelpFormatter)


def _add_mirror_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("Bragg mirror (thicknesses in nm)")
    group.add_argument("--n1", type=float, default=1.0, help="refractive index of layer 1")
    group.add_argument("--n2", type=float, default=1.5, help="refractive index of layer 2")
    group.add_argument("--d1", type=float, default=125.0, help="thickness of layer 1, nm")
    group.add_argument("--d2", type=float, default=375.0, help="thickness of layer 2, nm")
    group.add_argument("-N", "--periods", type=int, default=20, help="number of periods")
    group.add_argument("--host", type=float, default=None,
                       help="refractive index of the incident medium (default: n1)")
    parser.add_argument("--polarization", choices=("unpolarized", "s", "p"), default="unpolarized",
                        help="polarization of the light")
    parser.add_argument("--backend", choices=("gpu", "numpy"), default="gpu",
                        help="float32 WGSL kernels, or the float64 numpy reference")


def _radians(flag: str, degrees, high: float = 90.0, *, below_high: bool = False):
    """``degrees`` (a flag's value or values) in radians, once each lies in [0, high] (or
    [0, high) with ``below_high``); the library would report the range in radians."""
    values = np.asarray(degrees, dtype=np.float64)
    inside = (values >= 0.0) & ((values < high) if below_high else (values <= high))
    if not inside.all():  # NaN fails
        bracket = ")" if below_high else "]"
        raise ValueError(f"{flag} must be in [0, {high:g}{bracket} degrees")
    return np.radians(values)


def _mirror(args):
    from wgbragg.bsdf.materials import BraggMirror

    return BraggMirror(n1=args.n1, n2=args.n2, d1=args.d1, d2=args.d2, N=args.periods,
                       host=args.host)


def _reflectance(args) -> int:
    mirror = _mirror(args)
    wavelength = np.asarray(args.wavelength, dtype=np.float64)
    theta = _radians("--theta-deg", args.theta_deg)
    values = mirror.reflectance(wavelength[:, None], theta[None, :], args.polarization,
                                args.backend)
    print("wavelength_nm " + " ".join(f"theta={t:g}deg" for t in args.theta_deg))
    for w, row in zip(args.wavelength, values, strict=True):
        print(f"{w:g} " + " ".join(f"{v:.6f}" for v in row))
    return 0


def _map(args) -> int:
    from wgbragg.app.maps import reflectance_map, save_reflectance_map

    check_output_path(args.output, "--output", ".png")
    mirror = _mirror(args)
    start = time.perf_counter()
    result = reflectance_map(mirror, polarization=args.polarization, backend=args.backend)
    seconds = time.perf_counter() - start
    title = f"{mirror!r}\n{result.values.size} evaluations ({args.backend}) in {seconds:.3f} s"
    save_reflectance_map(result, args.output, title)
    print(args.output)
    return 0


def _report(event) -> None:
    from tqdm import tqdm

    reason = f" ({event.reason})" if event.reason else ""
    # Through tqdm, so the line lands above the progress bar instead of through it.
    tqdm.write(f"{event.action}: {event.path}{reason}", file=sys.stdout)


def _bake(args) -> int:
    from tqdm import tqdm

    from wgbragg.bsdf import filter_cache
    from wgbragg.colour import tables
    from wgbragg.common import luts

    # Every parameter is checked before the first bake, so a bad value at the end of the list
    # does not surface only after minutes of baking the others.
    for alpha in args.alpha:
        filter_cache.transmission_filter_parameters(alpha, args.resolution_deg, args.psi_samples)
    if args.cache is not None:
        if not args.cache:  # Path("") is the current folder
            raise ValueError("--cache must be a folder path, got ''")
        check_output_folder(args.cache, "--cache")
    jobs = [
        # shared=False: baking means checking every file, even one read before.
        functools.partial(filter_cache.transmission_filter, alpha, args.resolution_deg,
                          args.psi_samples, args.backend, shared=False)
        for alpha in args.alpha
    ]
    if args.colour_tables:
        jobs.append(tables.colour_tables)
    if not jobs:
        raise ValueError("nothing to bake: give --alpha or leave --colour-tables on")
    with warnings.catch_warnings():
        # The "re-baked: PATH (reason)" line already says what a LutWarning would.
        warnings.simplefilter("ignore", luts.LutWarning)
        for job in tqdm(jobs, desc="baking LUTs", unit="table", disable=not args.progress):
            job(cache=args.cache, force=args.force, progress=_report)
    return 0


def _cache(args) -> int:
    from wgbragg.bsdf import filter_cache
    from wgbragg.colour import tables
    from wgbragg.common import luts

    if args.cache is not None and not args.cache:  # Path("") is the current folder
        raise ValueError("--cache must be a folder path, got ''")
    folder = luts.cache_dir() if args.cache is None else args.cache
    if args.cache_command == "clear":
        entries = luts.clear_cache(folder)
    else:
        checks = {luts.TRANSMISSION_FILTER: filter_cache.check_filter_tables,
                  luts.COLOUR_TABLES: tables.check_colour_tables}
        entries = luts.verify_cache(folder, checks, repair=args.repair)
    for entry in entries:
        reason = f" ({entry.reason})" if entry.reason else ""
        print(f"{entry.status}: {entry.path}{reason}")
    counts = collections.Counter(entry.status for entry in entries)
    summary = ", ".join(f"{counts[status]} {status}" for status in ("ok", "removed", "kept", "bad")
                        if counts[status])
    print(f"{folder}: {summary or 'no cache files'}")
    return 1 if counts["bad"] else 0


def _scatterogram(args) -> int:
    from wgbragg.app.scatterogram import jewel_beetle, save_scatterogram, scatterogram
    from wgbragg.bsdf.layered.model import LayeredBragg
    from wgbragg.bsdf.materials import BraggMirror
    from wgbragg.bsdf.rough_layer import RoughBraggLayer

    check_output_path(args.output, "--output", ".png")
    theta = _radians("--theta-deg", args.theta_deg, below_high=True)
    # Before the work, as the output path: the scatterogram itself checks them only after it.
    if not SCATTEROGRAM_SIZES[0] <= args.size <= SCATTEROGRAM_SIZES[1]:
        raise ValueError(f"--size must be an integer in [{SCATTEROGRAM_SIZES[0]}, "
                         f"{SCATTEROGRAM_SIZES[1]}], got {args.size}")
    if args.exposure is not None and not (np.isfinite(args.exposure) and args.exposure > 0.0):
        raise ValueError(f"--exposure must be finite and > 0, got {args.exposure}")
    if not np.isfinite(args.phi_deg):
        raise ValueError(f"--phi-deg must be a finite number of degrees, got {args.phi_deg}")
    if args.preset is not None:
        structure = jewel_beetle(args.preset)
        label = f"jewel beetle, {args.preset} area (Table 3)"
    else:
        mirror = BraggMirror(n1=args.n1, n2=args.n2, d1=args.d1, d2=args.d2, N=args.periods,
                             host=args.host)
        structure = LayeredBragg([RoughBraggLayer(mirror, args.alpha)],
                                 base_albedo=args.base_albedo)
        label = (f"n1={mirror.n1:g} n2={mirror.n2:g} d1={mirror.d1:g} d2={mirror.d2:g} nm "
                 f"N={mirror.N} alpha={args.alpha:g}")
    start = time.perf_counter()
    result = scatterogram(structure, theta, np.radians(args.phi_deg), size=args.size,
                          backend=args.backend, progress=args.progress)
    seconds = time.perf_counter() - start
    title = f"{label}\nlight at {args.theta_deg:g} deg; {args.size}x{args.size} in {seconds:.1f} s"
    save_scatterogram(result, args.output, title, exposure=args.exposure)
    print(args.output)
    return 0


def _check_render_size(size: tuple[int, int]) -> None:
    from wgbragg.render import check_size

    try:
        check_size(size)
    except ValueError as error:
        raise ValueError(f"--{error}") from None


def _size(text: str) -> tuple[int, int]:
    width, _, height = text.lower().partition("x")
    try:
        return int(width), int(height)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--size must be WIDTHxHEIGHT, got {text!r}") from None


def _exr_colour_attributes(space: str) -> dict:
    """The header attributes that name an EXR's colour space: ``colorInteropID`` and, for
    readers that predate it, ``chromaticities``."""
    from wgbragg.colour import colorimetry

    return {"colorInteropID": EXR_COLOUR_SPACES[space],
            "chromaticities": colorimetry.colour_space_chromaticities(space)}


EXIT_INTERRUPTED = 130
"""Exit status after SIGINT (Ctrl-C) or SIGTERM: 128 + SIGINT, as shells report it."""


class _Signals:
    """SIGINT and SIGTERM caught while installed (:meth:`caught`): the first sets :attr:`name`,
    which the render loop polls through :meth:`stop`; a second one interrupts at once."""

    def __init__(self):
        self.name: str | None = None

    def stop(self) -> bool:
        return self.name is not None

    def _handle(self, number, _frame) -> None:
        if self.name is not None:
            raise KeyboardInterrupt
        self.name = signal.Signals(number).name

    @contextlib.contextmanager
    def caught(self):
        previous = {number: signal.signal(number, self._handle)
                    for number in (signal.SIGINT, signal.SIGTERM)}
        try:
            yield self
        finally:
            for number, handler in previous.items():
                signal.signal(number, handler)


@contextlib.contextmanager
def _sigterm_interrupts():
    """SIGTERM raises KeyboardInterrupt, as SIGINT does, so that a terminated command cleans
    up (temporary files) and says so in one line. Only the main thread can set handlers."""
    def interrupt(_number, _frame):
        raise KeyboardInterrupt

    try:
        previous = signal.signal(signal.SIGTERM, interrupt)
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _denoised_path(path) -> Path:
    """Where ``--denoise`` writes an output's denoised twin: ``x.png`` -> ``x.denoised.png``."""
    path = Path(path)
    return path.with_name(f"{path.stem}.denoised{path.suffix}")


def _saved_elsewhere(write, suffix: str, stamp: str) -> Path | None:
    """Write an image that could not go where asked to ``wgbragg-render-STAMP[-k]SUFFIX`` in
    the working folder, else in the temporary folder; its path, or None if both fail."""
    for folder in (Path.cwd(), Path(tempfile.gettempdir())):
        for k in range(1, 100):
            path = folder / f"wgbragg-render-{stamp}{f'-{k}' if k > 1 else ''}{suffix}"
            if not path.exists():
                break
        try:
            write(path)
        except (OSError, ValueError):
            continue
        return path
    return None


def _write_outputs(outputs) -> tuple[list[str], list[str]]:
    """Write each ``(flag, path, suffix, write)`` output; one that fails is saved elsewhere
    (:func:`_saved_elsewhere`). Returns the paths written and a line per failure."""
    stamp = time.strftime("%Y%m%d-%H%M%S")
    written, failures = [], []
    for flag, path, suffix, write in outputs:
        try:
            write(path)
        except (OSError, ValueError) as error:
            saved = _saved_elsewhere(write, suffix, stamp)
            where = (f"the image is saved to {saved} instead" if saved is not None else
                     "nor could it be saved in the working or temporary folder")
            failures.append(f"cannot write {flag} {str(path)!r} ({error}); {where}")
            if saved is not None:
                written.append(str(saved))
        else:
            written.append(str(path))
    return written, failures


def _spp_text(renderer) -> str:
    """The samples per pixel a render holds: ``N``, or ``N-M`` when an interrupted or timed
    render ended inside a pass."""
    counts = renderer.sample_counts()
    low, high = int(counts.min()), int(counts.max())
    return f"{low}" if low == high else f"{low}-{high}"


def _render(args) -> int:
    from wgbragg import gpu
    from wgbragg._version import __version__
    from wgbragg.colour import colorimetry
    from wgbragg.common.exr import write_exr
    from wgbragg.render import Renderer, denoise_image, save_png
    from wgbragg.scene import load_preset

    if (args.scene_file is None) == (args.scene is None):
        raise ValueError("give either a scene file or --scene NAME, not both or neither")
    if args.spp is not None and args.seconds is not None:
        raise ValueError("give either --spp or --seconds, not both")
    # Before the render: a bad output path or amount must not cost its minutes.
    check_output_path(args.output, "--output", ".png")
    if args.exr is not None:
        check_output_path(args.exr, "--exr", ".exr")
    if args.denoise:
        for flag, path, suffix in (("--output", args.output, ".png"), ("--exr", args.exr, ".exr")):
            if path is not None:
                check_output_path(_denoised_path(path), f"{flag} (denoised)", suffix)
    if args.exr is None and args.colour_space != "srgb":
        raise ValueError("--colour-space applies to the EXR: give --exr FILE too")
    if args.spp is not None and args.spp < 1:
        raise ValueError(f"--spp must be an integer >= 1, got {args.spp}")
    if args.size is not None:
        _check_render_size(args.size)
    scene = load_preset(args.scene) if args.scene else export_cli.load_scene_argument(args)
    renderer = Renderer(scene, size=args.size, mode=args.mode, ibl=args.ibl,
                        light_sampling=args.light_sampling)
    start = time.perf_counter()
    # Ctrl-C or SIGTERM ends the render after the dispatch under way; the image so far is kept.
    with _Signals().caught() as signals:
        if args.seconds is not None:
            image = renderer.render(seconds=args.seconds, progress=args.progress,
                                    stop=signals.stop)
        else:
            spp = scene.settings.spp if args.spp is None else args.spp
            image = renderer.render(spp, progress=args.progress, stop=signals.stop)
    seconds = time.perf_counter() - start
    spp = _spp_text(renderer)
    if signals.name is not None and spp == "0":
        print(f"wgbragg: interrupted ({signals.name}) before the first sample: nothing written",
              file=sys.stderr)
        return EXIT_INTERRUPTED
    broken = int(np.count_nonzero(~np.isfinite(image).all(axis=-1)))
    if broken:
        # A kernel bug: say so, and write both files or neither.
        message = (f"{broken} of {renderer.width * renderer.height} pixels are not finite "
                   f"(NaN or infinite): please report the scene")
        if args.exr is not None:
            raise ValueError(f"{message}; --exr stores only finite images, nothing written")
        print(f"wgbragg: warning: {message}; they show black in {args.output}",
              file=sys.stderr)
    # What the EXR header and the PNG's text chunks say besides the colour space: the software,
    # the adapter with its driver version, the samples, and why the image is partial.
    facts = {"software": f"wgbragg {__version__}", "adapter": gpu.adapter_info()["driver"],
             "spp": renderer.passes}
    if signals.name is not None:
        facts["comments"] = f"wgbragg render interrupted ({signals.name}) at {spp} spp"
    images = [("", image, facts)]
    denoised_seconds = 0.0
    if args.denoise:
        begun = time.perf_counter()
        albedo, normal = renderer.features()
        # Pixels that are not finite (reported above) denoise as black.
        denoised = denoise_image(np.where(np.isfinite(image), image, 0.0), albedo, normal)
        denoised_seconds = time.perf_counter() - begun
        note = "denoised by Intel Open Image Denoise"
        images.append((" (denoised)", denoised, {
            **facts, "comments": f"{facts['comments']}; {note}" if "comments" in facts else note}))

    def png(pixels, header):
        text = {"Software": header["software"], "wgbragg:adapter": header["adapter"],
                "wgbragg:spp": str(header["spp"])}
        if "comments" in header:
            text["Comment"] = header["comments"]
        return lambda path: save_png(pixels, path, scene.settings.exposure, text, args.view)

    def exr(pixels, header):
        return lambda path: write_exr(
            path, colorimetry.linear_srgb_to(pixels, args.colour_space),
            attributes={**_exr_colour_attributes(args.colour_space), **header})

    outputs = []
    for which, pixels, header in images:
        twin = _denoised_path if which else Path
        outputs.append((f"--output{which}", twin(args.output),
                        f"{'.denoised' if which else ''}.png", png(pixels, header)))
        if args.exr is not None:
            outputs.append((f"--exr{which}", twin(args.exr),
                            f"{'.denoised' if which else ''}.exr", exr(pixels, header)))
    written, failures = _write_outputs(outputs)
    for failure in failures:
        print(f"wgbragg: error: {failure}", file=sys.stderr)
    if signals.name is not None:
        print(f"wgbragg: interrupted ({signals.name}) at {spp} spp after {seconds:.1f} s: wrote "
              f"{', '.join(written) or 'nothing'}", file=sys.stderr)
        return EXIT_INTERRUPTED
    denoised_text = f", denoised in {denoised_seconds:.2f} s" if args.denoise else ""
    print(f"{', '.join(written)}: {renderer.width}x{renderer.height}, {renderer.mode}, "
          f"ibl {renderer.ibl}, lights {renderer.light_sampling}, {spp} spp in "
          f"{seconds:.1f} s{denoised_text}")
    return 2 if failures else 0


def build_parser() -> argparse.ArgumentParser:
    """The ``wgbragg`` argument parser; building it imports nothing beyond this module's
    imports."""
    parser = argparse.ArgumentParser(prog="wgbragg", description=DESCRIPTION)
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    info_cli.add_info_command(commands, _command)  # info, --fetch-driver
    _add_reflectance_command(commands)
    _add_map_command(commands)
    _add_bake_command(commands)
    _add_cache_command(commands)
    _add_scatterogram_command(commands)
    _add_render_command(commands)
    sweep_cli.add_commands(commands, _command, _size)  # sweep, atlas, render-batch (Dask)
    design_cli.add_design_commands(commands, _command)  # fit, design (inverse design)
    export_cli.add_export_command(commands, _command)  # export: glTF 2.0, MaterialX
    return parser


def _add_reflectance_command(commands) -> None:
    reflect = _command(commands, "reflectance", "print R(wavelength, theta) of a Bragg mirror")
    _add_mirror_arguments(reflect)
    reflect.add_argument("--wavelength", type=float, nargs="+", default=[450.0, 550.0, 650.0],
                         help="wavelengths in nm")
    reflect.add_argument("--theta-deg", type=float, nargs="+", default=[0.0, 30.0, 60.0],
                         help="angles of incidence in degrees, 0..90")
    reflect.set_defaults(run=_reflectance)


def _add_map_command(commands) -> None:
    mapping = _command(commands, "map", "reflectance map (wavelength x angle) of a Bragg "
                       "mirror as a PNG")
    _add_mirror_arguments(mapping)
    mapping.add_argument("-o", "--output", default="out/reflectance_map.png",
                         help="the PNG to write")
    mapping.set_defaults(run=_map)


def _add_bake_command(commands) -> None:
    bake = _command(commands, "bake", "bake transmission filters and colour tables into the "
                    "LUT cache")
    bake.add_argument("--alpha", type=float, nargs="*", default=list(DEFAULT_ALPHAS),
                      help="GGX roughnesses of the transmission filters (none: skip them)")
    bake.add_argument("--resolution-deg", type=float, default=0.25,
                      help="angular step of the filter tables, degrees in [0.05, 90]")
    bake.add_argument("--psi-samples", type=int, default=1000,
                      help="azimuth samples per filter entry, >= 1")
    bake.add_argument("--backend", choices=("gpu", "numpy"), default="gpu",
                      help="where filters are baked (not part of the cache key)")
    bake.add_argument("--cache", default=None,
                      help="cache folder (default: $WGBRAGG_CACHE, else the user cache folder)")
    bake.add_argument("--colour-tables", action=argparse.BooleanOptionalAction, default=True,
                      help="bake the colorimetry tables too")
    bake.add_argument("--force", action="store_true",
                      help="bake again even where a valid file exists")
    bake.add_argument("--no-progress", dest="progress", action="store_false",
                      help="no progress bar")
    # Each cache file is written to a temporary file and renamed (common.atomic.atomic_path):
    # an interrupted bake leaves whole files only.
    bake.set_defaults(run=_bake, interrupted="interrupted: the cache keeps the tables baked "
                      "so far, each whole; 'wgbragg bake' again bakes the rest")


def _add_cache_command(commands) -> None:
    cache = _command(commands, "cache", "check or empty the LUT cache")
    actions = cache.add_subparsers(dest="cache_command", required=True, metavar="ACTION")
    verify = _command(
        actions, "verify", "check every cache file ('ok: PATH' or 'bad: PATH (problem)'); exit "
        "status 1 if a problem remains")
    verify.add_argument("--repair", action="store_true",
                        help="remove invalid or unreadable cache files (re-baked on next use) "
                             "and temporary files of writes interrupted over an hour ago")
    clear = _command(
        actions, "clear", "remove the files the cache wrote (tables and stale temporary files), "
        "nothing else")
    for action in (verify, clear):
        action.add_argument("--cache", default=None,
                            help="cache folder (default: $WGBRAGG_CACHE, else the user cache "
                                 "folder)")
        action.set_defaults(run=_cache)


def _add_scatterogram_command(commands) -> None:
    scatter = _command(
        commands, "scatterogram", "reflected hemisphere of a rough Bragg layer for one light "
        "direction, as a PNG (Fig. 9)")
    scatter.add_argument("--preset", choices=("green", "red", "purple"), default=None,
                         help="a jewel-beetle cuticle area of Table 3 (overrides the mirror)")
    group = scatter.add_argument_group("Bragg layer (thicknesses in nm), without --preset")
    group.add_argument("--n1", type=float, default=1.0, help="refractive index of layer 1")
    group.add_argument("--n2", type=float, default=1.5, help="refractive index of layer 2")
    group.add_argument("--d1", type=float, default=250.0, help="thickness of layer 1, nm")
    group.add_argument("--d2", type=float, default=250.0, help="thickness of layer 2, nm")
    group.add_argument("-N", "--periods", type=int, default=10, help="number of periods")
    group.add_argument("--host", type=float, default=None,
                       help="refractive index of the medium above (default: n1)")
    group.add_argument("--alpha", type=float, default=0.1, help="GGX roughness")
    group.add_argument("--base-albedo", type=float, default=None,
                       help="grey Lambertian base (default: absorbing)")
    scatter.add_argument("--theta-deg", type=float, default=0.0,
                         help="polar angle of the light, degrees in [0, 90)")
    scatter.add_argument("--phi-deg", type=float, default=0.0,
                         help="azimuth of the light, degrees")
    scatter.add_argument("--size", type=int, default=256,
                         help="image side in pixels, in [%d, %d]" % SCATTEROGRAM_SIZES)
    scatter.add_argument("--exposure", type=float, default=None,
                         help="radiance scale (default: the brightest value maps to 1)")
    scatter.add_argument("--backend", choices=("gpu", "numpy"), default="gpu",
                         help="float32 WGSL kernels, or the float64 numpy reference (minutes "
                              "at 256 x 256)")
    scatter.add_argument("-o", "--output", default="out/scatterogram.png",
                         help="the PNG to write")
    scatter.add_argument("--no-progress", dest="progress", action="store_false",
                         help="no progress bar")
    scatter.set_defaults(run=_scatterogram)


def _add_render_command(commands) -> None:
    render = _command(
        commands, "render", "path-trace a scene to a PNG (8-bit sRGB) and optionally an EXR "
        "(linear)")
    render.add_argument("scene_file", nargs="?", default=None,
                        help="a scene file: TOML, .gltf or .glb")
    render.add_argument("--scene", default=None, metavar="NAME",
                        help="a built-in preset instead of a file: " + ", ".join(PRESET_NAMES))
    render.add_argument("--allow-outside-paths", action="store_true",
                        help="let the scene file name files outside its folder (../x.obj, "
                             "absolute paths, symlinks to elsewhere); refused by default")
    render.add_argument("-o", "--output", default="out/render.png",
                        help="the PNG to write (exposure, tone map, sRGB; colours outside the "
                             "display's gamut are desaturated at constant luminance)")
    render.add_argument("--view", choices=("standard", "filmic"), default="standard",
                        help="the PNG's tone curve: standard (Reinhard's Y / (1 + Y), as the "
                             "viewer shows) or filmic (ACES-like: deeper shadows, more contrast, "
                             "bright saturated colours go towards white) (default: standard)")
    render.add_argument("--spp", type=int, default=None,
                        help="samples per pixel (default: the scene's settings.spp)")
    render.add_argument("--size", type=_size, default=None,
                        help="WIDTHxHEIGHT in pixels (default: the scene's settings.size); "
                             "another aspect ratio keeps the scene's whole frame in view and "
                             "shows more above and below (narrower) or at the sides (wider)")
    render.add_argument("--seconds", type=float, default=None,
                        help="render for this long instead of a number of samples")
    render.add_argument("--mode", choices=("rgb", "spectral"), default=None,
                        help="light transport (default: the scene's settings.mode)")
    render.add_argument("--ibl", choices=("monte-carlo", "split-sum", "kneiphof"), default=None,
                        help="environment lighting: paths, or a filtered image-based lighting "
                             "mode (default: the scene's settings.ibl)")
    render.add_argument("--light-sampling", choices=("all", "power"), default="all",
                        help="next-event estimation at each path vertex: every light, or one "
                             "chosen by its power (fewer shadow rays, more noise; default all)")
    render.add_argument("--exr", default=None,
                        help="also write the linear image to this OpenEXR file")
    render.add_argument("--denoise", action="store_true",
                        help="also write the image denoised by Intel Open Image Denoise (on the "
                             "CPU, guided by the first hits' albedo and normal) beside each "
                             "output, as NAME.denoised.png and NAME.denoised.exr; the raw images "
                             "are written as always")
    render.add_argument("--colour-space", choices=tuple(EXR_COLOUR_SPACES), default="srgb",
                        help="colour space of the EXR's linear values, named in its header "
                             "(colorInteropID, chromaticities): srgb (linear Rec. 709, D65), "
                             "xyz (CIE 1931 XYZ, Y = 1 for white: no colour has negative "
                             "values) or acescg (ACES AP1, D65 adapted to the ACES white by "
                             "CAT02)")
    render.add_argument("--no-progress", dest="progress", action="store_false",
                        help="no progress bar")
    export_cli.add_gltf_options(render)  # --camera, --environment
    render.set_defaults(run=_render)


@contextlib.contextmanager
def _lut_warnings_in_one_line():
    """Print each LutWarning (a cache file re-baked or unusable) as one ``wgbragg: warning:``
    line, without the file, line number and source echo of Python's format."""
    with warnings.catch_warnings():
        show = warnings.showwarning

        def showwarning(message, category, filename, lineno, file=None, line=None):
            if not issubclass(category, LutWarning):
                return show(message, category, filename, lineno, file, line)
            text = " ".join(str(message).splitlines())
            print(f"wgbragg: warning: {text}", file=sys.stderr if file is None else file)
            return None

        warnings.showwarning = showwarning
        yield


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        with _lut_warnings_in_one_line(), _sigterm_interrupts():
            return args.run(args)
    except KeyboardInterrupt:
        # Ctrl-C or SIGTERM outside a render's samples (which keep their image: _render).
        print(f"wgbragg: {getattr(args, 'interrupted', 'interrupted')}", file=sys.stderr)
        return EXIT_INTERRUPTED
    except (ValueError, RuntimeError, OSError) as error:
        # OSError: a file that cannot be read or written (missing, a folder, no permission).
        print(f"wgbragg: error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
