"""The renderer's thin-film material (``type = "thin-film"``: GGX microfacets coated by a film,
Belcour & Barla 2017) on the device: RGB against spectral transport, the white furnace
against a numpy quadrature of the same BRDF, thickness maps, scenes mixing films with the
other materials, zero-thickness invariants, and the scene file's errors.

Images are tiny and seeds fixed. The file compiles six specialisations of the render pipeline
(RGB and spectral films, each with and without thickness maps, a scene of every material and a
Bragg layer alone), which is most of its time on lavapipe."""

from __future__ import annotations

import functools

import colour
import numpy as np
import pytest
from PIL import Image

from wgbragg import ThinFilm
from wgbragg.bsdf.microfacet import ggx_G1, ggx_sample_visible_normal
from wgbragg.render.renderer import Renderer
from wgbragg.scene import load_scene

# --------------------------------------------------------------------------------- helpers

_SPHERE = """
[camera]
position = [0.0, 0.0, 40.0]
look_at = [0.0, 0.0, 0.0]
fov_deg = 3.0

[environment]
type = "uniform"

[materials.film]
type = "thin-film"
{film}

[[objects]]
shape = "sphere"
material = "film"
"""


def _write(tmp_path, name: str, text: str):
    path = tmp_path / f"{name}.toml"
    path.write_text(text, encoding="utf-8")
    return load_scene(path)


def _sphere(tmp_path, name: str, film: str):
    return _write(tmp_path, name, _SPHERE.format(film=film))


def _lab(linear_srgb):
    xyz = colour.RGB_to_XYZ(linear_srgb, colour.RGB_COLOURSPACES["sRGB"],
                            apply_cctf_decoding=False)
    white = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    return colour.XYZ_to_Lab(xyz, white)


def _sphere_cosines(renderer):
    """For the pixel-centre rays: which hit the unit sphere at the origin, and the cosine
    between the normal and the direction to the camera there."""
    t, _ = renderer.primary_hits()
    origins, directions = renderer.camera_rays()
    hit = np.isfinite(t.ravel())
    normals = origins[hit] + directions[hit] * t.ravel()[hit, None]
    cosine = -(normals * directions[hit]).sum(axis=1) / np.linalg.norm(normals, axis=1)
    return hit, np.clip(cosine, 0.0, 1.0)


# ------------------------------------------------------------------------ RGB and spectral


@pytest.mark.parametrize("film", [
    "n_film = 1.33\nthickness_nm = 400.0\nn_base = 1.5\nalpha = 0.05",
    'n_film = 1.33\nthickness_nm = 400.0\nbase = "Au"\nalpha = 0.05',
], ids=["dielectric", "gold"])
def test_rgb_and_spectral_modes_agree_on_a_film_sphere(device, tmp_path, film):
    """A nearly smooth film sphere in a white environment shows the film's colour at each
    pixel's viewing angle: the Fourier-series colour (order 3) in RGB mode, the Airy
    reflectance at hero wavelengths in spectral mode. Seen almost orthographically, the angle
    depends on the distance from the image centre alone, so rings of pixels are averaged
    against the spectral noise; the colour issue's bounds are a mean dE2000 <= 0.5 and a
    maximum <= 1.5."""
    scene = _sphere(tmp_path, "film", film)
    rgb = Renderer(scene, size=(32, 32), seed=1, mode="rgb")
    hit, cosine = _sphere_cosines(rgb)
    rgb_image = rgb.render(128).reshape(-1, 3)[hit]
    spectral_image = Renderer(scene, size=(32, 32), seed=2, mode="spectral").render(
        512).reshape(-1, 3)[hit]
    assert np.isfinite(rgb_image).all() and np.isfinite(spectral_image).all()
    rings = np.minimum((cosine * 10).astype(int), 9)
    differences = []
    for ring in np.unique(rings):
        chosen = rings == ring
        differences.append(colour.delta_E(_lab(rgb_image[chosen].mean(axis=0)),
                                          _lab(spectral_image[chosen].mean(axis=0)),
                                          method="CIE 2000"))
    print(f"ring dE2000 {np.round(differences, 3)}")
    assert len(differences) >= 8
    assert np.mean(differences) <= 0.35 and np.max(differences) <= 1.2


# ----------------------------------------------------------------------------- the furnace


@functools.cache
def _film_albedo(n_film: float, d: float, alpha: float, method: str):
    """Directional albedo of the film BRDF against cos(theta_i), by a stratified quadrature
    over GGX visible normals: E[R(wi.m) G1(wo)], the renderer's BRDF-sampling weight, with R
    the film's linear sRGB colour (``method``) interpolated in angle."""
    film = ThinFilm(n_film, d)
    theta = np.linspace(0.0, 0.5 * np.pi, 721)
    colour_table = film.rgb(theta, method=method)
    cos_i = np.linspace(0.0, 1.0, 41)
    cos_i[0] = 1e-3
    u = (np.stack(np.meshgrid(np.arange(96), np.arange(96)), axis=-1).reshape(-1, 2)
         + 0.5) / 96.0
    albedo = np.zeros((cos_i.size, 3))
    for k, c in enumerate(cos_i):
        wi = np.array([np.sqrt(1.0 - c * c), 0.0, c])
        m = ggx_sample_visible_normal(wi, u, alpha)
        cos_d = np.clip(m @ wi, 0.0, 1.0)
        wo = 2.0 * cos_d[:, None] * m - wi
        weight = ggx_G1(np.clip(wo[:, 2], -1.0, 1.0), alpha)
        theta_d = np.arccos(cos_d)
        reflectance = np.stack([np.interp(theta_d, theta, colour_table[:, j])
                                for j in range(3)], axis=-1)
        albedo[k] = (reflectance * weight[:, None]).mean(axis=0)
    return cos_i, albedo


@pytest.mark.parametrize("mode", ["rgb", "spectral"])
def test_white_furnace_matches_a_quadrature_of_the_brdf(device, tmp_path, mode):
    """A free-standing, non-absorbing film (index 2.4 in air) in a uniform environment of
    radiance 1: the sphere alone reflects only the environment, so each pixel is the BRDF's
    directional albedo at its viewing angle, never above 1. The albedo comes from a numpy
    quadrature over visible normals with the film's colour by the same method as the mode
    (Fourier table of order 3, or the reference spectral integral)."""
    scene = _sphere(tmp_path, "furnace", "n_film = 2.4\nthickness_nm = 300.0\nalpha = 0.3")
    renderer = Renderer(scene, size=(24, 24), seed=5, mode=mode)
    hit, cosine = _sphere_cosines(renderer)
    image = renderer.render(512 if mode == "rgb" else 1024)
    assert np.isfinite(image).all()
    got = image.reshape(-1, 3)[hit]
    # The sphere's pixels (the background is the environment, 1 up to spectral noise).
    print(f"furnace {mode}: brightest sphere pixel {got.max():.4f}")
    assert got.max() <= 1.0 + 0.02
    method = "fourier-table" if mode == "rgb" else "reference"
    cos_i, albedo = _film_albedo(2.4, 300.0, 0.3, method)
    expected = np.stack([np.interp(cosine, cos_i, albedo[:, j]) for j in range(3)], axis=-1)
    # Pixels well inside the silhouette: jittered samples near its edge see the environment.
    inner = cosine > 0.3
    mean_got, mean_expected = got[inner].mean(axis=0), expected[inner].mean(axis=0)
    print(f"furnace {mode}: image {mean_got} quadrature {mean_expected}")
    np.testing.assert_allclose(mean_got, mean_expected, rtol=0.01)
    rings = np.minimum((cosine * 5).astype(int), 4)
    for ring in range(1, 5):
        chosen = inner & (rings == ring)
        error = np.abs(got[chosen].mean(axis=0) / expected[chosen].mean(axis=0) - 1.0).max()
        print(f"  ring {ring}: relative error {error:.4f}")
        assert error <= 0.03, (ring, error)
    # The film does colour the sphere: the albedo is far from grey somewhere.
    assert np.ptp(mean_expected) > 0.02


# ------------------------------------------------------------------------- thickness maps

_PLANE = """
[camera]
position = [0.0, 4.0, 0.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 0.0, -1.0]
fov_deg = 20.0

[environment]
type = "uniform"

[materials.film]
type = "thin-film"
n_film = 1.33
base = "Au"
alpha = 0.1
{thickness}

[[objects]]
shape = "plane"
material = "film"
"""


@pytest.mark.parametrize("mode", ["rgb", "spectral"])
def test_a_thickness_texture_sets_each_points_film(device, tmp_path, mode):
    """The plane's u runs left to right in the image; a texture black on its left half and
    white on its right makes the film 250 nm thick there and 450 nm here: each side renders
    as the uniform film of that thickness (the same seed draws the same paths)."""
    texture = np.zeros((4, 64), np.uint8)
    texture[:, 32:] = 255
    Image.fromarray(texture, "L").save(tmp_path / "halves.png")
    maps = 'thickness_map = { texture = "halves.png", range = [250.0, 450.0] }'
    mapped = Renderer(_write(tmp_path, "mapped", _PLANE.format(thickness=maps)),
                      size=(16, 16), seed=2, mode=mode).render(64)
    assert np.isfinite(mapped).all()
    sides = []
    for d, columns in ((250.0, slice(2, 6)), (450.0, slice(10, 14))):
        uniform = Renderer(_write(tmp_path, f"uniform{d:g}",
                                  _PLANE.format(thickness=f"thickness_nm = {d}")),
                           size=(16, 16), seed=2, mode=mode).render(64)
        got, want = mapped[2:14, columns], uniform[2:14, columns]
        error = np.abs(got - want).max()
        print(f"{mode} {d:g} nm: mapped {got.mean(axis=(0, 1))} uniform "
              f"{want.mean(axis=(0, 1))}, max |difference| {error:.2e}")
        assert error <= 1e-6  # measured: 0
        sides.append(got.mean(axis=(0, 1)))
    # The two thicknesses look different: the map did something.
    assert np.abs(sides[0] - sides[1]).max() > 0.05


# ---------------------------------------------------------------------------------- mixing

_MIXED = """
[camera]
position = [0.0, 5.0, 4.0]
look_at = [0.0, 0.0, 0.0]
fov_deg = 40.0

[environment]
type = "uniform"
"""

_MATERIALS = {
    "gold_film": """
[materials.gold_film]
type = "thin-film"
n_film = 1.45
thickness_nm = 300.0
base = "Au"
alpha = 0.15
""",
    "glass_film": """
[materials.glass_film]
type = "thin-film"
n_film = 2.0
thickness_nm = 350.0
n_base = 1.5
alpha = 0.1
""",
    "bragg": """
[materials.bragg]
type = "layered-bragg"
[[materials.bragg.layers]]
n1 = 1.0
n2 = 1.5
period_nm = 200.0
delta = 0.5
N = 10
alpha = 0.1
""",
    "grey": """
[materials.grey]
type = "lambertian"
albedo = 0.5
""",
}

# Four coplanar squares, one per material: none can see another.
_TILES = {"gold_film": (-1.0, -1.0), "glass_film": (1.0, -1.0), "bragg": (-1.0, 1.0),
          "grey": (1.0, 1.0)}


def _tiles(names) -> str:
    """The scene with the tiles of ``names`` and their materials only."""
    return _MIXED + "".join(_MATERIALS[name] for name in names) + "".join(f"""
[[objects]]
shape = "plane"
material = "{name}"
translate = [{_TILES[name][0]}, 0.0, {_TILES[name][1]}]
scale = 0.95
""" for name in names)


def test_films_mix_with_every_material(device, tmp_path):
    """Films on a metal and on a dielectric, a Bragg layer and a Lambertian surface in one
    scene: the films then share the metal's Fourier windows, the pipeline every material's
    code. Each object must look as it does alone (the same seed draws the same paths, so only
    the windows' interpolation differs), the Lambertian one as the furnace says (its albedo)."""
    mixed = _write(tmp_path, "mixed", _tiles(_TILES))
    renderer = Renderer(mixed, size=(32, 32), seed=3, mode="rgb")
    t, _ = renderer.primary_hits()
    image = renderer.render(64)
    assert np.isfinite(image).all()
    origins, directions = renderer.camera_rays()
    points = (origins + directions * np.where(np.isfinite(t), t, 0.0).reshape(-1, 1)).reshape(
        32, 32, 3)
    colours = {}
    for name, (x, z) in _TILES.items():
        # Pixels whose whole footprint lies on the tile, away from its edges.
        inside = (np.isfinite(t) & (np.abs(points[..., 0] - x) < 0.75)
                  & (np.abs(points[..., 2] - z) < 0.75))
        assert inside.sum() >= 20, name
        if name == "grey":
            print(f"grey: mixed {image[inside].mean(axis=0)}")
            np.testing.assert_allclose(image[inside].mean(axis=0), 0.5, rtol=0.01)
            continue
        alone = Renderer(_write(tmp_path, name, _tiles([name])), size=(32, 32),
                         seed=3, mode="rgb").render(64)
        error = np.abs(image[inside] - alone[inside]).max()
        print(f"{name}: mixed {image[inside].mean(axis=0)} alone "
              f"{alone[inside].mean(axis=0)}, max |difference| {error:.2e}")
        # Measured: 0 for the gold film and the Bragg layer, whose buffers are those they have
        # alone; 3e-6 for the glass film, whose colour the metal's windows interpolate.
        assert error <= (1e-5 if name == "glass_film" else 1e-6), name
        colours[name] = image[inside].mean(axis=0)
    # Three distinct colours: no material read another's records.
    values = list(colours.values())
    assert min(np.abs(a - b).max() for i, a in enumerate(values) for b in values[i + 1:]) > 0.02


# ------------------------------------------------------------------------- zero thickness


@pytest.mark.parametrize("mode", ["rgb", "spectral"])
def test_a_film_of_no_thickness_or_of_the_base_index_is_the_bare_base(device, tmp_path, mode):
    """With d = 0, or a film of the base's own index, the Airy sum collapses to the bare
    interface's Fresnel reflectance, whatever the other parameter. A film of the base's index
    has r23 = 0, which every method gives exactly, whatever its thickness. At d = 0, spectral
    mode's Airy formula is exact for any film index; RGB mode's Fourier series stops after
    (r12 r23)^3, so there the images may differ by at most the remainder in the film's colour
    (the BRDF is linear in it and its albedo weight is below 1), computed in numpy."""
    films = {"matched": (1.5, 0.0), "matched thick": (1.5, 400.0), "soap": (1.33, 0.0),
             "dense": (2.0, 0.0)}
    images = {}
    for k, (name, (n, d)) in enumerate(films.items()):
        film = f"n_film = {n}\nthickness_nm = {d}\nn_base = 1.5\nalpha = 0.2"
        images[name] = Renderer(_sphere(tmp_path, f"bare{k}", film), size=(12, 12), seed=8,
                                mode=mode).render(16)
    bare = images["matched"]
    assert bare.max() > 0.0
    theta = np.linspace(0.0, 0.5 * np.pi, 181)
    exact = ThinFilm(1.5, 0.0, 1.5).rgb(theta, method="fourier-table")
    for name in ("matched thick", "soap", "dense"):
        error = np.abs(images[name] - bare).max()
        bound = 2e-6
        if mode == "rgb" and name != "matched thick":
            colour_error = ThinFilm(films[name][0], 0.0, 1.5).rgb(theta, method="fourier-table")
            bound += np.abs(colour_error - exact).max()
        print(f"{mode} {name}: max |difference| {error:.2e} (bound {bound:.2e})")
        assert error <= bound, name
    if mode == "spectral":
        # Over gold too: the exact Airy formula has no truncation.
        gold = [Renderer(_sphere(tmp_path, f"gold{k}", f"n_film = {n}\nthickness_nm = 0.0\n"
                                                       'base = "Au"\nalpha = 0.2'),
                         size=(12, 12), seed=8, mode=mode).render(16) for k, n in
                enumerate((1.33, 2.0))]
        error = np.abs(gold[1] - gold[0]).max()
        print(f"gold: max |difference| {error:.2e}")
        assert gold[0].max() > 0.1 and error <= 2e-6


# ------------------------------------------------------------------------------ scene files

_FILM_FILE = """
[camera]
position = [0.0, 0.0, 4.0]
look_at = [0.0, 0.0, 0.0]
fov_deg = 35.0

[materials.soap]
type = "thin-film"
{film}

[[objects]]
shape = "sphere"
material = "soap"
"""


@pytest.mark.parametrize(("film", "match"), [
    ('n_film = 1.33\nalpha = 0.2\nthickness_nm = 400.0\n'
     'thickness_map = { procedural = "noise", range = [200.0, 700.0] }',
     r"materials\.soap: give the film's thickness as thickness_nm or as thickness_map"),
    ("n_film = 1.33\nalpha = 0.2", r"materials\.soap: give the film's thickness"),
    ('n_film = 1.33\nalpha = 0.2\nthickness_nm = 400.0\nbase = "Au"\nn_base = 1.5',
     r"materials\.soap\.base: a metal base replaces n_base and k_base"),
    ('n_film = 1.33\nalpha = 0.2\nthickness_nm = 400.0\nbase = "Au"\nk_base = 2.0',
     r"materials\.soap\.base: a metal base replaces"),
    ("n_film = 1.33\nalpha = 1.5\nthickness_nm = 400.0", r"materials\.soap\.alpha"),
    ("n_film = 1.33\nalpha = 0.001\nthickness_nm = 400.0", r"materials\.soap\.alpha"),
    ('n_film = 1.33\nalpha = 0.2\nthickness_nm = 400.0\nbase = "Pt"',
     r"materials\.soap\.base: must be one of 'Ag', 'Al', 'Au', 'Cu'"),
    ("n_film = 1.33\nalpha = 0.2\nthickness_nm = -5.0", r"materials\.soap\.thickness_nm"),
    ("n_film = 0.0\nalpha = 0.2\nthickness_nm = 400.0", r"materials\.soap\.n_film"),
    ("n_film = 1.33\nalpha = 0.2\nthickness_nm = 400.0\nk_base = -1.0",
     r"materials\.soap\.k_base"),
    ("thickness_nm = 400.0\nalpha = 0.2", r"materials\.soap\.n_film: missing"),
    ("n_film = 1.33\nalpha = 0.2\nthickness_nm = 400.0\nperiod_nm = 200.0",
     r"materials\.soap\.period_nm: unknown key"),
    ('n_film = 1.33\nalpha = 0.2\nthickness_map = { procedural = "waves", range = [1.0, 2.0] }',
     r"materials\.soap\.thickness_map\.procedural: must be one of"),
    ('n_film = 1.33\nalpha = 0.2\nthickness_map = { procedural = "noise", range = [700.0, '
     "200.0] }", r"materials\.soap\.thickness_map\.range: must be \[lo, hi\] with lo <= hi"),
    ('n_film = 1.33\nalpha = 0.2\nthickness_map = { texture = "missing.png", range = [1.0, '
     "2.0] }", r"materials\.soap\.thickness_map\.texture: no such file"),
], ids=["both thicknesses", "no thickness", "metal and n_base", "metal and k_base", "alpha high",
        "alpha low", "unknown metal", "negative thickness", "n_film zero", "negative k_base",
        "no n_film", "unknown key", "unknown map", "reversed range", "missing texture"])
def test_bad_thin_films_name_the_key(tmp_path, film, match):
    path = tmp_path / "scene.toml"
    path.write_text(_FILM_FILE.format(film=film), encoding="utf-8")
    with pytest.raises(ValueError, match=match):
        load_scene(path)


def test_a_thin_film_scene_is_parsed(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(_FILM_FILE.format(film='n_film = 1.33\nalpha = 0.2\nbase = "Cu"\n'
                                           'thickness_map = { procedural = "noise", '
                                           "range = [200.0, 700.0], scale = 4.0 }"),
                    encoding="utf-8")
    material = load_scene(path).materials["soap"]
    assert (material.n_film, material.alpha, material.base) == (1.33, 0.2, "Cu")
    assert material.thickness_map.procedural == "noise"
    assert material.thickness_map.range == (200.0, 700.0)
    film = material.to_film(520.0)
    assert film.d == 520.0 and film.dispersive
