"""A sweep as a lazy :class:`xarray.Dataset` (:func:`sweep_dataset`) and as a Zarr store
written a chunk at a time, resumably (:func:`init_store`, :func:`store_chunk`,
:func:`open_atlas`).

Resumable, and never half a chunk read as data
----------------------------------------------
The store's chunks are the sweep's chunks, so every task writes whole Zarr chunks that no
other task touches. After a chunk's data is written, its *completion marker* is written
atomically (a temporary file renamed, :mod:`wgbragg.common.atomic`) under
``STORE/.wgbragg/done/VARIABLE/i.j.k``. A run killed at any moment leaves each chunk either
marked (its data whole) or unmarked (its data absent or partial); a rerun computes exactly
the unmarked ones, and :func:`open_atlas` refuses an atlas with unmarked chunks (or, asked to,
masks them as NaN), so a partial chunk is never read as data.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.metadata
import json
import os
import shutil
import time
import warnings
from pathlib import Path

import numpy as np

from wgbragg._version import __version__
from wgbragg.common.atomic import write_text_atomic
from wgbragg.sweep.evaluate import evaluate_block
from wgbragg.sweep.spec import (
    ALBEDO,
    ANGLE,
    COLOUR_KINDS,
    ROUGH_MATERIALS,
    SPECTRAL_KINDS,
    Quantity,
    Sweep,
    parse_sweep,
    unit,
)

__all__ = ["chunk_key", "completed_chunks", "init_store", "open_atlas", "store_chunk",
           "stored_sweep", "sweep_dataset"]

_META = ".wgbragg"
_DONE = "done"
_READY = "ready.json"


@contextlib.contextmanager
def _quiet_zarr():
    """Without Zarr's warning that the markers' folder is no Zarr node (it is not meant to
    be one)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=f"Object at {_META} is not recognized")
        yield


def _version(package: str) -> str:
    try:
        return importlib.metadata.version(package)
    except importlib.metadata.PackageNotFoundError:
        return "not installed"


def _quantity(sweep: Sweep, name: str) -> Quantity:
    for q in sweep.quantities:
        if q.name == name:
            return q
    raise ValueError(f"no quantity named {name!r}")


def _variable_attrs(sweep: Sweep, q: Quantity) -> dict:
    if q.kind in SPECTRAL_KINDS:
        return {"long_name": f"{q.kind} ({q.polarization})", "units": "1",
                "polarization": q.polarization, "backend": sweep.backend}
    names = {"xyz": "CIE 1931 XYZ under D65 (perfect reflector Y = 1)",
             "rgb": "linear sRGB (D65)", "lab": "CIELAB (D65 white)", ALBEDO: "linear sRGB"}
    if sweep.material in ROUGH_MATERIALS:
        source = ("LayeredBragg.albedo" if sweep.material == "layered-bragg"
                  else "RoughThinFilm.albedo")
        attrs = {"units": "1", "backend": sweep.backend, "colour_method": q.method,
                 "colour_options": json.dumps(q.options, sort_keys=True)}
        if q.spectral:
            attrs["long_name"] = f"directional albedo, spectral, {source}"
        else:
            attrs["long_name"] = f"directional albedo, {names[q.kind]}, {source}"
            attrs["channels"] = list(COLOUR_KINDS["rgb" if q.kind == ALBEDO else q.kind])
        if sweep.material == "layered-bragg":
            attrs.update(samples=q.options["samples"], seed=q.options["seed"])
        return attrs
    return {"long_name": names[q.kind], "units": "1", "channels": list(COLOUR_KINDS[q.kind]),
            "colour_method": q.method, "colour_options": json.dumps(q.options, sort_keys=True),
            "backend": sweep.backend}


def sweep_dataset(sweep: Sweep):
    """The sweep as a lazy :class:`xarray.Dataset`: one dask array per quantity, one task per
    chunk (:func:`~wgbragg.sweep.evaluate.evaluate_block`); ``.compute()`` evaluates it where
    dask runs it. Coordinates and attributes record units, colour methods and options, the
    fixed parameters and the versions of wgbragg and colour-science."""
    import dask.array as da
    import xarray as xr

    variables = {}
    token = hashlib.sha256(sweep.to_json().encode()).hexdigest()[:16]
    for q in sweep.quantities:
        chunks = []
        for d in sweep.dims(q):
            if d == "channel":
                chunks.append((3,))
                continue
            n, step = len(sweep.coords[d]), sweep.chunks[d]
            chunks.append(tuple(min(step, n - s) for s in range(0, n, step)))

        def block(block_id=None, quantity=q):
            index = block_id if quantity.spectral else block_id[:-1]
            return evaluate_block(sweep, quantity, index)

        data = da.map_blocks(block, chunks=tuple(chunks), dtype=sweep.dtype,
                             meta=np.empty((0,) * len(chunks), dtype=sweep.dtype),
                             name=f"wgbragg-sweep-{q.name}-{token}")
        variables[q.name] = xr.Variable(sweep.dims(q), data, attrs=_variable_attrs(sweep, q))
    coords = {d: xr.Variable((d,), v, attrs={"units": unit(d)})
              for d, v in sweep.coords.items()}
    attrs = {
        "title": f"wgbragg sweep over a {sweep.material}",
        "material": sweep.material,
        "fixed": json.dumps(sweep.fixed, sort_keys=True),
        "angle": f"{ANGLE}: angle of incidence in the host, degrees",
        "wgbragg_version": __version__,
        "colour_science_version": _version("colour-science"),
        "wgbragg_sweep": sweep.to_json(),
    }
    if ANGLE not in sweep.coords:
        attrs[ANGLE] = float(sweep.fixed.get(ANGLE, 0.0))
    return xr.Dataset(variables, coords=coords, attrs=attrs)


# ---------------------------------------------------------------------- the store


def chunk_key(index) -> str:
    return ".".join(str(int(i)) for i in index)


def _marker(path: Path, name: str, index) -> Path:
    return path / _META / _DONE / name / chunk_key(index)


def stored_sweep(path) -> Sweep:
    """The sweep a store was made for (recorded when :func:`init_store` created it)."""
    ready = Path(path) / _META / _READY
    try:
        document = json.loads(ready.read_text(encoding="utf-8"))["wgbragg_sweep"]
        return parse_sweep(json.loads(document))
    except (OSError, KeyError, TypeError, json.JSONDecodeError, ValueError) as error:
        raise ValueError(f"{path} is not a readable wgbragg atlas ({error})") from None


def init_store(sweep: Sweep, path) -> bool:
    """Create the store for ``sweep`` at ``path`` (coordinates, attributes, empty chunks), or
    check that an existing one was made for the same sweep.

    Returns
    -------
    bool
        True if the store was created, False if an existing one is resumed.

    Raises
    ------
    ValueError
        If ``path`` holds another sweep, or something that is not a wgbragg atlas.
    """
    path = Path(path)
    ready = path / _META / _READY
    if ready.is_file():
        recorded = json.loads(ready.read_text(encoding="utf-8"))["wgbragg_sweep"]
        if recorded != sweep.to_json():
            raise ValueError(f"{path} holds another sweep (other coordinates, quantities, "
                             "chunks or options): write to a new path or delete it")
        return False
    if path.exists() and any(path.iterdir()) and not (path / _META).is_dir():
        raise ValueError(f"{path} exists and is not a wgbragg atlas: refusing to overwrite it")
    if path.exists():
        shutil.rmtree(path)  # a creation cut short: it holds no finished chunk
    (path / _META / _DONE).mkdir(parents=True)
    dataset = sweep_dataset(sweep)
    encoding = {q.name: {"chunks": sweep.chunk_shape(q)} for q in sweep.quantities}
    with _quiet_zarr():
        dataset.to_zarr(path, mode="a", compute=False, encoding=encoding, consolidated=False,
                        zarr_format=3)
    for q in sweep.quantities:
        (path / _META / _DONE / q.name).mkdir()
    write_text_atomic(ready, json.dumps({"wgbragg_sweep": sweep.to_json()}))
    return True


def completed_chunks(sweep: Sweep, path) -> set[tuple[str, str]]:
    """``(variable, chunk key)`` of every chunk whose completion marker exists."""
    done = set()
    for q in sweep.quantities:
        folder = Path(path) / _META / _DONE / q.name
        if folder.is_dir():
            done.update((q.name, entry.name) for entry in os.scandir(folder)
                        if not entry.name.startswith("."))
    return done


def store_chunk(sweep: Sweep, path, name: str, index) -> dict:
    """Evaluate chunk ``index`` of quantity ``name`` and write it into the store, then its
    completion marker (atomically). A chunk already marked is left alone.

    Returns
    -------
    dict
        ``name``, ``index``, ``computed`` (False if it was already marked), ``seconds`` and
        the worker's ``pid``.
    """
    import zarr

    path = Path(path)
    marker = _marker(path, name, index)
    if marker.exists():
        return {"name": name, "index": tuple(index), "computed": False, "seconds": 0.0,
                "pid": os.getpid()}
    start = time.perf_counter()
    q = _quantity(sweep, name)
    values = evaluate_block(sweep, q, index)
    ranges = sweep.block_slices(q, index)
    region = tuple(ranges[d] for d in sweep.grid_dims(q))
    array = zarr.open_array(store=str(path), path=name, mode="r+")
    array[region] = values
    digest = hashlib.sha256(np.ascontiguousarray(values).tobytes()).hexdigest()
    write_text_atomic(marker, json.dumps({"sha256": digest, "pid": os.getpid()}))
    return {"name": name, "index": tuple(index), "computed": True,
            "seconds": time.perf_counter() - start, "pid": os.getpid()}


def open_atlas(path, *, allow_incomplete: bool = False):
    """A stored sweep as a lazy :class:`xarray.Dataset`.

    Parameters
    ----------
    path : str or os.PathLike
        A store written by :func:`wgbragg.sweep.run_sweep` (``wgbragg sweep``).
    allow_incomplete : bool
        Open a store whose sweep was interrupted, its unfinished chunks NaN (whatever their
        files hold); otherwise such a store is refused.

    Raises
    ------
    ValueError
        If ``path`` is not a wgbragg atlas, or (without ``allow_incomplete``) a chunk is
        missing.
    """
    import dask.array as da
    import xarray as xr

    path = Path(path)
    sweep = stored_sweep(path)
    done = completed_chunks(sweep, path)
    missing = sweep.chunk_count() - len(done)
    with _quiet_zarr():
        dataset = xr.open_zarr(path, consolidated=False, zarr_format=3)
    if missing and not allow_incomplete:
        raise ValueError(f"{path}: {missing} of {sweep.chunk_count()} chunks are not written "
                         "yet; run the same 'wgbragg sweep' again to finish it")
    if missing:
        for q in sweep.quantities:
            keys = {key for name, key in done if name == q.name}
            variable = dataset[q.name]

            def written(block_info=None, spectral=q.spectral, keys=keys):
                # The dataset's chunks are the store's, so a block's location is its chunk's.
                info = block_info[None]
                location = info["chunk-location"]
                index = location if spectral else location[:-1]
                return np.full(info["chunk-shape"], chunk_key(index) in keys)

            marks = da.map_blocks(written, chunks=variable.data.chunks, dtype=bool)
            dataset[q.name] = variable.where(xr.DataArray(marks, dims=variable.dims))
    dataset.attrs["missing_chunks"] = int(missing)
    return dataset
