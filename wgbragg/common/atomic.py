"""Atomic file writes: a reader, or an interrupted run, never sees a half-written file.

Output paths are checked before the work they are for (:func:`check_output_path`,
:func:`check_output_folder`) by creating and removing a real file in the destination folder:
permission bits (``os.access``) say nothing for root, nor for read-only or virtual file
systems such as ``/proc``. Errors name the path as the caller gave it, never the temporary file
of :func:`atomic_path`.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

__all__ = ["atomic_path", "check_output_folder", "check_output_path", "write_text_atomic"]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` only on success.

    The temporary file keeps the final suffix so writers that infer the format from it
    (matplotlib, Pillow) behave as for the final name. The result gets the permissions an
    ordinary new file would (``mkstemp`` creates 0600).

    Raises
    ------
    OSError
        When the folder, the temporary file or the rename fails, or the writer raises one: the
        same error (errno and kind) naming ``path`` instead of the temporary file.
    """
    target = Path(path)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        handle, temporary = tempfile.mkstemp(
            prefix=f".{target.stem}.", suffix=target.suffix, dir=target.parent
        )
    except OSError as error:
        raise _naming(error, path, None) from None
    os.close(handle)
    try:
        try:
            yield Path(temporary)
            os.chmod(temporary, 0o666 & ~_umask())
            os.replace(temporary, target)
        except OSError as error:
            raise _naming(error, path, temporary) from error
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(temporary)


def _naming(error: OSError, path, temporary: str | None) -> OSError:
    """``error`` about the file the caller asked for: its errno (so its kind, e.g.
    PermissionError) with ``path`` as the file name, or its message with the temporary file's
    name replaced by ``path``."""
    text = os.fspath(path)
    if error.errno is not None and error.strerror:
        return OSError(error.errno, error.strerror, text)
    message = str(error)
    if temporary is not None:
        message = message.replace(temporary, text)
    return OSError(f"{message} (writing {text!r})" if text not in message else message)


def check_output_path(path, name: str, suffix: str) -> Path:
    """``path`` as a :class:`~pathlib.Path` if a ``suffix`` file can be written there, checked
    before any work is done for it.

    Raises
    ------
    ValueError
        Naming ``name``: an empty path, another suffix (the format follows it), an existing
        directory, or a folder that cannot be created or written (a file in the way, no
        permission).
    """
    try:
        text = os.fspath(path)
    except TypeError:
        raise ValueError(f"{name} must be a file path, got {path!r}") from None
    target = Path(text)
    if not text or not target.name:
        raise ValueError(f"{name} must be a file path ending in {suffix}, got {text!r}")
    if target.is_dir():
        raise ValueError(f"{name} is a folder, not a file: {text!r}")
    if target.suffix.lower() != suffix:
        raise ValueError(f"{name} must end in {suffix} (the format follows it), got {text!r}")
    _check_creatable(target.absolute().parent, name, text)
    return target


def check_output_folder(path, name: str) -> Path:
    """``path`` as a :class:`~pathlib.Path` if it is, or can be created as, a writable folder
    (raises ValueError naming ``name`` otherwise)."""
    target = Path(path)
    if target.exists() and not target.is_dir():
        raise ValueError(f"{name} is a file, not a folder: {os.fspath(path)!r}")
    _check_creatable(target.absolute(), name, os.fspath(path))
    return target


def _check_creatable(folder: Path, name: str, text: str) -> None:
    # The nearest folder that exists must be one we can create the rest in and write to.
    while not folder.exists():
        if folder.is_symlink():
            # mkdir would fail on the link's name, after the work was done.
            raise ValueError(f"{name} cannot be written: {folder} is a link to nothing "
                             f"(for {text!r})")
        folder = folder.parent
    reason = "not a folder"
    if folder.is_dir():
        # A real file, created and removed: os.access passes for root, and says nothing of
        # read-only or virtual file systems (/proc).
        try:
            handle, probe = tempfile.mkstemp(prefix=".wgbragg-probe.", dir=folder)
        except OSError as error:
            reason = error.strerror or type(error).__name__
        else:
            try:
                os.close(handle)
            finally:
                os.unlink(probe)
            return
    raise ValueError(f"{name} cannot be written: {folder} is not a writable folder ({reason}; "
                     f"for {text!r})")


def write_text_atomic(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    with atomic_path(path) as temporary:
        temporary.write_text(text, encoding="utf-8")
