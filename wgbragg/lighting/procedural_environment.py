"""The procedural environments of the path tracer in float64 numpy: the twin of
``environment_radiance`` in ``wgsl/lighting/procedural_environment.wgsl`` (its float32 twin,
included by ``wgsl/render/renderer.wgsl``), for references and tests.

``"uniform"``, ``"sky"``, ``"studio"`` and ``"softbox-studio"`` (:data:`PROCEDURAL_TYPES`): a
constant, or a gradient from horizon to zenith over a ground colour with a disc source (the
sun, a key light), and for the softbox studio (the studio and) three softboxes of different
sizes (:data:`STUDIO_SOFTBOXES`), in the scene's
relative radiance units (+y up). ``rotate_deg`` turns the disc and the softboxes about +y.
The renderer uploads the same parameters (:meth:`ProceduralEnvironment.from_scene`).
Details: ``docs/physics.md``, "Environment maps".
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

__all__ = ["PALETTES", "PROCEDURAL_TYPES", "SOFTBOX_EDGE", "STUDIO_SOFTBOXES",
           "ProceduralEnvironment", "environment_radiance"]

PALETTES = {
    "sky": ((0.25, 0.45, 0.9), (0.9, 0.95, 1.0), (0.1, 0.1, 0.1), 80.0, 2.5, 50.0, 30.0),
    "studio": ((0.6, 0.6, 0.6), (0.35, 0.35, 0.35), (0.03, 0.03, 0.03), 6.0, 15.0, 45.0, -45.0),
}
PALETTES["softbox-studio"] = PALETTES["studio"]
"""Per type: zenith, horizon and ground colours, disc radiance, disc radius (deg), disc
elevation (deg) and azimuth (deg, from +z towards +x)."""

STUDIO_SOFTBOXES = (
    (1.5, 35.0, 60.0, 150.0),
    (4.0, 12.0, 15.0, 95.0),
    (12.0, 4.0, 25.0, -140.0),
)
"""The softbox studio's softboxes besides its key light, as in the WGSL file's
``STUDIO_SOFTBOXES``:
per box its radiance (times ``intensity``), angular radius (deg), elevation and azimuth (deg,
from +z towards +x, before ``rotate_deg``). A large overhead box behind the subject, a
medium one low at the side and a small bright one: iridescent objects reflect three
differently sized highlights, each at its own angle and so in its own colour."""
SOFTBOX_EDGE = 0.2
"""A softbox's edge falls off smoothly (``smoothstep`` of the cosine) over this fraction of
its radius, inwards from the rim: no sharp edge to alias or to prefilter."""

PROCEDURAL_TYPES = ("uniform", "sky", "studio", "softbox-studio")
"""``Environment.type`` values this module evaluates."""


@dataclasses.dataclass(frozen=True)
class ProceduralEnvironment:
    """The parameters of a procedural environment as the renderer uploads them.

    Build one with :meth:`from_scene`.

    Parameters
    ----------
    zenith, horizon, ground : numpy.ndarray, shape (3,)
        Linear sRGB radiance straight up, at the horizon (``d_y = 0``) and below it.
    disc_radiance : numpy.ndarray, shape (3,)
        Linear sRGB radiance added inside the disc (zeros without one).
    disc_cos : float
        Cosine of the disc's angular radius; 1 without a disc (then nothing lies inside it
        since ``disc_direction`` is zero).
    disc_direction : numpy.ndarray, shape (3,)
        Unit direction towards the disc's centre, zeros without a disc.
    softbox_scale : float
        Scale of the :data:`STUDIO_SOFTBOXES` (the softbox studio's ``intensity``; 0
        elsewhere).
    turn_cos, turn_sin : float
        Cosine and sine of ``rotate_deg``, by which the softboxes turn about +y.
    """

    zenith: np.ndarray
    horizon: np.ndarray
    ground: np.ndarray
    disc_radiance: np.ndarray
    disc_cos: float
    disc_direction: np.ndarray
    softbox_scale: float = 0.0
    turn_cos: float = 1.0
    turn_sin: float = 0.0

    @classmethod
    def from_scene(cls, environment) -> ProceduralEnvironment:
        """The parameters of a scene's procedural environment, as the renderer uploads them.

        Parameters
        ----------
        environment : wgbragg.scene.model.Environment
            Of a type in :data:`PROCEDURAL_TYPES`.

        Returns
        -------
        ProceduralEnvironment

        Raises
        ------
        ValueError
            For an ``"exr"`` environment (see :mod:`wgbragg.lighting.environment_map`) or an unknown
            type.
        """
        if environment.type == "exr":
            raise ValueError("an 'exr' environment is an image, not a procedural environment: "
                             "evaluate it with wgbragg.lighting.environment_map")
        if environment.type not in PROCEDURAL_TYPES:
            raise ValueError(f"environment.type must be one of {PROCEDURAL_TYPES}, got "
                             f"{environment.type!r}")
        zeros = np.zeros(3)
        if environment.type == "uniform":
            radiance = np.asarray(environment.radiance, np.float64)
            return cls(radiance, radiance, radiance, zeros, 1.0, zeros)
        zenith, horizon, ground, disc, radius_deg, elevation_deg, azimuth_deg = (
            PALETTES[environment.type])
        scale = float(environment.intensity)
        # rotate_deg turns the environment about +y; only the disc's azimuth moves, since the
        # gradient and the ground depend on d_y alone.
        elevation = math.radians(elevation_deg)
        azimuth = math.radians(azimuth_deg + float(environment.rotate_deg))
        # Azimuth from +z towards +x, elevation from the horizon towards +y.
        direction = np.array([math.cos(elevation) * math.sin(azimuth), math.sin(elevation),
                              math.cos(elevation) * math.cos(azimuth)])
        turn = math.radians(float(environment.rotate_deg))
        return cls(np.multiply(zenith, scale), np.multiply(horizon, scale),
                   np.multiply(ground, scale), np.full(3, disc * scale),
                   math.cos(math.radians(radius_deg)), direction,
                   scale if environment.type == "softbox-studio" else 0.0, math.cos(turn),
                   math.sin(turn))

    @property
    def has_disc(self) -> bool:
        """Whether a disc source (the sun, a key light) adds radiance somewhere."""
        return bool(np.any(self.disc_radiance > 0.0) and np.any(self.disc_direction != 0.0))

    @property
    def disc_solid_angle(self) -> float:
        """Solid angle of the disc in sr, ``2 pi (1 - disc_cos)`` (0 without one)."""
        return 2.0 * math.pi * (1.0 - self.disc_cos) if self.has_disc else 0.0

    def radiance(self, directions, disc: bool = True) -> np.ndarray:
        """Radiance arriving from unit ``directions``.

        Parameters
        ----------
        directions : array_like, shape (..., 3)
            Unit directions towards the environment (+y up).
        disc : bool
            Add the disc; without it, the gradient and ground alone, which quadratures can
            integrate apart from the disc's sharp edge.

        Returns
        -------
        numpy.ndarray, shape (..., 3), float64
            Linear sRGB radiance.
        """
        d = np.asarray(directions, np.float64)
        if d.ndim == 0 or d.shape[-1] != 3:
            raise ValueError(f"directions must have a trailing axis of length 3, got shape "
                             f"{d.shape}")
        up = d[..., 1:2]
        # As the shader: the gradient for d_y >= 0 (sqrt of d_y), the ground below.
        sky = np.where(up >= 0.0,
                       self.horizon + np.sqrt(np.maximum(up, 0.0)) * (self.zenith - self.horizon),
                       self.ground)
        if self.softbox_scale > 0.0:
            sky = sky + self.softbox_scale * self.softboxes(d)[..., None]
        if disc and self.has_disc:
            inside = (d @ self.disc_direction >= self.disc_cos)[..., None]
            sky = sky + np.where(inside, self.disc_radiance, 0.0)
        return sky


    def softboxes(self, directions) -> np.ndarray:
        """The :data:`STUDIO_SOFTBOXES`' radiance (before ``softbox_scale``, grey) arriving
        from unit ``directions`` (..., 3): each box's radiance times ``smoothstep(cos r,
        cos((1 - SOFTBOX_EDGE) r), d . axis)``, the directions turned back by ``rotate_deg``
        first, as the shader does."""
        d = np.asarray(directions, np.float64)
        # The turn takes azimuth phi to phi + rotate_deg: look up the unturned boxes at R^-1 d.
        x = d[..., 0] * self.turn_cos - d[..., 2] * self.turn_sin
        z = d[..., 0] * self.turn_sin + d[..., 2] * self.turn_cos
        total = np.zeros(d.shape[:-1])
        for radiance, radius, elevation, azimuth in STUDIO_SOFTBOXES:
            r, e, a = math.radians(radius), math.radians(elevation), math.radians(azimuth)
            towards = (x * math.cos(e) * math.sin(a) + d[..., 1] * math.sin(e)
                       + z * math.cos(e) * math.cos(a))
            low, high = math.cos(r), math.cos((1.0 - SOFTBOX_EDGE) * r)
            t = np.clip((towards - low) / (high - low), 0.0, 1.0)
            total = total + radiance * t * t * (3.0 - 2.0 * t)
        return total


def environment_radiance(environment, directions) -> np.ndarray:
    """Radiance of a procedural environment arriving from unit ``directions``, in float64.

    The twin of ``environment_radiance`` in ``wgsl/lighting/procedural_environment.wgsl``, with the
    parameters :mod:`wgbragg.render` uploads for the environment (``docs/physics.md``,
    "Environment maps").

    Parameters
    ----------
    environment : wgbragg.scene.model.Environment
        Of a type in :data:`PROCEDURAL_TYPES`.
    directions : array_like, shape (..., 3)
        Unit directions towards the environment, in the scene's axes (+y up).

    Returns
    -------
    numpy.ndarray, shape (..., 3), float64
        Linear sRGB radiance in the scene's relative units.

    Raises
    ------
    ValueError
        For an ``"exr"`` environment (use :mod:`wgbragg.lighting.environment_map`), an unknown type,
        or directions without a trailing axis of 3.

    Examples
    --------
    >>> from wgbragg.scene.model import Environment
    >>> studio = Environment("studio", intensity=2.0)
    >>> environment_radiance(studio, [[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]]).tolist()
    [[1.2, 1.2, 1.2], [0.06, 0.06, 0.06]]
    """
    return ProceduralEnvironment.from_scene(environment).radiance(directions)
