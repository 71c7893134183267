"""``benchmarks.layered`` in its quick mode: it runs, writes its section between its markers
and every table holds finite numbers (no speed is asserted: the full run reports the targets)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import markdown_rows, quick_run

from benchmarks import layered as bench
from wgbragg import ShiftedPoints


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return quick_run(bench, tmp_path_factory.mktemp("docs"))


def _rows(text: str, heading: str) -> list[list[str]]:
    return markdown_rows(text, heading)[2:]


@pytest.mark.gpu
def test_section_written_once(run):
    text, printed = run
    assert text.count(bench.BEGIN_MARKER) == 1 and "stale" not in text
    assert "Quick mode" in text and bench.BEGIN_MARKER in printed


@pytest.mark.gpu
def test_every_estimator_is_timed_and_scored(run):
    text, _ = run
    rows = _rows(text, "### Time, SMAPE")
    cfg = bench.QUICK
    expected = []
    for label, *_, albedo in cfg.structures:
        expected.append((label, "GT (all paths)", str(cfg.gt_spp)))
        expected += [(label, e, str(spp)) for spp, _ in cfg.points
                     for e in bench.estimators(albedo)[1:]]
    assert [(r[0], r[1], r[2]) for r in rows] == expected
    assert {r[1] for r in rows} == {"GT (all paths)", *bench.ESTIMATORS[1:]}
    for row in rows:
        assert all(row[k] != "—" for k in (3, 4))  # both clocks timed every estimator
        if row[1] == "GT (all paths)":
            noise, label = row[5].split(" ", 1)
            assert 0.0 < float(noise) < 1.0 and label == "(own noise)"
        else:
            assert 0.0 <= float(row[5]) < 1.0
            assert float(row[6].replace(",", "")) >= 0.0
    targets = _rows(text, "### Targets")
    assert len(targets) == 4 * len(cfg.points)
    assert [r[1] for r in targets] == [str(spp) for _ in range(4) for spp, _ in cfg.points]
    assert all(r[3] in ("yes", "no") and r[5] in ("yes", "no") for r in targets)


def test_environment_is_its_formula():
    """The float32 environment against its formula in float64: each lamp a von Mises-Fisher
    glow exp(kappa (d . axis - 1)) times its colour, plus the sky (0.4 + 0.6 z) above the
    horizon and the ground below; on lamp axes, near the horizon and everywhere."""
    rng = np.random.default_rng(4)
    direction = rng.standard_normal((5, 3000, 3))
    direction[0, :2] = bench._lamp_axes()
    direction[1, :, 2] = rng.choice([-1e-7, 0.0, 1e-7], direction.shape[1])
    direction /= np.linalg.norm(direction, axis=-1, keepdims=True)
    expected = np.zeros(direction.shape)
    for axis, colour in bench.LAMPS:
        axis = np.asarray(axis) / np.linalg.norm(axis)
        glow = np.exp(bench.LAMP_KAPPA * (direction @ axis - 1.0))
        expected += glow[..., None] * np.asarray(colour)
    z = direction[..., 2:]
    expected += np.where(z > 0.0, (0.4 + 0.6 * z) * np.asarray(bench.SKY), bench.GROUND)
    radiance = bench.environment(direction)
    assert radiance.shape == direction.shape and radiance.dtype == np.float32
    np.testing.assert_allclose(radiance, expected, rtol=2e-5, atol=1e-6)
    assert radiance[0, 0].sum() > 25.0  # looking into the first lamp


def test_environment_sampling_matches_its_density():
    """The environment sampler's density integrates to 1 and its samples follow it (mean of
    1 / pdf estimates the sphere's area)."""
    rng = np.random.default_rng(0)
    direction, pdf = bench.sample_environment(rng, (200_000,))
    np.testing.assert_allclose(np.linalg.norm(direction, axis=-1), 1.0, atol=1e-6)  # float32
    assert np.mean(1.0 / pdf) == pytest.approx(4.0 * np.pi, rel=0.02)
    np.testing.assert_allclose(pdf, bench.environment_pdf(direction), rtol=1e-12)



def test_gt_noise_is_half_the_halves_smape():
    """GT's own noise: 0 for identical halves, half their SMAPE otherwise; and statistically,
    GT's SMAPE against the truth it estimates."""
    half = np.array([[1.0, 2.0, 3.0]])
    assert bench.gt_noise(half, half) == 0.0
    assert bench.gt_noise(half, 3.0 * half) == pytest.approx(0.25)  # |1 - 3| / (1 + 3) / 2
    rng = np.random.default_rng(3)
    truth = rng.uniform(0.5, 2.0, (100_000, 3))
    halves = [truth * (1.0 + 0.02 * rng.standard_normal(truth.shape)) for _ in range(2)]
    gt = 0.5 * (halves[0] + halves[1])
    assert bench.gt_noise(*halves) == pytest.approx(bench.smape(gt, truth), rel=0.02)


@pytest.mark.parametrize("sobol", [False, True])
def test_uniforms_lie_in_the_unit_cube(sobol):
    u = np.asarray(bench.uniforms(np.random.default_rng(1), 50, 64, 4, sobol))
    assert u.shape == (50, 64, 4) and u.min() >= 0.0 and u.max() < 1.0


def test_sobol_uniforms_are_a_set_shifted_per_pixel():
    """The Sobol' numbers go to the kernel as one set and one shift per pixel (their
    stratification is tested in tests/test_sampling.py)."""
    u = bench.uniforms(np.random.default_rng(2), 40, 64, 4, sobol=True)
    assert isinstance(u, ShiftedPoints)
    assert u.shape == (40, 64, 4) and u.points.shape == (64, 4) and u.shifts.shape == (40, 4)


def _results(bench, fast, sr_gpu_seconds=0.5):
    """Made-up results of the quick configuration: every estimator as efficient as the SR
    simulation, except those whose name holds one of ``fast``: 100 times; on GPU time, every
    estimator takes 0.5 s but the SR simulation ``sr_gpu_seconds``."""
    cfg = bench.QUICK
    environment = {"date": "-", "adapter": "-", "cpu": "-", "cores": 2, "python": "-",
                   "versions": {}, "background_cores": 0.0}
    results = bench.Results(cfg, environment)
    for label, *_, albedo in cfg.structures:
        results.seconds[label, "GT", cfg.gt_spp] = 1.0
        results.gpu_seconds[label, "GT", cfg.gt_spp] = 0.5
        results.errors[label, "GT", cfg.gt_spp] = 0.001
        for spp, _ in cfg.points:
            for estimator in bench.estimators(albedo)[1:]:
                results.seconds[label, estimator, spp] = 1.0
                results.gpu_seconds[label, estimator, spp] = (
                    sr_gpu_seconds if estimator == "SR sim." else 0.5)
                results.errors[label, estimator, spp] = (
                    0.001 if any(name in estimator for name in fast) else 0.1)
    return results


def test_targets_as_published_leave_out_sobol_and_base_interreflection():
    """The "as published" targets see neither Sobol' sampling nor the base's
    interreflection; the best-variant targets see both."""
    section = bench.render_section(_results(bench, (bench.SOBOL, bench.BASE_IR)), "-")
    rows = _rows(section, "### Targets")
    assert len(rows) == 4 * len(bench.QUICK.points)
    for text, _, measured, met, measured_gpu, met_gpu in rows:
        published = "as published" in text
        for value, verdict in ((measured, met), (measured_gpu, met_gpu)):
            ratio = float(value.split()[1].rstrip("\u00d7"))
            assert ratio == pytest.approx(1.0 if published else 100.0), (text, value)
            assert verdict == ("no" if published else "yes")


def test_gpu_time_targets_read_the_gpu_clock():
    """An SR simulation four times slower on the GPU clock only: every GPU-time ratio is four
    times its wall-clock twin, in the targets and in the table."""
    section = bench.render_section(_results(bench, (), sr_gpu_seconds=2.0), "-")
    for _, _, measured, met, measured_gpu, met_gpu in _rows(section, "### Targets"):
        assert measured.startswith("worst 1.00\u00d7 (") and met == "no"
        assert measured_gpu.startswith("worst 4.00\u00d7 (") and met_gpu == "yes"
    for row in _rows(section, "### Time, SMAPE"):
        if row[1] not in ("GT (all paths)", "SR sim."):
            assert (float(row[7].rstrip("\u00d7")), float(row[8].rstrip("\u00d7"))) == (1.0, 4.0)
