"""Spectral landmarks (Fourneau et al. 2024, sec. 3.2.1, App. A) against their definitions."""

import math

import numpy as np
import pytest

from wgbragg import BraggMirror
from wgbragg.optics import bloch_dispersion
from wgbragg.optics.landmarks import KINDS, VISIBLE_OMEGA, find_landmarks

EDGE_ATOL = 1e-9  # |cos K Lambda| - 1 at a band edge found by bisection
AIRY_ATOL = 1e-9  # cos K Lambda at an Airy point

MIRRORS = [
    BraggMirror(1.0, 1.5, 315.0, 315.0, 10),  # the paper's Fig. 3
    BraggMirror(1.0, 1.5, 61.0, 183.0, 20),
    BraggMirror(1.0, 1.5, 741.0, 247.0, 20),
    BraggMirror(1.33, 1.56, 900.0, 1100.0, 5),
    BraggMirror(1.59, 1.67, 81.6, 78.4, 8, host=1.0),
]
ANGLES = [0.0, 0.4, 0.9, 1.3]


def dispersion(mirror, landmarks, theta, pol):
    return bloch_dispersion(mirror.n1, mirror.n2, mirror.d1, mirror.d2, landmarks.wavelength_nm,
                            theta, pol, host=mirror.host)


@pytest.mark.parametrize("mirror", MIRRORS, ids=repr)
@pytest.mark.parametrize("pol", ["s", "p"])
def test_landmarks_satisfy_their_definitions(mirror, pol):
    for theta in ANGLES:
        found = mirror.landmarks(theta, pol)
        assert len(found) > 0
        assert np.all(np.diff(found.omega) >= 0.0)
        assert np.all((found.omega > VISIBLE_OMEGA[0]) & (found.omega < VISIBLE_OMEGA[1]))
        assert set(found.kind) <= set(KINDS)
        x, sin2 = dispersion(mirror, found, theta, pol)
        edges, airy, modes = found.kind == "edge", found.kind == "airy", found.kind == "mode"
        np.testing.assert_allclose(np.abs(x[edges]), 1.0, rtol=0, atol=EDGE_ATOL)
        np.testing.assert_allclose(x[airy], 0.0, rtol=0, atol=AIRY_ATOL)
        # Appendix A: every mode lies inside a band gap, with the sign of (-1)^m.
        assert np.all(sin2[modes] <= 1e-12)
        np.testing.assert_array_equal(np.sign(x[modes]), (-1.0) ** found.mode_number[modes])
        # Zero points: the Airy reflectance of one n2 slab vanishes, inside pass bands.
        zeros = found.kind == "zero"
        assert np.all(sin2[zeros] > 0.0)
        slab = mirror.__class__(mirror.n1, mirror.n2, mirror.d1, mirror.d2, 1, host=mirror.n1)
        np.testing.assert_allclose(slab.reflectance(found.wavelength_nm[zeros], theta, pol), 0.0,
                                   atol=1e-20)


def test_gaps_close_at_brewsters_angle():
    """App. A: for p at Brewster's angle every band gap shrinks onto its mode."""
    mirror = BraggMirror(1.0, 1.5, 315.0, 315.0, 10)
    found = mirror.landmarks(math.atan(1.5), "p")
    modes = found.omega[found.kind == "mode"]
    edges = found.omega[found.kind == "edge"]
    assert modes.size > 0
    assert np.abs(edges[:, None] - modes[None, :]).min(axis=1).max() < 1e-9 * modes.max()


@pytest.mark.parametrize("pol", ["s", "p"])
def test_evanescent_n2_landmarks_satisfy_their_definitions(pol):
    """Past n2's critical angle: modes of n_plus = q1 d1 in gaps with the sign of App. A, an
    Airy point and two edges between each pair, no zero points."""
    mirror = BraggMirror(1.5, 1.0, 300.0, 50.0, 20)
    theta = math.radians(45.0)  # beyond n2's critical angle (41.8 deg)
    found = mirror.landmarks(theta, pol)
    q1 = math.sqrt(1.5**2 - (1.5 * math.sin(theta)) ** 2)
    assert found.n_plus == pytest.approx(q1 * 300.0, rel=1e-12)
    assert set(found.kind) == {"mode", "airy", "edge"}
    x, sin2 = dispersion(mirror, found, theta, pol)
    edges, airy, modes = found.kind == "edge", found.kind == "airy", found.kind == "mode"
    np.testing.assert_allclose(np.abs(x[edges]), 1.0, rtol=0, atol=EDGE_ATOL)
    np.testing.assert_allclose(x[airy], 0.0, rtol=0, atol=AIRY_ATOL)
    assert np.all(sin2[modes] <= 0.0)
    np.testing.assert_array_equal(np.sign(x[modes]), (-1.0) ** found.mode_number[modes])
    np.testing.assert_allclose(found.omega[modes] * found.n_plus / np.pi,
                               found.mode_number[modes], atol=1e-9)
    # Between consecutive modes: edge, Airy point, edge.
    inner = found.kind[np.flatnonzero(modes)[0]:np.flatnonzero(modes)[-1] + 1]
    assert "".join(k[0] for k in inner).replace("eae", "") == "m" * int(modes.sum())


def _pass_band_edges_on_a_grid(mirror, theta, pol, grid):
    """Midpoints of the grid cells where sin^2 K Lambda changes sign: a brute-force search."""
    _, sin2 = bloch_dispersion(mirror.n1, mirror.n2, mirror.d1, mirror.d2, 2.0 * np.pi / grid,
                               theta, pol, host=mirror.host)
    change = np.flatnonzero((sin2[1:] > 0.0) != (sin2[:-1] > 0.0))
    return 0.5 * (grid[change] + grid[change + 1])


def test_evanescent_n2_band_edges_match_a_fine_scan():
    """Random dense hosts past n2's critical angle, some within 1e-5 of it: every edge a
    20001-point scan sees is found within one step, and every other edge found bounds a pass
    band narrower than two steps (tunnelling through thick n2, which the scan misses)."""
    rng = np.random.default_rng(11)
    grid = np.linspace(*VISIBLE_OMEGA, 20001)
    step = grid[1] - grid[0]
    unseen = 0
    for _ in range(40):
        n1 = rng.uniform(1.3, 3.0)
        n2 = rng.uniform(1.0, n1 - 0.05)
        host = rng.uniform(n2 + 0.01, 3.5)
        top = min(n1, host)
        s = n2 + (top - n2) * (10.0 ** rng.uniform(-5.0, -1.0) if rng.random() < 0.3
                               else rng.uniform(0.0, 1.0))
        mirror = BraggMirror(n1, n2, *10.0 ** rng.uniform(1.0, 3.4, 2), 10, host=host)
        theta = math.asin(s / host)
        for pol in "sp":
            found = mirror.landmarks(theta, pol)
            assert np.all(np.diff(found.omega) >= 0.0)
            edges = found.omega[found.kind == "edge"]
            scanned = _pass_band_edges_on_a_grid(mirror, theta, pol, grid)
            for edge in scanned:
                assert np.abs(edges - edge).min() <= step
            for i, edge in enumerate(edges):
                if scanned.size and np.abs(scanned - edge).min() <= step:
                    continue
                neighbours = np.abs(np.delete(edges, i) - edge)
                assert neighbours.min() < 2.0 * step
                unseen += 1
    assert unseen > 0  # the sample does hold bands below the scan's resolution


def test_tunnelling_pass_bands_narrower_than_any_grid_are_found():
    """A thick n2 barrier under a dense host: one pass band per pi of the n1 phase, 1.8 nm
    to 0.013 nm wide; a 512-point scan (our earlier search) missed those narrower than its
    step."""
    mirror = BraggMirror(2.4, 1.0, 2700.0, 1000.0, 10, host=2.7)
    theta = math.radians(23.0)
    s = mirror.host * math.sin(theta)
    q1 = math.sqrt(mirror.n1 ** 2 - s * s)
    phases = np.array(VISIBLE_OMEGA) * q1 * mirror.d1 / np.pi
    branches = int(np.ceil(phases[1]) - np.floor(phases[0]))
    for pol in "sp":
        found = mirror.landmarks(theta, pol)
        edges = found.omega[found.kind == "edge"]
        assert edges.size >= 2 * (branches - 2)
        lo, hi = edges[0::2], edges[1::2]
        assert np.all(hi > lo)
        assert np.sum(hi - lo < (VISIBLE_OMEGA[1] - VISIBLE_OMEGA[0]) / 511) >= 10
        middle = 2.0 * np.pi / (0.5 * (lo + hi))
        _, sin2 = bloch_dispersion(mirror.n1, mirror.n2, mirror.d1, mirror.d2, middle, theta,
                                   pol, host=mirror.host)
        assert np.all(sin2 > 0.0)  # each pair bounds a pass band
        x, _ = dispersion(mirror, found, theta, pol)
        np.testing.assert_allclose(np.abs(x[found.kind == "edge"]), 1.0, rtol=0, atol=1e-6)


@pytest.mark.parametrize("pol", ["s", "p"])
def test_landmarks_are_continuous_where_n2_turns_evanescent(pol):
    """At n2's critical angle (q2 = 0) the evanescent search is finite and meets the
    propagating one: the same modes, Airy points and edges just past it as just before it
    (the zero points, at z pi / (q2 d2), leave the range), and colours without a step."""
    from wgbragg.colour.colorimetry import delta_e_2000, xyz_to_linear_srgb

    mirror = BraggMirror(1.5, 1.0, 300.0, 50.0, 5)
    critical = math.asin(1.0 / 1.5)
    before = mirror.landmarks(critical - 1e-9, pol)
    kept = before.kind != "zero"
    for found in (mirror.landmarks(critical + 1e-9, pol), mirror.landmarks(critical, pol)):
        assert np.all(np.isfinite(found.omega))
        assert list(found.kind) == list(before.kind[kept])
        # q2 d2 ~ sqrt(2 n2 delta s) d2 moves the propagating modes by 7e-6 at 1e-9 rad.
        np.testing.assert_allclose(found.omega, before.omega[kept], rtol=1e-4)
    theta = np.array([critical - 1e-7, critical + 1e-7])
    for method in ("approx", "subdivided", "averaged"):
        rgb = xyz_to_linear_srgb(mirror.xyz(theta, method))
        assert delta_e_2000(rgb[0], rgb[1]) < 0.01, method


@pytest.mark.parametrize("mirror", [BraggMirror(1.0, 1.0, 100.0, 100.0, 5),
                                    BraggMirror(1.0, 1.5, 100.0, 0.0, 5),
                                    BraggMirror(1.3, 1.5, 100.0, 100.0, 5, host=2.0),
                                    BraggMirror(1.5, 1.0, 0.0, 50.0, 5)], ids=repr)
@pytest.mark.filterwarnings("error")
def test_no_structure_no_landmarks(mirror):
    theta = 1.2  # beyond n1's critical angle for the dense host, n2's for the n1 = 1.5 slab
    assert len(mirror.landmarks(theta, "s")) == 0


def test_landmarks_do_not_depend_on_n():
    few = find_landmarks(BraggMirror(1.0, 1.5, 125.0, 375.0, 3), 0.5, "s")
    many = find_landmarks(BraggMirror(1.0, 1.5, 125.0, 375.0, 10**6), 0.5, "s")
    np.testing.assert_array_equal(few.omega, many.omega)


def test_array_angles_give_an_array_of_landmarks():
    mirror = MIRRORS[0]
    found = mirror.landmarks(np.array([[0.0, 0.3, 0.6], [0.9, 1.2, 1.5]]), "p")
    assert found.shape == (2, 3)
    np.testing.assert_array_equal(found[1, 0].omega, mirror.landmarks(0.9, "p").omega)


@pytest.mark.parametrize(("kwargs", "name"), [({"polarization": "x"}, "polarization"),
                                              ({"polarization": "unpolarized"}, "polarization"),
                                              ({"polarization": ["s", "p"]}, "polarization"),
                                              ({"theta": -0.1}, "theta"),
                                              ({"theta": float("nan")}, "theta")])
def test_bad_input(kwargs, name):
    arguments = {"theta": 0.2, "polarization": "s"} | kwargs
    with pytest.raises(ValueError, match=name):
        MIRRORS[0].landmarks(**arguments)
