"""Colour spaces of the output: linear sRGB to XYZ and ACEScg (against colour-science), the EXR
header that names the space (``wgbragg render --colour-space``), and the display transform's
gamut mapping of colours outside sRGB (``docs/physics.md``, "Negative values")."""

from __future__ import annotations

import colour
import numpy as np
import OpenEXR
import pytest

from wgbragg.app import cli
from wgbragg.colour import colorimetry
from wgbragg.common.exr import read_exr, write_exr
from wgbragg.render.display import (
    LUMINANCE_WEIGHTS,
    decode_srgb,
    display_transform,
    encode_srgb,
    gamut_map,
)

# A saturated green and a pale orange, linear sRGB.
COLOURS = np.array([[0.05, 0.6, 0.1], [0.8, 0.45, 0.2]])


def _monochromatic_xyz(step_nm: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """Wavelengths 380-780 nm and the XYZ of light at each alone (the spectral locus)."""
    cmfs = colour.MSDS_CMFS[colorimetry.CMFS_NAME]
    wavelengths = np.arange(380, 781, step_nm)
    return wavelengths, np.array([cmfs[w] for w in wavelengths])


def _hsv_hue(rgb: np.ndarray) -> np.ndarray:
    """HSV hue in degrees of linear values: unchanged by adding grey and scaling."""
    r, g, b = np.moveaxis(np.asarray(rgb, np.float64), -1, 0)
    return np.degrees(np.arctan2(np.sqrt(3.0) * (g - b), 2.0 * r - g - b)) % 360.0


def _hue_distance(a, b):
    return np.abs((np.asarray(a) - b + 180.0) % 360.0 - 180.0)


def _decode(pixels: np.ndarray) -> np.ndarray:
    """8-bit sRGB back to linear."""
    v = pixels / 255.0
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


# ---------------------------------------------------------------------------- conversions


def test_acescg_is_colour_sciences_rgb_to_rgb():
    expected = colour.RGB_to_RGB(COLOURS, "sRGB", "ACEScg")  # linear, CAT02 by default
    np.testing.assert_allclose(colorimetry.linear_srgb_to(COLOURS, "acescg"), expected,
                               rtol=1e-12, atol=1e-14)
    # D65 white goes to the ACES white: (1, 1, 1) in ACEScg.
    np.testing.assert_allclose(colorimetry.linear_srgb_to([1.0, 1.0, 1.0], "acescg"),
                               [1.0, 1.0, 1.0], atol=1e-4)


def test_xyz_inverts_the_renderers_matrix():
    xyz = colorimetry.linear_srgb_to(COLOURS, "xyz")
    np.testing.assert_allclose(colorimetry.xyz_to_linear_srgb(xyz), COLOURS, atol=1e-14)
    # colour-science's sRGB -> XYZ matrix is the standard's rounded one: equal to 1e-4.
    np.testing.assert_allclose(xyz, colour.RGB_to_XYZ(COLOURS, "sRGB"), atol=1e-4)
    np.testing.assert_array_equal(colorimetry.linear_srgb_to(COLOURS, "srgb"), COLOURS)


def test_chromaticities_name_the_primaries_and_white():
    aces = colour.RGB_COLOURSPACES["ACEScg"]
    np.testing.assert_allclose(colorimetry.colour_space_chromaticities("acescg"),
                               [*aces.primaries.ravel(), *aces.whitepoint])
    assert colorimetry.colour_space_chromaticities("srgb") == pytest.approx(
        (0.64, 0.33, 0.30, 0.60, 0.15, 0.06, 0.3127, 0.3290))
    assert colorimetry.colour_space_chromaticities("xyz") == pytest.approx(
        (1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1 / 3, 1 / 3))
    with pytest.raises(ValueError, match=r"space must be one of \('srgb', 'xyz', 'acescg'\)"):
        colorimetry.linear_srgb_to(COLOURS, "rec2020")


def test_spectral_colours_are_negative_in_srgb_not_in_xyz():
    """What docs/physics.md says: every monochromatic light lies outside the sRGB gamut, none
    outside XYZ; ACEScg holds the sRGB gamut, and of the spectral colours only those of about
    531-630 nm."""
    wavelengths, xyz = _monochromatic_xyz()
    srgb = colorimetry.xyz_to_linear_srgb(xyz)
    assert (srgb < 0.0).any(axis=1).all()
    assert (colorimetry.linear_srgb_to(srgb, "xyz") >= -1e-12).all()
    acescg = colorimetry.linear_srgb_to(srgb, "acescg")
    inside = (acescg >= 0.0).all(axis=1)
    assert inside[(wavelengths >= 535) & (wavelengths <= 625)].all()
    assert not inside[(wavelengths <= 525) | (wavelengths >= 635)].any()
    corners = np.array([[r, g, b] for r in (0, 1) for g in (0, 1) for b in (0, 1)], float)
    assert (colorimetry.linear_srgb_to(corners, "acescg") >= 0.0).all()


# ---------------------------------------------------------------------------- gamut mapping


def test_srgb_transfer_function_is_colour_sciences():
    values = np.linspace(0.0, 1.0, 1998).reshape(-1, 3, 3)  # any shape
    np.testing.assert_allclose(encode_srgb(values), colour.cctf_encoding(values, "sRGB"),
                               atol=1e-15)
    np.testing.assert_allclose(decode_srgb(values), colour.cctf_decoding(values, "sRGB"),
                               atol=1e-15)
    np.testing.assert_allclose(decode_srgb(encode_srgb(values)), values, atol=1e-15)


def test_in_gamut_images_display_as_a_plain_clip_would():
    """The old transform (clip negatives, tone map, clip) bit for bit where nothing is out of
    gamut: every channel >= 0 and <= 1 after tone mapping."""
    rng = np.random.default_rng(5)
    image = rng.uniform(0.0, 1.0, (16, 16, 3)) * rng.uniform(0.0, 3.0, (16, 16, 1))
    scaled = image * 2.0**0.5
    mapped = scaled / (1.0 + scaled @ np.array([0.2126, 0.7152, 0.0722]))[..., None]
    keep = (mapped <= 1.0).all(axis=-1)
    assert keep.mean() > 0.5
    mapped = mapped.clip(0.0, 1.0)
    encoded = np.where(mapped <= 0.0031308, 12.92 * mapped,
                       1.055 * np.power(mapped, 1.0 / 2.4) - 0.055)
    old = np.round(encoded * 255.0).astype(np.uint8)
    np.testing.assert_array_equal(display_transform(image, 0.5)[keep], old[keep])


def test_negative_channels_keep_their_hue_and_luminance():
    out_of_gamut = np.array([[0.5, 0.3, -0.1], [-0.05, 0.4, 0.3], [0.2, -0.02, 0.6],
                             [1.6, 0.2, 0.05], [-0.3, 0.9, -0.1]])
    mapped = gamut_map(out_of_gamut)
    assert ((mapped >= 0.0) & (mapped <= 1.0)).all()
    np.testing.assert_allclose(mapped @ LUMINANCE_WEIGHTS, out_of_gamut @ LUMINANCE_WEIGHTS,
                               atol=1e-12)
    np.testing.assert_allclose(_hue_distance(_hsv_hue(mapped), _hsv_hue(out_of_gamut)), 0.0,
                               atol=1e-9)
    # Each pixel keeps as much saturation as fits: one channel ends on the cube's face.
    assert np.isclose(np.minimum(mapped, 1.0 - mapped).min(axis=1), 0.0, atol=1e-12).all()
    inside = np.array([[0.2, 0.5, 0.9], [0.0, 0.0, 0.0], [1.0, 1.0, 1.0]])
    np.testing.assert_array_equal(gamut_map(inside), inside)
    np.testing.assert_array_equal(gamut_map(np.array([[-0.5, 0.1, 0.1], [9.0, 9.0, 0.0]])),
                                  [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]])


def test_the_png_keeps_the_hue_a_clip_would_shift():
    """A blue-green outside sRGB (red negative) and an orange highlight (red > 1 after the
    tone map): the 8-bit pixel's hue is the linear colour's within quantisation, where
    clipping each channel would shift it by over 10 degrees."""
    image = np.array([[[-0.3, 0.5, 0.2], [8.0, 3.0, 0.2]]])
    pixels = display_transform(image)
    hue = _hsv_hue(image)
    assert _hue_distance(_hsv_hue(_decode(pixels)), hue).max() < 2.0
    tone_mapped = image / (1.0 + image @ LUMINANCE_WEIGHTS)[..., None]
    assert _hue_distance(_hsv_hue(tone_mapped.clip(0.0, 1.0)), hue).max() > 10.0


# ---------------------------------------------------------------------------- EXR files


def test_exr_attributes_are_written_and_checked(tmp_path):
    path = tmp_path / "a.exr"
    chroma = colorimetry.colour_space_chromaticities("acescg")
    write_exr(path, np.ones((2, 3, 3)), attributes={"colorInteropID": "lin_ap1_scene",
                                                   "chromaticities": chroma, "spp": 7})
    with OpenEXR.File(str(path)) as exr:
        header = dict(exr.header())  # the binding empties it on close
    assert header["colorInteropID"] == "lin_ap1_scene" and header["spp"] == 7
    np.testing.assert_allclose(header["chromaticities"], chroma, rtol=1e-6)
    for attributes, message in (({"compression": "none"}, "set by write_exr"),
                                ({"": "x"}, "non-empty strings"),
                                ({"chromaticities": (0.3, 0.3)}, "8 finite numbers"),
                                ({"note": [1, 2]}, "a str, an int or a finite float"),
                                ({"gain": float("nan")}, "a str, an int or a finite float")):
        with pytest.raises(ValueError, match=message):
            write_exr(tmp_path / "b.exr", np.ones((2, 3, 3)), attributes=attributes)
    assert not (tmp_path / "b.exr").exists()


def test_the_cli_names_each_colour_space():
    assert tuple(cli.EXR_COLOUR_SPACES) == colorimetry.COLOUR_SPACES
    for space, interop in cli.EXR_COLOUR_SPACES.items():
        expected = OpenEXR.colorInteropIDToChromaticities(interop)
        if expected is not None:  # OpenEXR maps the RGB IDs, not XYZ's
            np.testing.assert_allclose(colorimetry.colour_space_chromaticities(space),
                                       expected, atol=1e-4)


def test_a_colour_space_without_an_exr_is_refused_before_the_render(tmp_path, capsys):
    argv = ["render", "--scene", "furnace", "--colour-space", "xyz", "-o",
            str(tmp_path / "a.png")]
    assert cli.main(argv) == 2
    assert "--colour-space applies to the EXR: give --exr FILE too" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


@pytest.mark.gpu
def test_render_writes_the_chosen_colour_space(tmp_path, capsys):
    """fig12 (Bragg layers) in spectral mode at 2 spp: the sRGB EXR holds negative values, the
    XYZ one of the same paths none, and each file names its space."""
    images, headers = {}, {}
    for space in cli.EXR_COLOUR_SPACES:
        exr = tmp_path / f"{space}.exr"
        argv = ["render", "--scene", "fig12", "--size", "24x24", "--spp", "2", "--mode",
                "spectral", "--no-progress", "-o", str(tmp_path / f"{space}.png"), "--exr",
                str(exr), "--colour-space", space]
        assert cli.main(argv) == 0, capsys.readouterr().err
        images[space] = read_exr(exr).astype(np.float64)
        with OpenEXR.File(str(exr)) as file:
            headers[space] = dict(file.header())
    srgb = images["srgb"]
    assert srgb.min() < -0.01
    peak = np.abs(srgb).max()
    for space in ("xyz", "acescg"):
        np.testing.assert_allclose(images[space], colorimetry.linear_srgb_to(srgb, space),
                                   atol=1e-6 * peak)
    assert images["xyz"].min() >= -1e-6 * peak
    for space, interop in cli.EXR_COLOUR_SPACES.items():
        assert headers[space]["colorInteropID"] == interop
        np.testing.assert_allclose(headers[space]["chromaticities"],
                                   colorimetry.colour_space_chromaticities(space), rtol=1e-6)
    # The PNG does not depend on the EXR's space.
    pngs = {space: (tmp_path / f"{space}.png").read_bytes() for space in images}
    assert pngs["srgb"] == pngs["xyz"] == pngs["acescg"]
