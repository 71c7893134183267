"""Target colours of inverse design and the colour of populations of structures.

Targets come in any of :data:`TARGET_SPACES` and are compared in CIELAB (D65, the perfect
reflector ``Y = 1`` as :meth:`wgbragg.BraggMirror.xyz` returns) by CIE dE2000
(``colour.delta_E(..., method="CIE 2000")``). The "grid" search colour of a population is its
reflectance from the population kernel (one dispatch for all members and angles) on a
wavelength grid, integrated with the reference's D65 x CIE 1931 weights redistributed onto the
grid (:func:`grid_xyz_weights`).
"""

from __future__ import annotations

import re

import colour
import numpy as np

from wgbragg.colour.colorimetry import linear_srgb_to_xyz, xyz_to_lab, xyz_weights
from wgbragg.render.display import decode_srgb

__all__ = ["SEARCH_STEP_NM", "TARGET_SPACES", "delta_e", "grid_xyz_weights", "parse_targets"]

TARGET_SPACES = ("srgb", "linear-srgb", "xyz", "lab")
"""Spaces a target colour may be given in: gamma-encoded sRGB (also ``"#rrggbb"`` strings),
linear sRGB, CIE XYZ (D65, ``Y = 1`` white) or CIELAB (D65)."""

SEARCH_STEP_NM = 2.0
"""Wavelength step of the search's colour grid (nm)."""

_HEX = re.compile(r"^#?([0-9a-fA-F]{6})$")


def grid_xyz_weights(step_nm: float = SEARCH_STEP_NM) -> tuple[np.ndarray, np.ndarray]:
    """Nodes every ``step_nm`` over 360-830 nm and XYZ weights ``(K, 3)`` that integrate the
    linear interpolant of R between them with the reference's 1 nm weights (so R = 1 gives
    the reference white exactly)."""
    fine, weights = xyz_weights()
    nodes = np.arange(fine[0], fine[-1] + 0.5 * step_nm, step_nm)
    nodes[-1] = min(nodes[-1], fine[-1])
    position = np.clip(np.interp(fine, nodes, np.arange(nodes.size)), 0, nodes.size - 1)
    left = np.minimum(np.floor(position).astype(int), nodes.size - 2)
    t = position - left
    out = np.zeros((nodes.size, 3))
    np.add.at(out, left, weights * (1.0 - t)[:, None])
    np.add.at(out, left + 1, weights * t[:, None])
    return nodes, out


def delta_e(lab_a, lab_b) -> np.ndarray:
    """CIE dE2000 between CIELAB colours (broadcast)."""
    a, b = np.broadcast_arrays(np.asarray(lab_a, np.float64), np.asarray(lab_b, np.float64))
    return np.asarray(colour.delta_E(a, b, method="CIE 2000"), np.float64)


def _hex(text: str) -> np.ndarray:
    match = _HEX.match(text.strip())
    if match is None:
        raise ValueError(f"a hex colour must look like '#d4af37', got {text!r}")
    digits = match.group(1)
    return np.array([int(digits[i:i + 2], 16) / 255.0 for i in (0, 2, 4)])


def parse_targets(targets, count: int, space: str = "srgb") -> np.ndarray:
    """CIELAB ``(count, 3)`` of targets given in ``space``.

    Parameters
    ----------
    targets : array_like or sequence of str
        ``(count, 3)`` values in ``space``, or (``space="srgb"``) ``"#rrggbb"`` strings; one
        target per angle.
    count : int
        Number of angles.
    space : {"srgb", "linear-srgb", "xyz", "lab"}

    Raises
    ------
    ValueError
        For an unknown space, a shape other than ``(count, 3)``, a value that is not finite,
        encoded sRGB outside [0, 1], negative XYZ or Y, or L* outside [0, 100].
    """
    if space not in TARGET_SPACES:
        raise ValueError(f"space must be one of {TARGET_SPACES}, got {space!r}")
    items = [targets] if isinstance(targets, str) else targets
    if len(items) and all(isinstance(t, str) for t in items):
        if space != "srgb":
            raise ValueError(f"hex colours are encoded sRGB: use space='srgb', not {space!r}")
        values = np.array([_hex(t) for t in items])
    else:
        try:
            values = np.asarray(targets, np.float64)
        except (TypeError, ValueError):
            raise ValueError("targets must be numbers of shape (len(theta), 3) or hex "
                             "strings") from None
        values = values.reshape(1, 3) if values.shape == (3,) and count == 1 else values
    if values.shape != (count, 3):
        raise ValueError(f"targets must have shape (len(theta), 3) = ({count}, 3), got "
                         f"{values.shape}")
    if not np.all(np.isfinite(values)):
        raise ValueError("targets must be finite")
    if space == "srgb":
        if np.any((values < 0) | (values > 1)):
            raise ValueError("encoded sRGB targets must be in [0, 1]: use space='linear-srgb', "
                             "'xyz' or 'lab' for colours outside the sRGB gamut")
        return xyz_to_lab(linear_srgb_to_xyz(decode_srgb(values)))
    if space == "linear-srgb":
        xyz = linear_srgb_to_xyz(values)
    elif space == "xyz":
        xyz = values
    else:
        if np.any((values[:, 0] < 0) | (values[:, 0] > 100)):
            raise ValueError("L* of lab targets must be in [0, 100]")
        return values.copy()
    if np.any(xyz[:, 1] < 0):
        raise ValueError("targets have a negative luminance Y: not a physical colour")
    return xyz_to_lab(xyz)
