"""Scene files: presets, the data model, path resolution and the messages for bad input."""

import re
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from wgbragg import LayeredBragg
from wgbragg.bsdf import filter_cache
from wgbragg.scene import load_preset, load_scene
from wgbragg.scene import model as scene
from wgbragg.scene.model import (
    AreaLight,
    BraggLayerSpec,
    Camera,
    Environment,
    LambertianMaterial,
    LayeredBraggMaterial,
    ParameterMap,
    PointLight,
    Scene,
    SceneObject,
    Settings,
)

MINIMAL = """\
[camera]
position = [0.0, 0.0, 4.0]
look_at = [0.0, 0.0, 0.0]
fov_deg = 40.0

[materials.blue]
type = "layered-bragg"
base_albedo = 0.5
[[materials.blue.layers]]
n1 = 1.0
n2 = 1.5
d1_nm = 250.0
d2_nm = 250.0
N = 10
alpha = 0.1

[materials.white]
type = "lambertian"
albedo = 0.8

[[objects]]
shape = "sphere"
material = "blue"

[[objects]]
shape = "plane"
material = "white"
"""


def write(folder: Path, text: str, name: str = "scene.toml") -> Path:
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


def refused(tmp_path: Path, text: str) -> str:
    with pytest.raises(ValueError) as caught:
        load_scene(write(tmp_path, text))
    return str(caught.value)


@pytest.fixture
def no_filters(monkeypatch):
    """Make any bake or load of a transmission filter fail the test."""

    def forbidden(*args, **kwargs):
        raise AssertionError("a transmission filter was baked or loaded")

    monkeypatch.setattr(filter_cache, "transmission_filter", forbidden)


# ------------------------------------------------------------------------------------ presets


def test_presets_are_the_files_shipped():
    folder = resources.files("wgbragg.scene").joinpath("presets")
    shipped = {p.name.removesuffix(".toml") for p in folder.iterdir() if p.name.endswith(".toml")}
    assert shipped == set(scene.PRESETS)


@pytest.mark.parametrize("name", scene.PRESETS)
def test_every_preset_loads_and_builds_without_baking(name, no_filters):
    loaded = load_preset(name)
    assert isinstance(loaded, Scene)
    assert {o.material for o in loaded.objects} <= set(loaded.materials)
    for material in loaded.materials.values():
        if isinstance(material, LayeredBraggMaterial):
            structure = material.to_structure()
            assert isinstance(structure, LayeredBragg)
            assert len(structure.layers) == len(material.layers)
            # RoughBraggLayer.filter is a cached_property: absent from __dict__ until first use.
            assert all("filter" not in layer.__dict__ for layer in structure.layers)


def test_unknown_preset_lists_the_names():
    with pytest.raises(ValueError, match=r"preset must be one of .*'furnace'.*'fig12'"):
        load_preset("fig99")


def test_furnace_is_a_white_sphere_in_white_light():
    furnace = load_preset("furnace")
    (sphere,) = furnace.objects
    assert sphere.shape == "sphere"
    assert furnace.materials[sphere.material] == LambertianMaterial(1.0)
    assert furnace.environment == Environment("uniform", radiance=(1.0, 1.0, 1.0))
    assert furnace.lights == ()


def test_fig7_is_configuration_a():
    fig7 = load_preset("fig7")
    material = fig7.materials[fig7.objects[0].material]
    assert material.layers == (BraggLayerSpec(1.0, 1.5, 250.0, 250.0, 10, 0.1),)
    assert material.base_albedo == 0.5
    assert fig7.environment.type == "sky"


def test_fig11_is_coated_and_fig12_varies_over_the_surface(no_filters):
    for material in load_preset("fig11").materials.values():
        assert {(s.n1, s.n2) for s in material.layers} == {(1.4, 1.6)}
        assert material.to_structure().host_index == 1.4
    (varying,) = load_preset("fig12").materials.values()
    assert varying.period_map.procedural and varying.delta_map.procedural
    for period in varying.period_map.range:
        for delta in varying.delta_map.range:
            mirror = varying.to_structure(period_nm=period, delta=delta).layers[0].mirror
            assert mirror.period == pytest.approx(period)
            assert mirror.d1 == pytest.approx(delta * period)


# --------------------------------------------------------------------------------- round trip

FULL = """\
[settings]
size = [320, 240]
spp = 16
mode = "spectral"
exposure = -0.5

[camera]
position = [0.0, 1.0, 4.0]
look_at = [0.0, 0.5, 0.0]
up = [0.0, 0.0, 1.0]
fov_deg = 45.0

[environment]
type = "exr"
path = "maps/sky.exr"
intensity = 2.0

[materials.beetle]
type = "layered-bragg"
base_albedo = [0.1, 0.2, 0.3]
period_map = { texture = "maps/period.png", range = [150.0, 250.0] }
delta_map = { procedural = "noise", range = [0.4, 0.6], scale = 8.0 }
[[materials.beetle.layers]]
n1 = 1.6
n2 = 1.68
period_nm = 200.0
delta = 0.5
N = 8
alpha = 0.05
host = 1.0

[materials.matte]
type = "lambertian"
albedo = [0.2, 0.4, 0.6]

[[objects]]
shape = "mesh"
path = "meshes/bunny.obj"
material = "beetle"
translate = [1.0, 0.0, -1.0]
scale = [1.0, 2.0, 3.0]
rotate_deg = [0.0, 90.0, 0.0]

[[objects]]
shape = "teapot"
material = "matte"
scale = 0.5

[[lights]]
type = "point"
position = [2.0, 4.0, 2.0]
intensity = 10.0

[[lights]]
type = "area"
corner = [-1.0, 3.0, -1.0]
edge_u = [2.0, 0.0, 0.0]
edge_v = [0.0, 0.0, 2.0]
radiance = [1.0, 2.0, 3.0]
"""


def make_files(folder: Path) -> None:
    for name in ("maps/sky.exr", "maps/period.png", "meshes/bunny.obj"):
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        # Existence is all loading checks: reading the files is the renderer's job.
        (folder / name).write_bytes(b"")


def test_full_scene_round_trips_into_the_dataclasses(tmp_path):
    make_files(tmp_path)
    loaded = load_scene(write(tmp_path, FULL))
    root = tmp_path.resolve()
    expected = Scene(
        camera=Camera((0.0, 1.0, 4.0), (0.0, 0.5, 0.0), (0.0, 0.0, 1.0), 45.0),
        objects=(
            SceneObject("mesh", root / "meshes/bunny.obj", "beetle", (1.0, 0.0, -1.0),
                        (1.0, 2.0, 3.0), (0.0, 90.0, 0.0)),
            SceneObject("teapot", None, "matte", scale=(0.5, 0.5, 0.5)),
        ),
        materials={
            "beetle": LayeredBraggMaterial(
                layers=(BraggLayerSpec(1.6, 1.68, 100.0, 100.0, 8, 0.05, host=1.0),),
                base_albedo=(0.1, 0.2, 0.3),
                period_map=ParameterMap(root / "maps/period.png", None, (150.0, 250.0)),
                delta_map=ParameterMap(None, "noise", (0.4, 0.6), 8.0),
            ),
            "matte": LambertianMaterial((0.2, 0.4, 0.6)),
        },
        lights=(
            PointLight((2.0, 4.0, 2.0), (10.0, 10.0, 10.0)),
            AreaLight((-1.0, 3.0, -1.0), (2.0, 0.0, 0.0), (0.0, 0.0, 2.0), (1.0, 2.0, 3.0)),
        ),
        environment=Environment("exr", intensity=2.0, path=root / "maps/sky.exr"),
        settings=Settings((320, 240), 16, "spectral", -0.5),
    )
    assert loaded == expected
    assert list(loaded.materials) == ["beetle", "matte"]
    with pytest.raises(TypeError):
        loaded.materials["other"] = LambertianMaterial(0.5)


def test_defaults_fill_what_a_minimal_scene_leaves_out(tmp_path):
    loaded = load_scene(write(tmp_path, MINIMAL))
    assert loaded.camera.up == (0.0, 1.0, 0.0)
    assert loaded.lights == ()
    assert loaded.environment == Environment("uniform", radiance=(0.0, 0.0, 0.0))
    assert loaded.settings == Settings((512, 512), 64, "rgb", 0.0)
    assert loaded.objects[0] == SceneObject("sphere", None, "blue")
    assert loaded.materials["blue"].layers[0].period_nm == 500.0


def test_paths_resolve_against_the_scene_file_not_the_cwd(tmp_path, monkeypatch):
    scenes, elsewhere = tmp_path / "scenes", tmp_path / "elsewhere"
    make_files(scenes)
    elsewhere.mkdir()
    path = write(scenes, FULL)
    monkeypatch.chdir(elsewhere)
    loaded = load_scene(Path("..") / "scenes" / "scene.toml")
    assert loaded.objects[0].path == scenes.resolve() / "meshes" / "bunny.obj"
    assert loaded.environment.path == scenes.resolve() / "maps" / "sky.exr"
    assert loaded.materials["beetle"].period_map.texture == scenes.resolve() / "maps/period.png"

    # The same names beside the cwd only are not found.
    (scenes / "meshes" / "bunny.obj").rename(elsewhere / "bunny.obj")
    write(scenes, FULL.replace("meshes/bunny.obj", "bunny.obj"))
    with pytest.raises(ValueError, match=r"objects\[0\]\.path: no such file"):
        load_scene(path)


# ------------------------------------------------------------------------------------- errors


def test_invalid_toml_names_the_file_and_line(tmp_path):
    message = refused(tmp_path, MINIMAL.replace("fov_deg = 40.0", "fov_deg = = 40.0"))
    assert message.startswith("scene.toml: invalid TOML")
    assert "line 4" in message


@pytest.mark.parametrize(("old", "new", "key", "accepted"), [
    ("fov_deg = 40.0", "fov_deg = 40.0\ncolour = 1",
     "camera.colour", "accepted keys here: position, look_at, fov_deg, up"),
    ('[[objects]]\nshape = "plane"', '[[objects]]\nshape = "plane"\nsize = 2.0',
     "objects[1].size", "accepted keys here: shape, material, path, translate, scale"),
    ("[camera]", "[cameras]\nx = 1\n[camera]",
     "cameras", "accepted keys here: camera, materials, objects, lights"),
    ("alpha = 0.1", "alpha = 0.1\nroughness = 0.2",
     "materials.blue.layers[0].roughness", "n1, n2, N, alpha, d1_nm, d2_nm, period_nm"),
])
def test_unknown_keys_are_refused_with_the_accepted_ones(tmp_path, old, new, key, accepted):
    message = refused(tmp_path, MINIMAL.replace(old, new, 1))
    assert f": {key}: unknown key" in message
    assert accepted in message


def test_missing_keys_are_named(tmp_path):
    message = refused(tmp_path, MINIMAL.replace("fov_deg = 40.0\n", ""))
    assert "camera.fov_deg: missing; required keys here: position, look_at, fov_deg" in message


@pytest.mark.parametrize(("old", "new", "key", "accepted"), [
    ("fov_deg = 40.0", 'fov_deg = "40"', "camera.fov_deg", "a number in (0, 180), got a string"),
    ("N = 10", "N = 10.0", "materials.blue.layers[0].N", "an integer >= 1, got a float"),
    ("N = 10", "N = true", "materials.blue.layers[0].N", "an integer >= 1, got a boolean"),
    ("position = [0.0, 0.0, 4.0]", "position = [0.0, 4.0]", "camera.position", "[x, y, z]"),
    ('material = "blue"', "material = 1", "objects[0].material", "a string, got an integer"),
    ("[materials.white]", "[materials.white.x]", "materials.white.type", "missing; accepted "
     "values: 'layered-bragg', 'lambertian'"),
    ('shape = "sphere"', 'shape = "cube"', "objects[0].shape",
     "one of 'mesh', 'sphere', 'plane', 'teapot', got a string 'cube'"),
    ("[camera]", '[settings]\nmode = "hdr"\n[camera]', "settings.mode",
     "one of 'rgb', 'spectral'"),
    ("[camera]", "[settings]\nsize = [512.0, 512]\n[camera]", "settings.size[0]",
     "an integer in [1, 16384]"),
])
def test_wrong_types_are_refused(tmp_path, old, new, key, accepted):
    message = refused(tmp_path, MINIMAL.replace(old, new, 1))
    assert f": {key}: " in message
    assert accepted in message


def test_a_byte_order_mark_is_read_and_deep_nesting_refused(tmp_path):
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + MINIMAL.encode("utf-8"))
    assert load_scene(path).camera == load_scene(write(tmp_path, MINIMAL)).camera
    message = refused(tmp_path, MINIMAL + "deep = " + "[" * 5000 + "]" * 5000 + "\n")
    assert "invalid TOML" in message


@pytest.mark.parametrize(("old", "new", "key", "accepted"), [
    ("n2 = 1.5", "n2 = 0.0", "materials.blue.layers[0].n2", "refractive index in [0.01, 100]"),
    ("n2 = 1.5", "n2 = 1e20", "materials.blue.layers[0].n2", "refractive index in [0.01, 100]"),
    ("n1 = 1.0", "n1 = 0.9", "materials.blue.layers[0].n1", "must be >= 1"),
    ("d1_nm = 250.0", "d1_nm = -1.0", "materials.blue.layers[0].d1_nm",
     "thickness in [0, 1e+06] nm"),
    ("N = 10", "N = 0", "materials.blue.layers[0].N", "integer in [1, 2147483647]"),
    ("alpha = 0.1", "alpha = 0.005", "materials.blue.layers[0].alpha", "in [0.01, 1]"),
    ("alpha = 0.1", "alpha = 1.5", "materials.blue.layers[0].alpha", "in [0.01, 1]"),
    ("albedo = 0.8", "albedo = 1.2", "materials.white.albedo", "in [0, 1], got 1.2"),
    ("base_albedo = 0.5", "base_albedo = [0.5, -0.1, 0.5]", "materials.blue.base_albedo[1]",
     "in [0, 1]"),
    ("fov_deg = 40.0", "fov_deg = 180.0", "camera.fov_deg", "in (0, 180)"),
    ("fov_deg = 40.0", "fov_deg = 0", "camera.fov_deg", "in (0, 180)"),
    ("d1_nm = 250.0\nd2_nm = 250.0", "period_nm = 500.0\ndelta = 1.5",
     "materials.blue.layers[0].delta", "in [0, 1]"),
    ("d2_nm = 250.0", "period_nm = 500.0", "materials.blue.layers[0]",
     "d1_nm and d2_nm, or as period_nm and delta"),
    ('material = "white"', 'material = "white"\nscale = 0.0', "objects[1].scale",
     "in [1e-06, 1e+06]"),
    ('material = "white"', 'material = "white"\nscale = 1e300', "objects[1].scale",
     "in [1e-06, 1e+06]"),
    ("[camera]", "[settings]\nexposure = 1100.0\n[camera]", "settings.exposure",
     "in [-64, 64]"),
    ("[camera]", "[settings]\nsize = [16384, 16384]\n[camera]", "settings.size",
     "at most 134217728 pixels"),
    ("[camera]", '[environment]\ntype = "sky"\nintensity = 1e37\n[camera]',
     "environment.intensity", "in [0, 1e+09]"),
    ("[camera]", "[camera]\nup = [0.0, 1e300, 0.0]", "camera.up[1]", "in [-1e+09, 1e+09]"),
    ("[camera]", "[settings]\nspp = 0\n[camera]", "settings.spp", "an integer >= 1"),
    ("alpha = 0.1", 'alpha = 0.1\n[materials.blue.period_map]\nprocedural = "stripes"\n'
     "range = [300.0, 200.0]", "materials.blue.period_map.range", "lo <= hi"),
    ("alpha = 0.1", 'alpha = 0.1\n[materials.blue.delta_map]\nprocedural = "stripes"\n'
     "range = [0.2, 1.2]", "materials.blue.delta_map.range[1]", "in [0, 1]"),
    ("alpha = 0.1", 'alpha = 0.1\n[materials.blue.delta_map]\nprocedural = "noise"\n'
     "range = [0.2, 0.8]\nscale = 2e7", "materials.blue.delta_map.scale", "in (0, 1.67772e+07]"),
])
def test_out_of_range_numbers_are_refused(tmp_path, old, new, key, accepted):
    message = refused(tmp_path, MINIMAL.replace(old, new, 1))
    assert f": {key}: " in message
    assert accepted in message


def test_layers_the_library_cannot_stack_are_refused(tmp_path):
    second = "\n[[materials.blue.layers]]\nn1 = 1.4\nn2 = 1.6\nd1_nm = 100.0\nd2_nm = 100.0\n" \
             "N = 5\nalpha = 0.2\n"
    message = refused(tmp_path, MINIMAL.replace("alpha = 0.1\n", "alpha = 0.1\n" + second, 1))
    assert ": materials.blue.layers: every layer's mirror must share n1" in message


def test_unknown_material_names_are_refused_with_the_defined_ones(tmp_path):
    message = refused(tmp_path, MINIMAL.replace('material = "white"', 'material = "gold"'))
    assert "objects[1].material: unknown material 'gold'; defined: 'blue', 'white'" in message


@pytest.mark.parametrize(("old", "new", "key"), [
    ('shape = "sphere"', 'shape = "mesh"\npath = "missing.obj"', "objects[0].path"),
    ("alpha = 0.1", 'alpha = 0.1\n[materials.blue.period_map]\ntexture = "missing.png"\n'
     "range = [200.0, 300.0]", "materials.blue.period_map.texture"),
    ("[camera]", '[environment]\ntype = "exr"\npath = "missing.exr"\n[camera]',
     "environment.path"),
])
def test_missing_files_are_refused(tmp_path, old, new, key):
    message = refused(tmp_path, MINIMAL.replace(old, new, 1))
    # The path as the file writes it, then the folder it resolves against.
    written = re.search(r'(missing\.\w+)"', new).group(1)
    assert f': {key}: no such file: "{written}" (paths resolve against the scene file\'s ' \
           f"folder {tmp_path.resolve()})" in message


def test_files_of_unknown_types_are_refused(tmp_path):
    (tmp_path / "bunny.fbx").write_bytes(b"")
    message = refused(tmp_path, MINIMAL.replace('shape = "sphere"',
                                                'shape = "mesh"\npath = "bunny.fbx"'))
    assert "objects[0].path: must name a file of type .obj, .ply, .glb, .gltf, .stl" in message


def test_a_mesh_needs_a_path_and_only_a_mesh_takes_one(tmp_path):
    message = refused(tmp_path, MINIMAL.replace('shape = "sphere"', 'shape = "mesh"'))
    assert "objects[0].path: missing" in message
    (tmp_path / "m.obj").write_bytes(b"")
    message = refused(tmp_path, MINIMAL.replace('shape = "sphere"',
                                                'shape = "sphere"\npath = "m.obj"'))
    assert "objects[0].path: only mesh objects take a path" in message
    # The file system refuses the name itself: an OSError without the key, before.
    message = refused(tmp_path, MINIMAL.replace('shape = "sphere"',
                                                f'shape = "mesh"\npath = "{"m" * 300}.obj"'))
    assert "objects[0].path: cannot be read: File name too long" in message


def test_degenerate_geometry_is_refused(tmp_path):
    message = refused(tmp_path, MINIMAL.replace("look_at = [0.0, 0.0, 0.0]",
                                                "look_at = [0.0, 0.0, 4.0]"))
    assert "camera.look_at: must differ from camera.position" in message
    light = ('[[lights]]\ntype = "area"\ncorner = [0.0, 2.0, 0.0]\nedge_u = [1.0, 0.0, 0.0]\n'
             "edge_v = [2.0, 0.0, 0.0]\nradiance = 1.0\n")
    message = refused(tmp_path, MINIMAL + light)
    assert "lights[0].edge_v: must not be zero or parallel to edge_u" in message
    # Nearly parallel, relative to their lengths: the camera's frame was NaN, every ray lost.
    message = refused(tmp_path, MINIMAL.replace("[camera]", "[camera]\nup = [0.0, 1e-200, 1.0]"))
    assert "camera.up: must not be zero or parallel to look_at - position" in message
    message = refused(tmp_path, MINIMAL + light.replace("[2.0, 0.0, 0.0]", "[2.0, 1e-9, 0.0]"))
    assert "lights[0].edge_v: must not be zero or parallel to edge_u" in message
    tiny = MINIMAL.replace("[camera]", "[camera]\nup = [0.0, 1e-200, 1e-200]")
    assert load_scene(write(tmp_path, tiny)).camera.up == (0.0, 1e-200, 1e-200)


# ------------------------------------------------------------------------- loading runs nothing


def test_a_scene_that_tries_to_execute_is_just_data(tmp_path):
    sentinel = tmp_path / "pwned"
    payload = f"__import__('os').system('touch {sentinel}')"
    text = MINIMAL.replace("[materials.white]", f'[materials."{payload}"]').replace(
        'material = "white"', f'material = "{payload}"')
    loaded = load_scene(write(tmp_path, text))
    assert loaded.objects[1].material == payload
    assert isinstance(loaded.materials[payload], LambertianMaterial)

    for old, new, key in [
        ("fov_deg = 40.0", f'fov_deg = "{payload}"', "camera.fov_deg"),
        ('shape = "sphere"', f'shape = "mesh"\npath = "$(touch {sentinel}).obj"',
         "objects[0].path"),
        ("[camera]", '[settings]\nmode = "!!python/object/apply:os.system [\'touch x\']"\n'
                     "[camera]", "settings.mode"),
    ]:
        with pytest.raises(ValueError, match=re.escape(f": {key}: ")):
            load_scene(write(tmp_path, MINIMAL.replace(old, new, 1)))
    assert not sentinel.exists()
    assert not (tmp_path / "x").exists()


def test_base_interreflection_reaches_the_structure(tmp_path, no_filters):
    loaded = load_scene(write(tmp_path, MINIMAL.replace(
        "base_albedo = 0.5", "base_albedo = 0.5\nbase_interreflection = true", 1)))
    material = loaded.materials["blue"]
    assert material.base_interreflection
    assert material.to_structure().base_interreflection
    assert not load_scene(write(tmp_path, MINIMAL)).materials["blue"].base_interreflection
    message = refused(tmp_path, MINIMAL.replace(
        "base_albedo = 0.5", "base_albedo = 0.5\nbase_interreflection = 1", 1))
    assert ": materials.blue.base_interreflection: must be true or false, got 1" in message


def test_period_and_delta_convert_one_way_everywhere():
    """A layer given as (period, delta) has the thicknesses layer_thicknesses gives, in the
    reader, the spec and sweeps alike; period_and_delta inverts it."""
    from wgbragg.scene.model import BraggLayerSpec, layer_thicknesses, period_and_delta
    from wgbragg.sweep.spec import build_structure

    rng = np.random.default_rng(5)
    for period, delta in zip(rng.uniform(10, 500, 50), rng.uniform(0, 1, 50), strict=True):
        d1, d2 = layer_thicknesses(period, delta)
        assert d1 + d2 == pytest.approx(period, rel=1e-15)
        assert period_and_delta(d1, d2) == pytest.approx((period, delta), rel=1e-12)
        swept = build_structure("bragg-mirror", {"n1": 1.0, "n2": 1.5, "period_nm": period,
                                                 "delta": delta, "N": 5})
        assert (swept.d1, swept.d2) == (d1, d2)
        spec = BraggLayerSpec(1.0, 1.5, 100.0, 50.0, 5, 0.1).to_layer(period, delta).mirror
        assert (spec.d1, spec.d2) == (d1, d2)
    assert period_and_delta(0.0, 0.0) == (0.0, 0.5)
