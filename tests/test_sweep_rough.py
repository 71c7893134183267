"""Sweeps over rough structures (wgbragg.sweep): a LayeredBragg of several RoughBraggLayer with
per-layer coordinates (``layers[i].NAME``) and a RoughThinFilm; their colours (xyz, rgb, lab)
are those of the library's directional albedo, checked against its own calls."""

from __future__ import annotations

from pathlib import Path

import colour
import numpy as np
import pytest
from PIL import Image

from wgbragg import BraggMirror, LayeredBragg, RoughBraggLayer, RoughThinFilm, ThinFilm
from wgbragg.app import cli
from wgbragg.app.atlas import spectrum_plot
from wgbragg.colour.colorimetry import linear_srgb_to_xyz
from wgbragg.sweep import load_sweep, open_atlas, parse_sweep, sweep_dataset
from wgbragg.sweep.store import init_store, store_chunk

pytestmark = pytest.mark.gpu

ROOT = Path(__file__).resolve().parents[1]
WHITE = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]

STACK = """
material = "layered-bragg"

[fixed]
n1 = 1.0
N = 8
delta = 0.5
base_albedo = 0.1

[[fixed.layers]]
n2 = 1.5
alpha = 0.2

[[fixed.layers]]
n2 = 1.6
alpha = 0.3
period_nm = 300.0

[coords]
"layers[0].period_nm" = [200.0, 260.0]
theta_deg = [0.0, 40.0]

[[quantities]]
kind = "rgb"
options = { samples = 64 }

[[quantities]]
kind = "lab"
options = { samples = 64 }

[[quantities]]
kind = "albedo"
options = { samples = 64 }
"""


def test_a_stack_of_two_layers_is_the_library_albedo_colour(tmp_path):
    path = tmp_path / "stack.toml"
    path.write_text(STACK, encoding="utf-8")
    sweep = load_sweep(path)
    assert sweep.structure_dims == ("layers[0].period_nm",)
    # The same sweep with flat quoted keys instead of [[fixed.layers]].
    flat = dict(sweep.fixed)
    document = {"material": "layered-bragg", "fixed": flat,
                "coords": {"layers[0].period_nm": [200.0, 260.0], "theta_deg": [0.0, 40.0]},
                "quantities": [q.as_dict() for q in sweep.quantities]}
    assert parse_sweep(document).to_json() == sweep.to_json()
    store = tmp_path / "stack.zarr"
    init_store(sweep, store)
    for q in sweep.quantities:
        for index in sweep.blocks(q):
            store_chunk(sweep, store, q.name, index)
    data = open_atlas(store).compute()
    assert data["rgb"].dims == ("layers[0].period_nm", "theta_deg", "channel")
    assert data["layers[0].period_nm"].attrs["units"] == "nm"
    assert data["lab"].attrs["channels"] == ["L*", "a*", "b*"]
    assert "LayeredBragg.albedo" in data["rgb"].attrs["long_name"]
    # The second structure: top layer of period 260 nm, lower layer 300 nm, on the GPU.
    stack = LayeredBragg([RoughBraggLayer(BraggMirror(1.0, 1.5, 130.0, 130.0, 8), 0.2),
                          RoughBraggLayer(BraggMirror(1.0, 1.6, 150.0, 150.0, 8), 0.3)],
                         base_albedo=0.1)
    rgb = stack.albedo(np.radians([0.0, 40.0]), None, 64, 0, backend="gpu")
    np.testing.assert_array_equal(data["rgb"].values[1], rgb.astype(np.float32))
    np.testing.assert_array_equal(data["albedo"].values[1], rgb.astype(np.float32))
    lab = colour.XYZ_to_Lab(linear_srgb_to_xyz(rgb), WHITE)
    np.testing.assert_allclose(data["lab"].values[1], lab, rtol=1e-6, atol=1e-4)
    # The top layer alone differs: the lower layer is really there.
    assert not np.allclose(data["rgb"].values[1], LayeredBragg(
        [stack.layers[0]], base_albedo=0.1).albedo(np.radians([0.0, 40.0]), None, 64, 0,
                                                   backend="gpu"), atol=1e-3)


def test_a_rough_thin_film_is_the_library_albedo_colour():
    sweep = parse_sweep({
        "material": "rough-thin-film", "fixed": {"n_film": 1.33, "base": "Au"},
        "coords": {"thickness_nm": [300.0, 400.0], "alpha": [0.1, 0.3],
                   "theta_deg": [0.0, 60.0]},
        "quantities": [{"kind": "xyz", "options": {"order": 2, "nodes": 12}},
                       {"kind": "rgb", "method": "reference", "options": {"nodes": 6}}]})
    assert sweep.quantities[0].options == {"order": 2, "nodes": 12}
    data = sweep_dataset(sweep).compute(scheduler="synchronous")
    assert data["xyz"].dims == ("thickness_nm", "alpha", "theta_deg", "channel")
    assert data["xyz"].attrs["colour_method"] == "fourier-table"
    theta = np.radians([0.0, 60.0])
    surface = RoughThinFilm(ThinFilm(1.33, 400.0, base="Au"), alpha=0.3)
    xyz = linear_srgb_to_xyz(surface.albedo(theta, None, "fourier-table", order=2, nodes=12))
    np.testing.assert_allclose(data["xyz"].values[1, 1], xyz, rtol=1e-6, atol=1e-7)
    rgb = surface.albedo(theta, None, "reference", nodes=6)
    np.testing.assert_array_equal(data["rgb"].values[1, 1], rgb.astype(np.float32))


FIXED = {"n1": 1.0, "N": 8, "delta": 0.5, "n2": 1.5, "alpha": 0.2}


@pytest.mark.parametrize(("fixed", "coords", "message"), [
    ({**FIXED, "layers[16].n2": 1.5}, {}, r"at most 16 layers"),
    ({**FIXED, "layers[0].hue": 1.0}, {}, r"fixed.layers\[0\].hue: not a parameter"),
    ({**FIXED, "layers[01].n2": 1.5}, {}, r"not a parameter"),
    ({**FIXED, "layers": {"n2": 1.5}}, {}, "fixed.layers must be an array of tables"),
    ({**FIXED, "layers": [{"n2": 1.5}], "layers[0].n2": 1.4}, {}, "given twice"),
    ({**FIXED, "layers[1].d1_nm": 100.0}, {}, r"layers\[1\]: a Bragg mirror takes"),
    ({**FIXED, "layers[1].n1": 1.2}, {}, "share n1"),
    ({**FIXED, "layers[1].delta": 1.5}, {}, r"layers\[1\].delta must lie in \[0, 1\]"),
    ({k: v for k, v in FIXED.items() if k != "alpha"}, {"layers[0].alpha": [0.1, 0.2]},
     r"layers\[1\]: layered-bragg needs alpha"),
])
def test_bad_layer_keys_are_refused_naming_the_key(fixed, coords, message):
    document = {"material": "layered-bragg", "fixed": {"period_nm": 250.0, **fixed},
                "coords": {"theta_deg": [0.0, 30.0], **coords},
                "quantities": [{"kind": "rgb"}]}
    if "layers[1].d1_nm" in fixed or "layers[1].n1" in fixed or "layers[1].delta" in fixed:
        document["fixed"].setdefault("layers[1].n2", 1.6)
    if coords:
        document["fixed"]["layers[1].n2"] = 1.6
    with pytest.raises(ValueError, match=message):
        parse_sweep(document)


def test_layers_and_rough_films_are_refused_where_they_do_not_apply():
    bragg = {"material": "bragg-mirror", "fixed": {"n1": 1.0, "n2": 1.5, "N": 8,
                                                    "delta": 0.5, "period_nm": 200.0},
             "quantities": [{"kind": "rgb"}]}
    with pytest.raises(ValueError, match=r"layers\[0\].n2: not a parameter of bragg-mirror"):
        parse_sweep({**bragg, "coords": {"layers[0].n2": [1.4, 1.5]}})
    with pytest.raises(ValueError, match="only a layered-bragg has layers"):
        parse_sweep({**bragg, "fixed": {**bragg["fixed"], "layers": [{}]}})
    film = {"material": "rough-thin-film", "fixed": {"n_film": 1.33, "thickness_nm": 300.0}}
    with pytest.raises(ValueError, match="rough-thin-film needs alpha"):
        parse_sweep({**film, "quantities": [{"kind": "rgb"}]})
    film["fixed"]["alpha"] = 0.2
    kinds = r"\('albedo', 'xyz', 'rgb', 'lab', 'albedo_spectrum'\)"
    with pytest.raises(ValueError, match=f"kind must be one of {kinds}"):
        parse_sweep({**film, "quantities": [{"kind": "reflectance"}]})
    with pytest.raises(ValueError, match="takes order, nodes"):
        parse_sweep({**film, "quantities": [{"kind": "rgb", "options": {"samples": 4}}]})
    with pytest.raises(ValueError, match="method must be one of"):
        parse_sweep({**film, "quantities": [{"kind": "rgb", "method": "averaged"}]})


def test_the_shipped_stack_example_parses():
    sweep = load_sweep(ROOT / "examples" / "sweeps" / "layered_stack.toml")
    assert sweep.structure_dims == ("layers[1].period_nm",)
    stack = sweep.structure({"layers[1].period_nm": 250.0})
    assert len(stack.layers) == 2 and stack.layers[1].mirror.d1 == pytest.approx(125.0)
    assert stack.layers[0].mirror.d1 == pytest.approx(90.0) and stack.layers[1].alpha == 0.3


def test_atlas_draws_spectra_as_a_map_and_as_lines(tmp_path, capsys):
    sweep = parse_sweep({
        "material": "bragg-mirror", "backend": "numpy",
        "fixed": {"n1": 1.0, "n2": 1.5, "N": 6, "delta": 0.5},
        "coords": {"period_nm": [200.0, 250.0, 300.0], "theta_deg": [0.0, 30.0, 60.0],
                   "wavelength_nm": {"start": 400.0, "stop": 700.0, "num": 31}},
        "quantities": [{"kind": "reflectance"}, {"kind": "rgb", "method": "approx"}]})
    store = tmp_path / "spectra.zarr"
    init_store(sweep, store)
    for q in sweep.quantities:
        for index in sweep.blocks(q):
            store_chunk(sweep, store, q.name, index)
    atlas = open_atlas(store)
    reflectance = atlas["reflectance"].values
    plot = spectrum_plot(atlas, "wavelength", "theta", facet="period_nm")
    assert (plot.variable, plot.x, plot.y, plot.lines) == (
        "reflectance", "wavelength_nm", "theta_deg", None)
    assert plot.values.shape == (3, 3, 31)  # period panels, theta rows, wavelength columns
    np.testing.assert_array_equal(plot.values[1], reflectance[1])
    lines = spectrum_plot(atlas, "wavelength", lines="period", select={"theta": 29.0})
    assert lines.values.shape == (1, 3, 31) and lines.lines == "period_nm"
    np.testing.assert_array_equal(lines.values[0], reflectance[:, 1])
    with pytest.raises(ValueError, match=r"fix \['theta_deg'\] with --sel"):
        spectrum_plot(atlas, "wavelength", lines="period")
    with pytest.raises(ValueError, match="spectra \\['reflectance'\\], got 'rgb'"):
        spectrum_plot(atlas, "wavelength", "theta", variable="rgb", facet="period")
    for extra, name in ((["--y", "theta", "--facet", "period", "--var", "reflectance"], "map"),
                        (["--lines", "period", "--sel", "theta=30"], "lines")):
        out = tmp_path / f"{name}.png"
        assert cli.main(["atlas", str(store), "--x", "wavelength", *extra, "-o",
                         str(out)]) == 0
        with Image.open(out) as image:
            assert image.format == "PNG" and image.size[0] > 300 and image.size[1] > 200
    # With --y and no --var, the colour chart as before; a colour chart needs --y.
    assert cli.main(["atlas", str(store), "--x", "period", "--y", "theta", "--sel",
                     "wavelength=500", "-o", str(tmp_path / "chart.png")]) == 0
    assert cli.main(["atlas", str(store), "--x", "period", "--var", "rgb",
                     "-o", str(tmp_path / "bad.png")]) == 2
    assert "a colour chart needs --y" in capsys.readouterr().err


def test_the_spectral_albedo_of_rough_structures_is_the_librarys():
    wavelength = np.array([400.0, 550.0, 700.0])
    stack = parse_sweep({
        "material": "layered-bragg", "backend": "numpy",
        "fixed": {"n1": 1.0, "n2": 1.5, "N": 8, "delta": 0.5, "alpha": 0.2,
                  "period_nm": 250.0, "layers[1].alpha": 0.4},
        "coords": {"theta_deg": [0.0, 50.0], "wavelength_nm": wavelength.tolist()},
        "quantities": [{"kind": "albedo_spectrum", "options": {"samples": 32, "seed": 3}}]})
    data = sweep_dataset(stack).compute(scheduler="synchronous")["albedo_spectrum"]
    assert data.dims == ("theta_deg", "wavelength_nm") and "channels" not in data.attrs
    layer = RoughBraggLayer(BraggMirror(1.0, 1.5, 125.0, 125.0, 8), 0.2)
    expected = LayeredBragg([layer, RoughBraggLayer(layer.mirror, 0.4)]).albedo(
        np.radians([0.0, 50.0])[:, None], wavelength[None, :], 32, 3)
    np.testing.assert_array_equal(data.values, expected.astype(np.float32))
    film = parse_sweep({
        "material": "rough-thin-film", "backend": "numpy",
        "fixed": {"n_film": 1.33, "thickness_nm": 400.0, "alpha": 0.2, "theta_deg": 30.0},
        "coords": {"wavelength_nm": wavelength.tolist()},
        "quantities": [{"kind": "albedo_spectrum", "options": {"nodes": 8}}]})
    values = sweep_dataset(film).compute(scheduler="synchronous")["albedo_spectrum"].values
    expected = RoughThinFilm(ThinFilm(1.33, 400.0), 0.2).albedo(np.radians(30.0), wavelength,
                                                                nodes=8)
    np.testing.assert_array_equal(values, expected.astype(np.float32))
    with pytest.raises(ValueError, match=r"must lie in \[360, 830\] nm"):
        parse_sweep({**stack.as_dict(), "backend": "gpu", "chunks": {},
                     "coords": {"wavelength_nm": [300.0, 500.0]}})
    # The LUT method's table is as short on numpy, where the exact method is not.
    beyond = {**stack.as_dict(), "chunks": {}, "coords": {"wavelength_nm": [300.0, 900.0]}}
    assert parse_sweep(beyond).coords["wavelength_nm"].max() == 900.0
    lut = [{"kind": "albedo_spectrum", "method": "single-reflection-lut"}]
    with pytest.raises(ValueError, match=r"must lie in \[360, 830\] nm \(the layered model's"):
        parse_sweep({**beyond, "quantities": lut})
