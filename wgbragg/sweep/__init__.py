"""Sweeps over structure parameters in chunks on Dask, stored as Zarr, resumable; batch
renders as Dask tasks.

A sweep (:class:`~wgbragg.sweep.spec.Sweep`, read from TOML by :func:`load_sweep`, format in
``docs/sweeps.md``) is a grid of named coordinates over a Bragg mirror, a thin film or a rough
structure (layered Bragg mirrors, a rough thin film) and the quantities evaluated on it;
:func:`sweep_dataset` makes it a lazy :class:`xarray.Dataset`,
:func:`run_sweep` stores it as Zarr through a Dask client (:func:`dask_client`), computing only
the chunks not stored yet, and :func:`open_atlas` reads it back.

Dask, distributed, xarray and zarr are imported by the functions that use them, not here.
"""

from wgbragg.sweep.engine import SweepReport, dask_client, run_sweep
from wgbragg.sweep.spec import Quantity, Sweep, load_sweep, parse_sweep
from wgbragg.sweep.store import open_atlas, sweep_dataset

__all__ = ["Quantity", "Sweep", "SweepReport", "dask_client", "load_sweep", "open_atlas",
           "parse_sweep", "run_sweep", "sweep_dataset"]
