"""Batch renders as Dask tasks (``wgbragg render-batch``): the frames of a turntable (the
camera orbiting its ``look_at`` point about the scene's +y axis) or of one scene value varied
over a range (``materials.coat.layers[0].period_nm=150:300:16``) or a list
(``materials.film.base=Au,Ag,Cu``), each frame one task.

Each frame is rendered where its task runs (the worker's own device) and written atomically
as ``frame_0000.png`` ...; a frame whose PNG exists is not rendered again, so a rerun resumes
(the folder's ``frames.json`` records what its frames are of, and a rerun asking for other
frames is refused). :func:`assemble` joins the frames into an animated GIF or WebP (Pillow).

A frame's scene is the scene file's data with the varied value set, read by the same reader
as ``wgbragg render`` (:func:`wgbragg.scene.load_scene`), so every key path and range of
``docs/scenes.md`` applies and a bad value is reported with its key before any frame runs.
"""

from __future__ import annotations

import copy
import hashlib
import json
import math
import os
import re
import sys
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

from wgbragg.common.atomic import atomic_path, check_output_path, write_text_atomic
from wgbragg.common.toml_values import toml_key, toml_value
from wgbragg.render import Renderer, save_png
from wgbragg.scene import load_scene, parse_scene
from wgbragg.scene.model import layer_thicknesses, period_and_delta
from wgbragg.sweep.engine import submit_bounded

__all__ = ["ANIMATION_SUFFIXES", "BatchReport", "Frame", "assemble", "parse_vary",
           "plan_frames", "render_batch", "render_frame", "set_key", "toml_text"]

ANIMATION_SUFFIXES = (".gif", ".webp")
MAX_FRAMES = 100_000
MANIFEST = "frames.json"
_BARE = re.compile(r"[A-Za-z0-9_-]+")
_INDEX = re.compile(r"\[\s*(\d+)\s*\]")
_BASIC = re.compile(r'"((?:[^"\\\x00-\x1f]|\\.)*)"')
_LITERAL = re.compile(r"'([^'\x00-\x1f]*)'")
_QUOTES = {'"': _BASIC, "'": _LITERAL}
_BOOLEANS = {"true": True, "false": False}


@dataclass(frozen=True)
class Frame:
    """One frame: its index, what varies (``label``), its scene as TOML text, the scene
    file's ``folder`` its relative paths start from, and whether they may point outside it
    (``allow_outside``, as :func:`wgbragg.scene.load_scene`)."""

    index: int
    label: str
    scene_text: str
    folder: str
    allow_outside: bool = False

    def scene(self):
        """The frame's :class:`~wgbragg.scene.Scene`, read with the scene reader's checks."""
        return parse_scene(self.scene_text, self.folder, origin=f"frame {self.index} "
                           f"({self.label})", allow_outside=self.allow_outside)

    @property
    def filename(self) -> str:
        return f"frame_{self.index:04d}.png"


# ---------------------------------------------------------------------- scene data


def toml_text(document: dict) -> str:
    """``document`` (tables, arrays, strings, numbers, booleans) as TOML, each top-level key
    an inline value: what :mod:`tomllib` reads back as the same data."""
    return "".join(f"{toml_key(k)} = {toml_value(v)}\n" for k, v in document.items())


def _name(match: re.Match, quote: str) -> str:
    if quote == "'":
        return match.group(1)
    try:
        return json.loads(f'"{match.group(1)}"')
    except json.JSONDecodeError:
        raise ValueError(f"--vary: bad escape in the quoted key {match.group(0)}") from None


def _read_key(text: str, stop: str = "") -> tuple[list, int]:
    """The segments of the key path at the start of ``text`` (names and ``[i]`` indices) and
    where it ends: before ``stop`` (a character outside quotes) or at the end. Names are bare
    (``A-Za-z0-9_-``) or quoted as TOML keys (``"my coat"``, ``'my coat'``), dots between them
    with optional spaces, as TOML's dotted keys."""
    parts: list = []
    pos, expect_name = 0, True
    while True:
        while pos < len(text) and text[pos] in " \t":
            pos += 1
        if expect_name:
            quote = text[pos:pos + 1]
            match = (_QUOTES[quote].match(text, pos) if quote in _QUOTES
                     else _BARE.match(text, pos))
            if not match:
                raise ValueError("not a key path")
            parts.append(_name(match, quote) if quote in _QUOTES else match.group(0))
            pos, expect_name = match.end(), False
            continue
        index = _INDEX.match(text, pos)
        if index:
            parts.append(int(index.group(1)))
            pos = index.end()
        elif text[pos:pos + 1] == ".":
            pos, expect_name = pos + 1, True
        elif pos == len(text) or text[pos] == stop:
            return parts, pos
        else:
            raise ValueError("not a key path")


def _segments(key: str) -> list:
    """A key path's segments. A path given whole inside one pair of quotes
    (``'materials.coat.layers[0].period_nm'``) is read as the path it quotes: no scene key
    holds a dot or a bracket at the top level."""
    try:
        parts, _ = _read_key(key)
        if len(parts) == 1 and isinstance(parts[0], str) and key.strip()[:1] in _QUOTES and (
                re.search(r"[.\[]", parts[0])):
            parts, _ = _read_key(parts[0])
    except ValueError:
        raise ValueError(f"--vary: {key!r} is not a key path such as "
                         "materials.coat.layers[0].period_nm (names bare or quoted as TOML "
                         "keys, [i] indices)") from None
    return parts


def _typed(key: str, old, value):
    """``value`` (a number, or a string from a list of values) as the type of the scene's
    ``old`` value at ``key``."""
    if isinstance(value, str) and not isinstance(old, str | None):
        text = value.strip()
        if isinstance(old, bool):
            if text not in _BOOLEANS:
                raise ValueError(f"--vary: {key} is true or false, got {value!r}")
            return _BOOLEANS[text]
        try:
            value = float(text)
        except ValueError:
            raise ValueError(f"--vary: {key} is a number of the scene; the list gives "
                             f"{value!r}") from None
        if not math.isfinite(value):
            raise ValueError(f"--vary: {key} must be finite, got {text!r}")
    if isinstance(old, str) or (old is None and isinstance(value, str)):
        if not isinstance(value, str):
            raise ValueError(f"--vary: {key} is not a number of the scene (it holds {old!r}): "
                             "give its values as a list, KEY=A,B,C")
        return value.strip()
    if isinstance(old, bool) or not isinstance(old, int | float):
        raise ValueError(f"--vary: {key} is not a number of the scene (it holds {old!r})")
    if isinstance(old, int):
        if value != round(value):
            raise ValueError(f"--vary: {key} is an integer; the range gives {value:g}")
        return int(value)  # integral, checked above
    return float(value)


def set_key(document: dict, key: str, value) -> None:
    """Set the value at key path ``key`` (``materials.coat.layers[0].period_nm``) of a scene
    file's data: a number, or a string (from a list of values) read as the type the scene
    holds there (number, ``true``/``false``, or text such as a film's ``base = "Au"``).

    A Bragg layer's ``period_nm`` or ``delta`` may be set on a layer that gives ``d1_nm`` and
    ``d2_nm`` (and these on one that gives ``period_nm`` and ``delta``): the other pair is
    converted, keeping the layer's other thickness value. A thin film's ``base`` may be set on
    a film without one: it replaces ``n_base`` and ``k_base``."""
    parts = _segments(key)
    node = document
    for depth, part in enumerate(parts[:-1]):
        where = key if depth == 0 else f"{part!r} in {key}"
        try:
            node = node[part]
        except (KeyError, IndexError, TypeError):
            raise ValueError(f"--vary: the scene has no {where}") from None
    last = parts[-1]
    if not isinstance(node, dict) or not isinstance(last, str):
        raise ValueError(f"--vary: {key} is not a value of the scene")
    pair = {"period_nm": ("d1_nm", "d2_nm"), "delta": ("d1_nm", "d2_nm"),
            "d1_nm": ("period_nm", "delta"), "d2_nm": ("period_nm", "delta")}
    if last not in node and last in pair and all(k in node for k in pair[last]):
        if last in ("period_nm", "delta"):
            node["period_nm"], node["delta"] = period_and_delta(float(node.pop("d1_nm")),
                                                                float(node.pop("d2_nm")))
        else:
            node["d1_nm"], node["d2_nm"] = layer_thicknesses(float(node.pop("period_nm")),
                                                             float(node.pop("delta")))
    old = node.get(last)
    if last == "base" and node.get("type") == "thin-film" and isinstance(value, str):
        node.pop("n_base", None)
        node.pop("k_base", None)
    elif old is None:
        raise ValueError(f"--vary: the scene has no {key} (it holds None)")
    node[last] = _typed(key, old, value)


def parse_vary(text: str) -> tuple[str, np.ndarray | list[str]]:
    """``KEY=START:STOP:COUNT`` as the key and its ``COUNT`` values from START to STOP, or
    ``KEY=A,B,C`` as the key and its listed values (strings, read as the scene's type by
    :func:`set_key`). ``KEY`` is a key path, names bare or quoted as TOML keys."""
    try:
        _, end = _read_key(text, stop="=")
    except ValueError:
        end = text.find("=")
    if end < 0 or end >= len(text) or text[end] != "=":
        raise ValueError(f"--vary must be KEY=START:STOP:COUNT or KEY=A,B,C, got {text!r}")
    key, spec = text[:end].strip(), text[end + 1:]
    _segments(key)
    if "," in spec or ":" not in spec:
        values = [v.strip() for v in spec.split(",")]
        if not all(values) or not 1 <= len(values) <= MAX_FRAMES:
            raise ValueError(f"--vary: a list KEY=A,B,C of 1 to {MAX_FRAMES} non-empty values, "
                             f"got {text!r}")
        return key, values
    fields = spec.split(":")
    if len(fields) != 3:
        raise ValueError(f"--vary must be KEY=START:STOP:COUNT or KEY=A,B,C, got {text!r}")
    try:
        start, stop, count = float(fields[0]), float(fields[1]), int(fields[2])
    except ValueError:
        raise ValueError(f"--vary must be KEY=START:STOP:COUNT with numbers and an integer "
                         f"count, got {text!r}") from None
    if not (math.isfinite(start) and math.isfinite(stop)) or not 1 <= count <= MAX_FRAMES:
        raise ValueError(f"--vary: finite START and STOP and a COUNT in [1, {MAX_FRAMES}], "
                         f"got {text!r}")
    return key, np.linspace(start, stop, count)


def _turntable(document: dict, angle_deg: float) -> None:
    camera = document["camera"]
    position = np.asarray(camera["position"], dtype=np.float64)
    centre = np.asarray(camera["look_at"], dtype=np.float64)
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    offset = position - centre
    rotated = np.array([c * offset[0] + s * offset[2], offset[1], -s * offset[0] + c * offset[2]])
    camera["position"] = [float(v) for v in centre + rotated]


def plan_frames(scene_path, *, turntable: int | None = None, vary: str | None = None,
                allow_outside: bool = False) -> list[Frame]:
    """The frames of a turntable of ``turntable`` frames, or of ``vary``
    (``KEY=START:STOP:COUNT`` or ``KEY=A,B,C``, :func:`parse_vary`), each checked by the scene
    reader.

    Raises
    ------
    ValueError
        For a scene file the reader refuses, a bad ``--vary`` or ``--turntable``, or a frame
        whose value is out of range (naming its key).
    """
    if (turntable is None) == (vary is None):
        raise ValueError("give one of --turntable FRAMES and --vary KEY=START:STOP:COUNT "
                         "(or KEY=A,B,C)")
    path = Path(scene_path)
    load_scene(path, allow_outside=allow_outside)  # the file as written, paths checked
    document = tomllib.loads(path.read_bytes().decode("utf-8-sig"))
    folder = os.fspath(path.resolve().parent)
    frames = []
    if turntable is not None:
        if isinstance(turntable, bool) or not isinstance(turntable, int) or not (
                1 <= turntable <= MAX_FRAMES):
            raise ValueError(f"--turntable must be a number of frames in [1, {MAX_FRAMES}], "
                             f"got {turntable!r}")
        steps = [(f"turntable {360.0 * k / turntable:g} deg", 360.0 * k / turntable)
                 for k in range(turntable)]
    else:
        key, values = parse_vary(vary)
        steps = [(f"{key} = {v if isinstance(v, str) else format(v, 'g')}", v)
                 for v in values]
    for index, (label, value) in enumerate(steps):
        data = copy.deepcopy(document)
        if turntable is not None:
            _turntable(data, value)
        else:
            set_key(data, key, value)
        frame = Frame(index=index, label=label, scene_text=toml_text(data), folder=folder,
                      allow_outside=allow_outside)
        frame.scene()  # checked as the file would be: ranges, files, the folder rule
        frames.append(frame)
    return frames


# ---------------------------------------------------------------------- rendering


def render_frame(frame: Frame, folder, *, size=None, spp: int | None = None,
                 mode: str | None = None, seed: int = 0) -> dict:
    """Render ``frame`` into ``folder/frame_NNNN.png`` (atomically) unless it is there.

    Returns
    -------
    dict
        ``index``, ``rendered`` (False if the PNG existed), ``seconds``, ``pid``.
    """
    target = Path(folder) / frame.filename
    if target.exists():
        return {"index": frame.index, "rendered": False, "seconds": 0.0, "pid": os.getpid()}
    start = time.perf_counter()
    scene = frame.scene()
    renderer = Renderer(scene, size=size, mode=mode, seed=seed)
    image = renderer.render(scene.settings.spp if spp is None else spp)
    save_png(image, target, scene.settings.exposure)
    return {"index": frame.index, "rendered": True, "seconds": time.perf_counter() - start,
            "pid": os.getpid()}


@dataclass(frozen=True)
class BatchReport:
    """What :func:`render_batch` did: frames ``rendered`` this run, ``skipped`` (already
    there), their ``paths`` in order, and ``seconds``."""

    rendered: int
    skipped: int
    paths: tuple
    seconds: float

    def line(self) -> str:
        return (f"{self.rendered} frames rendered, {self.skipped} already there, "
                f"{len(self.paths)} in all in {self.seconds:.1f} s")


def _manifest(frames: list[Frame], size, spp, mode, seed) -> str:
    digest = hashlib.sha256("\n".join(f.scene_text for f in frames).encode()).hexdigest()
    return json.dumps({"frames": len(frames), "scenes_sha256": digest,
                       "size": None if size is None else list(size), "spp": spp, "mode": mode,
                       "seed": seed}, sort_keys=True)


def _render_item(frame, *, folder, size, spp, mode, seed):
    return render_frame(frame, folder, size=size, spp=spp, mode=mode, seed=seed)


def render_batch(frames: list[Frame], folder, client, *, size=None, spp: int | None = None,
                 mode: str | None = None, seed: int = 0, progress: bool = True
                 ) -> BatchReport:
    """Render every frame not yet in ``folder`` as a Dask task through ``client``.

    Raises
    ------
    ValueError
        If ``folder`` holds the frames of another batch (other scenes, size, samples or mode).
    """
    from tqdm import tqdm

    # Checked here, before any task: the workers' renderer checks them again, on their device.
    if spp is not None and (isinstance(spp, bool) or not isinstance(spp, int) or spp < 1):
        raise ValueError(f"--spp must be an integer >= 1, got {spp!r}")
    if size is not None and not (len(size) == 2 and all(
            isinstance(n, int) and not isinstance(n, bool) and n >= 1 for n in size)):
        raise ValueError(f"--size must be two integers >= 1 (WIDTHxHEIGHT), got {size!r}")
    start = time.perf_counter()
    folder = Path(folder).absolute()
    folder.mkdir(parents=True, exist_ok=True)
    manifest = folder / MANIFEST
    wanted = _manifest(frames, size, spp, mode, seed)
    if manifest.is_file():
        if manifest.read_text(encoding="utf-8") != wanted:
            raise ValueError(f"{folder} holds the frames of another batch (other scene, values, "
                             "size, samples or mode): use another folder or empty it")
    elif any(p.name.startswith("frame_") for p in folder.iterdir()):
        raise ValueError(f"{folder} holds frames without {MANIFEST}: use another folder")
    else:
        write_text_atomic(manifest, wanted)
    todo = [f for f in frames if not (folder / f.filename).exists()]
    rendered = 0
    bar = tqdm(total=len(frames), initial=len(frames) - len(todo), desc="frames", unit="frame",
               disable=not progress, file=sys.stderr)
    try:
        for record in submit_bounded(client, _render_item, todo, folder=str(folder),
                                     size=size, spp=spp, mode=mode, seed=seed,
                                     key=lambda f: f"wgbragg-frame-{f.index}-"
                                                   f"{os.urandom(4).hex()}"):
            rendered += int(record["rendered"])
            bar.update(1)
    finally:
        bar.close()
    return BatchReport(rendered=rendered, skipped=len(frames) - len(todo),
                       paths=tuple(folder / f.filename for f in frames),
                       seconds=time.perf_counter() - start)


def assemble(paths, output, *, fps: float = 12.0) -> Path:
    """Join frame PNGs into an animated GIF or WebP (by ``output``'s suffix), looping,
    written atomically."""
    suffix = Path(output).suffix.lower()
    if suffix not in ANIMATION_SUFFIXES:
        raise ValueError(f"--animation must end in {' or '.join(ANIMATION_SUFFIXES)}, got "
                         f"{os.fspath(output)!r}")
    check_output_path(output, "--animation", suffix)
    if not (isinstance(fps, int | float) and 0.1 <= fps <= 100.0):
        raise ValueError(f"--fps must be in [0.1, 100], got {fps!r}")
    images = []
    for path in paths:
        with Image.open(path) as image:
            images.append(image.convert("RGB"))
    if not images:
        raise ValueError("no frames to assemble")
    duration = max(10, round(1000.0 / fps))
    with atomic_path(output) as temporary:
        options = {"lossless": True} if suffix == ".webp" else {"optimize": False}
        images[0].save(temporary, format=suffix[1:].upper(), save_all=True,
                       append_images=images[1:], duration=duration, loop=0, **options)
    return Path(output)
