"""Files of inverse design: measured spectra in (CSV, :func:`read_spectrum_csv`) and designed
structures out, as a scene TOML whose material ``wgbragg render`` uses directly
(:func:`scene_toml`).

CSV format (``docs/inverse_design.md``, "CSV format"): comma-separated text, ``#`` comments and
blank lines ignored; an optional header row whose first cell is text; then one row per
wavelength: the wavelength in nm, then one reflectance in [0, 1] per angle. Wavelengths strictly
increase. With a header, the angle columns may be named by their angle in degrees
(``wavelength_nm,0,30,60``), which then serves as ``--theta-deg``.
"""

from __future__ import annotations

import json
import math
import os
import re

import numpy as np

from wgbragg.bsdf.materials import BraggMirror, ThinFilm
from wgbragg.common.atomic import write_text_atomic
from wgbragg.common.validation import WAVELENGTH_RANGE_NM

__all__ = ["MeasuredSpectrum", "read_spectrum_csv", "scene_toml", "write_scene_toml"]


class MeasuredSpectrum:
    """A measured spectrum: ``wavelength_nm`` ``(W,)``, ``reflectance`` ``(W, A)`` and the
    angles in degrees the header named (None without)."""

    def __init__(self, wavelength_nm, reflectance, theta_deg):
        self.wavelength_nm = wavelength_nm
        self.reflectance = reflectance
        self.theta_deg = theta_deg


def _cell(text: str, row: int, column: int, path) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"{path}: line {row}, column {column}: not a number: {text!r}") from None
    if not math.isfinite(value):
        raise ValueError(f"{path}: line {row}, column {column}: {text!r} is not finite (NaN "
                         "or infinite values cannot be fitted: remove the row)")
    return value


def read_spectrum_csv(path: str | os.PathLike) -> MeasuredSpectrum:
    """Read a measured spectrum (format in the module docstring).

    Raises
    ------
    ValueError
        Naming the file and line: no data, fewer than 3 rows, rows of unequal length, no
        reflectance column, a cell that is not a finite number, a reflectance outside
        [-0.05, 1.05] (noise allowed), wavelengths not strictly increasing or outside
        [1, 1e6] nm, or header angles that are not numbers in [0, 90].
    OSError
        When the file cannot be read.
    """
    with open(path, encoding="utf-8") as handle:
        lines = handle.read().splitlines()
    rows, header, theta_deg = [], None, None
    for number, line in enumerate(lines, start=1):
        text = line.split("#", 1)[0].strip()
        if not text:
            continue
        cells = [c.strip() for c in text.split(",")]
        if header is None and not rows:
            try:
                float(cells[0])
            except ValueError:
                header = cells
                continue
        rows.append((number, cells))
    if not rows:
        raise ValueError(f"{path}: no data rows (expected 'wavelength_nm,R_angle1,...')")
    width = len(rows[0][1])
    if width < 2:
        raise ValueError(f"{path}: needs a wavelength column and at least one reflectance "
                         "column")
    for number, cells in rows:
        if len(cells) != width:
            raise ValueError(f"{path}: line {number} has {len(cells)} columns, expected {width}")
    if len(rows) < 3:
        raise ValueError(f"{path}: needs at least 3 wavelengths, got {len(rows)}")
    data = np.array([[_cell(c, n, j + 1, path) for j, c in enumerate(cells)]
                     for n, cells in rows])
    wavelength = data[:, 0]
    if np.any(np.diff(wavelength) <= 0):
        bad = rows[int(np.flatnonzero(np.diff(wavelength) <= 0)[0]) + 1][0]
        raise ValueError(f"{path}: wavelengths must strictly increase (line {bad})")
    low, high = WAVELENGTH_RANGE_NM
    if wavelength[0] < low or wavelength[-1] > high:
        raise ValueError(f"{path}: wavelengths must be in [{low:g}, {high:g}] nm")
    reflectance = data[:, 1:]
    if np.any((reflectance < -0.05) | (reflectance > 1.05)):
        raise ValueError(f"{path}: reflectances must be fractions in [0, 1] (not percent)")
    if header is not None and len(header) == width:
        try:
            theta_deg = np.array([float(c) for c in header[1:]])
        except ValueError:
            theta_deg = None
        if theta_deg is not None and np.any((theta_deg < 0) | (theta_deg > 90)):
            raise ValueError(f"{path}: header angles must be degrees in [0, 90]")
    return MeasuredSpectrum(wavelength, reflectance, theta_deg)


def _number(value: float) -> str:
    return repr(float(value))


def _string(text: str) -> str:
    """A TOML basic string (JSON's escapes are TOML's, but for DEL)."""
    return json.dumps(text, ensure_ascii=False).replace("\x7f", "\\u007f")


def _key(name: str) -> str:
    """A TOML key: bare where it may be, else quoted."""
    return name if re.fullmatch(r"[A-Za-z0-9_-]+", name) else _string(name)


def scene_toml(structure, *, alpha: float = 0.1, name: str = "design") -> str:
    """A complete scene (a sphere under a sky) whose material ``name`` is ``structure``, as
    TOML text that :func:`wgbragg.load_scene` reads and ``wgbragg render`` renders.

    A Bragg mirror becomes one rough layer (``type = "layered-bragg"``, GGX ``alpha``) over
    an absorbing base; a film a ``"thin-film"`` material. Scenes lie in air: a mirror whose
    host and ``n1`` are below 1, or a film under a host other than air, cannot be written.

    Raises
    ------
    ValueError
        For another structure, or one a scene cannot hold.
    """
    if not 0.01 <= float(alpha) <= 1.0:
        raise ValueError(f"alpha must be in [0.01, 1], got {alpha!r}")
    if not isinstance(name, str) or not name:
        raise ValueError(f"name must be a non-empty string, got {name!r}")
    table = f"materials.{_key(name)}"
    lines = [f"# {structure!r}", "", "[settings]", "size = [512, 512]", "spp = 64",
             "mode = \"rgb\"", "", "[camera]", "position = [0.0, 0.0, 3.0]",
             "look_at = [0.0, 0.0, 0.0]", "fov_deg = 40.0", "", "[environment]",
             "type = \"sky\"", "", f"[{table}]"]
    if isinstance(structure, BraggMirror):
        if structure.host < 1.0 or (structure.host == structure.n1 and structure.n1 < 1.0):
            raise ValueError("a scene's mirror lies under air: host (or n1) must be >= 1")
        lines += ["type = \"layered-bragg\"", "", f"[[{table}.layers]]",
                  f"n1 = {_number(structure.n1)}", f"n2 = {_number(structure.n2)}",
                  f"d1_nm = {_number(structure.d1)}", f"d2_nm = {_number(structure.d2)}",
                  f"N = {int(structure.N)}", f"alpha = {_number(alpha)}"]
        if structure.host != structure.n1:
            lines.append(f"host = {_number(structure.host)}")
    elif isinstance(structure, ThinFilm):
        if structure.host != 1.0:
            raise ValueError("a scene's thin film lies in air: host must be 1")
        lines += ["type = \"thin-film\"", f"n_film = {_number(structure.n_film)}",
                  f"thickness_nm = {_number(structure.d)}", f"alpha = {_number(alpha)}"]
        if structure.base is not None:
            lines.append(f"base = {_string(structure.base.name)}")
        else:
            lines += [f"n_base = {_number(structure.n_base)}",
                      f"k_base = {_number(structure.k_base)}"]
    else:
        raise ValueError(f"structure must be a BraggMirror or a ThinFilm, got {structure!r}")
    lines += ["", "[[objects]]", "shape = \"sphere\"", f"material = {_string(name)}", ""]
    return "\n".join(lines)


def write_scene_toml(structure, path, *, alpha: float = 0.1, name: str = "design") -> None:
    """Write :func:`scene_toml` to ``path`` atomically."""
    write_text_atomic(path, scene_toml(structure, alpha=alpha, name=name))
