"""glTF 2.0 in and out (wgbragg.scene.gltf, gltf_export) and MaterialX out (scene.materialx).

Small glTF files are built in code (a quad, a camera, a point light, a material with
``KHR_materials_iridescence`` and both its textures); the Scene read from them is checked value
by value, a render of one against the same scene written as TOML, exports re-read by pygltflib,
trimesh and wgbragg, and MaterialX documents by MaterialX's own validation.
"""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
import warnings

import numpy as np
import pygltflib
import pytest
import trimesh
from PIL import Image

from wgbragg.common.metrics import smape
from wgbragg.scene import (
    GltfWarning,
    load_gltf,
    load_preset,
    load_scene,
    parse_scene,
    save_materialx,
)
from wgbragg.scene.gltf_fallback import BRAGG_EXTENSION, bragg_colours, fit_fallback
from wgbragg.scene.gltf_io import GltfBuilder
from wgbragg.scene.materialx import scene_to_materialx, validate_materialx
from wgbragg.scene.meshes import load_mesh
from wgbragg.scene.model import Environment, ThinFilmMaterial
from wgbragg.scene.parameter_maps import map_values

QUAD = np.array([[-1.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 0.0, -1.0], [-1.0, 0.0, -1.0]])
QUAD_UV = np.array([[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]])  # glTF: v down
QUAD_FACES = np.array([0, 1, 2, 0, 2, 3])


def _png(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    Image.fromarray(array).save(buffer, format="PNG")
    return buffer.getvalue()


def _thickness_texels() -> np.ndarray:
    texels = np.zeros((4, 4, 3), np.uint8)
    texels[..., 1] = (np.arange(16) * 17).reshape(4, 4)  # G: the thickness
    texels[..., 0] = 200  # R and B are not read
    return texels


def _build(path, *, film=None, factor_texture=True, metallic=0.0, colour=(0.0, 0.0, 0.0),
           extra_material=None, required=None, light_type="point", cameras=1):
    b = GltfBuilder("wgbragg tests")
    g = pygltflib
    film = {"iridescenceFactor": 1.0, "iridescenceIor": 1.8, "iridescenceThicknessMinimum": 200.0,
            "iridescenceThicknessMaximum": 600.0} if film is None else film
    if "iridescenceThicknessTexture" not in film and film.get("textures", True):
        film["iridescenceThicknessTexture"] = {"index": b.image(_png(_thickness_texels()))}
    film.pop("textures", None)
    if factor_texture:
        mask = np.full((4, 4, 3), 255, np.uint8)
        mask[:2, :, 0] = 0  # R: no film on the image's top half
        film["iridescenceTexture"] = {"index": b.image(_png(mask))}
    material = g.Material(name="film", pbrMetallicRoughness=g.PbrMetallicRoughness(
        baseColorFactor=[*colour, 1.0], metallicFactor=metallic, roughnessFactor=0.4),
        extensions={"KHR_materials_iridescence": film, **(extra_material or {})})
    b.document.materials.append(material)
    mesh = b.mesh({"POSITION": b.accessor(QUAD), "NORMAL": b.accessor(np.tile([0.0, 1, 0], (4, 1))),
                   "TEXCOORD_0": b.accessor(QUAD_UV)}, b.accessor(QUAD_FACES, indices=True), 0)
    for i in range(cameras):
        b.document.cameras.append(g.Camera(type="perspective", name=f"cam{i}", perspective=(
            g.Perspective(yfov=0.7 + 0.1 * i, aspectRatio=1.5, znear=0.1))))
    b.document.extensions = {"KHR_lights_punctual": {"lights": [
        {"type": light_type, "color": [1.0, 0.5, 0.25], "intensity": 20.0}]}}
    b.document.extensionsUsed = ["KHR_materials_iridescence", "KHR_lights_punctual"]
    b.document.extensionsRequired = required or []
    b.document.nodes += [g.Node(mesh=mesh, translation=[0.0, 0.5, 0.0]),
                         g.Node(extensions={"KHR_lights_punctual": {"light": 0}},
                                translation=[1.0, 3.0, 1.0])]
    b.document.nodes += [g.Node(camera=i, name=f"node{i}", translation=[0.0, 2.0, 5.0 + i])
                         for i in range(cameras)]
    b.document.scenes.append(g.Scene(nodes=list(range(len(b.document.nodes)))))
    b.document.scene = 0
    b.save(path)
    return path


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("WGBRAGG_CACHE", str(tmp_path / "cache"))


def _load(path, **options):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = load_gltf(path, **options)
    lines = [str(w.message) for w in caught if issubclass(w.category, GltfWarning)]
    assert len(lines) <= 1
    return scene, (lines[0] if lines else "")


# ------------------------------------------------------------------------------------ import


@pytest.mark.parametrize("suffix", [".glb", ".gltf"])
def test_the_scene_read_from_a_file_built_in_code(tmp_path, suffix):
    scene, warning = _load(_build(tmp_path / f"a{suffix}"))
    assert scene.camera.position == (0.0, 2.0, 5.0)
    assert scene.camera.look_at == (0.0, 2.0, 4.0)
    assert scene.camera.fov_deg == pytest.approx(np.degrees(0.7), rel=1e-12)
    assert scene.settings.size == (768, 512)  # aspectRatio 1.5
    (light,) = scene.lights
    assert light.position == (1.0, 3.0, 1.0) and light.intensity == (20.0, 10.0, 5.0)
    assert scene.environment == Environment("uniform", radiance=(1.0, 1.0, 1.0))
    film = scene.materials["film"]
    assert isinstance(film, ThinFilmMaterial)
    assert (film.n_film, film.n_base, film.k_base) == (1.8, 1.5, 0.0)
    assert film.alpha == pytest.approx(0.16, rel=1e-12)  # roughness 0.4 squared
    (obj,) = scene.objects
    mesh = load_mesh(obj.path)
    placed = QUAD + np.array([0.0, 0.5, 0.0])
    assert np.allclose(np.sort(mesh.vertices, axis=0), np.sort(placed, axis=0))
    assert mesh.uv is not None
    assert np.allclose(mesh.normals, [0.0, 1.0, 0.0])
    # The map: thickness = mask(R >= 0.5) * (200 + 400 G) at each texel's centre. uv in the OBJ
    # convention (v up): texel (row r, column c) of the 4x4 images is at u = (c + 1/2) / 4,
    # v = 1 - (r + 1/2) / 4.
    rows, columns = np.mgrid[0:4, 0:4]
    uv = np.stack([(columns + 0.5) / 4, 1.0 - (rows + 0.5) / 4], axis=-1)
    expected = np.where(rows >= 2, 200.0 + 400.0 * _thickness_texels()[..., 1] / 255.0, 0.0)
    assert np.allclose(map_values(film.thickness_map, uv), expected, atol=600 / 65535)
    assert warning == ""  # everything in this file is read


def test_without_a_factor_texture_the_thickness_map_is_the_green_channel(tmp_path):
    scene, _ = _load(_build(tmp_path / "a.glb", factor_texture=False))
    film = scene.materials["film"]
    assert film.thickness_map.range == (200.0, 600.0)
    rows, columns = np.mgrid[0:4, 0:4]
    uv = np.stack([(columns + 0.5) / 4, 1.0 - (rows + 0.5) / 4], axis=-1)
    expected = 200.0 + 400.0 * _thickness_texels()[..., 1] / 255.0
    # 8-bit texels, exact but for the float32 in which the map's texture is read.
    assert np.allclose(map_values(film.thickness_map, uv), expected, rtol=1e-6)


def test_without_textures_the_thickness_is_the_maximum_and_factor_zero_is_no_film(tmp_path):
    film = {"iridescenceFactor": 1.0, "iridescenceThicknessMaximum": 321.0, "textures": False}
    scene, _ = _load(_build(tmp_path / "a.glb", film=film, factor_texture=False))
    assert scene.materials["film"].thickness_nm == 321.0
    assert scene.materials["film"].n_film == 1.3  # the extension's default index
    # The extension's default factor is 0: no film; a black dielectric is a black Lambertian.
    scene, _ = _load(_build(tmp_path / "b.glb", film={"textures": False}, factor_texture=False))
    assert scene.materials["film"].albedo == [0.0, 0.0, 0.0] or \
        tuple(scene.materials["film"].albedo) == (0.0, 0.0, 0.0)


def test_metallic_bases(tmp_path):
    grey, _ = _load(_build(tmp_path / "a.glb", metallic=1.0, colour=(0.5, 0.5, 0.5)))
    film = grey.materials["film"]
    root = np.sqrt(0.5)  # the extension's Fresnel0ToIor
    assert film.n_base == pytest.approx((1 + root) / (1 - root), rel=1e-12) and film.k_base == 0
    gold, warning = _load(_build(tmp_path / "b.glb", metallic=1.0, colour=(0.9, 0.6, 0.25)))
    assert gold.materials["film"].base == "Au"
    assert "nearest bundled metal Au" in warning


def test_everything_unsupported_is_listed_in_one_line(tmp_path):
    path = _build(tmp_path / "a.glb", light_type="spot", colour=(0.2, 0.3, 0.4), extra_material={
        "KHR_materials_clearcoat": {"clearcoatFactor": 1.0}}, cameras=2)
    scene, warning = _load(path)
    assert "\n" not in warning
    for text in ("KHR_materials_clearcoat", "spot light", "diffuse base colour"):
        assert text in warning, text
    assert len(scene.lights) == 1  # the spot light as a point light


def test_a_named_camera_and_an_environment(tmp_path):
    path = _build(tmp_path / "a.glb", cameras=2)
    scene, _ = _load(path, camera="cam1", environment=Environment("sky", intensity=2.0))
    assert scene.camera.position == (0.0, 2.0, 6.0)
    assert scene.environment == Environment("sky", intensity=2.0)
    scene, _ = _load(path, camera="node0")
    assert scene.camera.position == (0.0, 2.0, 5.0)
    with pytest.raises(ValueError, match=r"no camera named 'x'; its cameras: 'cam0', 'cam1'"):
        load_gltf(path, camera="x")


def test_refusals_are_one_line_and_name_the_file(tmp_path):
    fifo = tmp_path / "pipe.glb"
    os.mkfifo(fifo)
    with pytest.raises(ValueError, match=r"pipe\.glb: not a regular file"):
        load_gltf(fifo)
    bad = tmp_path / "bad.glb"
    bad.write_bytes(b"glTF\x02\x00\x00\x00garbage")
    with pytest.raises(ValueError, match=r"bad\.glb: not a readable glTF 2\.0 file"):
        load_gltf(bad)
    required = _build(tmp_path / "draco.glb", required=["KHR_draco_mesh_compression"])
    with pytest.raises(ValueError, match="KHR_draco_mesh_compression is required"):
        load_gltf(required)
    outside = tmp_path / "sub" / "x.gltf"
    outside.parent.mkdir()
    text = json.loads(_build(tmp_path / "ok.gltf").read_text())
    text["buffers"][0]["uri"] = "../secret.bin"
    outside.write_text(json.dumps(text))
    with pytest.raises(ValueError, match=r"lies outside the glTF file's folder"):
        load_gltf(outside)
    text["buffers"][0]["uri"] = "https://example.com/x.bin"
    outside.write_text(json.dumps(text))
    with pytest.raises(ValueError, match="nothing is fetched"):
        load_gltf(outside)
    with pytest.raises(ValueError, match="options of glTF files only"):
        load_scene(tmp_path / "x.toml", camera="a")


# ------------------------------------------------------------------------------ round trips


def test_round_trips_keep_every_value(tmp_path):
    for preset in ("thin_film", "fig12", "fig11"):
        scene = load_preset(preset)
        scene.save_gltf(tmp_path / f"{preset}.glb")
        again = load_scene(tmp_path / f"{preset}.glb")
        assert dict(again.materials) == dict(scene.materials)  # every Bragg number bit for bit
        assert (again.camera, again.lights, again.environment, again.settings, again.objects) == \
            (scene.camera, scene.lights, scene.environment, scene.settings, scene.objects)


def test_an_export_is_valid_for_pygltflib_and_trimesh(tmp_path):
    scene = load_preset("fig12")
    data = scene.to_gltf()
    document = pygltflib.GLTF2.load_from_bytes(data)
    (material,) = document.materials
    extension = material.extensions[BRAGG_EXTENSION]
    assert extension["layers"][0]["d1_nm"] == scene.materials["varying"].layers[0].d1_nm
    assert extension["period_map"]["procedural"] == "noise"
    fallback = material.extensions["KHR_materials_iridescence"]
    assert fallback["iridescenceFactor"] == 1.0
    assert material.pbrMetallicRoughness.metallicFactor == 1.0
    assert BRAGG_EXTENSION not in (document.extensionsRequired or [])
    loaded = trimesh.load(io.BytesIO(data), file_type="glb")
    assert len(loaded.geometry) == 1 and next(iter(loaded.geometry.values())).faces.shape[1] == 3


def test_the_bragg_fallback_error_is_as_documented():
    material = load_preset("fig7").materials["config_a"]
    fallback = fit_fallback(material)
    # docs/scenes.md: fig7's configuration A, mean dE2000 19.8 (max 26.8); one base colour
    # without a film 38.1. Pinned within 0.5 of the measured values.
    assert fallback.delta_e_mean == pytest.approx(19.8, abs=0.5)
    assert fallback.delta_e_max == pytest.approx(26.8, abs=0.5)
    assert fallback.constant_delta_e_mean == pytest.approx(38.1, abs=0.5)
    assert bragg_colours(material, [0.0]).shape == (1, 3)


def test_materialx_documents_validate(tmp_path):
    for preset in ("thin_film", "fig7"):
        text, _ = scene_to_materialx(load_preset(preset))
        assert validate_materialx(text) == (True, "")
    path = save_materialx(load_preset("thin_film"), tmp_path / "film.mtlx")
    text = path.read_text()
    assert 'name="thin_film_thickness"' in text and (tmp_path / "film_film_thickness.png").is_file()
    assert 'name="thin_film_ior" type="float" value="2.0"' in text
    ok, message = validate_materialx(text.replace('"thin_film_ior"', '"thin_film_index"'))
    assert not ok and "thin_film_index" in message


# --------------------------------------------------------------------------------- renders

_TOML = """
[settings]
size = [768, 512]
[camera]
position = [0.0, 2.0, 5.0]
look_at = [0.0, 2.0, 4.0]
fov_deg = {fov}
[environment]
type = "uniform"
[materials.film]
type = "thin-film"
n_film = 1.8
alpha = 0.16000000000000003
n_base = 1.5
thickness_map = {{ texture = "thickness.png", range = [200.0, 600.0] }}
[[objects]]
shape = "mesh"
path = "quad.obj"
material = "film"
translate = [0.0, 0.5, 0.0]
[[lights]]
type = "point"
position = [1.0, 3.0, 1.0]
intensity = [20.0, 10.0, 5.0]
"""


def test_a_gltf_file_renders_as_the_same_scene_in_toml(device, tmp_path):
    from wgbragg.render import Renderer

    path = _build(tmp_path / "a.glb", factor_texture=False)
    Image.fromarray(_thickness_texels()[..., 1]).save(tmp_path / "thickness.png")
    (tmp_path / "quad.obj").write_text(
        "".join(f"v {x} {y} {z}\n" for x, y, z in QUAD) + "vn 0 1 0\n"
        + "".join(f"vt {u} {1 - v}\n" for u, v in QUAD_UV)
        + "f 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n")
    toml = parse_scene(_TOML.format(fov=repr(float(np.degrees(0.7)))), tmp_path)
    scene, _ = _load(path)
    assert dict(scene.materials)["film"].thickness_map.range == (200.0, 600.0)
    gltf = Renderer(scene, size=(48, 32), seed=3).render(8)
    same = Renderer(toml, size=(48, 32), seed=3).render(8)
    other = Renderer(toml, size=(48, 32), seed=4).render(8)
    floor = smape(same, other)
    print(f"SMAPE glTF vs TOML (same seed) {smape(gltf, same):.2e}, noise floor {floor:.2e}")
    assert floor > 0.0 and smape(gltf, same) < 0.1 * floor


def test_a_film_scene_renders_the_same_after_a_round_trip(device, tmp_path):
    from wgbragg.render import Renderer

    scene = load_preset("thin_film")
    scene.save_gltf(tmp_path / "film.glb")
    again = load_scene(tmp_path / "film.glb")
    a = Renderer(scene, size=(32, 24), seed=1).render(4)
    b = Renderer(again, size=(32, 24), seed=1).render(4)
    assert smape(a, b) == 0.0  # the same scene exactly: the same image


# ------------------------------------------------------------------------------------- CLI


def test_the_cli_exports_and_renders_gltf(tmp_path):
    from wgbragg.app import cli

    assert cli.main(["export", "--scene", "thin_film", "-o", str(tmp_path / "f.glb")]) == 0
    assert cli.main(["export", "--scene", "thin_film", "-o", str(tmp_path / "f.mtlx")]) == 0
    assert cli.main(["export", "--scene", "thin_film", "-o", str(tmp_path / "f.obj")]) == 2
    assert (tmp_path / "f.glb").is_file() and (tmp_path / "f.mtlx").is_file()
    assert cli.main(["render", str(tmp_path / "f.glb"), "--camera", "nope", "-o",
                     str(tmp_path / "r.png")]) == 2


def test_export_help_imports_nothing_heavy():
    code = ("import contextlib, io, json, sys\nimport wgbragg.app.cli as cli\n"
            "with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):\n"
            "    cli.build_parser().parse_args(['export', '--help'])\n"
            "print(json.dumps(sorted({n.split('.')[0] for n in sys.modules})))")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=True, timeout=120)
    loaded = set(json.loads(result.stdout.splitlines()[-1]))
    assert not loaded & {"pygltflib", "MaterialX", "trimesh", "colour", "wgpu", "scipy"}
