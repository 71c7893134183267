"""Measured complex refractive indices ``n + i k`` of a few metals over the visible range.

Verbatim excerpts of the refractiveindex.info database (public domain, CC0) for Ag, Al, Au and
Cu, interpolated linearly in wavelength; a :class:`SpectralIndex` refuses to extrapolate. The
sources: ``docs/physics.md``, section 1.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from wgbragg.common.validation import MAX_EXTINCTION, MAX_INDEX, MIN_INDEX, check_wavelength

__all__ = ["METALS", "SpectralIndex", "metal"]

# Verbatim rows (wavelength in micrometres, n, k) of the database files named above.
_JOHNSON_CHRISTY_AG = """
0.3542 0.10 1.419
0.3679 0.07 1.657
0.3815 0.05 1.864
0.3974 0.05 2.070
0.4133 0.05 2.275
0.4305 0.04 2.462
0.4509 0.04 2.657
0.4714 0.05 2.869
0.4959 0.05 3.093
0.5209 0.05 3.324
0.5486 0.06 3.586
0.5821 0.05 3.858
0.6168 0.06 4.152
0.6595 0.05 4.483
0.7045 0.04 4.838
0.7560 0.03 5.242
0.8211 0.04 5.727
0.8920 0.04 6.312
"""

_JOHNSON_CHRISTY_AU = """
0.3542 1.50 1.866
0.3679 1.48 1.895
0.3815 1.46 1.933
0.3974 1.47 1.952
0.4133 1.46 1.958
0.4305 1.45 1.948
0.4509 1.38 1.914
0.4714 1.31 1.849
0.4959 1.04 1.833
0.5209 0.62 2.081
0.5486 0.43 2.455
0.5821 0.29 2.863
0.6168 0.21 3.272
0.6595 0.14 3.697
0.7045 0.13 4.103
0.7560 0.14 4.542
0.8211 0.16 5.083
0.8920 0.17 5.663
"""

_JOHNSON_CHRISTY_CU = """
0.3542 1.37 1.916
0.3679 1.36 1.975
0.3815 1.33 2.045
0.3974 1.32 2.116
0.4133 1.28 2.207
0.4305 1.25 2.305
0.4509 1.24 2.397
0.4714 1.25 2.483
0.4959 1.22 2.564
0.5209 1.18 2.608
0.5486 1.02 2.577
0.5821 0.70 2.704
0.6168 0.30 3.205
0.6595 0.22 3.747
0.7045 0.21 4.205
0.7560 0.24 4.665
0.8211 0.26 5.180
0.8920 0.30 5.768
"""

_RAKIC_AL = """
3.2628E-01 3.1474E-01 3.9165E+00
3.6466E-01 3.9877E-01 4.3957E+00
4.1328E-01 5.2135E-01 5.0008E+00
4.4280E-01 6.0790E-01 5.3676E+00
4.7687E-01 7.2780E-01 5.7781E+00
5.1660E-01 8.7340E-01 6.2418E+00
5.6357E-01 1.0728E+00 6.7839E+00
6.1993E-01 1.3660E+00 7.4052E+00
6.5225E-01 1.5724E+00 7.7354E+00
6.8881E-01 1.8301E+00 8.0601E+00
7.2932E-01 2.1606E+00 8.3565E+00
7.7491E-01 2.6154E+00 8.4914E+00
7.9478E-01 2.7675E+00 8.3866E+00
8.1569E-01 2.7668E+00 8.2573E+00
8.3774E-01 2.6945E+00 8.1878E+00
8.8561E-01 2.2802E+00 8.1134E+00
"""


@dataclass(frozen=True, eq=False)
class SpectralIndex:
    """A tabulated complex index ``n(lambda) + i k(lambda)``, linear between its rows.

    Parameters
    ----------
    name : str
        Short label, e.g. ``"Au"``.
    wavelength_nm, n, k : array_like
        Rows, wavelengths strictly increasing in nm; ``n`` in [0.01, 100], ``k >= 0``.
    source : str
        Citation of the data.

    Raises
    ------
    ValueError
        For fewer than two rows, rows of different lengths, wavelengths not increasing, or
        ``n <= 0``, ``k < 0``, NaN.
    """

    name: str
    wavelength_nm: np.ndarray = field(repr=False)
    n: np.ndarray = field(repr=False)
    k: np.ndarray = field(repr=False)
    source: str = ""

    def __post_init__(self):
        arrays = [np.array(value, dtype=np.float64).ravel()
                  for value in (self.wavelength_nm, self.n, self.k)]
        wavelength, n, k = arrays
        if not (wavelength.size == n.size == k.size >= 2):
            raise ValueError("wavelength_nm, n and k must have the same length >= 2")
        if not np.all(np.isfinite(wavelength)) or np.any(np.diff(wavelength) <= 0):
            raise ValueError("wavelength_nm must be finite and strictly increasing")
        if not (np.all((n >= MIN_INDEX) & (n <= MAX_INDEX))
                and np.all((k >= 0) & (k <= MAX_EXTINCTION))):
            raise ValueError(f"n must be in [{MIN_INDEX:g}, {MAX_INDEX:g}] and k in "
                             f"[0, {MAX_EXTINCTION:g}]")
        for name, array in zip(("wavelength_nm", "n", "k"), arrays, strict=True):
            array.setflags(write=False)
            object.__setattr__(self, name, array)

    @property
    def range_nm(self) -> tuple[float, float]:
        """First and last tabulated wavelengths, nm."""
        return float(self.wavelength_nm[0]), float(self.wavelength_nm[-1])

    def __call__(self, wavelength_nm) -> np.ndarray:
        """Complex index ``n + i k`` at ``wavelength_nm`` (nm, any shape).

        Raises
        ------
        ValueError
            For a wavelength outside :attr:`range_nm` (no extrapolation), NaN or <= 0.
        """
        wavelength = check_wavelength(wavelength_nm)
        low, high = self.range_nm
        if np.any((wavelength < low) | (wavelength > high)):
            raise ValueError(
                f"wavelength_nm must lie in the tabulated range {low:g}-{high:g} nm of "
                f"{self.name!r}"
            )
        n = np.interp(wavelength, self.wavelength_nm, self.n)
        k = np.interp(wavelength, self.wavelength_nm, self.k)
        return n + 1j * k


def _table(name: str, rows: str, source: str) -> SpectralIndex:
    values = np.array([line.split() for line in rows.strip().splitlines()], dtype=np.float64)
    return SpectralIndex(name, 1000.0 * values[:, 0], values[:, 1], values[:, 2], source)


_JC = "Johnson & Christy, Phys. Rev. B 6, 4370 (1972), via refractiveindex.info"
METALS: dict[str, SpectralIndex] = {
    "Ag": _table("Ag", _JOHNSON_CHRISTY_AG, _JC),
    "Al": _table("Al", _RAKIC_AL, "Rakic, Appl. Opt. 34, 4755 (1995), via refractiveindex.info"),
    "Au": _table("Au", _JOHNSON_CHRISTY_AU, _JC),
    "Cu": _table("Cu", _JOHNSON_CHRISTY_CU, _JC),
}
"""The bundled metals by name; each covers 360-830 nm."""


def metal(name: str) -> SpectralIndex:
    """The bundled :class:`SpectralIndex` of a metal.

    Parameters
    ----------
    name : {"Ag", "Al", "Au", "Cu"}

    Raises
    ------
    ValueError
        For an unknown name.

    Examples
    --------
    >>> index = metal("Au")(550.0)
    >>> round(float(index.real), 3), round(float(index.imag), 3)
    (0.424, 2.472)
    """
    if not isinstance(name, str) or name not in METALS:
        raise ValueError(f"base must be one of {tuple(METALS)} or a SpectralIndex, got {name!r}")
    return METALS[name]
