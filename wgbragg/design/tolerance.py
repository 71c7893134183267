"""Fabrication tolerance of a structure's colour: :func:`tolerance`.

Monte Carlo on the GPU: ``samples`` perturbed copies of the structure, every thickness moved by
a normal error of ``sigma_thickness_nm`` and every index by one of ``sigma_index``, are
evaluated as one population (one dispatch), and their colour over angle is compared with the
nominal one by CIE dE2000. By default the errors are per parameter: all the ``d1`` layers of a
Bragg mirror move together (a deposition-rate calibration error), and the population kernels
evaluate periodic mirrors. With ``per_layer=True`` every layer carries its own errors (independent
deposition errors); the perturbed stacks are no longer periodic and run on the stack twins
(:mod:`wgbragg.design.stack_gpu`, Abeles matrices on the GPU, or the float64 transfer-matrix
solver with ``backend="numpy"``), from the same draws either way.
The sensitivities are float64 finite differences of the reference colour.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from wgbragg.bsdf.materials import BraggMirror, ThinFilm
from wgbragg.colour.colorimetry import xyz_to_lab
from wgbragg.common.validation import check_angle, check_backend
from wgbragg.design import population, population_gpu, stack, stack_gpu
from wgbragg.design.colour_targets import delta_e, grid_xyz_weights

__all__ = ["DEFAULT_THETA", "ToleranceResult", "check_theta", "family_name",
           "layer_perturbations", "layer_spectra", "perturb", "perturb_layers",
           "perturbations", "structure_members", "tolerance"]

DEFAULT_THETA = (0.0, math.radians(30.0), math.radians(60.0))
"""Angles of :func:`tolerance` by default: 0, 30 and 60 degrees (radians)."""

_THICKNESSES = {"bragg": ("d1", "d2"), "film": ("d",)}
_INDICES = {"bragg": ("n1", "n2"), "film": ("n_film",)}
# Layers (rows x 2N) of perturbed stacks drawn and evaluated at a time with per_layer.
_LAYER_BLOCK_ROWS = 1 << 20


@dataclass(frozen=True)
class ToleranceResult:
    """What :func:`tolerance` found.

    Attributes
    ----------
    delta_e : numpy.ndarray
        ``(samples,)`` mean over the angles of dE2000 between each perturbed structure and the
        nominal one.
    delta_e_per_angle : numpy.ndarray
        ``(samples, len(theta))``.
    sensitivity : dict
        dE2000 (mean over angles) per nm of each thickness, per unit of each index, from a
        float64 finite difference (1 nm, 1e-3).
    percentiles : dict
        The 50th, 90th and 99th percentiles of ``delta_e``.
    """

    delta_e: np.ndarray
    delta_e_per_angle: np.ndarray
    sensitivity: dict
    percentiles: dict

    def share_below(self, threshold: float = 1.0) -> float:
        """Share of samples with ``delta_e <= threshold``."""
        return float(np.mean(self.delta_e <= threshold))


def perturbations(family: str, samples: int, sigma_thickness_nm: float, sigma_index: float,
                  seed=None, quasi_random: bool = False) -> dict[str, np.ndarray]:
    """Normal errors ``(samples,)`` of each thickness (nm) and index of ``family``:
    pseudo-random, or (``quasi_random``) scrambled Sobol points mapped through the normal
    quantile, whose sample mean of a smooth function converges much faster (the draws of a
    robust design's objective, which a search would otherwise fit to)."""
    names = (*_THICKNESSES[family], *_INDICES[family])
    if quasi_random:
        from scipy.special import ndtri
        from scipy.stats import qmc

        unit = qmc.Sobol(len(names), scramble=True, seed=seed).random_base2(
            max(0, math.ceil(math.log2(samples))))[:samples]  # balanced for powers of 2
        normal = ndtri(np.clip(unit, 1e-12, 1.0 - 1e-12)).T
    else:
        rng = np.random.default_rng(seed)
        normal = rng.standard_normal((len(names), samples))
    return {name: (sigma_thickness_nm if name in _THICKNESSES[family] else sigma_index) * z
            for name, z in zip(names, normal, strict=True)}


def layer_perturbations(samples: int, layers: int, sigma_thickness_nm: float,
                        sigma_index: float, seed=None,
                        quasi_random: bool = False) -> dict[str, np.ndarray]:
    """Per-layer normal errors: ``"layer_thickness"`` (nm) and ``"layer_index"``, each
    ``(samples, layers)``, for stacks of up to ``layers`` layers (a shorter stack uses the
    first of them); pseudo-random or scrambled Sobol points through the normal quantile, as
    :func:`perturbations`. ``seed`` may be a :class:`numpy.random.Generator`, whose stream
    consecutive calls continue (pseudo-random draws in blocks equal one draw)."""
    if quasi_random:
        from scipy.special import ndtri
        from scipy.stats import qmc

        unit = qmc.Sobol(2 * layers, scramble=True, seed=seed).random_base2(
            max(0, math.ceil(math.log2(samples))))[:samples]
        normal = ndtri(np.clip(unit, 1e-12, 1.0 - 1e-12))
    else:
        normal = np.random.default_rng(seed).standard_normal((samples, 2 * layers))
    return {"layer_thickness": sigma_thickness_nm * normal[:, :layers],
            "layer_index": sigma_index * normal[:, layers:]}


def perturb_layers(members, errors):
    """Bragg mirrors of a population (``(P,)`` arrays) as stacks under every per-layer error
    of :func:`layer_perturbations` (``(K, M)``, ``M >= 2N``), grouped by N: yields
    ``(rows, host, indices, thicknesses, base)`` with ``rows`` the member-major positions
    ``p * K + k`` of each group's ``(G * K, 2N)`` stacks. Thicknesses stay >= 0 and indices
    >= 0.01; the host and the substrate (``n1``) keep their index, as ``tolerance``'s."""
    count = errors["layer_thickness"].shape[0]
    periods = np.asarray(members["N"]).astype(int)
    for n in np.unique(periods):
        group = np.flatnonzero(periods == n)
        pair = [np.stack([members[a][group], members[b][group]], -1)
                for a, b in (("n1", "n2"), ("d1", "d2"))]
        indices, thicknesses = (np.tile(p, (1, n))[:, None, :] for p in pair)
        indices = np.maximum(indices + errors["layer_index"][None, :, :2 * n], 0.01)
        thicknesses = np.maximum(thicknesses + errors["layer_thickness"][None, :, :2 * n], 0.0)
        rows = (group[:, None] * count + np.arange(count)).ravel()
        yield (rows, np.repeat(members["host"][group], count),
               indices.reshape(-1, 2 * n), thicknesses.reshape(-1, 2 * n),
               np.repeat(members["n1"][group], count))


def perturb(family: str, members, errors) -> dict[str, np.ndarray]:
    """Every member of a population (``(P,)`` arrays) under every error of
    :func:`perturbations` (``(K,)``): ``(P * K,)`` arrays, member-major. Thicknesses stay >= 0
    and indices >= 0.01; a mirror whose host is its ``n1`` keeps it so."""
    size = len(next(iter(members.values())))
    count = len(next(iter(errors.values())))
    out = {k: np.repeat(np.asarray(v, np.float64), count) for k, v in members.items()}
    matched = out["host"] == out["n1"] if family == "bragg" else None
    for name, error in errors.items():
        floor = 0.0 if name in _THICKNESSES[family] else 0.01
        out[name] = np.maximum(out[name] + np.tile(error, size), floor)
    if matched is not None:
        out["host"] = np.where(matched, out["n1"], out["host"])
    return out


def family_name(structure) -> str:
    """``"bragg"`` or ``"film"``: the family of a structure :func:`tolerance` accepts."""
    if isinstance(structure, BraggMirror):
        return "bragg"
    if isinstance(structure, ThinFilm):
        return "film"
    raise ValueError(f"structure must be a BraggMirror or a ThinFilm, got {type(structure)}")


def structure_members(structure, family: str, size: int = 1) -> dict[str, np.ndarray]:
    """The population of ``size`` copies of ``structure`` (its numeric constructor
    parameters, each ``(size,)``)."""
    names = (("n1", "n2", "d1", "d2", "N", "host") if family == "bragg"
             else ("n_film", "d", "n_base", "k_base", "host"))
    return {n: np.full(size, float(getattr(structure, n))) for n in names}


def check_theta(theta) -> np.ndarray:
    """Angles of incidence as a flat array of at least one angle (radians in [0, pi/2])."""
    angle = check_angle(theta).reshape(-1)
    if angle.size == 0:
        raise ValueError("theta must hold at least one angle")
    return angle


def _sigma(name: str, value) -> float:
    try:
        sigma = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number >= 0, got {value!r}") from None
    if not (math.isfinite(sigma) and sigma >= 0):
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    return sigma


def tolerance(structure, sigma_thickness_nm=2.0, sigma_index=0.0, samples=1000,
              theta=DEFAULT_THETA, *, per_layer=False, backend="gpu",
              seed=None) -> ToleranceResult:
    """The dE2000 distribution of ``structure``'s colour under fabrication errors.

    Parameters
    ----------
    structure : BraggMirror or ThinFilm
    sigma_thickness_nm : float
        Standard deviation of each thickness's error, nm (>= 0).
    sigma_index : float
        Standard deviation of each index's error (>= 0); a mirror whose host is its ``n1``
        keeps it so.
    samples : int
        Monte Carlo samples, in [1, 10**6].
    theta : array_like
        Angles of incidence in the host, radians.
    per_layer : bool
        Give each of a mirror's 2N layers its own errors (independent deposition errors)
        instead of moving all layers of one kind together. The perturbed stacks are no longer
        periodic: they run on the GPU stack kernel (:mod:`wgbragg.design.stack_gpu`), or with
        ``backend="numpy"`` on the float64 transfer-matrix solver
        (:func:`~wgbragg.optics.transfer_matrix_reflectance`, one call per sample), from the
        same draws; the host and the substrate keep their index. A film has one layer: the
        same as the default.
    backend : {"gpu", "numpy"}
    seed : int, optional

    Returns
    -------
    ToleranceResult
    """
    family = family_name(structure)
    sig_d = _sigma("sigma_thickness_nm", sigma_thickness_nm)
    sig_n = _sigma("sigma_index", sigma_index)
    if not isinstance(samples, int | np.integer) or not 1 <= samples <= 10**6:
        raise ValueError(f"samples must be an integer in [1, 1000000], got {samples!r}")
    check_backend(backend)
    angle = check_theta(theta)
    matched = family == "bragg" and structure.host == structure.n1
    nodes, weights = grid_xyz_weights()
    wl, th = np.tile(nodes, angle.size), np.repeat(angle, nodes.size)
    if per_layer and family == "bragg":
        spectra = _layer_spectra(structure, sig_d, sig_n, samples, wl, th, seed, backend)
    else:
        nominal = structure_members(structure, family, 1)
        errors = perturbations(family, samples, sig_d, sig_n, seed)
        members = {k: np.concatenate([nominal[k], v])
                   for k, v in perturb(family, nominal, errors).items()}
        base_index = (structure.base(wl) if family == "film" and structure.base is not None
                      else None)
        twin = population_gpu if backend == "gpu" else population
        spectra = twin.population_reflectance(family, members, wl, th, "unpolarized",
                                              base_index)
    lab = xyz_to_lab(np.maximum(spectra.reshape(-1, angle.size, nodes.size) @ weights, 0.0))
    per_angle = delta_e(lab[1:], lab[0])
    spread = per_angle.mean(axis=-1)
    return ToleranceResult(
        delta_e=spread, delta_e_per_angle=per_angle,
        sensitivity=_sensitivity(structure, family, angle, matched),
        percentiles={q: float(np.percentile(spread, q)) for q in (50, 90, 99)})


def layer_spectra(members, errors, wavelength, theta, backend) -> np.ndarray:
    """Reflectance ``(P * K, L)``, member-major, of every Bragg mirror of a population under
    every per-layer error (:func:`layer_perturbations`): non-periodic stacks
    (:func:`perturb_layers`) by the stack twins, float32 GPU Abeles matrices or the float64
    transfer-matrix solver."""
    twin = stack_gpu if backend == "gpu" else stack
    count = errors["layer_thickness"].shape[0]
    out = np.empty((len(members["N"]) * count, np.asarray(wavelength).size))
    for rows, host, indices, thicknesses, base in perturb_layers(members, errors):
        out[rows] = twin.stack_reflectance(host, indices, thicknesses, base, wavelength, theta)
    return out


def _layer_spectra(mirror, sigma_d, sigma_n, samples, wavelength, theta, seed, backend):
    """Spectra ``(1 + samples, L)`` of the mirror and of copies whose 2N layers each carry
    their own normal errors, a bounded block of copies at a time; the draws continue one
    generator, so they do not depend on the block size."""
    layers = 2 * mirror.N
    # The GPU's stack kernel takes what the device's loop budget allows; numpy a block of
    # copies holds at least one copy.
    most = stack_gpu.max_layers() if backend == "gpu" else _LAYER_BLOCK_ROWS
    if layers > most:
        raise ValueError(f"per_layer takes mirrors of at most {most // 2} periods with "
                         f"backend={backend!r}, got N = {mirror.N}")
    rng = np.random.default_rng(seed)
    members = structure_members(mirror, "bragg")
    nominal = {"layer_thickness": np.zeros((1, layers)), "layer_index": np.zeros((1, layers))}
    out = np.empty((samples + 1, wavelength.size))
    out[0] = layer_spectra(members, nominal, wavelength, theta, backend)[0]
    block = max(1, _LAYER_BLOCK_ROWS // layers)
    for start in range(0, samples, block):
        count = min(block, samples - start)
        errors = layer_perturbations(count, layers, sigma_d, sigma_n, rng)
        out[1 + start:1 + start + count] = layer_spectra(members, errors, wavelength, theta,
                                                         backend)
    return out


def _sensitivity(structure, family, angle, matched) -> dict:
    nominal = xyz_to_lab(structure.xyz(angle, method="reference"))
    out = {}
    steps = {**{n: 1.0 for n in _THICKNESSES[family]}, **{n: 1e-3 for n in _INDICES[family]}}
    for name, step in steps.items():
        changes = {name: float(getattr(structure, name)) + step}
        if matched and name == "n1":
            changes["host"] = changes["n1"]
        moved = _replace(structure, changes)
        lab = xyz_to_lab(moved.xyz(angle, method="reference"))
        out[name] = float(delta_e(lab, nominal).mean() / step)
    return out


def _replace(structure, changes):
    if isinstance(structure, BraggMirror):
        fields = {n: getattr(structure, n) for n in ("n1", "n2", "d1", "d2", "N", "host")}
        return BraggMirror(**{**fields, **changes})
    fields = {n: getattr(structure, n) for n in ("n_film", "d", "n_base", "k_base", "host",
                                                 "base")}
    return ThinFilm(**{**fields, **changes})
