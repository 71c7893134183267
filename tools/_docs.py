"""Report helpers shared by the scripts under ``tools/``: marker sections of
``docs/benchmarks.md`` and the machine facts every report states.

Each benchmark script owns one section of the document, delimited by
``<!-- NAME:begin -->`` and ``<!-- NAME:end -->``, and rewrites it whole; everything outside
its markers (the intro, other scripts' sections, hand-written text) is left alone. The file
is replaced atomically, so a reader or an interrupted run never sees half a document.
"""

from __future__ import annotations

import argparse
import datetime
import math
import os
import platform
import shlex
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from wgbragg.common.atomic import write_text_atomic

__all__ = [
    "DOC_INTRO",
    "TIMES",
    "LoadMeter",
    "cpu_model",
    "human_ratio",
    "human_time",
    "markdown_table",
    "markers",
    "parse_ratio",
    "parse_time",
    "publish",
    "run_facts",
    "section_main",
    "update_document",
    "write_section",
]

TIMES = "\u00d7"  # an escape: ruff flags a literal multiplication sign as confusable with "x"

DOC_INTRO = """# Benchmarks

Throughput measurements of wgbragg, each produced by a script under `tools/`. Every section
sits between a pair of `<!-- NAME:begin -->` / `<!-- NAME:end -->` markers and is rewritten
whole by the script that owns it, so edit text outside the markers only. Numbers depend on the
machine: the reference is lavapipe (Mesa's CPU Vulkan driver) on 2 CPU cores, where the "GPU"
runs on the same two cores as the CPU methods it is compared with.
"""


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
        times = os.times()
        return times.user + times.system

    def background_cores(self) -> float | None:
        """Average number of cores busy with other processes (or stolen by the hypervisor)."""
        wall0, busy0, own0 = self._start
        busy = self._busy()
        if busy is None or busy0 is None:
            return None
        wall = time.perf_counter() - wall0
        return max(0.0, (busy - busy0 - (self._own() - own0)) / max(wall, 1e-9))


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def add_section_arguments(parser, default_output, quick_help: str) -> None:
    """The options every benchmark shares: ``--quick``, ``--output`` / ``--no-write`` and
    ``--no-progress``."""
    parser.add_argument("--quick", action="store_true", help=quick_help)
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--output", type=Path, default=None,
                       help=f"markdown file to update (full mode default: {default_output})")
    where.add_argument("--no-write", action="store_true", help="print the section only")
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bars")


def section_output(args, default_output):
    """Where a benchmark section goes: ``--output``, else ``default_output`` in full mode only
    (quick runs, the test suite's, never touch docs/)."""
    if args.no_write:
        return None
    if args.output is not None:
        return args.output
    return None if args.quick else default_output


def run_facts(gpu_error: str | None = None) -> dict[str, Any]:
    """What a report states about its run: date, adapter (or why there is none), CPU, cores,
    Python and the wgbragg and numpy versions."""
    import numpy as np

    from wgbragg import __version__
    from wgbragg import gpu

    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cores = os.cpu_count() or 1
    if gpu_error is None:
        info = gpu.adapter_info()
        adapter = f"{info['name']} [{info['backend']}]"
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


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    """Lines of a markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join(["---"] * len(header)) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return lines


def human_time(seconds: float) -> str:
    """Duration with 3 significant digits and a unit: ``"123 ns"``, ``"4.56 µs"``, ``"1.20 ms"``."""
    for scale, unit in ((1.0, "s"), (1e-3, "ms"), (1e-6, "µs"), (1e-9, "ns")):
        value = float(f"{seconds / scale:.3g}")
        # Round first so that 999.7 µs becomes "1.00 ms", not "1e+03 µs".
        if value >= 1.0 or unit == "ns":
            digits = max(0, 2 - math.floor(math.log10(value))) if value > 0 else 2
            return f"{value:.{digits}f} {unit}"
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
    digits = max(0, 2 - math.floor(math.log10(rounded))) if rounded > 0 else 2
    return f"{rounded:.{digits}f}{TIMES}"


def parse_ratio(text: str) -> float:
    """Inverse of :func:`human_ratio`."""
    return float(text.strip().removesuffix(TIMES).replace(",", ""))


def publish(section: str, path: Path | None, begin: str, end: str) -> None:
    """Print a benchmark's section and, when ``path`` is given (see :func:`section_output`),
    write it there between its markers."""
    import sys

    print(section)
    if path is not None:
        write_section(path, section, begin, end)
        print(f"wrote {path}", file=sys.stderr)


def section_main(argv: Sequence[str] | None, script: str, description: str, quick_help: str,
                 default_output: Path, markers: tuple[str, str],
                 measure: Callable[[bool, bool, str], str]) -> int:
    """The ``main`` of a benchmark that owns one section of the document.

    Parameters
    ----------
    argv : sequence of str or None
        Arguments without the program name; default ``sys.argv[1:]``.
    script : str
        The file name under ``tools/``, quoted in the section's command line.
    description, quick_help : str
        The command line's help texts (see :func:`add_section_arguments`).
    default_output : Path
        Where full runs write (:func:`section_output`).
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
    parser = argparse.ArgumentParser(prog=script, description=description)
    add_section_arguments(parser, default_output, quick_help)
    args = parser.parse_args(argv)
    command = shlex.join(["python", f"tools/{script}", *argv])
    section = measure(args.quick, not args.no_progress, command)
    publish(section, section_output(args, default_output), *markers)
    return 0
