"""Start-up time of the ``wgbragg`` command line.

Measures, each in a fresh interpreter (a subprocess, wall clock from start to exit):

- **the interpreter alone** (``python -c pass``) and **``import wgbragg``**, for scale;
- **``wgbragg --help``** and **``wgbragg COMMAND --help``** of every command, against the
  target of 1 s: help must not wait for the renderer, colour-science or wgpu
  (:mod:`wgbragg.app.cli` imports each command's modules when it runs);

and, in one more run of each, which of the heavy packages (colour-science, matplotlib,
trimesh, wgpu, scipy) the process had imported when it exited. The command is the installed
``wgbragg`` script beside the interpreter, or ``python -m wgbragg.app.cli`` without one.

It prints a markdown section and writes it into ``docs/benchmarks.md`` between
``<!-- bench_cli:begin -->`` and ``<!-- bench_cli:end -->`` (full mode).

Usage::

    python -m benchmarks.cli                # full run (about a minute)
    python -m benchmarks.cli --quick        # one run each, print only
"""

from __future__ import annotations

import dataclasses
import json
import shlex
import statistics
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from benchmarks import report
from benchmarks.report import human_time, progress_bar, yes_no
from benchmarks.report import markdown_table as _table

__all__ = ["BEGIN_MARKER", "COMMANDS", "END_MARKER", "FULL", "HEAVY", "QUICK", "TARGET_S",
           "Config", "main", "run_benchmarks"]

MODULE = "benchmarks.cli"
BEGIN_MARKER, END_MARKER = report.markers("bench_cli")
TARGET_S = 1.0
"""Most seconds a ``--help`` may take."""
COMMANDS = ("info", "reflectance", "map", "bake", "cache", "scatterogram", "render", "sweep",
            "atlas", "render-batch", "fit", "design")
HEAVY = ("colour", "matplotlib", "trimesh", "wgpu", "scipy", "dask", "distributed", "xarray",
         "zarr", "cma")
"""Top-level packages only the commands that compute may import."""

# Runs a command line's module as __main__ and reports the heavy packages loaded at exit
# (``--help`` exits through SystemExit, which atexit still sees).
_PROBE = """
import atexit, json, runpy, sys
atexit.register(lambda: print(json.dumps(sorted({{n.split(".")[0] for n in sys.modules}}
                                                & set({heavy}))), file=sys.stderr))
sys.argv = {argv}
{run}
"""


@dataclasses.dataclass(frozen=True)
class Config:
    """Timed runs of each command line."""

    name: str
    runs: int


FULL = Config("full", runs=7)
QUICK = Config("quick", runs=1)


def _wgbragg() -> tuple[list[str], str]:
    """How to run the command line: the installed script, else the module; and its label."""
    script = Path(sys.executable).with_name("wgbragg")
    if script.is_file():
        return [str(script)], "wgbragg"
    return [sys.executable, "-m", "wgbragg.app.cli"], "python -m wgbragg.app.cli"


def _cases() -> list[tuple[str, list[str], str]]:
    """(label, argv, probe code) of every measured command line."""
    prefix, name = _wgbragg()
    python = sys.executable
    cases = [("python -c pass (the interpreter)", [python, "-c", "pass"], "pass"),
             ("python -c 'import wgbragg'", [python, "-c", "import wgbragg"], "import wgbragg")]
    cli_run = "runpy.run_module('wgbragg.app.cli', run_name='__main__')"
    for args in [["--help"], *([command, "--help"] for command in COMMANDS)]:
        cases.append((f"{name} {shlex.join(args)}", [*prefix, *args],
                      _PROBE.format(heavy=list(HEAVY), argv=["wgbragg", *args], run=cli_run)))
    return cases


def _run(argv: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True,
                   timeout=300)
    return time.perf_counter() - start


def _heavy_imports(code: str) -> list[str]:
    """The heavy packages a probe's process imported (its last stderr line)."""
    if code in ("pass", "import wgbragg"):
        code = _PROBE.format(heavy=list(HEAVY), argv=["python"], run=code)
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            timeout=300)
    return json.loads(result.stderr.strip().splitlines()[-1])


def run_benchmarks(cfg: Config, progress: bool = True) -> dict:
    """Time every command line ``cfg.runs`` times (after one untimed run that warms the file
    cache) and probe its imports."""
    meter = report.LoadMeter()
    results: dict = {"rows": []}
    cases = _cases()
    for label, argv, probe in progress_bar(cases, show=progress, desc="command lines"):
        _run(argv)
        times = [_run(argv) for _ in range(cfg.runs)]
        results["rows"].append((label, statistics.median(times), max(times),
                                _heavy_imports(probe)))
    _, gpu_error = report.gpu_available()
    results["environment"] = report.run_facts(gpu_error)
    results["environment"]["background_cores"] = meter.background_cores()
    return results


def render_section(results: dict, cfg: Config, command: str) -> str:
    lines = report.section_head(
        BEGIN_MARKER, f"Command-line start-up (`python -m {MODULE}`)", command,
        results["environment"], "one run each" if cfg.name == "quick" else None)
    lines += [
        f"- Wall clock of each command line in a fresh process, median and maximum of "
        f"{cfg.runs} runs after an untimed one; the heavy imports are those loaded when it "
        "exited (one more run).",
        "",
        "### Start-up",
        "",
    ]
    rows = []
    for label, median, top, heavy in results["rows"]:
        help_row = label.endswith("--help")
        rows.append([f"`{label}`", human_time(median), human_time(top),
                     ", ".join(heavy) or "none",
                     yes_no(top < TARGET_S) if help_row else report.NOT_MEASURED])
    lines += _table(["command", "median", "max", "heavy imports",
                     f"< {TARGET_S:g} s"], rows)
    lines += [
        "",
        f"Heavy imports are any of {', '.join(HEAVY)}. A command that computes imports what "
        "it needs when it runs: the renderer wgpu and trimesh, the colour code colour-science "
        "and scipy, the figures matplotlib.",
        END_MARKER,
    ]
    return "\n".join(lines)


def parse_args(argv: Sequence[str] | None):
    return report.argument_parser(MODULE, "Start-up time of the wgbragg command line.",
                                  "one run of each command line, print only").parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Run, print the section and write it (docs/benchmarks.md in full mode)."""

    def measure(quick: bool, progress: bool, command: str) -> str:
        cfg = QUICK if quick else FULL
        return render_section(run_benchmarks(cfg, progress), cfg, command)

    return report.section_main(argv, MODULE, parse_args, (BEGIN_MARKER, END_MARKER), measure)


if __name__ == "__main__":
    sys.exit(main())
