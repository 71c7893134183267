"""The device's loop budget, measured: whether and where its shader compiler ends loops.

Loop budget
-----------
Some shader compilers end every loop of an invocation once the loops of its SIMD group have
taken a fixed number of iterations in total, counted over all loops, nested ones included, as
the slowest lane of the group sees them. They do so silently: the kernel returns a partial
sum, or a walk stops early. llvmpipe (lavapipe's compiler) did so up to Mesa 22 (65535
back-edges, ``LP_MAX_TGSI_LOOP_ITERATIONS`` in gallivm); Mesa 25's has no such budget.

The budget is therefore measured, not assumed from the adapter's name: :func:`loop_budget`
runs ``wgsl/gpu/loops_probe.wgsl`` once per driver (one invocation asking for
:data:`PROBE_ITERATIONS` iterations over two loops) and keeps the answer in
:func:`loop_budget_path`, keyed by the adapter's name and the driver's description (which
names the Mesa and LLVM versions). A cached answer is validated before use; a file of another
format, an implausible value or another probe length is probed again and rewritten.

Kernels whose loop count comes from their inputs plan for :func:`planned_loop_iterations` an
invocation: half the budget (:func:`safe_loop_iterations`, which leaves room for the short
inner loops the plans do not count), or :data:`ITERATIONS_WITHOUT_BUDGET` where there is none.
They keep within it by splitting the work over invocations or dispatches or by refusing the
input with a ``ValueError``. Kernels that can still overrun report it through
``loops_were_cut()`` (``gpu/harness.wgsl``), and the host turns the flags into a
:class:`LoopBudgetError` with :func:`check_loops`; without a budget no flag is ever set.
"""

from __future__ import annotations

import functools
import json
import os
from pathlib import Path

import numpy as np

from wgbragg.common.atomic import write_text_atomic
from wgbragg.common.luts import cache_dir
from wgbragg.gpu.device import adapter_info
from wgbragg.gpu.pipelines import compute_pipeline

__all__ = [
    "CACHE_FORMAT",
    "CACHE_NAME",
    "ITERATIONS_WITHOUT_BUDGET",
    "PROBE_ITERATIONS",
    "LoopBudgetError",
    "cached_loop_budget",
    "check_loops",
    "describe_loop_budget",
    "loop_budget",
    "loop_budget_path",
    "planned_loop_iterations",
    "probe_loop_budget",
    "safe_loop_iterations",
]

PROBE_ITERATIONS = 1 << 22
"""Loop iterations the probe asks one invocation for: 4,194,304, 64 times Mesa 22's budget,
in 40 ms on Mesa 25's lavapipe. A budget beyond it is not seen (:func:`loop_budget` is then
None)."""

ITERATIONS_WITHOUT_BUDGET = 1 << 20
"""Loop iterations a kernel may plan for one invocation where the device has no loop budget:
32 times Mesa 22's :func:`safe_loop_iterations`. It bounds a dispatch's time (milliseconds an
invocation on a CPU), not its correctness, so that the limits that were the budget's stay
finite."""

CACHE_NAME = "loop-budget.json"
"""File name of the measured budgets in the cache folder (:func:`loop_budget_path`)."""

CACHE_FORMAT = "wgbragg-loop-budget"
"""The ``format`` entry of that file; its ``version`` is 1."""

_CACHE_VERSION = 1
_PROBE = "gpu/loops_probe.wgsl"


# --------------------------------------------------------------------------- measuring


def probe_loop_budget(iterations: int = PROBE_ITERATIONS) -> int | None:
    """Run the probe kernel now: where does this device end an invocation's loops?

    One invocation runs the probe's two loops of ``iterations // 2`` each.

    Parameters
    ----------
    iterations : int
        Iterations asked for in all, even, 2 to ``2**32 - 2``.

    Returns
    -------
    int or None
        The iterations the invocation took before its loops were ended (65536 on Mesa
        22.3.6's lavapipe, all in the first loop), or None if it took them all and
        ``loops_were_cut()`` saw no cut.
    """
    if isinstance(iterations, bool) or not isinstance(iterations, int | np.integer) or not (
            2 <= iterations <= 2**32 - 2 and iterations % 2 == 0):
        raise ValueError(f"iterations must be an even integer in [2, 2**32 - 2], got "
                         f"{iterations!r}")
    counts = np.array([iterations // 2], np.uint32)
    (out,) = compute_pipeline(_PROBE).run([counts], [((1, 2), np.uint32)])
    taken, cut = int(out[0, 0]), bool(out[0, 1])
    if taken >= iterations and not cut:
        return None
    return max(1, taken)


def loop_budget_path() -> Path:
    """The file of measured budgets: :data:`CACHE_NAME` in
    :func:`~wgbragg.common.luts.cache_dir`."""
    return cache_dir() / CACHE_NAME


def _identity() -> tuple[str, str]:
    """(adapter name, driver description): what the budget is a property of."""
    info = adapter_info()
    return str(info["name"]), str(info["description"])


def _valid_entry(entry) -> bool:
    """Whether a cached device entry is well formed, its budget None or a count the probe can
    have measured."""
    if not isinstance(entry, dict) or set(entry) != {"name", "description", "budget"}:
        return False
    if not isinstance(entry["name"], str) or not isinstance(entry["description"], str):
        return False
    budget = entry["budget"]
    return budget is None or (type(budget) is int and 1 <= budget <= PROBE_ITERATIONS)


def _read_entries(path: Path) -> dict[str, dict]:
    """The valid device entries of the cache file; none if it is missing, unreadable or not
    of this format and probe length (invalid entries are dropped one by one)."""
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError):
        return {}
    if not (isinstance(document, dict)
            and document.get("format") == CACHE_FORMAT
            and document.get("version") == _CACHE_VERSION
            and document.get("probe_iterations") == PROBE_ITERATIONS
            and isinstance(document.get("devices"), dict)):
        return {}
    return {key: entry for key, entry in document["devices"].items()
            if _valid_entry(entry) and key == f"{entry['name']} | {entry['description']}"}


def cached_loop_budget(path: str | os.PathLike | None = None) -> int | None:
    """This device's loop budget from the cache file, probed (and the file rewritten) when the
    file holds no valid entry for this adapter and driver.

    Parameters
    ----------
    path : path-like, optional
        The file; default :func:`loop_budget_path`.

    Returns
    -------
    int or None
        As :func:`probe_loop_budget`.

    Notes
    -----
    The file is written atomically (:func:`~wgbragg.common.atomic.write_text_atomic`) with
    the other drivers' valid entries kept. A file that cannot be written costs one probe per
    process, nothing more.
    """
    path = loop_budget_path() if path is None else Path(path)
    name, description = _identity()
    key = f"{name} | {description}"
    entries = _read_entries(path)
    if key in entries:
        return entries[key]["budget"]
    budget = probe_loop_budget()
    entries[key] = {"name": name, "description": description, "budget": budget}
    document = {"format": CACHE_FORMAT, "version": _CACHE_VERSION,
                "probe_iterations": PROBE_ITERATIONS, "devices": entries}
    try:
        write_text_atomic(path, json.dumps(document, indent=1, sort_keys=True) + "\n")
    except OSError:
        pass  # a read-only cache: the next process probes again
    return budget


@functools.cache
def loop_budget() -> int | None:
    """Loop iterations this device lets one SIMD group take before it ends its loops.

    Measured once per driver (:func:`cached_loop_budget`), then once per process.

    Returns
    -------
    int or None
        65536 on Mesa 22.3.6's lavapipe; None where the probe found no cut within
        :data:`PROBE_ITERATIONS` (Mesa 25.0.7's lavapipe).
    """
    return cached_loop_budget()


def safe_loop_iterations() -> int | None:
    """Iterations a kernel may plan for one invocation under the budget: half of
    :func:`loop_budget` (32768 on Mesa 22), leaving room for the short inner loops (Newton
    steps, bisections, unrolled sums) that the plans do not count; None without a budget."""
    budget = loop_budget()
    return None if budget is None else budget // 2


def planned_loop_iterations() -> int:
    """Iterations a kernel plans for one invocation on this device:
    :func:`safe_loop_iterations`, or :data:`ITERATIONS_WITHOUT_BUDGET` where there is no
    budget. The limits and refusals that follow from the budget are computed from it."""
    safe = safe_loop_iterations()
    return ITERATIONS_WITHOUT_BUDGET if safe is None else safe


def describe_loop_budget() -> str:
    """The budget in words, for error messages: what this device allows."""
    budget = loop_budget()
    if budget is None:
        return "this device has no measured loop budget"
    return f"this device allows {budget} loop iterations per invocation"


# --------------------------------------------------------------------------- reporting


class LoopBudgetError(ValueError):
    """The device ended a kernel's loops before its work was done (:func:`loop_budget`): the
    input asks for more iterations than this backend can run."""


def check_loops(cut, what: str) -> None:
    """Raise :class:`LoopBudgetError` if any ``loops_were_cut()`` flag in ``cut`` is set.

    Parameters
    ----------
    cut : array_like
        The kernel's flags (non-zero = cut), any shape: one per point, or a single word
        that any cut invocation sets.
    what : str
        The work and the input that sizes it, for the message.
    """
    cut = np.asarray(cut)
    if np.any(cut != 0):
        # Kernels that report in one shared word cannot say where.
        where = (" at some points" if cut.size == 1
                 else f" at {np.count_nonzero(cut)} of {cut.size} points")
        raise LoopBudgetError(
            f"{what}: the GPU ({adapter_info()['name']}) ended the kernel's loops early{where} "
            f"({describe_loop_budget()}); use backend='numpy', or ask for less work per point"
        )
