"""No lost work: outputs checked by a real file before the work, errors that name the user's
path, a fallback file when writing fails at the end, and an interrupted render that keeps its
image (``wgbragg.common.atomic``, ``wgbragg render``, ``wgbragg bake``)."""

from __future__ import annotations

import errno
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import OpenEXR
import pytest
from PIL import Image

from wgbragg.app.cli import EXIT_INTERRUPTED, main
from wgbragg.common.atomic import atomic_path, check_output_folder, check_output_path
from wgbragg.common.exr import read_exr

ROOT = Path(__file__).resolve().parents[1]


# ---------------------------------------------------------------------------- checks up front


@pytest.mark.parametrize("check", [
    lambda path: check_output_path(path / "x.png", "--output", ".png"),
    lambda path: check_output_folder(path / "frames", "--cache"),
])
def test_a_folder_that_cannot_take_a_file_is_refused_for_root_too(check):
    """/proc refuses new files whatever the permission bits say (os.access passes for root)."""
    with pytest.raises(ValueError, match=r"cannot be written: /proc is not a writable folder"):
        check(Path("/proc"))


def test_the_check_leaves_nothing_behind(tmp_path):
    target = tmp_path / "a" / "x.png"
    assert check_output_path(target, "--output", ".png") == target
    assert list(tmp_path.iterdir()) == []


def test_atomic_writes_name_the_users_path_not_the_temporary_file(tmp_path):
    with pytest.raises(FileNotFoundError) as caught, atomic_path("/proc/x.png"):
        pass
    assert str(caught.value) == "[Errno 2] No such file or directory: '/proc/x.png'"
    target = tmp_path / "image.png"
    with pytest.raises(OSError) as caught, atomic_path(target) as temporary:
        raise OSError(errno.ENOSPC, "No space left on device", str(temporary))
    assert caught.value.errno == errno.ENOSPC and caught.value.filename == str(target)
    with pytest.raises(OSError) as caught, atomic_path(target) as temporary:
        raise OSError(f"cannot write mode RGBA as JPEG to {temporary}")
    assert str(target) in str(caught.value) and ".image." not in str(caught.value)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("argv", [
    ["-o", "/proc/x.png"],
    ["-o", "{tmp}/ok.png", "--exr", "/proc/x.exr"],
    ["-o", "{tmp}/file.txt/x.png"],
    ["-o", "{tmp}/ok.png", "--denoise"],  # ok.denoised.png is a folder
])
def test_render_outputs_are_refused_before_any_work(argv, tmp_path, capsys, monkeypatch):
    (tmp_path / "file.txt").write_text("in the way")
    (tmp_path / "ok.denoised.png").mkdir()
    import wgbragg.scene
    from wgbragg.render import renderer

    def forbidden(*args, **kwargs):
        raise AssertionError("the work started before the outputs were checked")

    monkeypatch.setattr(renderer.Renderer, "__init__", forbidden)
    monkeypatch.setattr(wgbragg.scene, "load_preset", forbidden)
    before = sorted(tmp_path.rglob("*"))
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    assert main(["render", "--scene", "furnace", *argv]) == 2
    error = capsys.readouterr().err
    named = [a for a in argv if a.startswith(("/", str(tmp_path)))]
    assert error.startswith("wgbragg: error:") and error.count("\n") == 1
    assert any(repr(a) in error or repr(a.replace(".png", ".denoised.png")) in error
               for a in named), error
    assert sorted(tmp_path.rglob("*")) == before


# ---------------------------------------------------------------------------- failures at the end


@pytest.mark.gpu
def test_an_image_that_cannot_be_written_at_the_end_is_saved_in_the_working_folder(
        tmp_path, capsys, monkeypatch):
    """The outputs pass the check, then the disk fills up: each image that cannot go where
    asked goes to ./wgbragg-render-<time>.<suffix>, and the message says where."""
    import wgbragg.common.exr
    import wgbragg.render

    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    png, exr = tmp_path / "out" / "x.png", tmp_path / "out" / "x.exr"
    originals = {"png": wgbragg.render.save_png, "exr": wgbragg.common.exr.write_exr}

    def failing(kind, path_at):
        def write(*args, **kwargs):
            path = args[path_at]
            if Path(path).parent == png.parent:
                raise OSError(errno.ENOSPC, "No space left on device", str(path))
            return originals[kind](*args, **kwargs)
        return write

    monkeypatch.setattr(wgbragg.render, "save_png", failing("png", 1))  # (image, path, ...)
    monkeypatch.setattr(wgbragg.common.exr, "write_exr", failing("exr", 0))  # (path, image, ...)
    assert main(["render", "--scene", "furnace", "--size", "8x6", "--spp", "2", "-o", str(png),
                 "--exr", str(exr), "--no-progress"]) == 2
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    saved = sorted(work.iterdir())
    assert [p.suffix for p in saved] == [".exr", ".png"]
    assert all(re.fullmatch(r"wgbragg-render-\d{8}-\d{6}\.(png|exr)", p.name) for p in saved)
    assert len(lines) == 2
    for line, path, flag in zip(lines, (png, exr), ("--output", "--exr"), strict=True):
        assert line.startswith(f"wgbragg: error: cannot write {flag} {str(path)!r} ([Errno "
                               f"{errno.ENOSPC}] No space left on device")
        fallback = work / f"{saved[0].stem}{path.suffix}"
        assert line.endswith(f"the image is saved to {fallback} instead")
    assert captured.out.startswith(f"{work / saved[1].name}, {work / saved[0].name}: 8x6")
    assert np.asarray(Image.open(saved[1])).shape == (6, 8, 3)
    assert read_exr(saved[0]).shape == (6, 8, 3)
    assert not png.exists() and not exr.exists()


# ---------------------------------------------------------------------------- interruptions


def _stderr_reader(process) -> tuple[list[bytes], threading.Thread]:
    chunks: list[bytes] = []

    def read():
        while chunk := os.read(process.stderr.fileno(), 4096):
            chunks.append(chunk)

    thread = threading.Thread(target=read, daemon=True)
    thread.start()
    return chunks, thread


@pytest.mark.gpu
@pytest.mark.parametrize("signal_number", [signal.SIGINT, signal.SIGTERM])
def test_an_interrupted_render_writes_the_image_so_far(tmp_path, signal_number):
    png, exr = tmp_path / "partial.png", tmp_path / "partial.exr"
    process = subprocess.Popen(
        [sys.executable, "-m", "wgbragg.app.cli", "render", "--scene", "furnace", "--size",
         "32x24", "--spp", "100000000", "-o", str(png), "--exr", str(exr)],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    chunks, reader = _stderr_reader(process)
    # Wait until the progress bar shows samples done (the render loop runs), for at most 5
    # minutes of pipeline compilation on a loaded machine.
    progress = re.compile(rb"\| *[1-9]\d*/100000000 ")
    deadline = time.monotonic() + 300.0
    while not progress.search(b"".join(chunks)):
        if process.poll() is not None or time.monotonic() > deadline:
            process.kill()
            pytest.fail(f"no progress line: {b''.join(chunks)[-2000:]!r}")
        time.sleep(0.2)
    process.send_signal(signal_number)
    process.wait(timeout=300)  # its stdout is a line at most: the pipe cannot fill up
    out = process.stdout.read()
    reader.join(30)
    err = b"".join(chunks).decode()
    assert process.returncode == EXIT_INTERRUPTED, err
    assert "Traceback" not in err and out == b""
    # Besides the progress bar (redrawn with \r), one line.
    lines = [line for line in re.split(r"[\r\n]", err) if line and not line.startswith("render:")]
    name = signal.Signals(signal_number).name
    assert len(lines) == 1, lines
    match = re.fullmatch(rf"wgbragg: interrupted \({name}\) at (\d+) spp after [\d.]+ s: wrote "
                         rf"{re.escape(str(png))}, {re.escape(str(exr))}", lines[0])
    assert match, lines[0]
    spp = int(match[1])
    assert spp > 0
    assert np.asarray(Image.open(png)).shape == (24, 32, 3)
    image = read_exr(exr)
    assert image.shape == (24, 32, 3) and image.mean() > 0.1  # the furnace: a grey sphere, lit
    with OpenEXR.File(str(exr)) as file:
        header = file.header()
        assert header["spp"] == spp
        assert header["comments"] == f"wgbragg render interrupted ({name}) at {spp} spp"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["partial.exr", "partial.png"]


def test_an_interrupted_bake_says_so_in_one_line_and_leaves_whole_files(tmp_path, capsys,
                                                                         monkeypatch):
    """Ctrl-C in the middle of writing a table: exit 130, one line, the file written before
    it intact, no temporary file left."""
    from wgbragg.colour import tables

    cache = tmp_path / "cache"
    cache.mkdir()
    (cache / "earlier.npz").write_bytes(b"a whole table")

    def interrupted(cache=None, force=False, progress=None):
        with atomic_path(Path(cache) / "colour-tables-x.npz") as temporary:
            temporary.write_bytes(b"half a tab")
            raise KeyboardInterrupt

    monkeypatch.setattr(tables, "colour_tables", interrupted)
    assert main(["bake", "--cache", str(cache), "--alpha", "--no-progress"]) == EXIT_INTERRUPTED
    captured = capsys.readouterr()
    assert captured.err == ("wgbragg: interrupted: the cache keeps the tables baked so far, each "
                            "whole; 'wgbragg bake' again bakes the rest\n")
    assert sorted(p.name for p in cache.iterdir()) == ["earlier.npz"]
    assert (cache / "earlier.npz").read_bytes() == b"a whole table"


def test_sigterm_outside_a_render_is_one_line_too(tmp_path, capsys, monkeypatch):
    from wgbragg.colour import tables

    def terminated(cache=None, force=False, progress=None):
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(5)  # the handler raises before this ends
        raise AssertionError("SIGTERM did not interrupt")

    monkeypatch.setattr(tables, "colour_tables", terminated)
    previous = signal.getsignal(signal.SIGTERM)
    assert main(["bake", "--cache", str(tmp_path), "--alpha", "--no-progress"]) == 130
    assert capsys.readouterr().err.startswith("wgbragg: interrupted")
    assert signal.getsignal(signal.SIGTERM) is previous
