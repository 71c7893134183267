"""Reproductions of Figures 3 and 4 of Fourneau, Pacanowski & Barla 2024, as PNG files.

- ``fig3_spectrum.png`` (paper's Fig. 3): the Bragg mirror ``n1 = 1, n2 = 1.5,
  d1 = d2 = 315 nm, N = 10`` at normal incidence, s polarisation. Top: the reflectance
  spectrum ``R(omega)`` (blue), its envelope ``R^e`` (grey, eq 11), band gaps shaded, and the
  piecewise-constant spectrum of sec. 3.2.2 (dashed red). Bottom: the dispersion relation
  ``cos K Lambda`` (black) with the spectral landmarks: modes (red crosses), Airy points
  (cyan), band-gap edges (green dots) and zero points (black dots).
- ``fig4_gradients.png`` (paper's Fig. 4): rows ``Lambda`` in {244, 500, 988} nm (the periods
  of the paper's Table 1; the caption of Fig. 4 gives none), columns a thin-film slab
  (``n = 1.5`` in air, thickness ``Lambda``) then Bragg mirrors ``n1 = 1, n2 = 1.5, N = 20``
  with ``d1 / Lambda`` in {0.25, 0.5, 0.75}. Each cell plots the unpolarized reflectance
  against the angle of incidence at the three wavelengths of the caption, and below it colour
  strips over 0-90 degrees for the reference and the approximations (Bragg: ``approx``,
  ``subdivided``, ``averaged``; thin film: ``spectral``).

Everything is computed with the float64 numpy backend, so the figures need no GPU. The
piecewise-constant spectrum of Fig. 3 is rebuilt here from the mirror's public landmarks,
:func:`wgbragg.colour.landmark_methods.envelope` and
:func:`~wgbragg.colour.landmark_methods.angular_correction`,
with the same boxes as :func:`wgbragg.colour.landmark_methods.approx_xyz` (basic variant).

``gallery`` renders every scene preset instead (on the GPU, or lavapipe), one PNG each in
``docs/images/`` by default, and prints each preset's look as measured at 256 x 256, 16 spp
(:mod:`wgbragg.render.look`): the share of pixels with a saturation above 0.5 (all, and on the
iridescent objects), the hue range over those objects, flat bands of 8 rows or more and the
share of dark background pixels; ``docs/scenes.md`` quotes the table.

Usage::

    python tools/figures.py                      # writes out/figures/*.png
    python tools/figures.py --out /tmp/figs --quick
    python tools/figures.py gallery              # docs/images/<preset>.png and the look table
    python tools/figures.py gallery --presets fig1 --width 512 --spp 256
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import colour
import numpy as np

# Figures built without pyplot render through the Agg canvas: no display, no global backend
# state, whatever MPLBACKEND says.
from matplotlib.figure import Figure
from tqdm import tqdm

from wgbragg import BraggMirror, ThinFilm
from wgbragg.colour.landmark_methods import angular_correction, envelope
from wgbragg.common.atomic import atomic_path
from wgbragg.optics import bloch_dispersion, yeh_reflectance
from wgbragg.optics.landmarks import VISIBLE_OMEGA

__all__ = [
    "FIG3_MIRROR",
    "FIG4_PERIODS_NM",
    "FIG4_RATIOS",
    "FIG4_WAVELENGTHS_NM",
    "GALLERY_OUT",
    "encode_srgb",
    "figure3",
    "figure4",
    "gallery",
    "main",
    "piecewise_constant_spectrum",
    "preset_look",
]

REPO_ROOT = Path(__file__).resolve().parents[1]
DEFAULT_OUT = REPO_ROOT / "out" / "figures"
GALLERY_OUT = REPO_ROOT / "docs" / "images"

FIG3_MIRROR = BraggMirror(n1=1.0, n2=1.5, d1=315.0, d2=315.0, N=10)
FIG3_POLARIZATION = "s"

# Table 1's periods; Fig. 4's caption does not list its own.
FIG4_PERIODS_NM = (244.0, 500.0, 988.0)
FIG4_RATIOS = (0.25, 0.5, 0.75)
FIG4_N = 20
FIG4_N1, FIG4_N2 = 1.0, 1.5
# The caption reads {559, 556, 442} nm for "the CMF peaks"; 559 is a typo for 599 nm, the peak
# of x-bar (556 and 442 nm are its values for y-bar and z-bar).
FIG4_WAVELENGTHS_NM = (599.0, 556.0, 442.0)
FIG4_LINE_COLOURS = ("tab:red", "tab:green", "tab:blue")
# Strip rows: (method, label). The thin film has no landmark methods.
BRAGG_STRIPS = (("reference", "ref."), ("approx", "app."), ("subdivided", "sub."),
                ("averaged", "avg."))
FILM_STRIPS = (("reference", "ref."), ("spectral", "spec."))

# Landmark colours and markers of the paper's Fig. 3.
LANDMARK_STYLE = {
    "mode": {"marker": "x", "color": "red", "s": 40, "label": "modes"},
    "airy": {"marker": "o", "color": "cyan", "s": 25, "label": "Airy points",
             "edgecolors": "teal"},
    "edge": {"marker": "o", "color": "green", "s": 18, "label": "band-gap edges"},
    "zero": {"marker": "o", "color": "black", "s": 18, "label": "zero points"},
}


def encode_srgb(linear_rgb) -> np.ndarray:
    """Display sRGB in [0, 1] from linear sRGB: clip to [0, 1], then the sRGB transfer function.

    Clipping comes first because the transfer function is defined on [0, 1] only: the vivid
    colours of Bragg mirrors are often out of gamut (negative components).
    """
    clipped = np.clip(np.asarray(linear_rgb, dtype=np.float64), 0.0, 1.0)
    return np.clip(colour.cctf_encoding(clipped, function="sRGB"), 0.0, 1.0)


def piecewise_constant_spectrum(mirror: BraggMirror, theta: float, polarization: str,
                                omega) -> np.ndarray:
    """The paper's basic piecewise-constant spectrum ``R~(omega)`` (sec. 3.2.2, eq 14).

    Boxes span consecutive landmarks (and the ends of the visible range); inside band gaps the
    weight is 1, elsewhere ``w~(theta1) R^e`` at the box's middle (Appendix B), the same boxes
    that :func:`wgbragg.colour.landmark_methods.approx_xyz` integrates.

    Parameters
    ----------
    mirror : BraggMirror
    theta : float
        Angle of incidence in the host, radians.
    polarization : {"s", "p"}
    omega : array_like
        Angular wavenumbers (rad/nm) at which to evaluate the step function.

    Returns
    -------
    numpy.ndarray
        ``R~`` at ``omega`` (NaN outside the visible range, where there are no boxes).
    """
    landmarks = mirror.landmarks(theta, polarization)
    bounds = np.concatenate([[VISIBLE_OMEGA[0]], landmarks.omega, [VISIBLE_OMEGA[1]]])
    middle = 0.5 * (bounds[:-1] + bounds[1:])
    _, sin2 = bloch_dispersion(mirror.n1, mirror.n2, mirror.d1, mirror.d2, 2.0 * np.pi / middle,
                               theta, polarization, host=mirror.host)
    theta1 = np.arcsin(np.clip(mirror.host * np.sin(theta) / mirror.n1, 0.0, 1.0))
    weight = np.where(sin2 <= 0.0, 1.0,
                      angular_correction(mirror.n1, mirror.n2, theta1)
                      * envelope(mirror, middle, theta, polarization))
    omega = np.asarray(omega, dtype=np.float64)
    box = np.clip(np.searchsorted(bounds, omega, side="right") - 1, 0, weight.size - 1)
    inside = (omega >= bounds[0]) & (omega <= bounds[-1])
    return np.where(inside, weight[box], np.nan)


def _wavelength_axis(ax) -> None:
    """A secondary x axis in wavelength (nm) over an axis in omega (rad/nm)."""

    def convert(x):
        # 2 pi / x is its own inverse; guard 0, which matplotlib probes while laying out.
        x = np.asarray(x, dtype=np.float64)
        with np.errstate(divide="ignore"):
            return np.where(x > 0.0, 2.0 * np.pi / np.where(x > 0.0, x, 1.0), np.inf)

    top = ax.secondary_xaxis("top", functions=(convert, convert))
    top.set_xlabel("wavelength (nm)")
    top.set_xticks([400, 450, 500, 550, 600, 700, 800])


def figure3(quick: bool = False):
    """Fig. 3: reflectance, envelope, piecewise-constant spectrum and dispersion relation.

    Parameters
    ----------
    quick : bool
        Coarse sampling (for tests).

    Returns
    -------
    matplotlib.figure.Figure
    """
    mirror, pol, theta = FIG3_MIRROR, FIG3_POLARIZATION, 0.0
    omega = np.linspace(*VISIBLE_OMEGA, 300 if quick else 4000)
    wavelength = 2.0 * np.pi / omega
    R = yeh_reflectance(mirror.n1, mirror.n2, mirror.d1, mirror.d2, mirror.N, wavelength, theta,
                        pol, host=mirror.host)
    Re = envelope(mirror, omega, theta, pol)
    Rt = piecewise_constant_spectrum(mirror, theta, pol, omega)
    x, sin2 = bloch_dispersion(mirror.n1, mirror.n2, mirror.d1, mirror.d2, wavelength, theta,
                               pol, host=mirror.host)
    landmarks = mirror.landmarks(theta, pol)

    fig = Figure(figsize=(9, 7))
    top, bottom = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [1.2, 1]})
    gap = sin2 <= 0.0
    for ax in (top, bottom):
        # Band gaps shaded on both panels, from the dispersion relation itself (|cos K L| >= 1).
        ax.fill_between(omega, 0, 1, where=gap, transform=ax.get_xaxis_transform(),
                        color="0.88", linewidth=0, label="band gaps" if ax is top else None)
    top.plot(omega, Re, color="0.55", linewidth=2.0, label=r"envelope $R^e_\omega$ (eq 11)")
    top.plot(omega, R, color="tab:blue", linewidth=1.0, label=r"$R_\omega$ (Yeh)")
    top.plot(omega, Rt, color="red", linestyle="--", linewidth=1.4,
             label=r"piecewise constant $\tilde R_\omega$ (sec. 3.2.2)")
    top.set_ylim(-0.02, 1.05)
    top.set_ylabel("reflectance")
    # Over the pass band after the first gap, where R stays low: the legend hides no curve.
    top.legend(loc="upper left", bbox_to_anchor=(0.085, 0.98), fontsize=8, framealpha=0.9)
    _wavelength_axis(top)
    top.set_title(
        f"Bragg mirror n1 = {mirror.n1:g}, n2 = {mirror.n2:g}, d1 = {mirror.d1:g} nm, "
        f"d2 = {mirror.d2:g} nm, N = {mirror.N}; normal incidence, {pol} polarisation",
        fontsize=10, pad=28,
    )

    bottom.plot(omega, x, color="black", linewidth=1.2, label=r"$\cos K\Lambda$")
    for level in (-1.0, 1.0):
        bottom.axhline(level, color="0.4", linestyle=":", linewidth=0.8)
    at_landmarks = bloch_dispersion(mirror.n1, mirror.n2, mirror.d1, mirror.d2,
                                    landmarks.wavelength_nm, theta, pol, host=mirror.host)[0]
    for kind, style in LANDMARK_STYLE.items():
        chosen = landmarks.kind == kind
        bottom.scatter(landmarks.omega[chosen], at_landmarks[chosen], zorder=3, **style)
    bottom.set_xlabel(r"$\omega = 2\pi/\lambda$ (rad/nm)")
    bottom.set_ylabel(r"$\cos K\Lambda$")
    bottom.set_xlim(*VISIBLE_OMEGA)
    # Headroom above the curve for the legend, so it hides no landmark.
    bottom.set_ylim(-1.3, 1.75)
    bottom.legend(loc="upper center", fontsize=8, ncol=5, framealpha=0.9)
    fig.tight_layout()
    return fig


def _fig4_material(period: float, column: int):
    """Column 0: the thin-film slab of thickness ``period``; then the Bragg mirrors."""
    if column == 0:
        return ThinFilm(n_film=FIG4_N2, d=period, n_base=FIG4_N1, host=FIG4_N1), FILM_STRIPS
    ratio = FIG4_RATIOS[column - 1]
    mirror = BraggMirror(n1=FIG4_N1, n2=FIG4_N2, d1=ratio * period, d2=(1.0 - ratio) * period,
                         N=FIG4_N)
    return mirror, BRAGG_STRIPS


def _strip_angles(count: int) -> np.ndarray:
    """Pixel-centre angles over [0, 90) degrees, in radians.

    Centres rather than end points: 90 degrees exactly is a degenerate limit (no landmarks,
    R = 1) that the strips need not sample.
    """
    return np.radians((np.arange(count) + 0.5) * 90.0 / count)


def figure4(quick: bool = False, progress: bool = False):
    """Fig. 4: reflectance against angle at three wavelengths, and colour strips.

    Parameters
    ----------
    quick : bool
        Coarse sampling (for tests).
    progress : bool
        Show a tqdm bar over the cells on stderr.

    Returns
    -------
    matplotlib.figure.Figure
    """
    plot_angles = np.radians(np.linspace(0.0, 90.0, 31 if quick else 721))
    strip_angles = _strip_angles(6 if quick else 90)
    rows, columns = len(FIG4_PERIODS_NM), 1 + len(FIG4_RATIOS)
    fig = Figure(figsize=(3.2 * columns, 3.6 * rows))
    outer = fig.add_gridspec(rows, columns, hspace=0.35, wspace=0.25)
    cells = [(i, j) for i in range(rows) for j in range(columns)]
    for i, j in tqdm(cells, desc="fig4", unit="cell", disable=not progress, file=sys.stderr):
        period = FIG4_PERIODS_NM[i]
        material, strips = _fig4_material(period, j)
        inner = outer[i, j].subgridspec(2, 1, height_ratios=[3.0, 0.25 * len(strips)],
                                        hspace=0.08)
        ax = fig.add_subplot(inner[0])
        for wavelength, line_colour in zip(FIG4_WAVELENGTHS_NM, FIG4_LINE_COLOURS,
                                           strict=True):
            R = material.reflectance(wavelength, plot_angles, "unpolarized")
            ax.plot(np.degrees(plot_angles), R, color=line_colour, linewidth=1.0,
                    label=f"{wavelength:g} nm")
        ax.set_xlim(0.0, 90.0)
        ax.set_ylim(0.0, 1.02)
        ax.tick_params(labelsize=7, labelbottom=False)
        if j == 0:
            ax.set_ylabel(f"Λ = {period:g} nm\nreflectance", fontsize=9)
        if i == 0:
            title = (f"thin film, n = {FIG4_N2:g}, d = Λ" if j == 0
                     else f"Bragg, d1/Λ = {FIG4_RATIOS[j - 1]:g}")
            ax.set_title(title, fontsize=9)
        if i == 0 and j == 0:
            ax.legend(fontsize=6, loc="upper left")
        image = np.stack([encode_srgb(material.rgb(strip_angles, method))
                          for method, _ in strips])
        strip = fig.add_subplot(inner[1])
        strip.imshow(image, aspect="auto", interpolation="nearest",
                     extent=(0.0, 90.0, len(strips) - 0.5, -0.5))
        strip.set_yticks(range(len(strips)), [label for _, label in strips], fontsize=6)
        strip.set_xticks([0, 30, 60, 90])
        strip.tick_params(axis="x", labelsize=7)
        if i == rows - 1:
            strip.set_xlabel("angle of incidence (deg)", fontsize=8)
    fig.suptitle(
        f"Angular colour gradients, n1 = {FIG4_N1:g}, n2 = {FIG4_N2:g}, N = {FIG4_N} "
        "(after Fourneau et al. 2024, Fig. 4); unpolarized R at 599 / 556 / 442 nm; "
        "colours D65 sRGB (clipped)", fontsize=10,
    )
    return fig


def save_png(fig, path: Path, dpi: int) -> Path:
    """Write ``fig`` to ``path`` atomically (a temporary file renamed on success)."""
    with atomic_path(path) as temporary:
        fig.savefig(temporary, dpi=dpi, format="png")
    return path


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    """Parse the command line (``argv`` without the program name)."""
    parser = argparse.ArgumentParser(
        prog="figures.py", description="Reproduce Figs. 3 and 4 of Fourneau et al. 2024 as PNGs."
    )
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT,
                        help=f"output folder (default {DEFAULT_OUT})")
    parser.add_argument("--quick", action="store_true", help="tiny resolutions (for tests)")
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    return parser.parse_args(argv)


def preset_look(name: str, size: int = 256, spp: int = 16, seed: int = 0,
                view: str = "standard") -> dict:
    """Render preset ``name`` at ``size`` x ``size`` and ``spp`` and measure its look.

    Returns
    -------
    dict
        ``pixels`` (the 8-bit sRGB image), ``saturated`` (share of pixels with saturation
        > 0.5), ``saturated_object`` (the same over the pixels whose first hit is not
        Lambertian: the iridescent objects), ``hue_range`` (degrees, over those objects),
        ``bands`` (flat bands of 8 rows or more), ``dark_background`` (share of pixels that
        see no object and are darker than 2 % of the mean), ``histogram`` and
        ``histogram_clip`` (saturation counts in 5 bins with the gamut map, and with each
        channel clipped instead), ``out_of_gamut`` (share of pixels the gamut map moves).
    """
    from wgbragg.render import Renderer, display, look
    from wgbragg.scene import load_preset
    from wgbragg.scene.model import LambertianMaterial

    scene = load_preset(name)
    renderer = Renderer(scene, size=(size, size), seed=seed)
    _, face = renderer.primary_hits()
    geometry = renderer.world_geometry()
    triangles, spheres = len(geometry.material), len(geometry.sphere_material)
    per_primitive = np.concatenate([geometry.material, geometry.sphere_material,
                                    geometry.parallelogram_material])
    material = np.full(face.shape, -1)
    hit = (face >= 0) & (face < triangles + spheres + len(geometry.parallelogram_material))
    material[hit] = per_primitive[face[hit]]
    iridescent = [k for k, m in enumerate(scene.materials.values())
                  if not isinstance(m, LambertianMaterial)]
    objects = np.isin(material, iridescent)
    image = renderer.render(spp)
    pixels = display.display_transform(image, scene.settings.exposure, view)
    scaled = np.nan_to_num(image.astype(np.float64)) * 2.0**scene.settings.exposure
    luminance = scaled @ display.LUMINANCE_WEIGHTS
    tone_mapped = np.where((luminance > 0.0)[..., None], scaled, 0.0) / (
        1.0 + np.maximum(luminance, 0.0))[..., None]
    inside = ((tone_mapped >= 0.0) & (tone_mapped <= 1.0)).all(axis=-1)
    clipped = np.round(display.encode_srgb(tone_mapped.clip(0.0, 1.0)) * 255.0).astype(np.uint8)
    return {
        "pixels": pixels,
        "saturated": look.saturated_fraction(pixels),
        "saturated_object": look.saturated_fraction(pixels, objects),
        "hue_range": look.hue_range_deg(pixels, objects),
        "bands": look.flat_bands(pixels),
        "dark_background": look.dark_background(pixels, face < 0),
        "histogram": look.saturation_histogram(pixels, 5),
        "histogram_clip": look.saturation_histogram(clipped, 5),
        "out_of_gamut": float(np.mean(~inside)),
    }


def gallery(argv: Sequence[str]) -> int:
    """``python tools/figures.py gallery``: every preset as a PNG, and the look table."""
    from PIL import Image

    from wgbragg.render import Renderer, save_png
    from wgbragg.scene import PRESETS, load_preset

    parser = argparse.ArgumentParser(
        prog="figures.py gallery",
        description="Render every scene preset to OUT/<preset>.png and measure its look.")
    parser.add_argument("--out", type=Path, default=GALLERY_OUT,
                        help=f"output folder (default {GALLERY_OUT})")
    parser.add_argument("--presets", default=",".join(PRESETS),
                        help="comma-separated presets (default: all)")
    parser.add_argument("--width", type=int, default=320,
                        help="image width in pixels, the preset's aspect ratio kept "
                             "(default 320)")
    parser.add_argument("--spp", type=int, default=64, help="samples per pixel (default 64)")
    parser.add_argument("--view", choices=("standard", "filmic"), default="standard")
    parser.add_argument("--no-measure", dest="measure", action="store_false",
                        help="skip the look measurements at 256 x 256, 16 spp")
    args = parser.parse_args(argv)
    names = [n for n in args.presets.split(",") if n]
    for name in names:
        if name not in PRESETS:
            parser.error(f"--presets: unknown preset {name!r}; one of {', '.join(PRESETS)}")
    if not 16 <= args.width <= 4096:
        parser.error(f"--width must be in [16, 4096], got {args.width}")
    if args.spp < 1:
        parser.error(f"--spp must be >= 1, got {args.spp}")
    rows = []
    for name in names:
        scene = load_preset(name)
        width, height = scene.settings.size
        size = (args.width, max(1, round(args.width * height / width)))
        image = Renderer(scene, size=size).render(args.spp)
        path = args.out / f"{name}.png"
        save_png(image, path, scene.settings.exposure, view=args.view)
        Image.open(path).verify()
        print(path)
        if args.measure:
            m = preset_look(name, view=args.view)
            rows.append(f"| `{name}` | {100 * m['saturated']:.1f} % | "
                        f"{100 * m['saturated_object']:.1f} % | {m['hue_range']:.0f} deg | "
                        f"{len(m['bands'])} | {100 * m['dark_background']:.2f} % | "
                        f"{100 * m['out_of_gamut']:.2f} % | {m['histogram_clip'].tolist()} | "
                        f"{m['histogram'].tolist()} |")
    if rows:
        print("| preset | saturation > 0.5 | on the objects | hue range | flat bands "
              "| dark background | out of gamut | saturation histogram, clipped "
              "| gamut-mapped |")
        print("|---|---|---|---|---|---|---|---|---|")
        print("\n".join(rows))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Write both figures into ``--out`` and print each path (``gallery``: see
    :func:`gallery`).

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name; default ``sys.argv[1:]``.

    Returns
    -------
    int
        Exit status.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["gallery"]:
        return gallery(argv[1:])
    args = parse_args(argv)
    dpi = 60 if args.quick else 150
    written = [
        save_png(figure3(args.quick), args.out / "fig3_spectrum.png", dpi),
        save_png(figure4(args.quick, progress=not args.no_progress),
                 args.out / "fig4_gradients.png", dpi),
    ]
    for path in written:
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
