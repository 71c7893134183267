"""What every benchmark shares: its section of ``docs/benchmarks.md``, the facts of its run,
its tables and number formats, and its command line.

Each benchmark owns one section of the document (:mod:`benchmarks.ibl` two), delimited by
``<!-- NAME:begin -->`` and ``<!-- NAME:end -->``, and rewrites it whole; everything outside
its markers (the intro, other benchmarks' sections, hand-written text) is left alone. The file
is replaced atomically, so a reader or an interrupted run never sees half a document.

The section names are those of the scripts the benchmarks once were (``bench_rgb`` for
:mod:`benchmarks.rgb`, ...), so that a run replaces the section an older run wrote.
"""

from __future__ import annotations

import argparse
import datetime
import importlib
import math
import os
import platform
import shlex
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tqdm import tqdm

from wgbragg.common.atomic import write_text_atomic

__all__ = [
    "ALPHA",
    "DEFAULT_OUTPUT",
    "DOC_INTRO",
    "NOT_MEASURED",
    "REPO_ROOT",
    "RHO",
    "SIGMA",
    "TIMES",
    "LoadMeter",
    "Stats",
    "adapter_line",
    "add_section_arguments",
    "argument_parser",
    "command_line",
    "console_header",
    "cpu_model",
    "delta_e_xyz",
    "gpu_available",
    "human_bytes",
    "human_rate",
    "human_ratio",
    "human_time",
    "markdown_table",
    "markers",
    "optional_import",
    "parse_bytes",
    "parse_rate",
    "parse_ratio",
    "parse_stats",
    "parse_time",
    "progress_bar",
    "publish",
    "run_facts",
    "run_lines",
    "section_head",
    "section_main",
    "section_output",
    "timed",
    "update_document",
    "write_section",
    "yes_no",
]

REPO_ROOT = Path(__file__).resolve().parents[1]
DEFAULT_OUTPUT = REPO_ROOT / "docs" / "benchmarks.md"
"""The document full runs write into."""

# Escapes: ruff flags a literal multiplication sign and Greek letters as confusable with x, a,
# o and p.
TIMES = "\u00d7"
ALPHA = "\u03b1"
SIGMA = "\u03c3"
RHO = "\u03c1"
NOT_MEASURED = "—"
"""The cell of a table where nothing was measured."""

DOC_INTRO = """# Benchmarks

Throughput measurements of wgbragg, each produced by a module of the `benchmarks` package
(`python -m benchmarks.NAME`). Every section sits between a pair of `<!-- NAME:begin -->` /
`<!-- NAME:end -->` markers and is rewritten whole by the module that owns it, so edit text
outside the markers only. Numbers depend on the machine: the reference is lavapipe (Mesa's CPU
Vulkan driver) on 2 CPU cores, where the "GPU" runs on the same two cores as the CPU methods it
is compared with.
"""


# --------------------------------------------------------------------------- the document


def markers(name: str) -> tuple[str, str]:
    """The begin and end markers of section ``name``.

    Parameters
    ----------
    name : str
        Section name, e.g. ``"bench_reflectance"``.

    Returns
    -------
    begin, end : str
        ``"<!-- NAME:begin -->"`` and ``"<!-- NAME:end -->"``.
    """
    return f"<!-- {name}:begin -->", f"<!-- {name}:end -->"


def update_document(text: str | None, section: str, begin: str, end: str,
                    intro: str = DOC_INTRO) -> str:
    """Put ``section`` into a benchmarks document, replacing an earlier version of it.

    Parameters
    ----------
    text : str or None
        Current document, or None if it does not exist yet.
    section : str
        The new section, markers included.
    begin, end : str
        Its markers (see :func:`markers`).
    intro : str
        Head of a new document.

    Returns
    -------
    str
        ``text`` with the part from ``begin`` to ``end`` replaced by ``section``; ``section``
        appended if ``text`` has no markers; ``intro`` followed by ``section`` if ``text`` is
        None.

    Raises
    ------
    ValueError
        If the markers are unpaired, repeated or out of order: rewriting then could eat
        someone else's section.
    """
    if text is None:
        return f"{intro}\n{section}\n"
    begins, ends = text.count(begin), text.count(end)
    if begins == ends == 0:
        return f"{text.rstrip()}\n\n{section}\n"
    start, stop = text.find(begin), text.find(end)
    if begins != 1 or ends != 1 or stop < start:
        raise ValueError(
            f"expected one {begin} followed by one {end}; found {begins} and "
            f"{ends}: fix the document by hand"
        )
    return text[:start] + section + text[stop + len(end):]


def write_section(path: str | os.PathLike, section: str, begin: str, end: str) -> None:
    """Read ``path`` (if it exists), put ``section`` in it and replace the file atomically.

    Parameters
    ----------
    path : path-like
        The markdown document.
    section, begin, end : str
        As for :func:`update_document`.
    """
    target = Path(path)
    current = target.read_text(encoding="utf-8") if target.exists() else None
    write_text_atomic(target, update_document(current, section, begin, end))


def publish(section: str, path: Path | None, begin: str, end: str) -> None:
    """Print a benchmark's section and, when ``path`` is given (see :func:`section_output`),
    write it there between its markers."""
    print(section)
    if path is not None:
        write_section(path, section, begin, end)
        print(f"wrote {path}", file=sys.stderr)


# --------------------------------------------------------------------------- the run's facts


class LoadMeter:
    """CPU time that other processes used since creation, from ``/proc/stat`` (Linux).

    The GPU of lavapipe and the CPU methods share the same few cores with whatever else runs
    on the machine, so the report says how busy the machine was besides this benchmark.
    """

    def __init__(self):
        self._start = (time.perf_counter(), self._busy(), self._own())

    @staticmethod
    def _busy() -> float | None:
        try:
            fields = Path("/proc/stat").read_text().splitlines()[0].split()
        except (OSError, IndexError):
            return None
        # user nice system idle iowait irq softirq steal: busy = all but idle and iowait.
        user, nice, system, _idle, _iowait, irq, softirq, steal = map(int, fields[1:9])
        return (user + nice + system + irq + softirq + steal) / os.sysconf("SC_CLK_TCK")

    @staticmethod
    def _own() -> float:
        # The benchmark's own child processes (Mitsuba's variants, benchmarks.drivers'
        # workloads) are part of it, not other load: their CPU time counts once waited for.
        times = os.times()
        return times.user + times.system + times.children_user + times.children_system

    def background_cores(self) -> float | None:
        """Average number of cores busy with other processes (or stolen by the hypervisor)."""
        wall0, busy0, own0 = self._start
        busy = self._busy()
        if busy is None or busy0 is None:
            return None
        wall = time.perf_counter() - wall0
        return max(0.0, (busy - busy0 - (self._own() - own0)) / max(wall, 1e-9))


def cpu_model() -> str:
    """The CPU's model name (``/proc/cpuinfo``), else what :mod:`platform` knows."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def gpu_available() -> tuple[bool, str | None]:
    """``(True, None)`` if the wgpu device opens, else ``(False, why)`` in one line: a
    benchmark then still measures its CPU methods and says why the GPU ones are missing."""
    from wgbragg import gpu

    try:
        gpu.get_device()
    except Exception as exc:  # no adapter
        return False, f"{type(exc).__name__}: {exc}".splitlines()[0]
    return True, None


def optional_import(name: str) -> tuple[Any, str | None]:
    """``(module, None)``, or ``(None, why)`` in one line when ``name`` cannot be imported (a
    peer package that is not installed: its rows then say so)."""
    try:
        return importlib.import_module(name), None
    except Exception as exc:  # a broken torch raises OSError etc., not only ImportError
        return None, f"{type(exc).__name__}: {exc}".splitlines()[0]


def run_facts(gpu_error: str | None = None) -> dict[str, Any]:
    """What a report states about its run: date, adapter (or why there is none), CPU, cores,
    Python and the wgbragg and numpy versions.

    A benchmark adds ``"background_cores"`` (:meth:`LoadMeter.background_cores`), more
    ``"versions"`` and, for a CPU peer that runs threads, ``"torch_threads"``; :func:`run_lines`
    states them.
    """
    import numpy as np

    from wgbragg import __version__

    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cores = os.cpu_count() or 1
    if gpu_error is None:
        adapter = adapter_line()
    else:
        adapter = f"none ({gpu_error})"
    return {
        "date": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC"),
        "adapter": adapter,
        "cpu": cpu_model(),
        "cores": cores,
        "python": platform.python_version(),
        "versions": {"wgbragg": __version__, "numpy": np.__version__},
    }


DRIVER_SOURCES = {"user": "chosen by the user", "system": "the system's",
                  "cache": "fetched into wgbragg's driver cache",
                  "old": "the system's, older than Mesa 24"}
"""How :func:`adapter_line` words ``adapter_info()['driver_source']``."""


def adapter_line() -> str:
    """The adapter with its driver version and where the driver came from, e.g.
    ``llvmpipe (LLVM 15.0.6, 256 bits), Mesa 25.0.7 [Vulkan] (fetched into wgbragg's driver
    cache)``: every section and console header names it, since the driver alone changes
    wgbragg's speed severalfold (docs/performance.md, "Drivers")."""
    from wgbragg import gpu

    info = gpu.adapter_info()
    return f"{info['driver']} ({DRIVER_SOURCES.get(info['driver_source'], '?')})"


def console_header(module: str) -> None:
    """Print ``MODULE on ADAPTER`` to standard error as a benchmark starts (nothing without an
    adapter: the benchmark then says why itself)."""
    available, _ = gpu_available()
    if available:
        print(f"{module} on {adapter_line()}", file=sys.stderr)


def run_lines(command: str, env: dict[str, Any]) -> list[str]:
    """The bullets every section opens with: command, date, adapter, CPU, the load of other
    processes and the versions (``env`` from :func:`run_facts`)."""
    busy = env.get("background_cores")
    background = ("unknown (no /proc/stat)" if busy is None else
                  f"{busy:.2f} cores busy on average (from /proc/stat)")
    threads = f", torch threads {env['torch_threads']}" if "torch_threads" in env else ""
    versions = ", ".join(f"{k} {v}" for k, v in env["versions"].items())
    return [
        f"- Command: `{command}`",
        f"- Date: {env['date']}",
        f"- Adapter: {env['adapter']}",
        f"- CPU: {env['cpu']}, {env['cores']} cores available{threads}",
        f"- Other processes on the machine during the run: {background}",
        f"- Python {env['python']}; {versions}",
    ]


def section_head(begin: str, title: str, command: str, env: dict[str, Any],
                 quick: str | None = None) -> list[str]:
    """The first lines of a section: its begin marker, ``## title``, the do-not-edit line, in
    quick mode ``"**Quick mode: QUICK, the numbers are not meaningful.**"``, and
    :func:`run_lines`. The benchmark's own bullets follow."""
    out = [begin, f"## {title}", "", f"**Driver: {env['adapter']}**", "",
           "_Generated by the command below; do not edit between the markers._"]
    if quick is not None:
        out += ["", f"**Quick mode: {quick}, the numbers are not meaningful.**"]
    return [*out, "", *run_lines(command, env)]


# --------------------------------------------------------------------------- measuring


def timed(fn: Callable[[], Any]) -> tuple[Any, float]:
    """``fn()`` and its wall-clock seconds."""
    start = time.perf_counter()
    value = fn()
    return value, time.perf_counter() - start


def progress_bar(iterable: Iterable | None = None, *, show: bool, desc: str, unit: str = "it",
                 total: int | None = None) -> tqdm:
    """A tqdm bar on stderr (stdout carries the section), hidden unless ``show``."""
    return tqdm(iterable, desc=desc, unit=unit, total=total, disable=not show, file=sys.stderr)


def delta_e_xyz(xyz_a, xyz_b):
    """CIE dE2000 between two sets of XYZ colours, through linear sRGB (D65)."""
    from wgbragg.colour.colorimetry import delta_e_2000, xyz_to_linear_srgb

    return delta_e_2000(xyz_to_linear_srgb(xyz_a), xyz_to_linear_srgb(xyz_b))


# --------------------------------------------------------------------------- tables and cells


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    """Lines of a markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join(["---"] * len(header)) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return lines


def yes_no(flag: bool) -> str:
    """The "met" cell of a target."""
    return "yes" if flag else "no"


@dataclass(frozen=True)
class Stats:
    """Mean, 95th percentile and maximum of a set of values (dE2000 in the colour tables)."""

    mean: float
    p95: float
    max: float

    @classmethod
    def of(cls, values) -> Stats:
        """Statistics of ``values`` (any shape, non-empty)."""
        import numpy as np

        flat = np.asarray(values, dtype=np.float64).ravel()
        return cls(float(flat.mean()), float(np.percentile(flat, 95)), float(flat.max()))

    def cell(self) -> str:
        """``"mean / p95 / max"`` with two decimals."""
        return f"{self.mean:.2f} / {self.p95:.2f} / {self.max:.2f}"


def parse_stats(text: str) -> tuple[float, float, float]:
    """Inverse of :meth:`Stats.cell`."""
    mean, p95, top = (float(v) for v in text.split("/"))
    return mean, p95, top


def _decimals(value: float, zero: int = 2) -> int:
    """Decimals that show ``value`` (already rounded to 3 significant digits) with 3
    significant digits; ``zero`` for 0."""
    return max(0, 2 - math.floor(math.log10(value))) if value > 0 else zero


def human_time(seconds: float) -> str:
    """Duration with 3 significant digits and a unit: ``"123 ns"``, ``"4.56 µs"``, ``"1.20 ms"``."""
    for scale, unit in ((1.0, "s"), (1e-3, "ms"), (1e-6, "µs"), (1e-9, "ns")):
        value = float(f"{seconds / scale:.3g}")
        # Round first so that 999.7 µs becomes "1.00 ms", not "1e+03 µs".
        if value >= 1.0 or unit == "ns":
            return f"{value:.{_decimals(value)}f} {unit}"
    raise AssertionError("unreachable")


def parse_time(text: str) -> float:
    """Inverse of :func:`human_time` (seconds)."""
    number, unit = text.strip().split()
    return float(number) * {"s": 1.0, "ms": 1e-3, "µs": 1e-6, "ns": 1e-9}[unit]


def human_ratio(ratio: float) -> str:
    """Speed-up with 3 significant digits, e.g. ``"4,310×"``, ``"12.5×"``, ``"0.0123×"``."""
    rounded = float(f"{ratio:.3g}")
    if rounded >= 100:
        return f"{rounded:,.0f}{TIMES}"
    return f"{rounded:.{_decimals(rounded)}f}{TIMES}"


def parse_ratio(text: str) -> float:
    """Inverse of :func:`human_ratio`."""
    return float(text.strip().removesuffix(TIMES).replace(",", ""))


def _prefixed(value: float, units: Sequence[tuple[float, str]], zero: int) -> str:
    """``value`` with 3 significant digits in the largest of ``units`` ((scale, name),
    largest first, the last of scale 1) that keeps it >= 1."""
    rounded = float(f"{value:.3g}")
    for scale, unit in units:
        # Round first so that 999.7 k becomes "1.00 M", not "1e+03 k".
        if rounded >= scale or scale == 1.0:
            scaled = rounded / scale
            return f"{scaled:.{_decimals(scaled, zero)}f} {unit}"
    raise AssertionError("unreachable")


def _unprefixed(text: str, units: Sequence[tuple[float, str]]) -> float:
    number, unit = text.strip().split()
    return float(number) * {name: scale for scale, name in units}[unit]


_RATE_UNITS = ((1e12, "T/s"), (1e9, "G/s"), (1e6, "M/s"), (1e3, "k/s"), (1.0, "/s"))
_BYTE_UNITS = ((1e9, "GB"), (1e6, "MB"), (1e3, "KB"), (1.0, "B"))


def human_rate(rate: float) -> str:
    """Rate with 3 significant digits and an SI prefix, e.g. ``"123 M/s"``, ``"1.10 k/s"``."""
    return _prefixed(rate, _RATE_UNITS, 2)


def parse_rate(text: str) -> float:
    """Inverse of :func:`human_rate` (per second)."""
    return _unprefixed(text, _RATE_UNITS)


def human_bytes(size: float) -> str:
    """Size with 3 significant digits and a decimal unit: ``"520 KB"``, ``"1.40 MB"``."""
    return _prefixed(size, _BYTE_UNITS, 0)


def parse_bytes(text: str) -> float:
    """Inverse of :func:`human_bytes` (bytes); a leading ``"≈ "`` is ignored."""
    return _unprefixed(text.strip().removeprefix("≈"), _BYTE_UNITS)


# --------------------------------------------------------------------------- the command line


def add_section_arguments(parser: argparse.ArgumentParser, quick_help: str,
                          default_output: Path = DEFAULT_OUTPUT) -> None:
    """The options every benchmark shares: ``--quick``, ``--output`` / ``--no-write`` and
    ``--no-progress``."""
    parser.add_argument("--quick", action="store_true", help=quick_help)
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--output", type=Path, default=None,
                       help=f"markdown file to update (full mode default: {default_output})")
    where.add_argument("--no-write", action="store_true", help="print the section only")
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bars")


def argument_parser(module: str, description: str, quick_help: str) -> argparse.ArgumentParser:
    """The command line of ``python -m MODULE`` with the options of
    :func:`add_section_arguments`; a benchmark may add its own."""
    parser = argparse.ArgumentParser(prog=f"python -m {module}", description=description)
    add_section_arguments(parser, quick_help)
    return parser


def section_output(args: argparse.Namespace,
                   default_output: Path = DEFAULT_OUTPUT) -> Path | None:
    """Where a benchmark section goes: ``--output``, else ``default_output`` in full mode only
    (quick runs, the test suite's, never touch docs/)."""
    if args.no_write:
        return None
    if args.output is not None:
        return args.output
    return None if args.quick else default_output


def command_line(module: str, argv: Sequence[str]) -> str:
    """The command a section quotes: ``python -m MODULE ARGV...``."""
    return shlex.join(["python", "-m", module, *argv])


def section_main(argv: Sequence[str] | None, module: str,
                 parse_args: Callable[[Sequence[str]], argparse.Namespace],
                 markers: tuple[str, str], measure: Callable[[bool, bool, str], str]) -> int:
    """The ``main`` of a benchmark that owns one section of the document.

    Parameters
    ----------
    argv : sequence of str or None
        Arguments without the program name; default ``sys.argv[1:]``.
    module : str
        The benchmark's module, e.g. ``"benchmarks.rough"``, quoted in the section's command.
    parse_args : callable
        The benchmark's parser of ``argv`` (from :func:`argument_parser`).
    markers : (str, str)
        The section's begin and end markers.
    measure : callable
        ``measure(quick, progress, command)`` runs the benchmark and returns its section.

    Returns
    -------
    int
        Exit status.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parse_args(argv)
    console_header(module)
    section = measure(args.quick, not args.no_progress, command_line(module, argv))
    publish(section, section_output(args), *markers)
    return 0
