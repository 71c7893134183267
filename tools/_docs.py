"""Marker sections of ``docs/benchmarks.md``, shared by the scripts under ``tools/``.

Each benchmark script owns one section of the document, delimited by
``<!-- NAME:begin -->`` and ``<!-- NAME:end -->``, and rewrites it whole; everything outside
its markers (the intro, other scripts' sections, hand-written text) is left alone. The file
is replaced atomically, so a reader or an interrupted run never sees half a document.
"""

from __future__ import annotations

import os
from pathlib import Path

from wgbragg._io import write_text_atomic

__all__ = ["DOC_INTRO", "markers", "update_document", "write_section"]

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
