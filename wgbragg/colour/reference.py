"""Colour of a material by direct spectral integration: the "reference" and "spectral" methods.

Both integrate the exact unpolarized reflectance (mean of s and p) against the D65-weighted
CIE 1931 XYZ weights of :mod:`wgbragg.colour.colorimetry`, and differ only in their nodes:

- ``reference``: every nm from 360 to 830 nm (471 nodes), weights :func:`colorimetry.xyz_weights`.
  This is the ground truth the approximate methods are measured against.
- ``spectral``: K stratified wavelengths (see :func:`stratified_nodes`), the cheap estimator a
  progressive renderer would use, self-normalised (:func:`self_normalised_weights`): a
  perfect reflector is exactly white for every K and seed, and the estimate converges to
  the reference as K grows.

``backend="numpy"`` evaluates ``material.reflectance`` in float64; ``backend="gpu"`` runs one
float32 WGSL invocation per angle over the same nodes (:mod:`wgbragg.colour.reference_gpu`).
"""

from __future__ import annotations

import numpy as np

from wgbragg.colour import colorimetry, reference_gpu
from wgbragg.common.validation import (
    as_float_array,
    check_angle,
    check_backend,
    check_count,
    check_material,
    check_seed,
    check_wavelength,
)

__all__ = [
    "MAX_SAMPLES",
    "STRATA_RANGE_NM",
    "WHITE_XYZ",
    "integrate_xyz",
    "reference_xyz",
    "self_normalised_weights",
    "spectral_xyz_stratified",
    "stratified_nodes",
]

STRATA_RANGE_NM = (
    colorimetry.WAVELENGTH_RANGE_NM[0] - 0.5 * colorimetry.WAVELENGTH_STEP_NM,
    colorimetry.WAVELENGTH_RANGE_NM[1] + 0.5 * colorimetry.WAVELENGTH_STEP_NM,
)
"""Interval split into strata, nm: 359.5-830.5, the union of the reference's 1 nm cells."""

MAX_SAMPLES = 100_000
"""Most strata of "spectral": far past convergence (strata of 0.005 nm), and the nodes of one
call stay in memory."""

WHITE_XYZ = colorimetry.xyz_weights()[1].sum(axis=0)
WHITE_XYZ.setflags(write=False)
"""XYZ of the perfect reflector by the reference: D65's white point with ``Y = 1``,
(0.95047, 1, 1.08883). "spectral" gives it exactly (to rounding) for ``R = 1``."""

# Reflectances evaluated per numpy block: bounds memory for large angle arrays.
_BLOCK = 1 << 20


def integrate_xyz(material, theta, wavelength_nm, weights, backend="numpy") -> np.ndarray:
    """``sum_k R(lambda_k, theta) w_k`` with ``R`` the unpolarized reflectance of ``material``.

    Parameters
    ----------
    material : BraggMirror or ThinFilm
        Or, with ``backend="numpy"``, any object with the same ``reflectance`` method.
    theta : array_like
        Angles of incidence in radians in ``[0, pi/2]``, any shape.
    wavelength_nm : array_like
        Nodes, shape ``(K,)``, nm in ``[1, 1e6]``.
    weights : array_like
        XYZ weights of the nodes, shape ``(K, 3)``.
    backend : {"numpy", "gpu"}

    Returns
    -------
    numpy.ndarray
        XYZ, float64, shape ``theta.shape + (3,)``.

    Raises
    ------
    ValueError
        For an angle outside ``[0, pi/2]`` or NaN, a node outside ``[1, 1e6]`` nm or NaN,
        weights not finite, an unknown backend, a material without a ``reflectance`` method
        (or not a BraggMirror / ThinFilm on the GPU), or nodes and weights of mismatched
        shapes.
    """
    check_backend(backend)
    check_material(material)
    angle = check_angle(theta)
    # Checked here for both backends: the kernel would integrate whatever it is given.
    wavelength = check_wavelength(wavelength_nm)
    weight = as_float_array("weights", weights)
    if wavelength.ndim != 1 or weight.shape != (wavelength.size, 3):
        raise ValueError(
            f"wavelength_nm must have shape (K,) and weights (K, 3), got {wavelength.shape} and "
            f"{weight.shape}"
        )
    if not np.all(np.isfinite(weight)):
        raise ValueError("weights must be finite")
    if backend == "gpu":
        return reference_gpu.integrate_xyz(material, angle, wavelength, weight)
    flat = angle.ravel()
    xyz = np.empty((flat.size, 3))
    block = max(1, _BLOCK // max(wavelength.size, 1))
    for start in range(0, flat.size, block):
        chunk = flat[start : start + block, None]
        reflectance = material.reflectance(wavelength, chunk, "unpolarized", "numpy")
        xyz[start : start + block] = colorimetry.spectral_xyz(reflectance, wavelength, weight)
    return xyz.reshape((*angle.shape, 3))


def reference_xyz(material, theta, backend="numpy") -> np.ndarray:
    """Reference colour: exact unpolarized reflectance integrated every nm over 360-830 nm.

    Parameters
    ----------
    material : BraggMirror or ThinFilm
        Or, with ``backend="numpy"``, any object with the same ``reflectance`` method.
    theta : array_like
        Angles of incidence in the host, radians in ``[0, pi/2]``, any shape.
    backend : {"numpy", "gpu"}
        float64 numpy, or the float32 WGSL kernel (one invocation per angle).

    Returns
    -------
    numpy.ndarray
        CIE XYZ under D65 (perfect reflector ``Y = 1``), float64, shape ``theta.shape + (3,)``;
        :func:`colorimetry.xyz_to_linear_srgb` turns it into linear sRGB.

    Raises
    ------
    ValueError
        For ``theta`` outside ``[0, pi/2]`` or NaN, an unknown backend, or an unsupported
        material.

    Notes
    -----
    ``XYZ(theta) = sum_{lambda = 360}^{830} R(lambda, theta) w(lambda)`` with ``w`` from
    :func:`colorimetry.xyz_weights`, ``R = (R_s + R_p) / 2``. 471 reflectance evaluations per
    angle, O(1) in the number of periods. The float32 kernel agrees with numpy within dE2000
    0.1 (tests/test_colour_reference.py).

    Examples
    --------
    >>> from wgbragg import BraggMirror
    >>> m = BraggMirror(n1=1.0, n2=1.5, d1=125.0, d2=375.0, N=20)
    >>> reference_xyz(m, [0.0, 0.5]).shape
    (2, 3)
    """
    wavelength, weights = colorimetry.xyz_weights()
    return integrate_xyz(material, theta, wavelength, weights, backend)


def stratified_nodes(samples: int, seed=None) -> tuple[np.ndarray, np.ndarray]:
    """K stratified wavelengths and their XYZ weights.

    Parameters
    ----------
    samples : int
        Number of strata K in [1, :data:`MAX_SAMPLES`].
    seed : None, int or numpy.random.Generator
        None: each node at the centre of its stratum (deterministic midpoint rule). Otherwise
        one uniform jitter per stratum from ``numpy.random.default_rng(seed)``.

    Returns
    -------
    wavelength_nm : numpy.ndarray
        Shape ``(K,)``, increasing, nm.
    weights : numpy.ndarray
        Shape ``(K, 3)``: ``xyz_density(lambda_k) * h``.

    Raises
    ------
    ValueError
        If ``samples`` is not an integer in [1, MAX_SAMPLES], or ``seed`` is none of the
        above.

    Notes
    -----
    :data:`STRATA_RANGE_NM` = [359.5, 830.5] nm is split into K strata of width
    ``h = 471 nm / K``; node ``k`` lies at ``359.5 + (k + u_k) h`` with ``u_k = 1/2`` (centred)
    or ``u_k ~ U[0, 1)`` (jittered), rounded to float32 (so both backends sample the same
    wavelengths), and is weighted by the density times the width. Jittered,
    this is the classic stratified Monte-Carlo estimator: unbiased for the integral of
    ``R * density`` whatever K (averaging many seeds converges to the continuous integral),
    with a variance that falls at least as 1/K. The range is the reference's 1 nm cells, so
    K = 471 centred puts the nodes on 360, 361, ..., 830 nm with exactly the reference weights:
    there the method *is* the reference. For a perfect reflector the centred rule gives
    ``Y -> 1`` as K grows (the density vanishes outside 360-830 nm).

    Examples
    --------
    >>> wavelength, weights = stratified_nodes(4)
    >>> wavelength.tolist()
    [418.375, 536.125, 653.875, 771.625]
    """
    count = check_count("samples", samples, MAX_SAMPLES)
    start, end = STRATA_RANGE_NM
    width = (end - start) / count
    if seed is None:
        offset = np.full(count, 0.5)
    else:
        offset = np.random.default_rng(check_seed(seed)).random(count)
    # float32-representable nodes: the GPU kernel then samples exactly the numpy wavelengths.
    wavelength = (start + (np.arange(count) + offset) * width).astype(np.float32).astype(float)
    return wavelength, colorimetry.xyz_density(wavelength) * width


def self_normalised_weights(weights) -> np.ndarray:
    """Node weights rescaled per channel so that they sum to :data:`WHITE_XYZ`.

    Integrating with them is the ratio estimator of the stratified sum: each channel's
    ``sum_k R_k w_k`` divided by the same nodes' estimate for ``R = 1``, ``sum_k w_k``, times
    the reference's white. A perfect reflector is then white to rounding for any nodes, and
    the estimate converges to the reference wherever the unnormalised one does (its
    denominator converges to the white).

    Parameters
    ----------
    weights : array_like
        Shape ``(K, 3)``, finite and >= 0 (:func:`stratified_nodes`'s).

    Returns
    -------
    numpy.ndarray
        Shape ``(K, 3)``, float64. A channel whose weights are all 0 (e.g. ``zbar`` for
        K = 1 and a node beyond 650 nm: no node sees its CMF) takes the unweighted mean over
        the nodes, ``WHITE_XYZ[c] / K`` each.

    Examples
    --------
    >>> _, weights = stratified_nodes(16, seed=3)
    >>> bool(np.allclose(self_normalised_weights(weights).sum(0), WHITE_XYZ, rtol=1e-15))
    True
    """
    weights = np.asarray(weights, np.float64)
    total = weights.sum(axis=0)
    seen = total > 0.0
    scaled = np.where(seen, weights / np.where(seen, total, 1.0), 1.0 / max(len(weights), 1))
    return scaled * WHITE_XYZ


def spectral_xyz_stratified(material, theta, samples=16, backend="numpy", seed=None) -> np.ndarray:
    """Colour from K stratified wavelength samples of the exact reflectance.

    Parameters
    ----------
    material : BraggMirror or ThinFilm
        Or, with ``backend="numpy"``, any object with the same ``reflectance`` method.
    theta : array_like
        Angles of incidence in radians in ``[0, pi/2]``, any shape.
    samples : int
        Number of strata K in [1, :data:`MAX_SAMPLES`] (cost: K reflectance evaluations per
        angle).
    backend : {"numpy", "gpu"}
    seed : None, int or numpy.random.Generator
        None: deterministic centred nodes. Otherwise jittered nodes, shared by all angles of
        the call (so numpy and GPU see the same nodes for the same seed).

    Returns
    -------
    numpy.ndarray
        CIE XYZ under D65, float64, shape ``theta.shape + (3,)``: the perfect reflector
        exactly :data:`WHITE_XYZ` (to rounding) whatever ``samples`` and ``seed``.

    Raises
    ------
    ValueError
        As :func:`stratified_nodes`, or as :func:`reference_xyz`.

    Notes
    -----
    The nodes are those of :func:`stratified_nodes`; their weights are self-normalised
    (:func:`self_normalised_weights`): ``XYZ_c = W_c sum_k R_k w_kc / sum_k w_kc``, the
    stratified estimate of each channel over the same nodes' estimate for ``R = 1``, times
    the white ``W``. Few nodes no longer make a white surface coloured (unnormalised, K = 16
    gave (0.962, 1.0065, 1.096), K = 1 (4.2, 2.77, 0.004)); the ratio is consistent (it
    converges to the reference as K grows) but, jittered, not unbiased for a fixed K. With
    K = 471 and ``seed=None`` the weights already sum to the white, and it reproduces
    :func:`reference_xyz`. Both backends integrate with the same normalised weights.

    Examples
    --------
    >>> from wgbragg import BraggMirror
    >>> m = BraggMirror(n1=1.0, n2=1.5, d1=125.0, d2=375.0, N=20)
    >>> spectral_xyz_stratified(m, [[0.0, 0.5]], samples=8).shape
    (1, 2, 3)
    """
    wavelength, weights = stratified_nodes(samples, seed)
    return integrate_xyz(material, theta, wavelength, self_normalised_weights(weights), backend)
