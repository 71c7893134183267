"""Fit a rough Bragg layer, alpha included, to its in-plane goniometric BRDF.

Synthetic data from the library's float64 model (``LayeredBragg.brdf`` of one
``RoughBraggLayer`` over an absorbing base, in air): 36 wavelengths in 400-750 nm, light at
15, 35 and 55 degrees, detector at specular and 10 degrees either side; fitted noiseless and
with 2 % multiplicative noise.

Usage::

    python examples/design/fit_rough_layer.py
"""

import numpy as np

from wgbragg import BraggMirror, LayeredBragg, RoughBraggLayer
from wgbragg.design import fit_spectrum
from wgbragg.design.rough import in_plane_directions

truth = RoughBraggLayer(BraggMirror(1.0, 1.55, 130.0, 85.0, 9), 0.13)
wavelength = np.linspace(400.0, 750.0, 36)[:, None, None]
theta_i = np.radians([15.0, 35.0, 55.0])[:, None]
theta_o = theta_i + np.radians([-10.0, 0.0, 10.0])
wi, wo = in_plane_directions(theta_i, theta_o)
brdf = LayeredBragg([truth]).brdf(wi, wo, wavelength)  # (36, 3, 3), 1/sr
noisy = brdf * (1.0 + 0.02 * np.random.default_rng(0).standard_normal(brdf.shape))
for name, measured in (("noiseless", brdf), ("2 % noise", noisy)):
    fit = fit_spectrum("rough", wavelength, theta_i, measured, fixed={"n1": 1.0},
                       bounds={"N": (2, 16)}, theta_out=theta_o, seed=1, generations=60)
    values = ", ".join(f"{k} {v:.5g} +- {fit.standard_errors[k]:.2g}"
                       for k, v in fit.parameters.items() if k in fit.standard_errors)
    print(f"{name}: N {fit.parameters['N']}, {values}; RMS {fit.rms:.2g} 1/sr, "
          f"{fit.seconds:.1f} s")
