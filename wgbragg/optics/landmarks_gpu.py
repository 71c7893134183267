"""Dispatch of the float32 landmark finder (``wgsl/optics/landmarks_eval.wgsl``, built on
``wgsl/optics/landmarks.wgsl``): the GPU twin of :func:`wgbragg.optics.landmarks.find_landmarks`,
which the tests compare it with."""

from __future__ import annotations

import numpy as np

from wgbragg import gpu
from wgbragg.optics import yeh_gpu
from wgbragg.optics.landmarks import KINDS

__all__ = ["LANDMARK_CAPACITY", "find_landmarks_gpu"]

WORKGROUP_SIZE = 64

LANDMARK_CAPACITY = 128
"""Landmarks per angle returned by :func:`find_landmarks_gpu`."""


def find_landmarks_gpu(mirror, theta, polarization: str = "s"):
    """Landmarks found by the float32 kernel (``wgsl/optics/landmarks_eval.wgsl``).

    A test aid mirroring :func:`wgbragg.optics.landmarks.find_landmarks`.

    Parameters
    ----------
    mirror : BraggMirror
    theta : array_like
        Angles in the host, radians, any shape.
    polarization : {"s", "p"}

    Returns
    -------
    list of (omega, kind) per angle (flattened order)
        ``omega`` float64 rad/nm increasing, ``kind`` strings of
        :data:`wgbragg.optics.landmarks.KINDS`; at most :data:`LANDMARK_CAPACITY` each.
    """
    if polarization not in ("s", "p"):
        raise ValueError(f"polarization must be 's' or 'p', got {polarization!r}")
    params = yeh_gpu.bragg_params(mirror.n1, mirror.n2, mirror.d1, mirror.d2, mirror.N, mirror.host)
    kernel = gpu.compute_pipeline(
        "optics/landmarks_eval.wgsl",
        constants={"POLARIZATION": int(polarization == "p"), "CAPACITY": LANDMARK_CAPACITY,
                   "WORKGROUP_SIZE": WORKGROUP_SIZE},
    )
    flat = np.ascontiguousarray(np.asarray(theta, np.float64), np.float32).ravel()
    found, count = kernel.run(
        [flat], [((flat.size * LANDMARK_CAPACITY, 4), np.float32), (flat.size, np.uint32)],
        params, count=flat.size,
    )
    found = found.reshape(flat.size, LANDMARK_CAPACITY, 4)
    kinds = np.array(KINDS)
    return [(found[i, : count[i], 0].astype(np.float64), kinds[found[i, : count[i], 1].astype(int)])
            for i in range(flat.size)]
