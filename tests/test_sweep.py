"""Sweeps on Dask stored as Zarr (wgbragg.sweep): a 2-worker LocalCluster stores what the
in-process computation gives, bit for bit (same chunks, same adapter: each chunk is the same
kernel calls on the same inputs); a worker killed by its PID mid-sweep leaves every chunk
stored once and equal to the reference; a killed client's sweep resumes computing only the
missing chunks. One cluster (two single-threaded worker processes) serves the module."""

from __future__ import annotations

import contextlib
import io
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import colour
import numpy as np
import pytest
from PIL import Image

from wgbragg import BraggMirror, LayeredBragg, RoughBraggLayer, ThinFilm
from wgbragg.app import cli
from wgbragg.app.atlas import colour_chart, display_srgb
from wgbragg.colour import colorimetry
from wgbragg.sweep import dask_client, load_sweep, open_atlas, parse_sweep, run_sweep, sweep_dataset
from wgbragg.sweep.store import completed_chunks, init_store

pytestmark = pytest.mark.gpu

ROOT = Path(__file__).resolve().parents[1]

SWEEP = """
material = "bragg-mirror"

[fixed]
n1 = 1.0
n2 = 1.5
delta = 0.5
N = 12

[coords]
period_nm = {{ start = 150.0, stop = 400.0, num = {periods} }}
theta_deg = [0.0, 20.0, 40.0, 60.0, 80.0]
{extra}
[chunks]
period_nm = 1

[[quantities]]
kind = "xyz"
method = "reference"

[[quantities]]
kind = "rgb"
method = "reference"
"""

SPECTRA = """
[[quantities]]
kind = "reflectance"
polarization = "s"

[[quantities]]
kind = "lab"
"""


def _write(tmp_path, name, periods, extra="", spectra=False) -> Path:
    path = tmp_path / name
    text = SWEEP.format(periods=periods, extra=extra) + (SPECTRA if spectra else "")
    path.write_text(text, encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def client():
    with dask_client(workers=2, dashboard=False) as client:
        yield client


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    """A sweep with a spectrum, its in-process dataset, and its store written by the
    cluster."""
    folder = tmp_path_factory.mktemp("small")
    path = _write(folder, "small.toml", 4, 'wavelength_nm = { start = 400.0, stop = 700.0, '
                  'num = 7 }\n', spectra=True)
    sweep = load_sweep(path)
    return sweep, sweep_dataset(sweep).compute(scheduler="synchronous"), folder


def _equal(stored, reference) -> None:
    for name in reference.data_vars:
        assert stored[name].dtype == reference[name].dtype == np.float32
        np.testing.assert_array_equal(stored[name].values, reference[name].values,
                                      err_msg=name)


def test_the_reference_is_the_library_colour(small):
    sweep, reference, _ = small
    # The third period of linspace(150, 400, 4) is 316.67 nm: check it against BraggMirror.
    mirror = sweep.structure({"period_nm": float(sweep.coords["period_nm"][2])})
    theta = np.radians(sweep.coords["theta_deg"])
    xyz = mirror.xyz(theta, "reference", "gpu")
    np.testing.assert_array_equal(reference["xyz"].values[2], xyz.astype(np.float32))
    spectrum = mirror.reflectance(sweep.coords["wavelength_nm"][None, :], theta[:, None], "s",
                                  "gpu")
    np.testing.assert_array_equal(reference["reflectance"].values[2],
                                  spectrum.astype(np.float32))
    # Against the float64 reference: float32 kernel accuracy.
    np.testing.assert_allclose(reference["xyz"].values[2], mirror.xyz(theta), atol=2e-3)
    # CIELAB: colour-science's, with the D65 white (a perfect reflector is L* = 100).
    white = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    np.testing.assert_allclose(reference["lab"].values[2],
                               colour.XYZ_to_Lab(xyz, white).astype(np.float32))
    assert colorimetry.xyz_to_lab([0.95047, 1.0, 1.08883])[0] == pytest.approx(100.0)


def test_two_workers_store_the_in_process_result_bit_for_bit(small, client):
    sweep, reference, folder = small
    report = run_sweep(sweep, folder / "atlas.zarr", client, progress=False)
    assert (report.computed, report.skipped, report.total) == (16, 0, 16)
    stored = open_atlas(folder / "atlas.zarr")
    _equal(stored.compute(), reference)
    # The atlas explains itself.
    assert stored["period_nm"].attrs["units"] == "nm"
    assert stored["theta_deg"].attrs["units"] == "deg"
    assert stored["rgb"].attrs["colour_method"] == "reference"
    assert stored["reflectance"].attrs["polarization"] == "s"
    assert stored.attrs["wgbragg_version"] and stored.attrs["colour_science_version"]
    assert json.loads(stored.attrs["fixed"]) == {"N": 12.0, "delta": 0.5, "n1": 1.0, "n2": 1.5}
    # Rerunning computes nothing.
    again = run_sweep(sweep, folder / "atlas.zarr", client, progress=False)
    assert (again.computed, again.skipped) == (0, 16)
    # The chart of the atlas shows the stored colours.
    chart = colour_chart(stored, "period_nm", "theta")
    assert chart.y == "theta_deg" and chart.variable == "xyz"
    chart = colour_chart(stored, "period_nm", "theta", variable="rgb")
    np.testing.assert_allclose(chart.pixels[0], display_srgb(
        reference["rgb"].values.transpose(1, 0, 2)))
    with contextlib.redirect_stdout(io.StringIO()):
        assert cli.main(["atlas", str(folder / "atlas.zarr"), "--x", "period_nm", "--y",
                         "theta", "--var", "rgb", "-o", str(folder / "chart.png")]) == 0
    with Image.open(folder / "chart.png") as image:
        assert image.format == "PNG" and image.size[0] > 100


def test_a_worker_killed_mid_sweep(tmp_path, client):
    sweep = load_sweep(_write(tmp_path, "kill.toml", 24))
    reference = sweep_dataset(sweep).compute(scheduler="synchronous")
    killed = {}
    records = []

    def kill_a_busy_worker(record):
        records.append(record)
        if killed:
            return
        busy = [address for address, keys in client.processing().items() if keys]
        assert busy, "the sweep ended before a worker could be killed"
        pid = client.run(os.getpid, workers=[busy[0]])[busy[0]]
        os.kill(pid, signal.SIGKILL)
        killed.update(pid=pid, after=len(records))

    report = run_sweep(sweep, tmp_path / "atlas.zarr", client, progress=False,
                       on_chunk=kill_a_busy_worker)
    assert killed and len(records) > killed["after"]  # chunks finished after the kill
    assert (report.computed, report.skipped, report.total) == (48, 0, 48)
    # Every chunk reported once and stored once (one marker each: a rerun of a task whose
    # result died with the worker finds the marker and writes nothing), equal to the
    # reference.
    chunks = [(r["name"], r["index"]) for r in records]
    assert len(set(chunks)) == len(chunks) == 48
    assert sum(r["computed"] for r in records) <= 48
    done = completed_chunks(sweep, tmp_path / "atlas.zarr")
    assert len(done) == 48
    _equal(open_atlas(tmp_path / "atlas.zarr").compute(), reference)


def test_an_existing_cluster_from_the_environment(client, monkeypatch):
    monkeypatch.setenv("DASK_SCHEDULER_ADDRESS", client.scheduler.address)
    lines = []
    with dask_client(log=lines.append) as other:
        assert other.scheduler.address == client.scheduler.address
    # (1 or 2 workers: the one killed above may still be restarting)
    assert lines[0].startswith(f"dask: scheduler {client.scheduler.address}, ")
    with pytest.raises(ValueError, match="--workers sizes an embedded cluster"), \
            dask_client(workers=3):
        pass
    with pytest.raises(ValueError, match="--workers must be an integer >= 1"), \
            dask_client(workers=0):
        pass


def _markers(store: Path) -> int:
    return sum(len([n for n in os.listdir(store / ".wgbragg" / "done" / q)
                    if not n.startswith(".")]) for q in ("xyz", "rgb"))


def test_a_killed_client_resumes_with_the_missing_chunks_only(tmp_path, client):
    path = _write(tmp_path, "resume.toml", 40)
    store = tmp_path / "atlas.zarr"
    argv = [sys.executable, "-m", "wgbragg.app.cli", "sweep", str(path), "-o", str(store),
            "--scheduler", client.scheduler.address, "--no-progress"]
    process = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                               start_new_session=True)
    try:
        deadline = time.monotonic() + 60.0
        while time.monotonic() < deadline and process.poll() is None:
            if (store / ".wgbragg" / "ready.json").exists() and _markers(store) >= 2:
                break
            time.sleep(0.005)
    finally:
        process.kill()
        _, errors = process.communicate()
    assert process.returncode == -signal.SIGKILL, errors.decode()
    before = _markers(store)
    assert 2 <= before < 80
    # An unfinished atlas is refused, or read with its missing chunks masked.
    with pytest.raises(ValueError, match="chunks are not written yet"):
        open_atlas(store)
    partial = open_atlas(store, allow_incomplete=True)
    assert 0 < partial.attrs["missing_chunks"] <= 80 - before
    marked = set(os.listdir(store / ".wgbragg" / "done" / "xyz"))
    values = partial["xyz"].values  # chunks: one period x every angle
    shown = {f"{i}.0" for i in range(40) if not np.isnan(values[i]).any()}
    blank = {f"{i}.0" for i in range(40) if np.isnan(values[i]).all()}
    assert shown | blank == {f"{i}.0" for i in range(40)} and shown <= marked
    assert blank and shown  # (chunks may have landed since the marker listing above)
    time.sleep(0.5)  # chunks in flight when the client died may still land: let them
    started_with = _markers(store)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert cli.main(["sweep", str(path), "-o", str(store), "--scheduler",
                         client.scheduler.address, "--no-progress"]) == 0
    line = out.getvalue()
    computed, skipped = int(line.split(": ")[1].split()[0]), int(line.split(", ")[1].split()[0])
    assert skipped >= started_with and computed == 80 - skipped and computed > 0, line
    sweep = load_sweep(path)
    _equal(open_atlas(store).compute(), sweep_dataset(sweep).compute(scheduler="synchronous"))


# ---------------------------------------------------------------------- without a cluster


def test_a_store_of_another_sweep_is_refused(tmp_path):
    first = load_sweep(_write(tmp_path, "a.toml", 3))
    second = load_sweep(_write(tmp_path, "b.toml", 4))
    assert init_store(first, tmp_path / "s.zarr") is True
    assert init_store(first, tmp_path / "s.zarr") is False
    with pytest.raises(ValueError, match="holds another sweep"):
        init_store(second, tmp_path / "s.zarr")
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("mine")
    with pytest.raises(ValueError, match="not a wgbragg atlas"):
        init_store(first, tmp_path / "other")
    with pytest.raises(ValueError, match="not a readable wgbragg atlas"):
        open_atlas(tmp_path / "other")


BASE = {"material": "bragg-mirror", "fixed": {"n1": 1.0, "n2": 1.5, "N": 10, "delta": 0.5},
        "coords": {"period_nm": [200.0, 250.0], "theta_deg": [0.0, 30.0]},
        "quantities": [{"kind": "rgb", "method": "approx"}]}


def _with(**changes) -> dict:
    document = json.loads(json.dumps(BASE))
    for key, value in changes.items():
        if value is None:
            document.pop(key)
        else:
            document[key] = value
    return document


@pytest.mark.parametrize(("changes", "message"), [
    ({"material": "opal"}, "material must be one of"),
    ({"colour": 1}, "unknown key 'colour'"),
    ({"fixed": {"n1": 1.0, "n2": 1.5, "N": 10}}, "period_nm and delta, or d1_nm and d2_nm"),
    ({"fixed": {"n1": 1.0, "n2": 1.5, "N": 10, "delta": 0.5, "d1_nm": 3.0}},
     "period_nm and delta, or d1_nm and d2_nm"),
    ({"fixed": {"n1": 1.0, "n2": 1.5, "N": 10, "delta": 1.5}}, "delta must lie in"),
    ({"fixed": {"n1": 1.0, "n2": 500.0, "N": 10, "delta": 0.5}}, "n2"),
    ({"coords": {"period_nm": [200.0, 200.0]}}, "repeats a value"),
    ({"coords": {"period_nm": [200.0], "N": [2.5, 3.0]}}, "both fixed and a coordinate"),
    ({"coords": {"period_nm": [200.0], "theta_deg": [95.0]}}, r"\[0, 90\] degrees"),
    ({"coords": {"period_nm": {"start": 1.0, "stop": 2.0}}}, "start, stop, num"),
    ({"quantities": [{"kind": "hue"}]}, "kind must be one of"),
    ({"quantities": [{"kind": "rgb", "method": "fourier-table"}]}, "method must be one of"),
    ({"quantities": [{"kind": "rgb", "method": "subdivided", "options": {"order": 3}}]},
     "options.order"),
    ({"quantities": [{"kind": "rgb", "method": "subdivided", "options": {"s": 0}}]},
     "quantity 'rgb'"),
    ({"quantities": [{"kind": "rgb"}, {"kind": "rgb"}]}, "a second quantity named 'rgb'"),
    ({"quantities": [{"kind": "reflectance"}]}, "spectra need coords.wavelength_nm"),
    ({"chunks": {"n2": 2}}, "chunks.n2: not a coordinate"),
    ({"chunks": {"period_nm": 0}}, "chunks.period_nm must be an integer >= 1"),
])
def test_bad_sweeps_are_refused_naming_the_key(changes, message):
    with pytest.raises(ValueError, match=message):
        parse_sweep(_with(**changes))


def test_default_chunks_keep_angles_whole_and_group_structures():
    document = _with(coords={"n2": [1.2, 1.4, 1.6], "period_nm": list(np.linspace(
        100.0, 500.0, 100)), "theta_deg": list(np.linspace(0.0, 90.0, 91))},
        fixed={"n1": 1.0, "N": 10, "delta": 0.5})
    sweep = parse_sweep(document)
    assert sweep.chunks == {"n2": 1, "period_nm": 64, "theta_deg": 91}
    quantity = sweep.quantities[0]
    assert sweep.dims(quantity) == ("n2", "period_nm", "theta_deg", "channel")
    assert sweep.block_counts(quantity) == (3, 2, 1) and sweep.chunk_count() == 6


def test_the_albedo_of_a_layered_structure_is_the_library_albedo():
    sweep = parse_sweep({
        "material": "layered-bragg", "backend": "numpy",  # its GPU kernels: test_layered_gpu
        "fixed": {"n1": 1.0, "n2": 1.5, "N": 10, "delta": 0.5, "base_albedo": 0.2},
        "coords": {"period_nm": [260.0], "alpha": [0.3], "theta_deg": [0.0, 45.0]},
        "quantities": [{"kind": "albedo", "options": {"samples": 64}}]})
    albedo = sweep_dataset(sweep).compute(scheduler="synchronous")["albedo"]
    assert albedo.dims == ("period_nm", "alpha", "theta_deg", "channel")
    assert albedo.attrs["samples"] == 64 and albedo.attrs["channels"] == ["R", "G", "B"]
    structure = LayeredBragg([RoughBraggLayer(BraggMirror(1.0, 1.5, 130.0, 130.0, 10), 0.3)],
                             base_albedo=0.2)
    expected = structure.albedo(np.radians([0.0, 45.0]), None, 64, 0, backend="numpy")
    np.testing.assert_array_equal(albedo.values[0, 0], expected.astype(np.float32))
    with pytest.raises(ValueError, match=r"method must be one of \('single-reflection',"):
        parse_sweep({**_with(), "material": "layered-bragg",
                     "fixed": {**BASE["fixed"], "alpha": 0.1}})
    with pytest.raises(ValueError, match=r"kind must be one of \('albedo', 'xyz', 'rgb', 'l"):
        parse_sweep({**_with(), "material": "layered-bragg", "quantities": [
            {"kind": "reflectance"}], "fixed": {**BASE["fixed"], "alpha": 0.1}})
    with pytest.raises(ValueError, match="below 90 degrees"):
        parse_sweep({"material": "layered-bragg", "fixed": {**BASE["fixed"], "alpha": 0.1},
                     "coords": {"period_nm": [200.0], "theta_deg": [0.0, 90.0]},
                     "quantities": [{"kind": "albedo"}]})


def test_a_thin_film_sweep_is_the_library_colour_and_transmittance():
    sweep = parse_sweep({
        "material": "thin-film", "fixed": {"n_film": 1.33, "theta_deg": 30.0},
        "coords": {"thickness_nm": [200.0, 350.0, 500.0], "n_base": [1.0, 1.5],
                   "wavelength_nm": [450.0, 550.0, 650.0]},
        "chunks": {"thickness_nm": 2},
        "quantities": [{"kind": "rgb", "method": "fourier-table", "options": {"order": 2}},
                       {"kind": "transmittance"}]})
    data = sweep_dataset(sweep).compute(scheduler="synchronous")
    assert data["rgb"].dims == ("thickness_nm", "n_base", "channel")
    assert data["transmittance"].dims == ("thickness_nm", "n_base", "wavelength_nm")
    assert data.attrs["theta_deg"] == 30.0
    film = ThinFilm(n_film=1.33, d=350.0, n_base=1.5)
    theta = np.radians(30.0)
    np.testing.assert_array_equal(data["rgb"].values[1, 1], film.rgb(
        theta, "fourier-table", "gpu", order=2).astype(np.float32))
    np.testing.assert_array_equal(data["transmittance"].values[1, 1], film.transmittance(
        np.array([450.0, 550.0, 650.0]), theta, backend="gpu").astype(np.float32))


def test_the_shipped_example_sweep_parses():
    sweep = load_sweep(ROOT / "examples" / "sweeps" / "bragg_colour_chart.toml")
    assert sweep.structure_dims == ("n2", "period_nm")
    assert [q.method for q in sweep.quantities] == ["averaged", "reference"]


def test_cli_errors_are_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('material = "bragg-mirror"\n[coords]\nperiod_nm = 3\n', encoding="utf-8")
    assert cli.main(["sweep", str(bad), "-o", str(tmp_path / "x.zarr")]) == 2
    error = capsys.readouterr().err
    assert error.startswith("wgbragg: error: bad.toml: coords.period_nm") and error.count("\n") == 1
    assert cli.main(["atlas", str(tmp_path), "--x", "period_nm", "--y", "theta",
                     "-o", str(tmp_path / "c.png")]) == 2
    assert "not a readable wgbragg atlas" in capsys.readouterr().err
