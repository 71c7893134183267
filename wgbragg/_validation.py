"""Input checks shared by every public entry point.

Bad input raises :class:`ValueError` naming the parameter and its accepted range, so that no
kernel ever sees a value that would make it return NaN.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

__all__ = [
    "BACKENDS",
    "MAX_EXTINCTION",
    "MAX_INDEX",
    "MAX_THICKNESS_NM",
    "POLARIZATIONS",
    "UNIT_TOLERANCE",
    "WAVELENGTH_RANGE_NM",
    "check_angle",
    "check_backend",
    "check_broadcast",
    "check_count",
    "check_directions",
    "check_extinction",
    "check_index",
    "check_polarization",
    "check_real",
    "check_thickness",
    "check_wavelength",
]

POLARIZATIONS = ("s", "p", "unpolarized")
BACKENDS = ("numpy", "gpu")


def _as_float_array(name: str, value) -> np.ndarray:
    message = f"{name} must be a real number or array of real numbers"
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError) as error:
        raise ValueError(message) from error
    # Strings would convert ("500" -> 500.0); refuse them rather than guess.
    if raw.dtype.kind not in "biuf":
        raise ValueError(f"{message}, got dtype {raw.dtype}")
    array = raw.astype(np.float64)
    if np.isnan(array).any():
        raise ValueError(f"{name} contains NaN")
    return array


def _as_float(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be a real number, got {value!r}")
    value = float(value)
    if math.isnan(value):
        raise ValueError(f"{name} is NaN")
    return value


# Bounds that keep every float32 kernel finite: squares and fourth powers of indices (Fresnel
# and admittance products) stay far below float32's 3e38, and a layer's phase in cycles
# (n d / lambda, at most 1e8) stays finite. They do not promise a resolved phase at their
# corners: a 1 mm layer at 1 nm is incoherent anyway, and visible-range optics needs n < 10,
# k < 15 (metals) and layers far thinner than a millimetre; k up to 1e4 models a perfect
# conductor (R = 1 - 4e-8 against air).
MAX_INDEX = 100.0
MAX_EXTINCTION = 1e4
MAX_THICKNESS_NM = 1e6
WAVELENGTH_RANGE_NM = (1.0, 1e6)


def check_index(name: str, value) -> float:
    """A real refractive index in (0, :data:`MAX_INDEX`]."""
    value = _as_float(name, value)
    if not (0.0 < value <= MAX_INDEX):
        raise ValueError(f"{name} must be a refractive index in (0, {MAX_INDEX:g}], got {value}")
    return value


def check_extinction(name: str, value) -> float:
    """An extinction coefficient (imaginary part of an index) in [0, :data:`MAX_EXTINCTION`]."""
    value = _as_float(name, value)
    if not (0.0 <= value <= MAX_EXTINCTION):
        raise ValueError(f"{name} must be an extinction coefficient in [0, {MAX_EXTINCTION:g}], "
                         f"got {value}")
    return value


def check_thickness(name: str, value) -> float:
    """A layer thickness in nm, in [0, :data:`MAX_THICKNESS_NM`]."""
    value = _as_float(name, value)
    if not (0.0 <= value <= MAX_THICKNESS_NM):
        raise ValueError(f"{name} must be a thickness in [0, {MAX_THICKNESS_NM:g}] nm, "
                         f"got {value}")
    return value


MAX_PERIODS = 2**31 - 1


def check_count(name: str, value) -> int:
    """A number of periods: an integer in [1, 2**31 - 1] (integral floats are accepted)."""
    if isinstance(value, bool):
        raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
    if isinstance(value, numbers.Integral):
        count = int(value)
    elif isinstance(value, numbers.Real) and float(value).is_integer():
        count = int(value)
    else:
        raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
    if not 1 <= count <= MAX_PERIODS:
        raise ValueError(f"{name} must be an integer in [1, {MAX_PERIODS}], got {count}")
    return count


def check_real(name: str, value, low: float, high: float) -> float:
    """``value`` as a float if it is a real number (not a bool) in [low, high]."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not (
            low <= value <= high):  # NaN fails
        raise ValueError(f"{name} must be a real number in [{low:g}, {high:g}], got {value!r}")
    return float(value)


def check_wavelength(value, name: str = "wavelength_nm") -> np.ndarray:
    """Wavelengths in nm, in :data:`WAVELENGTH_RANGE_NM`."""
    array = _as_float_array(name, value)
    low, high = WAVELENGTH_RANGE_NM
    if not np.all((array >= low) & (array <= high)):
        raise ValueError(f"{name} must be in [{low:g}, {high:g}] nm")
    return array


def check_angle(value, name: str = "theta") -> np.ndarray:
    """Angles of incidence in radians, in [0, pi/2]."""
    array = _as_float_array(name, value)
    if not np.all((array >= 0.0) & (array <= np.pi / 2)):
        raise ValueError(f"{name} must be in [0, pi/2] radians")
    return array


# Unit vectors rounded to float32 and back are off by ~1e-7; anything further is a caller's bug.
UNIT_TOLERANCE = 1e-5


def check_directions(value, name: str, upper: bool = False) -> np.ndarray:
    """Unit vectors with a trailing axis of 3 (norm within :data:`UNIT_TOLERANCE` of 1);
    with ``upper``, also z >= 0."""
    array = _as_float_array(name, value)
    if array.ndim == 0 or array.shape[-1] != 3:
        raise ValueError(f"{name} must have a trailing axis of length 3, got shape {array.shape}")
    if not np.all(np.abs(np.linalg.norm(array, axis=-1) - 1.0) <= UNIT_TOLERANCE):
        raise ValueError(f"{name} must hold unit vectors (norm within {UNIT_TOLERANCE} of 1)")
    if upper and not np.all(array[..., 2] >= 0.0):
        raise ValueError(f"{name} must lie in the upper hemisphere: {name}[..., 2] in [0, 1]")
    return array


def check_broadcast(**shapes: tuple[int, ...]) -> tuple[int, ...]:
    """The broadcast of the named shapes, or a ValueError naming them with their shapes."""
    try:
        return np.broadcast_shapes(*shapes.values())
    except ValueError:
        named = " and ".join(f"{name} {shape}" for name, shape in shapes.items())
        raise ValueError(f"{named} do not broadcast against each other") from None


def check_polarization(value) -> str:
    if value not in POLARIZATIONS:
        raise ValueError(f"polarization must be one of {POLARIZATIONS}, got {value!r}")
    return value


def check_backend(value) -> str:
    if value not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {value!r}")
    return value
