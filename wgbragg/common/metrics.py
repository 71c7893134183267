"""Image error metrics for convergence and accuracy measurements.

References
----------
Fourneau, Pacanowski, Barla, "Interactive Exploration of Vivid Structural Colors with Bragg
Mirrors", Computer Graphics Forum 43(2), 2024: Table 2 reports SMAPE with the mean
``(|a| + |b|) / 2`` as denominator, twice the values here.
"""

from __future__ import annotations

import numpy as np

__all__ = ["smape"]


def smape(estimate, reference) -> float:
    """Symmetric mean absolute percentage error, ``mean |a - b| / (|a| + |b|)``.

    The mean runs over all entries (pixels and channels) where either value is nonzero; the
    result is in [0, 1]: without the factor 2 of the Bragg paper's form (its Table 2 values
    are twice these; ratios of SMAPE, and so of efficiency, are the same). Absolute values
    keep it meaningful for linear sRGB with slightly negative out-of-gamut channels.

    Parameters
    ----------
    estimate, reference : array_like
        Same shape, finite.

    Returns
    -------
    float
        0 for identical inputs (also when both are all zero).

    Raises
    ------
    ValueError
        If the shapes differ or a value is not finite.
    """
    a = np.asarray(estimate, np.float64)
    b = np.asarray(reference, np.float64)
    if a.shape != b.shape:
        raise ValueError(f"estimate and reference must have the same shape, got {a.shape} "
                         f"and {b.shape}")
    if not (np.isfinite(a).all() and np.isfinite(b).all()):
        raise ValueError("estimate and reference must be finite")
    total = np.abs(a) + np.abs(b)
    keep = total > 0.0
    if not keep.any():
        return 0.0
    return float(np.mean(np.abs(a - b)[keep] / total[keep]))
