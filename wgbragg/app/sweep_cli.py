"""The commands on Dask: ``wgbragg sweep`` (a sweep file to a Zarr atlas, resumable),
``wgbragg atlas`` (colour charts of an atlas) and ``wgbragg render-batch`` (turntables and
parameter animations, frame by frame, resumable).

Registered into the ``wgbragg`` parser by :func:`add_commands`; like :mod:`wgbragg.app.cli`,
this module imports nothing heavy at import time, and each command imports what it runs
(dask, xarray, zarr, matplotlib, wgpu) when it runs, so ``wgbragg --help`` stays fast.
"""

from __future__ import annotations

import sys
from pathlib import Path

from wgbragg.common.atomic import check_output_folder, check_output_path

__all__ = ["add_commands"]

INTERRUPTED_SWEEP = ("interrupted: the atlas keeps every chunk finished so far; the same "
                     "'wgbragg sweep' command computes the rest")
INTERRUPTED_BATCH = ("interrupted: the frames finished so far are kept; the same "
                     "'wgbragg render-batch' command renders the rest")


def _log(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def _sweep(args) -> int:
    from wgbragg.sweep import dask_client, load_sweep, run_sweep
    from wgbragg.sweep.engine import missing_chunks
    from wgbragg.sweep.store import init_store

    sweep = load_sweep(args.sweep_file)
    output = check_output_folder(args.output, "--output")
    init_store(sweep, output)  # another sweep's store is refused before a cluster starts
    if not missing_chunks(sweep, output):
        total = sweep.chunk_count()
        print(f"{args.output}: 0 chunks computed, {total} already stored, {total} in all "
              f"({sweep.points()} points): nothing to do")
        return 0
    with dask_client(args.scheduler, args.workers, log=_log) as client:
        report = run_sweep(sweep, output, client, progress=args.progress)
    print(f"{args.output}: {report.line()}")
    return 0


def _selection(items) -> dict:
    select = {}
    for item in items or ():
        name, sep, value = item.partition("=")
        try:
            select[name.strip()] = float(value)
        except ValueError:
            sep = ""
        if not sep or not name.strip():
            raise ValueError(f"--sel must be NAME=NUMBER, got {item!r}")
    return select


def _atlas(args) -> int:
    from wgbragg.app.atlas import (
        colour_chart,
        is_spectrum,
        save_colour_chart,
        save_spectrum_plot,
        spectrum_plot,
    )
    from wgbragg.sweep import open_atlas

    check_output_path(args.output, "--output", ".png")
    dataset = open_atlas(args.atlas, allow_incomplete=args.allow_incomplete)
    select = _selection(args.sel)
    spectra = [name for name in dataset.data_vars if is_spectrum(dataset, name)]
    only_spectra = len(spectra) == len(dataset.data_vars)
    if is_spectrum(dataset, args.var) or (args.var is None and spectra and (
            args.y is None or only_spectra)):
        plot = spectrum_plot(dataset, args.x, args.y, variable=args.var, facet=args.facet,
                             lines=args.lines, select=select)
        save_spectrum_plot(plot, dataset, args.output)
    else:
        if args.y is None or args.lines is not None:
            raise ValueError("a colour chart needs --y (and takes no --lines: that is for "
                             "spectra, --var reflectance)")
        chart = colour_chart(dataset, args.x, args.y, variable=args.var, facet=args.facet,
                             select=select)
        save_colour_chart(chart, dataset, args.output)
    missing = dataset.attrs.get("missing_chunks", 0)
    note = f" ({missing} chunks not written yet, shown blank)" if missing else ""
    print(f"{args.output}{note}")
    return 0


def _render_batch(args) -> int:
    from wgbragg.sweep import dask_client
    from wgbragg.sweep.render_batch import assemble, plan_frames, render_batch

    if args.animation is not None:
        suffix = Path(args.animation).suffix.lower()
        if suffix not in (".gif", ".webp"):
            raise ValueError(f"--animation must end in .gif or .webp, got {args.animation!r}")
        check_output_path(args.animation, "--animation", suffix)
    output = check_output_folder(args.output, "--output")
    frames = plan_frames(args.scene_file, turntable=args.turntable, vary=args.vary,
                         allow_outside=args.allow_outside_paths)
    with dask_client(args.scheduler, args.workers, log=_log) as client:
        report = render_batch(frames, output, client, size=args.size, spp=args.spp,
                              mode=args.mode, progress=args.progress)
    print(f"{args.output}: {report.line()}")
    if args.animation is not None:
        print(assemble(report.paths, args.animation, fps=args.fps))
    return 0


def _add_engine_arguments(parser) -> None:
    group = parser.add_argument_group("Dask cluster")
    group.add_argument("--scheduler", default=None, metavar="ADDR",
                       help="an existing scheduler, e.g. tcp://HOST:8786 (default: "
                            "$DASK_SCHEDULER_ADDRESS, else an embedded cluster)")
    group.add_argument("--workers", type=int, default=None, metavar="K",
                       help="worker processes of the embedded cluster (default: one per CPU "
                            "core)")
    parser.add_argument("--no-progress", dest="progress", action="store_false",
                        help="no progress bar")


def add_commands(commands, command, size) -> None:
    """Add ``sweep``, ``atlas`` and ``render-batch`` to the subcommands ``commands``;
    ``command(commands, name, text)`` makes each subparser (the CLI's own style) and ``size``
    parses ``--size WIDTHxHEIGHT`` as ``wgbragg render`` does."""
    sweep = command(commands, "sweep", "compute a sweep file (TOML, docs/sweeps.md) into a "
                    "Zarr atlas on a Dask cluster; rerun to resume")
    sweep.add_argument("sweep_file", help="a sweep TOML file")
    sweep.add_argument("-o", "--output", required=True, help="the atlas folder (Zarr)")
    _add_engine_arguments(sweep)
    sweep.set_defaults(run=_sweep, interrupted=INTERRUPTED_SWEEP)

    atlas = command(commands, "atlas", "draw colour charts of an atlas as a PNG: colours over "
                    "two coordinates, one panel per value of a third; or its spectra, as a "
                    "map over two coordinates or lines over one")
    atlas.add_argument("atlas", help="an atlas folder written by 'wgbragg sweep'")
    atlas.add_argument("--x", required=True, help="coordinate across, e.g. period_nm")
    atlas.add_argument("--y", default=None,
                       help="coordinate up, e.g. theta (theta_deg); a spectrum without --y is "
                            "drawn as lines over --x")
    atlas.add_argument("--facet", default=None, help="coordinate of the panels")
    atlas.add_argument("--lines", default=None,
                       help="spectra without --y: one line per value of this coordinate")
    atlas.add_argument("--var", default=None,
                       help="the quantity: a colour (default: the atlas's first colour) or a "
                            "spectrum, e.g. reflectance")
    atlas.add_argument("--sel", action="append", default=None, metavar="NAME=VALUE",
                       help="fix another coordinate at its nearest value (repeatable)")
    atlas.add_argument("--allow-incomplete", action="store_true",
                       help="draw an atlas whose sweep is unfinished, missing chunks blank")
    atlas.add_argument("-o", "--output", default="out/atlas.png", help="the PNG to write")
    atlas.set_defaults(run=_atlas)

    batch = command(commands, "render-batch", "render the frames of a turntable or of a "
                    "varied scene value as Dask tasks, resumably, and optionally an animation")
    batch.add_argument("scene_file", help="a scene TOML file")
    what = batch.add_mutually_exclusive_group(required=True)
    what.add_argument("--turntable", type=int, default=None, metavar="FRAMES",
                      help="frames of a camera orbit about look_at (the scene's +y axis)")
    what.add_argument("--vary", default=None, metavar="KEY=VALUES",
                      help="a value of the scene file varied: KEY=START:STOP:COUNT, e.g. "
                           "materials.coat.layers[0].period_nm=150:300:16, or KEY=A,B,C, "
                           "e.g. materials.film.base=Au,Ag,Cu (key parts may be quoted as "
                           "in TOML)")
    batch.add_argument("-o", "--output", default="out/frames",
                       help="folder of the frames (frame_0000.png, ...)")
    batch.add_argument("--animation", default=None,
                       help="also join the frames into this animated .gif or .webp")
    batch.add_argument("--fps", type=float, default=12.0, help="frames per second")
    batch.add_argument("--size", type=size, default=None,
                       help="WIDTHxHEIGHT (default: the scene's settings.size)")
    batch.add_argument("--spp", type=int, default=None,
                       help="samples per pixel (default: the scene's settings.spp)")
    batch.add_argument("--mode", choices=("rgb", "spectral"), default=None,
                       help="light transport (default: the scene's settings.mode)")
    batch.add_argument("--allow-outside-paths", action="store_true",
                       help="let the scene file name files outside its folder")
    _add_engine_arguments(batch)
    batch.set_defaults(run=_render_batch, interrupted=INTERRUPTED_BATCH)
