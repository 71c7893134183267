"""``wgbragg fit`` and ``wgbragg design``: tables, a report PNG, a scene TOML that the scene
loader reads back as the structure, and one-line errors that write nothing."""

from __future__ import annotations

import re

import numpy as np
import pytest

from wgbragg import BraggMirror, load_scene
from wgbragg.app import cli
from wgbragg.colour.colorimetry import delta_e_2000
from wgbragg.design.files import read_spectrum_csv

pytestmark = pytest.mark.gpu

TRUTH = BraggMirror(1.0, 1.5, 120.0, 90.0, 7)


def _csv(path, header="wavelength_nm,0,30,60", rows=None):
    wavelength = np.arange(400.0, 751.0, 10.0)
    reflectance = TRUTH.reflectance(wavelength[:, None], np.radians([0.0, 30.0, 60.0]))
    lines = [] if header is None else [header]
    lines += rows if rows is not None else [
        f"{w:g},{r[0]:.7f},{r[1]:.7f},{r[2]:.7f}" for w, r in zip(wavelength, reflectance,
                                                                   strict=True)]
    path.write_text("# a synthetic spectrum\n" + "\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_fit_prints_a_table_and_writes_a_report_and_a_scene(tmp_path, capsys):
    spectrum = _csv(tmp_path / "s.csv")
    out = tmp_path / "out" / "fit"
    code = cli.main(["fit", str(spectrum), "--family", "bragg", "--fixed", "n1=1.0",
                     "--bounds", "N=2:12", "--seed", "0", "--generations", "40",
                     "--samples", "50", "-o", str(out), "--no-progress"])
    text = capsys.readouterr().out
    assert code == 0, text
    assert "std error" in text and "(fixed)" in text and "(integer)" in text
    assert (tmp_path / "out" / "fit.png").stat().st_size > 10_000
    mirror = load_scene(tmp_path / "out" / "fit.toml").materials["design"].to_structure()
    fitted = mirror.layers[0].mirror
    assert fitted.N == 7
    for name in ("n1", "n2", "d1", "d2"):
        assert getattr(fitted, name) == pytest.approx(getattr(TRUTH, name), rel=1e-5)


def test_design_writes_a_film_material_the_scene_loader_reads(tmp_path, capsys):
    out = tmp_path / "design"
    code = cli.main(["design", "--target", "#b08d57@0", "--target", "#6a5acd@45",
                     "--family", "film", "--fixed", "base=Au", "--seed", "1",
                     "--generations", "10", "--samples", "50", "-o", str(out),
                     "--no-progress"])
    text = capsys.readouterr().out
    assert code == 0, text
    assert "grid dE" in text
    film = load_scene(tmp_path / "design.toml").materials["design"].to_film()
    assert film.base is not None and film.base.name == "Au"
    best = float(text.splitlines()[1].split()[1])
    # The table's dE2000, recomputed from the written film and the targets decoded by hand.
    rgb = film.rgb(np.radians([0.0, 45.0]), method="reference")
    encoded = np.array([[0xb0, 0x8d, 0x57], [0x6a, 0x5a, 0xcd]]) / 255.0
    linear = np.where(encoded <= 0.04045, encoded / 12.92, ((encoded + 0.055) / 1.055) ** 2.4)
    de = delta_e_2000(rgb, linear)
    assert float(de.mean()) == pytest.approx(best, abs=0.006)  # the table rounds to 0.01


@pytest.mark.parametrize(("rows", "argv", "message"), [
    ([], [], "no data rows"),
    (["500,0.1", "490,0.2", "510,0.3"], ["--theta-deg", "0"], r"strictly increase \(line 3\)"),
    (["500,0.1", "510,nan", "520,0.3"], ["--theta-deg", "0"], "line 3, column 2"),
    (["500,0.1,0.2", "510,0.2", "520,0.3,0.1"], ["--theta-deg", "0,30"], "line 3 has 2"),
    (["500,10", "510,20", "520,30"], ["--theta-deg", "0"], "fractions in"),
    (["500,0.1", "510,0.2", "520,0.3"], [], "--theta-deg is required"),
    (["500,0.1", "510,0.2", "520,0.3"], ["--theta-deg", "0,30"], "gives 2 angles"),
    (["500,0.1", "510,0.2", "520,0.3"], ["--theta-deg", "0", "--bounds", "n2=1.5"],
     "needs LOW:HIGH"),
    (["500,0.1", "510,0.2", "520,0.3"], ["--theta-deg", "0", "--bounds", "q=1:2"],
     "unknown parameter 'q'"),
])
def test_fit_mistakes_are_one_line_errors(tmp_path, capsys, rows, argv, message):
    spectrum = _csv(tmp_path / "s.csv", header=None, rows=rows)
    code = cli.main(["fit", str(spectrum), "--family", "bragg", "-o",
                     str(tmp_path / "fit"), *argv])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("wgbragg: error:") and len(err.strip().splitlines()) == 1
    assert re.search(message, err), err
    assert not (tmp_path / "fit.png").exists() and not (tmp_path / "fit.toml").exists()


@pytest.mark.parametrize(("argv", "message"), [
    (["--target", "#d4af37"], "COLOUR@DEGREES"),
    (["--target", "#d4af3@0"], "hex colour must look like"),
    (["--target", "#d4af37@100"], r"in \[0, 90\] degrees"),
    (["--target", "1,2@0"], "three numbers"),
    (["--target", "#d4af37@0", "--max-seconds", "-2"], "max_seconds must be"),
    (["--target", "#d4af37@0", "--alpha", "2"], r"--alpha must be in \[0.01, 1\]"),
    (["--target", "#d4af37@0", "--samples", "0"], "--samples must be in"),
    (["--target", "#d4af37@0", "--robust", "0"], r"--robust must be in \[1, 4096\]"),
    (["--target", "#d4af37@0", "--robust", "4", "--sigma-thickness-nm", "0"],
     "robust needs sigma_thickness_nm > 0"),
    (["--target", "#d4af37@0", "--family", "film", "--colour-method", "averaged"],
     r"for a 'film' design must be one of \('grid',\)"),
])
def test_design_mistakes_are_one_line_errors(tmp_path, capsys, argv, message):
    code = cli.main(["design", "--family", "bragg", "-o", str(tmp_path / "d"), *argv])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("wgbragg: error:"), err
    assert re.search(message, err), err


def test_fit_chooses_a_film_base_among_metals(tmp_path, capsys):
    from wgbragg import ThinFilm

    film = ThinFilm(1.45, 380.0, base="Ag")
    wavelength = np.arange(400.0, 751.0, 10.0)
    reflectance = film.reflectance(wavelength[:, None], np.radians([0.0, 45.0]))
    spectrum = _csv(tmp_path / "f.csv", header="wavelength_nm,0,45",
                    rows=[f"{w:g},{r[0]:.7f},{r[1]:.7f}" for w, r in zip(wavelength, reflectance,
                                                                       strict=True)])
    code = cli.main(["fit", str(spectrum), "--family", "film", "--bounds", "base=Au:Ag",
                     "--seed", "0", "--generations", "15", "--samples", "20", "-o",
                     str(tmp_path / "f"), "--no-progress"])
    text = capsys.readouterr().out
    assert code == 0, text
    assert re.search(r"^base\s+Ag\s+\(chosen\)$", text, re.MULTILINE), text
    written = load_scene(tmp_path / "f.toml").materials["design"].to_film()
    assert written.base.name == "Ag" and written.d == pytest.approx(380.0, rel=1e-5)


def test_csv_header_names_the_angles(tmp_path):
    spectrum = read_spectrum_csv(_csv(tmp_path / "s.csv"))
    np.testing.assert_array_equal(spectrum.theta_deg, [0.0, 30.0, 60.0])
    assert spectrum.reflectance.shape == (36, 3)
    np.testing.assert_allclose(
        spectrum.reflectance,
        TRUTH.reflectance(spectrum.wavelength_nm[:, None], np.radians([0.0, 30.0, 60.0])),
        atol=1e-7)


@pytest.mark.parametrize("per_layer", [False, True])
def test_design_robust_prints_the_averaged_objective(tmp_path, capsys, per_layer):
    from wgbragg.design.colour_design import perturbed_delta_e
    from wgbragg.design.tolerance import layer_perturbations, perturbations

    out = tmp_path / "robust"
    code = cli.main(["design", "--target", "#d4af37@0", "--target", "#2e8b57@60", "--family",
                     "bragg", "--fixed", "n1=1", "--bounds", "N=2:8", "--robust", "4",
                     "--sigma-thickness-nm", "3", "--seed", "0", "--generations", "5",
                     "--samples", "20", "-o", str(out), "--no-progress",
                     *(["--per-layer"] if per_layer else [])])
    text = capsys.readouterr().out
    assert code == 0, text
    assert "robust dE" in text.splitlines()[0]
    material = load_scene(tmp_path / "robust.toml").materials["design"]
    mirror = material.to_structure().layers[0].mirror
    draws = (layer_perturbations(4, 16, 3.0, 0.0, seed=0, quasi_random=True) if per_layer
             else perturbations("bragg", 4, 3.0, 0.0, seed=0, quasi_random=True))
    mean = perturbed_delta_e(mirror, ["#d4af37", "#2e8b57"], np.radians([0.0, 60.0]), draws)
    assert float(text.splitlines()[1].split()[3]) == pytest.approx(mean.mean(), abs=0.006)


@pytest.mark.parametrize("name", ["design", "my design", 'gold "A"', "é.1"])
def test_scene_toml_reads_back_under_any_material_name(tmp_path, name):
    from wgbragg import ThinFilm
    from wgbragg.design.files import scene_toml
    from wgbragg.scene import parse_scene

    for structure in (TRUTH, ThinFilm(1.45, 300.0, base="Au")):
        scene = parse_scene(scene_toml(structure, name=name), tmp_path)
        assert list(scene.materials) == [name]
        assert scene.objects[0].material == name
