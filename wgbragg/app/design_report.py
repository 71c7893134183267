"""Report figures of inverse design (PNG, matplotlib): a fit's measured and fitted spectra, a
design's target and achieved colours over angle, and a tolerance histogram."""

from __future__ import annotations

import numpy as np

from wgbragg.colour.colorimetry import lab_to_xyz, xyz_to_linear_srgb
from wgbragg.common.atomic import atomic_path, check_output_path
from wgbragg.render.display import encode_srgb

__all__ = ["display_srgb", "save_design_report", "save_fit_report"]


def display_srgb(xyz) -> np.ndarray:
    """Gamma-encoded sRGB in [0, 1] for display (out-of-gamut colours clipped)."""
    return encode_srgb(np.clip(xyz_to_linear_srgb(np.asarray(xyz, np.float64)), 0.0, 1.0))


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _histogram(axes, spread, title):
    axes.hist(spread, bins=40, color="0.4")
    axes.axvline(1.0, color="crimson", lw=1, label="dE2000 = 1")
    axes.set_xlabel("dE2000 to nominal (mean over angles)")
    axes.set_ylabel("samples")
    axes.set_title(title, fontsize=9)
    axes.legend(fontsize=8)


def save_fit_report(result, wavelength_nm, theta, measured, path, tolerance=None):
    """Measured (points) against fitted (lines) reflectance per angle, the residuals and,
    when given, a :class:`~wgbragg.design.ToleranceResult` histogram; written atomically."""
    check_output_path(path, "report", ".png")
    plt = _pyplot()
    wavelength = np.asarray(wavelength_nm, np.float64).ravel()
    angle = np.asarray(theta, np.float64).ravel()
    data = np.asarray(measured, np.float64).reshape(wavelength.size, angle.size)
    dense = np.linspace(wavelength[0], wavelength[-1], 600)
    fitted = result.structure.reflectance(dense[:, None], angle[None, :])
    panels = 3 if tolerance is not None else 2
    figure, axes = plt.subplots(1, panels, figsize=(5 * panels, 4), dpi=110,
                                layout="constrained")
    for j, a in enumerate(angle):
        colour = f"C{j}"
        axes[0].plot(wavelength, data[:, j], ".", ms=3, color=colour,
                     label=f"measured {np.degrees(a):.0f} deg")
        axes[0].plot(dense, fitted[:, j], "-", lw=1, color=colour)
        axes[1].plot(wavelength, result.residual.reshape(data.shape)[:, j], ".-", ms=2,
                     lw=0.5, color=colour)
    axes[0].set_xlabel("wavelength (nm)")
    axes[0].set_ylabel("reflectance")
    figure.suptitle(f"fit: {result.structure!r}", fontsize=8)
    axes[0].legend(fontsize=7)
    axes[1].set_xlabel("wavelength (nm)")
    axes[1].set_ylabel("weighted residual")
    count = len(result.optima)
    axes[1].set_title(f"RMS {result.rms:.4g}, {count} distinct optim{'um' if count == 1 else 'a'}",
                      fontsize=9)
    if tolerance is not None:
        _histogram(axes[2], tolerance.delta_e, "tolerance of the fit")
    with atomic_path(path) as temporary:
        figure.savefig(temporary, format="png")
    plt.close(figure)
    return path


def save_design_report(candidates, theta, target_lab, path, tolerance=None):
    """Target colours (squares at their angles) against each candidate's colour over angle
    (a strip from 0 to 90 degrees), and a tolerance histogram of the best; atomically."""
    check_output_path(path, "report", ".png")
    plt = _pyplot()
    angle = np.asarray(theta, np.float64).ravel()
    sweep = np.radians(np.linspace(0.0, 90.0, 91))
    rows = len(candidates)
    panels = 2 if tolerance is not None else 1
    figure, axes = plt.subplots(1, panels, figsize=(6 * panels, 1.2 + 0.8 * (rows + 1)),
                                dpi=110, layout="constrained", squeeze=False)
    ax = axes[0, 0]
    targets = display_srgb(lab_to_xyz(target_lab))
    for j, a in enumerate(np.degrees(angle)):
        ax.add_patch(plt.Rectangle((a - 2.0, rows + 0.1), 4.0, 0.8, color=targets[j]))
    for i, candidate in enumerate(candidates):
        strip = display_srgb(candidate.structure.xyz(sweep, method="reference"))
        ax.imshow(strip[None], extent=(0, 90, rows - i - 1 + 0.1, rows - i - 0.1),
                  aspect="auto")
        ax.text(91, rows - i - 0.5, f"dE {candidate.delta_e:.2f}  ({candidate.method} "
                f"{candidate.delta_e_method:.2f})  complexity {candidate.complexity:g}",
                va="center", fontsize=7)
    ax.set_xlim(0, 150)
    ax.set_ylim(0, rows + 1)
    ax.set_yticks([rows + 0.5] + [rows - i - 0.5 for i in range(rows)])
    ax.set_yticklabels(["target"] + [f"#{i + 1}" for i in range(rows)])
    ax.set_xticks([0, 30, 60, 90])
    ax.set_xlabel("angle of incidence (degrees)")
    ax.set_title("target against achieved colour over angle", fontsize=9)
    if tolerance is not None:
        _histogram(axes[0, 1], tolerance.delta_e, "tolerance of candidate #1")
    with atomic_path(path) as temporary:
        figure.savefig(temporary, format="png")
    plt.close(figure)
    return path
