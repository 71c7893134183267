"""Bundled metal indices and dispersive bases of ThinFilm: values against the published rows,
interpolation, range checks and the ValueErrors of the API."""

import numpy as np
import pytest

from wgbragg import ThinFilm
from wgbragg.optics.metals import METALS, SpectralIndex, metal

# Rows copied from the database files, checked here at the rows themselves (interpolation is
# exact there): (wavelength nm, n, k).
PUBLISHED = {
    "Ag": [(450.9, 0.04, 2.657), (659.5, 0.05, 4.483)],
    "Al": [(516.6, 0.8734, 6.2418), (815.69, 2.7668, 8.2573)],
    "Au": [(548.6, 0.43, 2.455), (495.9, 1.04, 1.833)],
    "Cu": [(616.8, 0.30, 3.205), (354.2, 1.37, 1.916)],
}


@pytest.mark.parametrize("name", sorted(METALS))
def test_published_rows(name):
    for wavelength, n, k in PUBLISHED[name]:
        assert complex(metal(name)(wavelength)) == pytest.approx(complex(n, k), abs=1e-12)


@pytest.mark.parametrize("name", sorted(METALS))
def test_tables_cover_the_visible_range(name):
    low, high = metal(name).range_nm
    assert low <= 360.0 and high >= 830.0
    index = metal(name)(np.linspace(360.0, 830.0, 471))
    assert index.shape == (471,) and np.all(index.real > 0) and np.all(index.imag > 0)


def test_linear_interpolation_between_rows():
    table = metal("Au")
    midpoint = 0.5 * (table.wavelength_nm[10] + table.wavelength_nm[11])
    want = 0.5 * (complex(table.n[10], table.k[10]) + complex(table.n[11], table.k[11]))
    assert complex(table(midpoint)) == pytest.approx(want, abs=1e-12)


def test_out_of_range_and_bad_tables():
    with pytest.raises(ValueError, match="tabulated range"):
        metal("Cu")(300.0)
    with pytest.raises(ValueError, match=r"\bwavelength_nm\b"):
        metal("Cu")(np.nan)
    with pytest.raises(ValueError, match=r"\bbase\b"):
        metal("Fe")
    for name in (["Au"], {"Au": 1}, np.array("Au"), None):  # unhashable or not one string
        with pytest.raises(ValueError, match=r"\bbase\b"):
            metal(name)
    for args in (([400.0], [1.0], [1.0]), ([400.0, 300.0], [1, 1], [0, 0]),
                 ([400.0, 500.0], [1.0, -1.0], [0, 0]), ([400.0, 500.0], [1, 1], [0, -1]),
                 ([400.0, 500.0], [1, 1, 1], [0, 0])):
        with pytest.raises(ValueError):
            SpectralIndex("x", *args)
    # The float32-safe bounds of a constant base hold for a tabulated one too.
    for n, k in (([1.0, 1e20], [0.0, 0.0]), ([1.0, 1.0], [0.0, 1e20]), ([1.0, np.nan], [0, 0]),
                 ([1.0, 0.005], [0.0, 0.0])):
        with pytest.raises(ValueError, match=r"n must be in \[0.01, 100\] and k in \[0, 10000\]"):
            SpectralIndex("x", [400.0, 500.0], n, k)


def test_thin_film_base_api():
    film = ThinFilm(1.5, 200.0, base="Au")
    assert film.dispersive and film.base is METALS["Au"]
    assert not ThinFilm(1.5, 200.0).dispersive
    np.testing.assert_array_equal(film.base_index([500.0, 600.0]), METALS["Au"]([500.0, 600.0]))
    assert ThinFilm(1.5, 200.0, n_base=0.3, k_base=2.0).base_index(500.0) == 0.3 + 2.0j
    with pytest.raises(ValueError, match=r"\bbase\b"):
        ThinFilm(1.5, 200.0, base="Unobtainium")
    with pytest.raises(ValueError, match=r"\bbase\b"):
        ThinFilm(1.5, 200.0, base=1.5)
    with pytest.raises(ValueError, match=r"\bn_base\b"):
        ThinFilm(1.5, 200.0, n_base=1.2, base="Cu")
    with pytest.raises(ValueError, match="tabulated range"):
        film.reflectance(300.0, 0.0)
