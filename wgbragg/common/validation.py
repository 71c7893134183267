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
    "MIN_INDEX",
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
    "check_integer",
    "check_material",
    "check_polarization",
    "check_real",
    "check_seed",
    "check_thickness",
    "check_wavelength",
]

POLARIZATIONS = ("s", "p", "unpolarized")
BACKENDS = ("numpy", "gpu")


def as_float_array(name: str, value, keep_float32: bool = False, copy: bool = True
                   ) -> np.ndarray:
    """``value`` as float64, or as it is if ``keep_float32`` and it is float32 already (for a
    float32 kernel's input: no copy there and back).

    ``copy=False`` also returns a float64 array as it is, not a copy: for callers that only
    read the result (it may be the caller's own array)."""
    return _extent(name, value, keep_float32, copy)[0]


def _extent(name: str, value, keep_float32: bool = False, copy: bool = True):
    """(:func:`as_float_array`, its least value, its greatest value); (array, None, None) for
    an empty one. One reduction each, no temporary of the array's size; a NaN anywhere makes
    both NaN, and is refused."""
    message = f"{name} must be a real number or array of real numbers"
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError) as error:
        raise ValueError(message) from error
    # Strings would convert ("500" -> 500.0) and booleans read as 0 and 1 (True -> 1 nm);
    # refuse them rather than guess, as scalars are refused.
    if raw.dtype.kind not in "iuf":
        raise ValueError(f"{message}, got dtype {raw.dtype}")
    if keep_float32 and raw.dtype == np.float32:
        array = raw
    else:
        array = raw.astype(np.float64) if copy else np.asarray(raw, np.float64)
    if not array.size:
        return array, None, None
    low, high = float(array.min()), float(array.max())
    if math.isnan(low) or math.isnan(high):
        raise ValueError(f"{name} contains NaN")
    return array, low, high


def as_float(name: str, value) -> float:
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
# The float32 kernels keep their float64 twins' accuracy down to n = 0.01 (largest |R - R64|
# 7e-5 over films and mirrors, grazing included); at 1e-3 a film's R is 2e-2 off, below 1e-6
# up to 1 off, and below 1e-20 the p admittances q / n^2 underflow to NaN. No medium comes
# near: silver's n is 0.03 at its lowest in the visible, the alkali metals' 0.04.
MIN_INDEX = 0.01
MAX_EXTINCTION = 1e4
MAX_THICKNESS_NM = 1e6
WAVELENGTH_RANGE_NM = (1.0, 1e6)


def check_index(name: str, value) -> float:
    """A real refractive index in [:data:`MIN_INDEX`, :data:`MAX_INDEX`]."""
    value = as_float(name, value)
    if not (MIN_INDEX <= value <= MAX_INDEX):
        raise ValueError(f"{name} must be a refractive index in [{MIN_INDEX:g}, {MAX_INDEX:g}], "
                         f"got {value}")
    return value


def check_extinction(name: str, value) -> float:
    """An extinction coefficient (imaginary part of an index) in [0, :data:`MAX_EXTINCTION`]."""
    value = as_float(name, value)
    if not (0.0 <= value <= MAX_EXTINCTION):
        raise ValueError(f"{name} must be an extinction coefficient in [0, {MAX_EXTINCTION:g}], "
                         f"got {value}")
    return value


def check_thickness(name: str, value) -> float:
    """A layer thickness in nm, in [0, :data:`MAX_THICKNESS_NM`]."""
    value = as_float(name, value)
    if not (0.0 <= value <= MAX_THICKNESS_NM):
        raise ValueError(f"{name} must be a thickness in [0, {MAX_THICKNESS_NM:g}] nm, "
                         f"got {value}")
    return value


MAX_PERIODS = 2**31 - 1


def check_integer(name: str, value, low: int, high: int | None = None) -> int:
    """``value`` as an int if it is an integer (Python or numpy, not a bool, not a float) in
    [low, high] (``high=None``: no upper bound)."""
    if (isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < low
            or (high is not None and value > high)):
        accepted = f">= {low}" if high is None else f"in [{low}, {high}]"
        raise ValueError(f"{name} must be an integer {accepted}, got {value!r}")
    return int(value)


def check_count(name: str, value, high: int = MAX_PERIODS) -> int:
    """A count: an integer in [1, ``high``] (integral floats are accepted); ``high`` defaults
    to a number of periods' 2**31 - 1."""
    if (isinstance(value, numbers.Real) and not isinstance(value, numbers.Integral)
            and float(value).is_integer()):
        value = int(value)
    return check_integer(name, value, 1, high)


def check_real(name: str, value, low: float, high: float) -> float:
    """``value`` as a float if it is a real number (not a bool) in [low, high]."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not (
            low <= value <= high):  # NaN fails
        raise ValueError(f"{name} must be a real number in [{low:g}, {high:g}], got {value!r}")
    return float(value)


def check_wavelength(value, name: str = "wavelength_nm", copy: bool = True) -> np.ndarray:
    """Wavelengths in nm, in :data:`WAVELENGTH_RANGE_NM`: a new float64 array, or with
    ``copy=False`` a float32 or float64 array as it is (for callers that only read it, such
    as a float32 kernel's: no copy of a large input)."""
    array, least, greatest = _extent(name, value, keep_float32=not copy, copy=copy)
    low, high = WAVELENGTH_RANGE_NM
    if least is not None and not (low <= least and greatest <= high):
        raise ValueError(f"{name} must be in [{low:g}, {high:g}] nm")
    return array


# pi/2 rounded to float32 (1.5707964) lies above pi/2: a float32 caller's pi/2 is accepted.
_HALF_PI_FLOAT32 = float(np.float32(np.pi / 2))


def check_angle(value, name: str = "theta", copy: bool = True) -> np.ndarray:
    """Angles of incidence in radians, in [0, pi/2]; float32's pi/2 is accepted and clipped to
    pi/2. A new float64 array; with ``copy=False`` a float32 or float64 array as it is where
    nothing needs clipping (for callers that only read it)."""
    array, least, greatest = _extent(name, value, keep_float32=not copy, copy=copy)
    if least is not None and not (0.0 <= least and greatest <= _HALF_PI_FLOAT32):
        raise ValueError(f"{name} must be in [0, pi/2] radians")
    if not copy:
        if least is None or greatest <= np.pi / 2:
            return array
        array = array.astype(np.float64)
    return np.minimum(array, np.pi / 2, out=array)  # array is a fresh copy


# Unit vectors rounded to float32 and back are off by ~1e-7; anything further is a caller's bug.
UNIT_TOLERANCE = 1e-5


def check_directions(value, name: str, upper: bool = False) -> np.ndarray:
    """Unit vectors with a trailing axis of 3 (norm within :data:`UNIT_TOLERANCE` of 1);
    with ``upper``, also z >= 0."""
    array = as_float_array(name, value)
    if array.ndim == 0 or array.shape[-1] != 3:
        raise ValueError(f"{name} must have a trailing axis of length 3, got shape {array.shape}")
    # |norm - 1| <= tol as (1 - tol)^2 <= norm^2 <= (1 + tol)^2: one pass for the squared
    # norms and two reductions, where numpy.linalg.norm took 24 ms per million vectors.
    if array.size:
        squares = np.einsum("...i,...i->...", array, array)
        low, high = (1.0 - UNIT_TOLERANCE) ** 2, (1.0 + UNIT_TOLERANCE) ** 2
        if not (low <= squares.min() and squares.max() <= high):
            raise ValueError(f"{name} must hold unit vectors (norm within {UNIT_TOLERANCE} of 1)")
    if upper and array.size and not array[..., 2].min() >= 0.0:
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
    # One string: an array would compare elementwise ("s" == np.array("s") passes).
    if not isinstance(value, str) or value not in POLARIZATIONS:
        raise ValueError(f"polarization must be one of {POLARIZATIONS}, got {value!r}")
    return value


def check_backend(value) -> str:
    if not isinstance(value, str) or value not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {value!r}")
    return value


def check_seed(value, name: str = "seed"):
    """A random seed: None, an integer >= 0, or a numpy.random Generator, BitGenerator or
    SeedSequence (returned as is)."""
    if value is None or isinstance(value, (np.random.Generator, np.random.BitGenerator,
                                           np.random.SeedSequence)):
        return value
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 0:
        raise ValueError(f"{name} must be None, an integer >= 0 or a numpy.random Generator, "
                         f"BitGenerator or SeedSequence, got {value!r}")
    return value


def check_material(material, name: str = "material") -> None:
    """An object with the ``reflectance`` method of :class:`~wgbragg.BraggMirror` and
    :class:`~wgbragg.ThinFilm`."""
    if not callable(getattr(material, "reflectance", None)):
        raise ValueError(
            f"{name} must have a reflectance(wavelength_nm, theta, polarization, backend) "
            f"method (a BraggMirror or ThinFilm), got {type(material).__name__}"
        )
