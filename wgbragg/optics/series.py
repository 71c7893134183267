"""``sin(z)/z`` and ``sinh(z)/z`` without the 0/0 at ``z = 0`` (real or complex ``z``).

They let layer formulas divide ``sin(delta)`` by a normal component ``q`` that may vanish (at a
critical angle), since ``sin(k q d) / q = k d sinc(k q d)``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["sinc", "sinhc"]

# Below this |z| the two-term series is exact to float64 (next term z^4 / 120 < 1e-18).
_SERIES_BELOW = 1e-4


def sinc(z):
    """``sin(z) / z``, 1 at 0."""
    small = np.abs(z) < _SERIES_BELOW
    safe = np.where(small, 1.0, z)
    return np.where(small, 1.0 - z * z / 6.0, np.sin(safe) / safe)


def sinhc(z):
    """``sinh(z) / z``, 1 at 0."""
    small = np.abs(z) < _SERIES_BELOW
    safe = np.where(small, 1.0, z)
    return np.where(small, 1.0 + z * z / 6.0, np.sinh(safe) / safe)
