"""The path tracer (wgbragg.render.renderer, wgsl/render/renderer.wgsl) converges to independent
numpy integrations
of its models: the procedural environments seen by missed camera rays against their float64 twin
(wgbragg.lighting.procedural_environment), and a sphere under the studio environment against a
deterministic quadrature of the reflected radiance, for a Lambertian, a layered Bragg and a
coated layered Bragg material, and in spectral mode.

The sphere is the built-in unit sphere (exact), seen by a nearly orthographic camera (40 units
away, 3 deg field of view). The reference integrates, per pixel,

    L = int f(wi, wo) L_env(wo) cos(theta_o) dwo  (+ R_c(theta_i) L_env(mirror of wi))

over the directions above the sphere's normal (the geometric and the shading normal, as the
shader's next-event estimation and BSDF sampling both require). The sphere is convex, so a path
escapes after its first bounce and the environment is all the light there is. Quadrature:
Gauss-Legendre in sqrt(y) over the upper hemisphere (the sky's gradient is linear in it, and
the horizon's jump is a grid line), Gauss-Legendre in y below, the key light's cone apart (its
edge is then a grid line too), and uniform steps in azimuth. The render is a box-filtered pixel
(jittered rays), so the smooth continuous part is box-filtered through its centre values and
their second differences, and the coating's mirror image (sharp edges) is averaged over sub-
pixel rays. Only pixels whose 3 x 3 neighbourhood lies on the sphere are compared.

Measured on lavapipe (2 cores), SMAPE over the 120 pixels compared: 0.0072 (Lambertian,
8192 spp), 0.0089 (layered, 8192 spp), 0.0078 (coated, 12288 spp), 0.0098 (spectral layered,
8192 spp). Longer renders bring it down as 1 / sqrt(spp), to 0.0024 to 0.0038 at 65536 spp,
with no floor in sight: Monte Carlo noise. The means over the sphere agree within 0.1% (0.25%
spectral). The file runs in about 45 s.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.interpolate import RegularGridInterpolator
from scipy.ndimage import binary_erosion, maximum_filter, minimum_filter

from wgbragg.bsdf.layered.model import LUT_RESOLUTION_DEG, coating_reflectance
from wgbragg.colour import colorimetry
from wgbragg.common.metrics import smape as paper_smape
from wgbragg.lighting.procedural_environment import ProceduralEnvironment, environment_radiance
from wgbragg.render import PARAMS_DTYPE, Renderer
from wgbragg.render import packing as packing_module
from wgbragg.scene import Camera, Environment, load_scene

SIZE = 16  # pixels a side: the sphere is about 15 pixels across
SMAPE_LIMIT = 0.02
QUADRATURE = (32, 128, 12)  # nodes in elevation, in azimuth, and across the disc's radius
LUT = "single-reflection-lut"

_SPHERE_SCENE = """
[camera]
position = [0.0, 0.0, 40.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov_deg = 3.0

[environment]
type = "studio"

[materials.m]
{material}

[[objects]]
shape = "sphere"
material = "m"
"""

_LAMBERTIAN = 'type = "lambertian"\nalbedo = 0.5'
_LAYERED = """type = "layered-bragg"
base_albedo = 0.5
[[materials.m.layers]]
n1 = {n1}
n2 = 1.5
period_nm = 500.0
delta = 0.5
N = 10
alpha = 0.2"""

MATERIALS = {
    "lambertian": _LAMBERTIAN,
    "layered": _LAYERED.format(n1=1.0),
    "coated": _LAYERED.format(n1=1.35),
}
# Samples per pixel, for SMAPE about 0.4 of the limit: the coating's mirror lobe, drawn with its
# Fresnel probability (about 4%), makes the coated sphere the noisiest.
SPP = {"lambertian": 8192, "layered": 8192, "coated": 12288}
SPP_SPECTRAL = 8192


def smape(a, b, floor: float = 1e-4) -> float:
    """Symmetric mean absolute percentage error ``mean |a - b| / ((|a| + |b|) / 2)`` over all
    pixels and channels, leaving out the values where both are below ``floor``.

    The stricter convention: twice the Bragg paper's ``mean |a - b| / (|a| + |b|)``."""
    a, b = np.ravel(a), np.ravel(b)
    kept = 0.5 * (np.abs(a) + np.abs(b)) > floor
    return 2.0 * paper_smape(a[kept], b[kept])


def _scene(folder, material: str):
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "sphere.toml"
    path.write_text(_SPHERE_SCENE.format(material=material), encoding="utf-8")
    return load_scene(path)


# ----------------------------------------------------------------------------- camera, hits


def _camera_directions(camera, width: int, height: int, x, y) -> np.ndarray:
    """Unit directions through image points (x, y) in pixels from the top left: the pinhole
    model of the scene docs, written out again rather than read from the renderer."""
    origin = np.asarray(camera.position, np.float64)
    forward = np.asarray(camera.look_at, np.float64) - origin
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, camera.up)
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    half = math.tan(math.radians(camera.fov_deg) / 2.0)
    ndc_x = (2.0 * np.asarray(x, np.float64) / width - 1.0)[..., None]
    ndc_y = (1.0 - 2.0 * np.asarray(y, np.float64) / height)[..., None]
    d = forward + ndc_x * right * (half * width / height) + ndc_y * up * half
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def _pixel_grid(width: int, height: int, k: int):
    """Image points of k x k sub-pixel centres, shape (height, width, k, k)."""
    sub = (np.arange(k) + 0.5) / k
    y = np.arange(height)[:, None, None, None] + sub[None, None, :, None]
    x = np.arange(width)[None, :, None, None] + sub[None, None, None, :]
    return np.broadcast_arrays(x, y)


def _shading(renderer: Renderer, directions: np.ndarray):
    """Hit mask, shading and geometric normals of camera rays, as surface_at makes them.

    The scene's one sphere is exact: the float64 intersection of the rays with the image of
    the unit sphere under its map (Renderer.world_geometry), whose normal is the gradient
    M^-T p of the hit's point p on the unit sphere. Both normals face the viewer.
    """
    shape = directions.shape[:-1]
    d = directions.reshape(-1, 3)
    (to_world,) = renderer.world_geometry().sphere_to_world
    inverse = np.linalg.inv(to_world[:, :3])
    origin = inverse @ (np.asarray(renderer.scene.camera.position, np.float64) - to_world[:, 3])
    local = d @ inverse.T
    a, b, c = np.sum(local * local, axis=1), local @ origin, origin @ origin - 1.0
    discriminant = b * b - a * c
    hit = discriminant >= 0.0
    t = (-b - np.sqrt(np.where(hit, discriminant, 0.0))) / a
    normal = (origin + t[:, None] * local) @ inverse
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    normal = np.where(np.sum(normal * d, axis=1, keepdims=True) > 0.0, -normal, normal)
    return hit.reshape(shape), normal.reshape(*shape, 3), normal.reshape(*shape, 3)


def _tangents(n: np.ndarray):
    """Any unit tangents (x, y) with (x, y, n) right-handed: the models are isotropic, so the
    frame's rotation about n does not matter."""
    helper = np.where(np.abs(n[..., :1]) < 0.9, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    x = np.cross(helper, n)
    x /= np.linalg.norm(x, axis=-1, keepdims=True)
    return x, np.cross(n, x)


# ----------------------------------------------------------------------------- quadrature


def _rings(cos_nodes: np.ndarray, cos_weights: np.ndarray, azimuths: int):
    """Directions about +y at the given cosines, uniform in azimuth, and their weights (sr)."""
    phi = (np.arange(azimuths) + 0.5) * (2.0 * math.pi / azimuths)
    c = cos_nodes[:, None]
    s = np.sqrt(np.maximum(0.0, 1.0 - c * c))
    d = np.stack(np.broadcast_arrays(s * np.cos(phi), c, s * np.sin(phi)), axis=-1)
    return d.reshape(-1, 3), np.repeat(cos_weights * (2.0 * math.pi / azimuths), azimuths)


def environment_quadrature(env: ProceduralEnvironment, elevations: int, azimuths: int,
                           disc_radii: int):
    """Directions (M, 3) and radiance times solid angle weight (M, 3): the sphere's integral
    of a smooth function times the environment is their weighted sum.

    Upper hemisphere: Gauss-Legendre in s = sqrt(y), dw = 2 s ds dphi; lower: in y. The disc
    is a cone of its own (Gauss-Legendre in the cosine about its axis), added on top as the
    shader adds it.
    """
    x, w = np.polynomial.legendre.leggauss(elevations)
    s, ws = 0.5 * (x + 1.0), 0.5 * w
    upper, upper_w = _rings(s * s, 2.0 * s * ws, azimuths)
    lower, lower_w = _rings(0.5 * (x - 1.0), 0.5 * w, azimuths)
    directions = [upper, lower]
    values = [env.radiance(upper, disc=False) * upper_w[:, None],
              env.radiance(lower, disc=False) * lower_w[:, None]]
    if env.has_disc:
        xd, wd = np.polynomial.legendre.leggauss(disc_radii)
        half = 0.5 * (1.0 - env.disc_cos)
        cone, cone_w = _rings(env.disc_cos + half * (xd + 1.0), half * wd, 2 * disc_radii)
        axis = env.disc_direction
        tx, ty = _tangents(axis)
        directions.append(cone[:, :1] * tx + cone[:, 1:2] * axis + cone[:, 2:] * ty)
        values.append(env.disc_radiance * cone_w[:, None])
    return np.concatenate(directions), np.concatenate(values)


def continuous_radiance(brdf, wi, shading, geometric, directions, values,
                        chunk: int = 262144) -> np.ndarray:
    """``sum f(wi, d) cos(theta_d) L w`` over the quadrature's directions above both normals.

    Parameters
    ----------
    brdf : callable or float
        ``brdf(to_light, to_viewer) -> (..., 3)``, linear sRGB in 1/sr, for unit directions
        in the shading frame (+z the shading normal); or a Lambertian albedo.
    wi, shading, geometric : numpy.ndarray, shape (P, 3)
        World directions towards the viewer and the normals of P shading points.
    directions, values : numpy.ndarray
        From :func:`environment_quadrature`.

    Returns
    -------
    numpy.ndarray, shape (P, 3)
    """
    cos = shading @ directions.T
    above = (cos > 0.0) & (geometric @ directions.T > 0.0)
    cos_i = np.sum(wi * shading, axis=-1)
    if not callable(brdf):
        return brdf / math.pi * ((cos * above) @ values) * (cos_i > 0.0)[:, None]
    tx, ty = _tangents(shading)
    wi_local = np.stack([np.sum(wi * tx, -1), np.sum(wi * ty, -1), cos_i], axis=-1)
    point, node = np.nonzero(above)
    total = np.zeros((len(wi), 3))
    for start in range(0, len(point), chunk):
        p, m = point[start:start + chunk], node[start:start + chunk]
        d = directions[m]
        light = np.stack([np.sum(d * tx[p], -1), np.sum(d * ty[p], -1), cos[p, m]], axis=-1)
        light /= np.linalg.norm(light, axis=-1, keepdims=True)
        term = brdf(light, wi_local[p]) * (cos[p, m, None] * values[m])
        for c in range(3):
            total[:, c] += np.bincount(p, term[:, c], minlength=len(wi))
    # The shader ends a path whose viewer is below the interpolated normal.
    return total * (cos_i > 0.0)[:, None]


def box_filtered(centre: np.ndarray) -> np.ndarray:
    """The mean of a smooth image over each pixel from its centre values: f + (f_xx + f_yy) / 24
    with second differences (exact for cubics); wrong on the border, which wraps around."""
    laplacian = (np.roll(centre, 1, 0) + np.roll(centre, -1, 0) + np.roll(centre, 1, 1)
                 + np.roll(centre, -1, 1) - 4.0 * centre)
    return centre + laplacian / 24.0


def mirror_radiance(renderer: Renderer, env: ProceduralEnvironment, host: float,
                    k: int = 8) -> np.ndarray:
    """The coating's Dirac reflection, ``R_c(theta_i) L_env(mirror direction)``, averaged over
    k x k sub-pixel rays per pixel, shape (height, width, 3)."""
    width, height = renderer.width, renderer.height
    x, y = _pixel_grid(width, height, k)
    d = _camera_directions(renderer.scene.camera, width, height, x, y)
    hit, shading, geometric = _shading(renderer, d)
    cos_i = -np.sum(d * shading, axis=-1)
    mirror = d + 2.0 * cos_i[..., None] * shading
    # The shader follows the mirror ray only if it leaves the face it starts from.
    seen = hit & (cos_i > 0.0) & (np.sum(mirror * geometric, axis=-1) > 0.0)
    value = coating_reflectance(np.clip(cos_i, 0.0, 1.0), host)[..., None] * env.radiance(mirror)
    return np.where(seen[..., None], value, 0.0).mean(axis=(2, 3))


def sphere_reference(renderer: Renderer, brdf, host: float = 1.0,
                     quadrature=QUADRATURE):
    """The numpy image of the sphere scene, and the mask of the pixels to compare.

    Parameters
    ----------
    renderer : Renderer
        Only its scene, size and (numpy) BVH are used.
    brdf : callable or float
        As for :func:`continuous_radiance`.
    host : float
        The coating's index (1: no coating, no mirror term).
    quadrature : tuple of 3 ints
        :func:`environment_quadrature`'s resolution.
    """
    width, height = renderer.width, renderer.height
    y, x = np.mgrid[0:height, 0:width] + 0.5
    d = _camera_directions(renderer.scene.camera, width, height, x, y)
    hit, shading, geometric = _shading(renderer, d)
    env = ProceduralEnvironment.from_scene(renderer.scene.environment)
    directions, values = environment_quadrature(env, *quadrature)
    centre = np.zeros((height, width, 3))
    centre[hit] = continuous_radiance(brdf, -d[hit], shading[hit], geometric[hit], directions,
                                      values)
    image = box_filtered(centre)
    if host != 1.0:
        image += mirror_radiance(renderer, env, host)
    # A pixel whose 3 x 3 neighbourhood is hit lies on the sphere, which is convex.
    inner = binary_erosion(hit, np.ones((3, 3), bool), border_value=0)
    return image, inner


# ----------------------------------------------------------------------------- materials


def _fill_mirror_colours(structure) -> None:
    """Fill the numpy model's table of each mirror's "averaged" colour over theta_d from the
    GPU twin of the colour method, after checking some of its rows against numpy.

    The whole numpy table takes over 10 s per mirror on two cores, the GPU twin
    (wgbragg.colour.landmark_methods_gpu, checked against numpy in test_colour_landmarks_gpu) about
    one; every other part of the model stays numpy float64. Should the table's cache key
    change, the model simply builds its own table, more slowly.
    """
    grid = np.radians(np.arange(0.0, 90.0 + LUT_RESOLUTION_DEG / 2, LUT_RESOLUTION_DEG))
    rows = np.arange(0, grid.size, 60)
    for index, layer in enumerate(structure.layers):
        table = layer.mirror.rgb(grid, method="averaged", backend="gpu")
        np.testing.assert_allclose(
            table[rows], layer.mirror.rgb(grid[rows], method="averaged"), atol=2e-4)
        structure._cached(("rgb", index, "numpy", "averaged"), lambda table=table: table)


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    folder = tmp_path_factory.mktemp("convergence")
    return {name: _scene(folder / name, material) for name, material in MATERIALS.items()}


@pytest.fixture(scope="module")
def structures(scenes):
    """The LayeredBragg of each layered material, its colour tables filled."""
    out = {}
    for name in ("layered", "coated"):
        out[name] = scenes[name].materials["m"].to_structure()
        _fill_mirror_colours(out[name])
    return out


def _factored(structure):
    """The renderer's RGB model of a layered material, eq 34 in numpy float64."""
    return lambda light, viewer: structure.brdf(light, viewer, method=LUT,
                                                colour_method="averaged")


def _spectral(material):
    """The colour of the spectral model (eq 34 on 1 nm nodes, ``colour_method="integrated"``)
    of an uncoated single layer over a base, as ``brdf(to_light, to_viewer)``, at the cost
    of an RGB one.

    Eq 34 is then ``f_1(i, o) + rho / pi t(i) t(o)``. The lobe ``f_1`` is a scalar times the
    mirror's reflectance, so its exact colour is the factored one with the mirror's exact
    (``"reference"``) colour. The base's term, the spectral model with the base less the one
    without, is ``q(theta_i) q(theta_o)`` per wavelength with ``q = sqrt(rho / pi) t``: read
    at theta_i = theta_o on the transmissivity tables' 0.25 deg grid (between whose nodes the
    model is linear in theta), its colour over every pair of nodes is a matrix product, and
    bilinear interpolation between them is exact. Checked against the integrated model
    itself at random pairs.
    """
    with_base = material.to_structure()
    absorbing = dataclasses.replace(material, base_albedo=None).to_structure()
    assert not with_base.has_coating and len(with_base.layers) == 1
    theta = np.radians(np.arange(0.0, 90.0 + LUT_RESOLUTION_DEG / 2, LUT_RESOLUTION_DEG))
    wi = np.stack([np.sin(theta), np.zeros_like(theta), np.cos(theta)], axis=-1)[:, None]
    wo = np.stack([np.zeros_like(theta), np.sin(theta), np.cos(theta)], axis=-1)[:, None]
    grid, weights = colorimetry.xyz_weights()
    base = (with_base.brdf(wo, wi, grid, method=LUT)
            - absorbing.brdf(wo, wi, grid, method=LUT))
    q = np.sqrt(np.maximum(base, 0.0))
    xyz = np.stack([(q * weights[:, c]) @ q.T for c in range(3)], axis=-1)
    base_term = RegularGridInterpolator((theta, theta), colorimetry.xyz_to_linear_srgb(xyz))

    def brdf(light, viewer):
        cosines = np.stack([light[..., 2], viewer[..., 2]], axis=-1)
        return (absorbing.brdf(light, viewer, method=LUT, colour_method="reference")
                + base_term(np.arccos(np.clip(cosines, 0.0, 1.0))))

    rng = np.random.default_rng(2)
    pairs = rng.normal(size=(2, 64, 3))
    pairs[..., 2] = np.abs(pairs[..., 2])
    pairs /= np.linalg.norm(pairs, axis=-1, keepdims=True)
    exact = with_base.brdf(pairs[0], pairs[1], method=LUT, colour_method="integrated")
    np.testing.assert_allclose(brdf(pairs[0], pairs[1]), exact, rtol=1e-3, atol=1e-4)
    return brdf


# ----------------------------------------------------------------------------- tests


@pytest.mark.parametrize("kind", ["uniform", "sky", "studio"])
def test_twin_reads_what_the_renderer_uploads(kind):
    environment = Environment(kind, radiance=(0.2, 0.5, 0.9), intensity=1.5)
    params = np.zeros((), PARAMS_DTYPE)
    packing_module._environment(environment, params)
    twin = ProceduralEnvironment.from_scene(environment)
    for name in ("zenith", "horizon", "ground", "disc_radiance", "disc_direction"):
        np.testing.assert_allclose(getattr(twin, name), params[name], rtol=1e-6, atol=1e-7)
    assert twin.disc_cos == pytest.approx(float(params["disc_cos"]), rel=1e-7)
    assert twin.has_disc == (kind != "uniform")


def test_twin_values():
    studio = ProceduralEnvironment.from_scene(Environment("studio", intensity=2.0))
    np.testing.assert_allclose(studio.radiance([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0],
                                                [0.0, -1.0, 0.0], [0.0, 0.25, -0.968246]]),
                               [[1.2] * 3, [0.7] * 3, [0.06] * 3, [0.95] * 3], rtol=1e-6)
    # The key light: 15 deg about elevation 45 deg, azimuth -45 deg, radiance 6 x 2 on top.
    axis = studio.disc_direction
    np.testing.assert_allclose(axis, [-0.5, math.sqrt(0.5), 0.5], atol=1e-15)
    tx, _ = _tangents(axis)
    for degrees, added in ((14.99, 12.0), (15.01, 0.0)):
        angle = math.radians(degrees)
        d = math.cos(angle) * axis + math.sin(angle) * tx
        difference = studio.radiance(d) - studio.radiance(d, disc=False)
        np.testing.assert_allclose(difference, added)
    assert studio.disc_solid_angle == pytest.approx(2.0 * math.pi * (1.0 - math.cos(
        math.radians(15.0))))
    with pytest.raises(ValueError, match="environment_map"):
        environment_radiance(Environment("exr"), [0.0, 1.0, 0.0])


def _look_at(environment) -> tuple[float, float, float]:
    """A point 20 deg above the horizon towards the disc's azimuth: with an 80 deg field of
    view from the origin, the disc, the gradient, the horizon and the ground are in sight."""
    disc = ProceduralEnvironment.from_scene(environment).disc_direction
    horizontal = np.array([disc[0], 0.0, disc[2]]) if np.any(disc) else np.array([0, 0, -1.0])
    horizontal /= np.linalg.norm(horizontal)
    return tuple(horizontal + np.array([0.0, math.tan(math.radians(20.0)), 0.0]))


_ENVIRONMENTS = {
    "uniform": 'type = "uniform"\nradiance = [0.2, 0.5, 0.9]',
    "sky": 'type = "sky"\nintensity = 0.5',
    "studio": 'type = "studio"\nintensity = 2.0',
}
_MISS_SCENE = """
[camera]  # replaced by one looking towards the disc
position = [0.0, 0.0, 0.0]
look_at = [0.0, 0.0, -1.0]
fov_deg = 80.0

[environment]
{environment}

[materials.m]
type = "lambertian"
albedo = 0.5

[[objects]]
shape = "sphere"
material = "m"
translate = [0.0, -100.0, 0.0]
scale = 0.01
"""


@pytest.mark.parametrize("kind", _ENVIRONMENTS)
def test_missed_rays_show_the_numpy_environment(device, tmp_path, kind):
    """Every pixel's mean over 256 jittered rays against the environment twin averaged over
    16 x 16 sub-pixel rays, within 6 standard errors of the jitter (the largest of ~4000
    errors is 4.2 of them): the twin's spread over the pixel where the environment is smooth
    around it; where the disc's edge or the horizon passes near, half the twin's range over
    the pixel and its neighbours (a bound that holds however little of the pixel the edge
    cuts off). The errors of the smooth pixels, in standard errors, have a standard deviation
    of 0.99 (sky) and 1.00 (studio): jitter noise only."""
    spp, k, width, height = 256, 16, 48, 32
    path = tmp_path / "miss.toml"
    path.write_text(_MISS_SCENE.format(environment=_ENVIRONMENTS[kind]), encoding="utf-8")
    scene = load_scene(path)
    scene = dataclasses.replace(scene, camera=Camera(
        (0.0, 0.0, 0.0), _look_at(scene.environment), (0.0, 1.0, 0.0), 80.0))
    image = Renderer(scene, size=(width, height), seed=3).render(spp).astype(np.float64)

    x, y = _pixel_grid(width, height, k)
    d = _camera_directions(scene.camera, width, height, x, y)
    twin = environment_radiance(scene.environment, d)
    expected = twin.mean(axis=(2, 3))
    env = ProceduralEnvironment.from_scene(scene.environment)
    # Which side of each jump a ray lies on, mixed anywhere in the 3 x 3 pixels: an edge.
    sides = 2 * (d[..., 1] >= 0.0) + (d @ env.disc_direction >= env.disc_cos)
    near = (maximum_filter(sides.max(axis=(2, 3)), size=3, mode="nearest")
            != minimum_filter(sides.min(axis=(2, 3)), size=3, mode="nearest"))
    spread = (maximum_filter(twin.max(axis=(2, 3)), size=(3, 3, 1), mode="nearest")
              - minimum_filter(twin.min(axis=(2, 3)), size=(3, 3, 1), mode="nearest"))
    sigma = np.where(near[..., None], 0.5 * spread, twin.std(axis=(2, 3)))
    tolerance = 6.0 * sigma / math.sqrt(spp) + 1e-5 * expected + 1e-6
    ratio = np.abs(image - expected) / tolerance
    print(f"{kind}: largest |error| / tolerance {ratio[~near].max():.3f} in smooth pixels, "
          f"{ratio.max():.3f} in all ({near.mean():.0%} near an edge)")
    assert ratio.max() <= 1.0
    if kind != "uniform":
        # The view holds what the test is about: the disc, the sky and the ground.
        assert (twin >= env.disc_radiance).any() and (twin == env.ground).any()
        assert 0.05 < near.mean() < 0.5


def test_reference_quadrature_has_converged(device, scenes, structures):
    """Doubling every resolution of the quadrature changes the reflected radiance by under
    0.1% at shading points all over the visible half of the sphere (coated: Fresnel,
    specular lobe and key light all present)."""
    rng = np.random.default_rng(1)
    normal = rng.normal(size=(16, 3))
    normal[:, 2] = np.abs(normal[:, 2]) + 0.2
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    wi = np.broadcast_to([0.0, 0.0, 1.0], normal.shape)
    env = ProceduralEnvironment.from_scene(scenes["coated"].environment)
    brdf = _factored(structures["coated"])
    coarse, fine = (
        continuous_radiance(brdf, wi, normal, normal, *environment_quadrature(env, *q))
        for q in (QUADRATURE, tuple(2 * n for n in QUADRATURE)))
    print(f"largest relative change {np.max(np.abs(coarse / fine - 1.0)):.2e}")
    np.testing.assert_allclose(coarse, fine, rtol=1e-3)


@pytest.mark.parametrize("name", MATERIALS)
def test_sphere_converges_to_numpy_integration(device, scenes, structures, name):
    renderer = Renderer(scenes[name], size=(SIZE, SIZE), seed=11)
    y, x = np.mgrid[0:SIZE, 0:SIZE] + 0.5
    centres = _camera_directions(renderer.scene.camera, SIZE, SIZE, x, y)
    np.testing.assert_allclose(renderer.camera_rays()[1], centres.reshape(-1, 3), atol=1e-9)
    if name == "lambertian":
        expected, inner = sphere_reference(renderer, 0.5)
    else:
        structure = structures[name]
        expected, inner = sphere_reference(renderer, _factored(structure), structure.host_index)
    image = renderer.render(SPP[name]).astype(np.float64)
    error = smape(image[inner], expected[inner])
    ratio = image[inner].mean(axis=0) / expected[inner].mean(axis=0)
    print(f"{name}: SMAPE {error:.4f} over {inner.sum()} pixels at {SPP[name]} spp, "
          f"ratio of the means {ratio}")
    assert inner.sum() >= 100
    assert error <= SMAPE_LIMIT
    # Noise averages out of the mean over the sphere, a bias would not.
    np.testing.assert_allclose(ratio, 1.0, atol=5e-3)


def test_spectral_sphere_converges_to_numpy_integration(device, scenes):
    """Hero-wavelength transport of the layered sphere against the spectral model's colour.

    The studio is grey, its upsampled spectrum flat (Mallett and Yuksel's basis adds up to 1),
    so each pixel is the environment's integral against the colour of the spectral BRDF."""
    spp = SPP_SPECTRAL
    renderer = Renderer(scenes["layered"], size=(SIZE, SIZE), seed=13, mode="spectral")
    expected, inner = sphere_reference(renderer, _spectral(scenes["layered"].materials["m"]))
    image = renderer.render(spp).astype(np.float64)
    error = smape(image[inner], expected[inner])
    ratio = image[inner].mean(axis=0) / expected[inner].mean(axis=0)
    print(f"spectral layered: SMAPE {error:.4f} over {inner.sum()} pixels at {spp} spp, "
          f"ratio of the means {ratio}")
    assert error <= SMAPE_LIMIT
    np.testing.assert_allclose(ratio, 1.0, atol=5e-3)
