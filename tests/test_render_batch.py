"""Batch renders as Dask tasks (wgbragg.sweep.render_batch, ``wgbragg render-batch``): frames
of a varied scene value or a turntable, each the image ``wgbragg render`` gives for that
scene, written atomically, resumed frame by frame, joined into an animation. Frames are 8 x 8
at 1 sample; the cluster is one worker thread of this process (its device is this one's)."""

from __future__ import annotations

import contextlib
import io
import tomllib

import numpy as np
import pytest
from PIL import Image

from wgbragg.app import cli
from wgbragg.render import Renderer
from wgbragg.render.display import display_transform
from wgbragg.scene import load_scene
from wgbragg.sweep import dask_client
from wgbragg.sweep.render_batch import (
    assemble,
    parse_vary,
    plan_frames,
    render_batch,
    set_key,
    toml_text,
)

pytestmark = pytest.mark.gpu

SCENE = """
[settings]
size = [8, 8]
spp = 1

[camera]
position = [0.0, 0.0, 3.0]
look_at = [0.0, 0.0, 0.0]
fov_deg = 40.0

[environment]
type = "uniform"
radiance = 1.0

[materials.coat]
type = "layered-bragg"
layers = [{ n1 = 1.0, n2 = 1.5, d1_nm = 100.0, d2_nm = 100.0, N = 10, alpha = 0.1 }]

[[objects]]
shape = "sphere"
material = "coat"
"""

VARY = "materials.coat.layers[0].period_nm=150:300:3"


@pytest.fixture
def scene(tmp_path):
    path = tmp_path / "scene" / "scene.toml"
    path.parent.mkdir()
    path.write_text(SCENE, encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def client():
    with dask_client(workers=1, processes=False, dashboard=False) as client:
        yield client


def _pixels(path) -> np.ndarray:
    with Image.open(path) as image:
        return np.asarray(image.convert("RGB"))


def test_frames_are_the_renders_of_their_scenes_and_resume(scene, tmp_path, client):
    frames = plan_frames(scene, vary=VARY)
    assert [f.label for f in frames] == [f"materials.coat.layers[0].period_nm = {v:g}"
                                         for v in (150, 225, 300)]
    out = tmp_path / "frames"
    report = render_batch(frames, out, client, progress=False)
    assert (report.rendered, report.skipped) == (3, 0)
    # Frame 1 is the scene with period 225 nm (d1 = d2 = 112.5 nm), rendered in-process.
    varied = tmp_path / "scene" / "varied.toml"
    varied.write_text(SCENE.replace("d1_nm = 100.0, d2_nm = 100.0", "period_nm = 225.0, "
                                    "delta = 0.5"), encoding="utf-8")
    image = Renderer(load_scene(varied)).render(1)
    np.testing.assert_array_equal(_pixels(report.paths[1]), display_transform(image))
    assert not np.array_equal(_pixels(report.paths[0]), _pixels(report.paths[2]))
    # A lost frame is rendered again, and only it.
    first = _pixels(report.paths[0])
    report.paths[0].unlink()
    again = render_batch(frames, out, client, progress=False)
    assert (again.rendered, again.skipped) == (1, 2)
    np.testing.assert_array_equal(_pixels(report.paths[0]), first)
    # Bad settings are refused before any task.
    with pytest.raises(ValueError, match="--spp must be an integer >= 1"):
        render_batch(frames, out, client, spp=0, progress=False)
    with pytest.raises(ValueError, match="--size must be two integers"):
        render_batch(frames, out, client, size=(0, 8), progress=False)
    # Other frames into the same folder are refused.
    with pytest.raises(ValueError, match="frames of another batch"):
        render_batch(plan_frames(scene, turntable=3), out, client, progress=False)
    # Joined into animations.
    for suffix in (".gif", ".webp"):
        animation = assemble(report.paths, tmp_path / f"anim{suffix}", fps=10)
        with Image.open(animation) as image:
            assert image.n_frames == 3 and image.info.get("loop") == 0
    assert not [p.name for p in tmp_path.rglob(".*")]  # no temporary files left


def test_the_command_line_renders_and_animates(scene, tmp_path, client):
    out = io.StringIO()
    argv = ["render-batch", str(scene), "--turntable", "2", "-o", str(tmp_path / "t"),
            "--animation", str(tmp_path / "t.gif"), "--scheduler", client.scheduler.address,
            "--no-progress"]
    with contextlib.redirect_stdout(out):
        assert cli.main(argv) == 0
    assert "2 frames rendered, 0 already there" in out.getvalue()
    with Image.open(tmp_path / "t.gif") as image:
        assert image.n_frames == 2


def test_a_turntable_orbits_the_camera_about_look_at(scene):
    frames = plan_frames(scene, turntable=4)
    positions = [tomllib.loads(f.scene_text)["camera"]["position"] for f in frames]
    np.testing.assert_allclose(positions, [[0, 0, 3], [3, 0, 0], [0, 0, -3], [-3, 0, 0]],
                               atol=1e-12)


def test_set_key_converts_the_thickness_pair_and_keeps_types():
    document = tomllib.loads(SCENE)
    set_key(document, "materials.coat.layers[0].period_nm", 300.0)
    assert document["materials"]["coat"]["layers"][0] == {
        "n1": 1.0, "n2": 1.5, "N": 10, "alpha": 0.1, "period_nm": 300.0, "delta": 0.5}
    set_key(document, "materials.coat.layers[0].d1_nm", 50.0)
    layer = document["materials"]["coat"]["layers"][0]
    assert layer["d1_nm"] == 50.0 and layer["d2_nm"] == 150.0 and "period_nm" not in layer
    set_key(document, "materials.coat.layers[0].N", 12.0)
    assert layer["N"] == 12 and isinstance(layer["N"], int)
    assert tomllib.loads(toml_text(document)) == document


@pytest.mark.parametrize(("vary", "message"), [
    ("materials.coat.layers[0].N=1:2:3", "N is an integer; the range gives 1.5"),
    ("materials.coat.layers[3].n2=1:2:3", "the scene has no"),
    ("materials.glass.n2=1:2:3", "the scene has no"),
    ("materials.coat.type=1:2:3", "is not a number of the scene"),
    ("materials.coat.layers[0].n2=1:200:3",
     r"frame 1 \(.*= 100.5\): materials.coat.layers\[0\].n2: n2 must"),
    ("materials..n2=1:2:3", "is not a key path"),
    ("materials.coat.layers[0].n2=1:2", "KEY=START:STOP:COUNT"),
    ("materials.coat.layers[0].n2=1:2:0", "COUNT in"),
])
def test_bad_variations_are_refused_before_any_frame(scene, vary, message):
    with pytest.raises(ValueError, match=message):
        plan_frames(scene, vary=vary)


def test_parse_vary():
    key, values = parse_vary(VARY)
    assert key == "materials.coat.layers[0].period_nm"
    np.testing.assert_array_equal(values, [150.0, 225.0, 300.0])


FILM = SCENE.replace('''type = "layered-bragg"
layers = [{ n1 = 1.0, n2 = 1.5, d1_nm = 100.0, d2_nm = 100.0, N = 10, alpha = 0.1 }]''',
                     '''type = "thin-film"
n_film = 1.33
alpha = 0.2
thickness_nm = 400.0
n_base = 1.5''')


@pytest.mark.parametrize("key", [
    "materials.coat.layers[0].n2", "'materials.coat.layers[0].n2'",
    '"materials.coat.layers[0].n2"', 'materials."coat".layers[0].n2',
    "materials . 'coat' . layers[ 0 ] . n2"])
def test_quoted_key_paths_name_the_same_value(key):
    document = tomllib.loads(SCENE)
    set_key(document, key, 1.7)
    assert document["materials"]["coat"]["layers"][0]["n2"] == 1.7
    assert parse_vary(f"{key}=1:2:3")[0] == key


def test_a_quoted_name_may_hold_dots_and_equals_signs():
    document = {"materials": {"a.b=c": {"type": "thin-film", "n_film": 1.3}}}
    set_key(document, 'materials."a.b=c".n_film', 1.5)
    assert document["materials"]["a.b=c"]["n_film"] == 1.5
    key, values = parse_vary("materials.'a.b=c'.n_film=1.4,1.6")
    assert key == "materials.'a.b=c'.n_film" and values == ["1.4", "1.6"]


def test_a_list_of_values_varies_numbers_booleans_and_a_films_base(tmp_path):
    scene = tmp_path / "film.toml"
    scene.write_text(FILM, encoding="utf-8")
    frames = plan_frames(scene, vary="materials.coat.base=Au, Ag,Cu")
    films = [tomllib.loads(f.scene_text)["materials"]["coat"] for f in frames]
    assert [f["base"] for f in films] == ["Au", "Ag", "Cu"]
    assert all("n_base" not in f for f in films)  # base replaces n_base and k_base
    assert [f.label for f in frames][1] == "materials.coat.base = Ag"
    frames = plan_frames(scene, vary="materials.coat.thickness_nm=250,400.5")
    assert [tomllib.loads(f.scene_text)["materials"]["coat"]["thickness_nm"]
            for f in frames] == [250.0, 400.5]
    document = tomllib.loads(SCENE)
    document["materials"]["coat"]["base_interreflection"] = False
    set_key(document, "materials.coat.base_interreflection", "true")
    assert document["materials"]["coat"]["base_interreflection"] is True
    set_key(document, "materials.coat.layers[0].N", "12")
    assert document["materials"]["coat"]["layers"][0]["N"] == 12


@pytest.mark.parametrize(("vary", "message"), [
    ("materials.coat.base=Au,Xx", r"frame 1 \(materials.coat.base = Xx\): .*base"),
    ("materials.coat.n_film=1.3,abc", "is a number of the scene; the list gives 'abc'"),
    ("materials.coat.n_film=1.3,,1.4", "non-empty values"),
    ("materials.coat.type=thin-film,2", "type"),
    ("materials.'coat.n_film=1:2:3", "is not a key path"),
])
def test_bad_lists_are_refused_before_any_frame(tmp_path, vary, message):
    scene = tmp_path / "film.toml"
    scene.write_text(FILM, encoding="utf-8")
    with pytest.raises(ValueError, match=message):
        plan_frames(scene, vary=vary)


def test_varied_paths_keep_the_scene_folder_rule(tmp_path):
    """A frame is read as its scene file would be: a varied file path resolves against the
    scene's folder and may not leave it unless allowed (the user's allow_outside)."""
    import trimesh

    folder = tmp_path / "scene"
    folder.mkdir()
    for place in (folder / "a.ply", tmp_path / "outside.ply"):
        trimesh.creation.icosphere(1).export(place)
    path = folder / "scene.toml"
    path.write_text(SCENE.replace('shape = "sphere"', 'shape = "mesh"\npath = "a.ply"'),
                    encoding="utf-8")
    vary = "objects[0].path=a.ply,../outside.ply"
    with pytest.raises(ValueError, match=r"^frame 1 \(objects\[0\]\.path = \.\./outside\.ply\)"
                                         r": objects\[0\]\.path: .* lies outside the scene"):
        plan_frames(path, vary=vary)
    frames = plan_frames(path, vary=vary, allow_outside=True)
    assert [tomllib.loads(f.scene_text)["objects"][0]["path"] for f in frames] == [
        "a.ply", "../outside.ply"]  # as written: relative to the scene's folder
    assert frames[1].scene().objects[0].path == folder / "../outside.ply"
