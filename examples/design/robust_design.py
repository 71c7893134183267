"""Plain against robust colour design, measured on the same fresh perturbations.

Designs a Bragg mirror (n1 = 1 fixed; n2, d1, d2, N in [1, 15] free) for the colour travel
(0, 30, 60 degrees) of BraggMirror(1.0, 1.6, 140, 90, 8), once for the nominal colour and once
with ``robust=`` (the objective averaged over SAMPLES fixed draws of a per-parameter thickness
error of SIGMA nm), then evaluates both designs on the search's own draws and on 300 fresh
ones (the same for both): the mean dE2000 to the target, and the nominal dE2000.

Usage::

    python examples/design/robust_design.py [SAMPLES [SIGMA_NM]]
"""

import sys
import time

import numpy as np

from wgbragg import BraggMirror
from wgbragg.design import design_colour
from wgbragg.design.colour_design import perturbed_delta_e
from wgbragg.design.tolerance import perturbations

theta = np.radians([0.0, 30.0, 60.0])
samples = int(sys.argv[1]) if len(sys.argv) > 1 else 32
sigma = float(sys.argv[2]) if len(sys.argv) > 2 else 3.0
target = BraggMirror(1.0, 1.6, 140.0, 90.0, 8).xyz(theta)
fresh = perturbations("bragg", 300, sigma, 0.0, seed=12345)
search_draws = perturbations("bragg", samples, sigma, 0.0, seed=0, quasi_random=True)
print(f"sigma {sigma} nm per parameter, {samples} draws in the objective, 300 fresh draws")
print("design   time   nominal dE   mean dE (search draws)   mean dE (fresh)   structure")
for name, robust in (("plain", None), ("robust", {"sigma_thickness_nm": sigma,
                                                   "samples": samples})):
    start = time.perf_counter()
    best = design_colour(target, theta, "bragg", fixed={"n1": 1.0}, bounds={"N": (1, 15)},
                         space="xyz", seed=0, generations=50, robust=robust)[0]
    seconds = time.perf_counter() - start
    on_draws = perturbed_delta_e(best.structure, target, theta, search_draws, space="xyz")
    on_fresh = perturbed_delta_e(best.structure, target, theta, fresh, space="xyz")
    s = best.structure
    print(f"{name:7s} {seconds:5.1f} s  {best.delta_e:10.3f}   {on_draws.mean():22.3f}"
          f"   {on_fresh.mean():15.3f}   n2 {s.n2:.4f} d1 {s.d1:.2f} d2 {s.d2:.2f} N {s.N}")
