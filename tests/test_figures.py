"""``tools/figures.py`` in its quick mode: both PNGs written, valid, not blank, atomically.

numpy only (no GPU). What the figures show is checked by eye; here only that they exist, are
real images of a sensible size with content, and that the piecewise-constant spectrum drawn in
Fig. 3 is the one the library integrates.
"""

from __future__ import annotations

import contextlib
import io

import numpy as np
import pytest
from conftest import load_tool
from PIL import Image

NAMES = ("fig3_spectrum.png", "fig4_gradients.png")


@pytest.fixture(scope="module")
def figures():
    with load_tool("figures") as module:
        yield module


@pytest.fixture(scope="module")
def quick_run(figures, tmp_path_factory):
    """One quick run into an empty folder: (folder, printed lines)."""
    out = tmp_path_factory.mktemp("figures")
    with contextlib.redirect_stdout(io.StringIO()) as capture:
        status = figures.main(["--quick", "--no-progress", "--out", str(out)])
    assert status == 0
    return out, capture.getvalue().splitlines()


def test_paths_printed(quick_run):
    out, printed = quick_run
    assert printed == [str(out / name) for name in NAMES]


@pytest.mark.parametrize("name", NAMES)
def test_png_valid_and_not_blank(quick_run, name):
    out, _ = quick_run
    path = out / name
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with Image.open(path) as image:
        image.verify()  # structure and CRCs
    with Image.open(path) as image:
        width, height = image.size
        pixels = np.asarray(image.convert("RGB"), dtype=np.float64)
    assert 200 <= width <= 4000 and 200 <= height <= 4000, (width, height)
    # A white canvas with axes only would have a tiny spread; plots and colour strips do not.
    assert pixels.std() > 20.0, pixels.std()
    # Not a single-hue image: the curves are blue/red/green, the strips coloured.
    assert np.abs(pixels[..., 0] - pixels[..., 2]).max() > 100


def test_no_temporary_files_left(quick_run):
    out, _ = quick_run
    assert sorted(p.name for p in out.iterdir()) == sorted(NAMES)


def test_piecewise_constant_matches_library(figures):
    """Integrating the drawn step spectra (s and p) against the CMFs gives the library's
    ``approx`` colour: the figure shows the boxes the library integrates."""
    from wgbragg.colour import colorimetry
    from wgbragg.colour.landmark_methods import approx_xyz
    from wgbragg.optics.landmarks import VISIBLE_OMEGA

    mirror, theta = figures.FIG3_MIRROR, 0.3
    omega = np.linspace(*VISIBLE_OMEGA, 200_001)
    wavelength = 2.0 * np.pi / omega[::-1]
    density = colorimetry.xyz_density(wavelength)
    xyz = np.zeros(3)
    for polarization in ("s", "p"):
        steps = figures.piecewise_constant_spectrum(mirror, theta, polarization, omega)
        assert np.all(np.isfinite(steps)) and np.all((steps >= 0) & (steps <= 1))
        xyz += 0.5 * np.trapezoid(steps[::-1, None] * density, wavelength, axis=0)
    np.testing.assert_allclose(xyz, approx_xyz(mirror, theta), atol=2e-4)


def test_encode_srgb(figures):
    encoded = figures.encode_srgb([[-0.5, 0.0, 0.0031308], [0.5, 1.0, 2.0]])
    np.testing.assert_allclose(encoded, [[0.0, 0.0, 0.04045], [0.7353569830524495, 1.0, 1.0]],
                               atol=1e-6)
