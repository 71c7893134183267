"""WGSL sources: the shader folder, the include composer and compile errors located in it.

:func:`load_shader` reads a file from :func:`shader_dir` and replaces each
``//! include "path.wgsl"`` line by that file's composed text (each file once), keeping a map
from composed lines back to the original files. :class:`ShaderCompileError` reports
composition, compilation and pipeline errors at those original lines. The ``//! if`` blocks
that pipelines resolve later are ``wgbragg/gpu/specialise.py``'s.
"""

from __future__ import annotations

import dataclasses
import os
import re
import textwrap
from pathlib import Path

from wgbragg.gpu.specialise import lines_in_block_comments

_INCLUDE_RE = re.compile(r'^\s*//!\s*include\s+"([^"]+)"\s*$')
_LOCATION_RE = re.compile(r"(┌─\s*)\S*?:(\d+):(\d+)")
_GUTTER_RE = re.compile(r"^((\s*)(\d+))( │)", re.MULTILINE)


class ShaderCompileError(Exception):
    """A WGSL source failed to compose, compile or link into a pipeline.

    The message starts with ``"<file>:<line>: "``, the file relative to
    :func:`shader_dir` and the line in that original file (not in the composed
    source), followed by the naga / wgpu message.

    Attributes
    ----------
    file : str
    line : int
    column : int or None
        Column of the naga span, where there is one.
    detail : str
        The message without the location prefix.
    """

    def __init__(self, file: str, line: int, detail: str):
        super().__init__(f"{file}:{line}: {detail}")
        self.file = file
        self.line = line
        self.column: int | None = None
        self.detail = detail


@dataclasses.dataclass(frozen=True)
class ShaderSource:
    """A WGSL source with its includes resolved.

    Attributes
    ----------
    name : str
        Entry file, relative to :func:`shader_dir`.
    code : str
        Composed source.
    line_map : tuple of (str, int)
        ``line_map[i]`` is the (file, line) that composed line ``i + 1`` came from.
    """

    name: str
    code: str
    line_map: tuple[tuple[str, int], ...]

    def locate(self, line: int) -> tuple[str, int]:
        """Original (file, line) of 1-based composed ``line``."""
        if 1 <= line <= len(self.line_map):
            return self.line_map[line - 1]
        return self.name, line


def shader_dir() -> Path:
    """Folder holding the WGSL files.

    Returns
    -------
    pathlib.Path
        ``wgbragg/wgsl`` in an installed wheel, else the repository's ``wgsl/``
        next to the package (source tree, editable install).
    """
    package = Path(__file__).resolve().parents[1]
    bundled = package / "wgsl"
    return bundled if bundled.is_dir() else package.parent / "wgsl"


# --------------------------------------------------------------------------- composer


# (root, name) -> (source, ((path, mtime_ns), ...)) so edits on disk invalidate the entry.
_source_cache: dict[tuple[Path, str], tuple[ShaderSource, tuple[tuple[Path, int], ...]]] = {}


def load_shader(name: str | os.PathLike) -> ShaderSource:
    """Read a WGSL file and resolve its include directives.

    A line ``//! include "optics/yeh.wgsl"`` (path relative to :func:`shader_dir`, else to
    the including file's folder) is replaced by that file's composed text. Each file is
    included at most once per composed source; later includes of it are dropped.

    Parameters
    ----------
    name : str or os.PathLike
        Path relative to :func:`shader_dir`, e.g. ``"optics/yeh_reflectance.wgsl"``, or an
        absolute path to a kernel kept elsewhere (the test suite's kernels).

    Returns
    -------
    ShaderSource

    Raises
    ------
    FileNotFoundError
        If ``name`` itself does not exist.
    ShaderCompileError
        On an include cycle or a missing include, located at the directive.
    """
    root = shader_dir()
    name = os.fspath(name)
    key = (root, name)
    hit = _source_cache.get(key)
    if hit is not None and all(_mtime(p) == m for p, m in hit[1]):
        return hit[0]
    if not (root / name).is_file():
        raise FileNotFoundError(f"shader {name!r} not found in {root}")
    code: list[str] = []
    line_map: list[tuple[str, int]] = []
    files: list[Path] = []
    _compose(root, _normalise(name), [], set(), code, line_map, files)
    source = ShaderSource(name=name, code="\n".join(code) + "\n", line_map=tuple(line_map))
    _source_cache[key] = (source, tuple((p, _mtime(p)) for p in files))
    return source


def _normalise(name: str) -> str:
    return Path(os.path.normpath(name)).as_posix()


def _mtime(path: Path) -> int:
    try:
        return path.stat().st_mtime_ns
    except OSError:
        return -1


def _compose(
    root: Path,
    name: str,
    stack: list[str],
    done: set[str],
    code: list[str],
    line_map: list[tuple[str, int]],
    files: list[Path],
) -> None:
    """Append the composed lines of ``name`` (and their origins) to ``code`` and ``line_map``,
    and the files read to ``files``; ``stack`` holds the files being composed, ``done`` those
    composed already."""
    path = root / name
    files.append(path)
    stack.append(name)
    text_of_file = path.read_text(encoding="utf-8")
    commented = lines_in_block_comments(text_of_file)
    for lineno, text in enumerate(text_of_file.splitlines(), start=1):
        match = None if lineno - 1 in commented else _INCLUDE_RE.match(text)
        if match is None:
            code.append(text)
            line_map.append((name, lineno))
            continue
        target = _normalise(match.group(1))
        if target not in stack and target not in done and not (root / target).is_file():
            target = _beside(root, path, target, name, lineno)
        if target in stack:
            chain = " -> ".join([*stack[stack.index(target) :], target])
            raise ShaderCompileError(name, lineno, f"include cycle: {chain}")
        if target not in done:
            _compose(root, target, stack, done, code, line_map, files)
    stack.pop()
    done.add(name)


def _beside(root: Path, including: Path, target: str, name: str, lineno: int) -> str:
    """``target`` in the folder of the file that includes it (``name``, at ``including``),
    which found no ``target`` under ``root``."""
    beside = _normalise(str(including.parent / target))
    if not Path(beside).is_file():
        raise ShaderCompileError(name, lineno, f'included file "{target}" not found in {root}')
    return beside


# --------------------------------------------------------------------------- compile errors


def shader_error(source: ShaderSource, exc: Exception, entry: str) -> ShaderCompileError:
    """A wgpu error on compiling ``source`` as a ShaderCompileError, located in the original
    file of the first naga span (else at the entry point ``entry``).

    Parameters
    ----------
    source : ShaderSource
        The source compiled.
    exc : Exception
        wgpu's error, whose message holds naga's report on the composed source.
    entry : str
        Entry point of the pipeline.

    Returns
    -------
    ShaderCompileError
        Its message naga's, with the composed line numbers of spans and snippet gutters
        replaced by the original ones.
    """
    lines = str(exc).strip().splitlines()
    # wgpu's "Validation Error / Caused by: / In wgpuDevice..." preamble says nothing useful
    # and would push naga's own first line off the exception's first line.
    while lines and (
        lines[0].strip() in ("", "Validation Error", "Caused by:")
        or lines[0].strip().startswith("In wgpuDevice")
    ):
        lines.pop(0)
    message = textwrap.dedent("\n".join(lines))
    match = _LOCATION_RE.search(message)
    if match is not None:

        def relabel(m: re.Match) -> str:
            file, line = source.locate(int(m.group(2)))
            return f"{m.group(1)}{file}:{line}:{m.group(3)}"

        def regutter(m: re.Match) -> str:
            line = source.locate(int(m.group(3)))[1]
            return f"{line:>{len(m.group(1))}}{m.group(4)}"

        # Spans and snippet gutters carry composed line numbers; show the original ones.
        message = _LOCATION_RE.sub(relabel, message)
        message = _GUTTER_RE.sub(regutter, message)
        error = ShaderCompileError(*source.locate(int(match.group(2))), message)
        error.column = int(match.group(3))
        return error
    # Pipeline-level errors (bad constants, missing entry) carry no span: point at the entry.
    entry_line = re.search(rf"\bfn\s+{re.escape(entry)}\s*\(", source.code)
    line = source.code.count("\n", 0, entry_line.start()) + 1 if entry_line else 1
    return ShaderCompileError(*source.locate(line), message)
