"""Input checks shared by the optics functions, on top of :mod:`wgbragg.common.validation`.

Ranges are the package's (:data:`~wgbragg.common.validation.MIN_INDEX` and friends).
"""

from __future__ import annotations

import numpy as np

from wgbragg.common.validation import (
    MAX_EXTINCTION,
    MAX_INDEX,
    MIN_INDEX,
    POLARIZATIONS,
    check_angle,
    check_wavelength,
)

__all__ = ["check_complex_index", "check_light"]


def check_complex_index(name: str, value) -> np.ndarray:
    """Indices ``n + i k`` (a number or an array) with ``n`` in [:data:`MIN_INDEX`,
    ``MAX_INDEX``] and ``k`` in [0, ``MAX_EXTINCTION``], as a complex128 array."""
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} must be a number n + i k or an array of them") from error
    if raw.dtype.kind not in "iufc":  # as common.validation: no strings ("1.5"), no booleans
        raise ValueError(f"{name} must be a number n + i k or an array of them, "
                         f"got dtype {raw.dtype}")
    index = raw.astype(np.complex128)
    n, k = index.real, index.imag
    good = (n >= MIN_INDEX) & (n <= MAX_INDEX) & (k >= 0.0) & (k <= MAX_EXTINCTION)  # NaN fails
    if not np.all(good):
        raise ValueError(f"{name} must be n + i k with n in [{MIN_INDEX:g}, "
                         f"{MAX_INDEX:g}] and k in [0, {MAX_EXTINCTION:g}], "
                         f"got {index[~good].flat[0]}")
    return index


def check_light(wavelength_nm, theta, polarization, polarizations=POLARIZATIONS):
    """Checked ``(wavelength, theta)`` arrays; ``polarization`` must be one of
    ``polarizations``."""
    wavelength, angle = check_wavelength(wavelength_nm), check_angle(theta)
    if not isinstance(polarization, str) or polarization not in polarizations:
        raise ValueError(f"polarization must be one of {polarizations}, got {polarization!r}")
    return wavelength, angle
