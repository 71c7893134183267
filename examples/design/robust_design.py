"""Plain against robust colour design, measured on the same fresh perturbations.

Designs a Bragg mirror (n1 = 1 fixed; n2, d1, d2, N in [1, 15] free) for the colour travel
(0, 30, 60 degrees) of BraggMirror(1.0, 1.6, 140, 90, 8), once for the nominal colour and once
with ``robust=`` (the objective averaged over SAMPLES fixed draws of a thickness error of
SIGMA nm, per parameter or, with ``--per-layer``, per layer), then evaluates both designs on
the search's own draws and on 300 fresh ones (the same for both): the mean dE2000 to the
target, and the nominal dE2000.

Usage::

    python examples/design/robust_design.py [SAMPLES [SIGMA_NM]] [--per-layer]
"""

import sys
import time

import numpy as np

from wgbragg import BraggMirror
from wgbragg.design import design_colour
from wgbragg.design.colour_design import perturbed_delta_e
from wgbragg.design.tolerance import layer_perturbations, perturbations

per_layer = "--per-layer" in sys.argv
arguments = [a for a in sys.argv[1:] if a != "--per-layer"]
theta = np.radians([0.0, 30.0, 60.0])
samples = int(arguments[0]) if arguments else 32
sigma = float(arguments[1]) if len(arguments) > 1 else 3.0
target = BraggMirror(1.0, 1.6, 140.0, 90.0, 8).xyz(theta)
if per_layer:  # errors for up to 2 x 15 layers, as the search draws them
    fresh = layer_perturbations(300, 30, sigma, 0.0, seed=12345)
    search_draws = layer_perturbations(samples, 30, sigma, 0.0, seed=0, quasi_random=True)
else:
    fresh = perturbations("bragg", 300, sigma, 0.0, seed=12345)
    search_draws = perturbations("bragg", samples, sigma, 0.0, seed=0, quasi_random=True)
kind = "layer" if per_layer else "parameter"
print(f"sigma {sigma} nm per {kind}, {samples} draws in the objective, 300 fresh draws")
print("design   time   nominal dE   mean dE (search draws)   mean dE (fresh)   structure")
for name, robust in (("plain", None), ("robust", {"sigma_thickness_nm": sigma,
                                                   "samples": samples,
                                                   "per_layer": per_layer})):
    start = time.perf_counter()
    best = design_colour(target, theta, "bragg", fixed={"n1": 1.0}, bounds={"N": (1, 15)},
                         space="xyz", seed=0, generations=50, robust=robust)[0]
    seconds = time.perf_counter() - start
    on_draws = perturbed_delta_e(best.structure, target, theta, search_draws, space="xyz",
                                 backend="gpu")
    on_fresh = perturbed_delta_e(best.structure, target, theta, fresh, space="xyz",
                                 backend="gpu")
    s = best.structure
    print(f"{name:7s} {seconds:5.1f} s  {best.delta_e:10.3f}   {on_draws.mean():22.3f}"
          f"   {on_fresh.mean():15.3f}   n2 {s.n2:.4f} d1 {s.d1:.2f} d2 {s.d2:.2f} N {s.N}")
