"""Inverse design: fit structures to measured spectra (:func:`fit_spectrum`; a rough layer to
its goniometric BRDF), design structures for target colours over angle (:func:`design_colour`,
optionally robust to fabrication errors) and predict their fabrication tolerance
(:func:`tolerance`). Populations of structures are evaluated in one GPU dispatch
(:mod:`wgbragg.design.population_gpu`, twin of :mod:`wgbragg.design.population`; non-periodic
stacks: :mod:`wgbragg.design.stack_gpu`, twin of :mod:`wgbragg.design.stack`); results are
polished and reported in float64. Guide: ``docs/inverse_design.md``."""

from wgbragg.design.colour_design import Candidate, design_colour, perturbed_delta_e, search_xyz
from wgbragg.design.fit import FitResult, LocalOptimum, fit_spectrum
from wgbragg.design.tolerance import ToleranceResult, tolerance

__all__ = ["Candidate", "FitResult", "LocalOptimum", "ToleranceResult", "design_colour",
           "fit_spectrum", "perturbed_delta_e", "search_xyz", "tolerance"]
