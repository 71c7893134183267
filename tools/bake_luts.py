"""Bake transmission filters and colour tables into the LUT cache: ``wgbragg bake`` as a
script beside the other tools.

Usage::

    python tools/bake_luts.py                         # default alphas and the colour tables
    python tools/bake_luts.py --alpha 0.1 0.2         # these filters and the colour tables
    python tools/bake_luts.py --alpha --cache /tmp/c  # colour tables only, into /tmp/c
    python tools/bake_luts.py --help                  # every option (see wgbragg.app.cli)
"""

from __future__ import annotations

import sys

from wgbragg.app.cli import main as _main


def main(argv: list[str] | None = None) -> int:
    """Run ``wgbragg bake`` with ``argv`` (default: the command line's arguments).

    Parameters
    ----------
    argv : list of str, optional
        Options of ``wgbragg bake``.

    Returns
    -------
    int
        Exit status: 0 on success, 2 on bad input.
    """
    return _main(["bake", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    sys.exit(main())
