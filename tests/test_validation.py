"""Input validation of the public API: bad input raises ValueError naming the parameter."""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest

import wgbragg
from wgbragg import BraggMirror, ThinFilm
from wgbragg.optics import transfer_matrix_reflectance

MAX_INT32 = 2**31 - 1
GOOD_MIRROR = {"n1": 1.0, "n2": 1.5, "d1": 125.0, "d2": 375.0, "N": 20, "host": 1.0}
GOOD_FILM = {"n_film": 1.3, "d": 290.0, "n_base": 1.0, "k_base": 0.0, "host": 1.0}
BAD_INDICES = [0.0, 0.005, -1.5, 100.5, 1e20, math.nan, math.inf, -math.inf, "1.5", 1.5 + 0j, True]
BAD_THICKNESSES = [-1e-9, -100.0, 1.0000001e6, 1e300, math.nan, math.inf, "10", None]
BAD_COUNTS = [0, -3, 2.5, True, False, np.True_, 2**31, 2**40, math.nan, math.inf, "20", None]


def with_value(good, name, value):
    return {**good, name: value}


def names(parameter):
    """A pattern matching the parameter's name as a word in the error message."""
    return rf"\b{parameter}\b"


# --------------------------------------------------------------------------- constructors


@pytest.mark.parametrize("value", BAD_INDICES)
@pytest.mark.parametrize("name", ["n1", "n2", "host"])
def test_mirror_rejects_bad_indices(name, value):
    with pytest.raises(ValueError, match=names(name)):
        BraggMirror(**with_value(GOOD_MIRROR, name, value))


@pytest.mark.parametrize("value", BAD_THICKNESSES)
@pytest.mark.parametrize("name", ["d1", "d2"])
def test_mirror_rejects_bad_thicknesses(name, value):
    with pytest.raises(ValueError, match=names(name)):
        BraggMirror(**with_value(GOOD_MIRROR, name, value))


@pytest.mark.parametrize("value", BAD_COUNTS)
def test_mirror_rejects_bad_period_counts(value):
    with pytest.raises(ValueError, match=names("N")):
        BraggMirror(**with_value(GOOD_MIRROR, "N", value))


@pytest.mark.parametrize("value", [1, 20, 20.0, np.int64(7), np.float32(3.0), MAX_INT32,
                                   float(MAX_INT32)])
def test_mirror_accepts_integral_period_counts(value):
    mirror = BraggMirror(**with_value(GOOD_MIRROR, "N", value))
    assert mirror.N == int(value)
    assert type(mirror.N) is int


@pytest.mark.parametrize("backend", ["numpy", pytest.param("gpu", marks=pytest.mark.gpu)])
def test_mirror_accepts_the_edges_of_its_domain(backend):
    mirror = BraggMirror(n1=0.01, n2=100.0, d1=0.0, d2=1e6, N=MAX_INT32)
    assert mirror.host == mirror.n1  # host defaults to n1
    R = mirror.reflectance([1.0, 1e6], [0.0, math.pi / 2], backend=backend)
    assert np.all((R >= 0) & (R <= 1))


@pytest.mark.parametrize("value", [*BAD_INDICES, None])
@pytest.mark.parametrize("name", ["n_film", "n_base", "host"])
def test_film_rejects_bad_indices(name, value):
    with pytest.raises(ValueError, match=names(name)):
        ThinFilm(**with_value(GOOD_FILM, name, value))


@pytest.mark.parametrize("value", [-1e-12, -2.0, 1.00001e4, 1e10, math.nan, math.inf, "0", None])
def test_film_rejects_bad_extinction(value):
    with pytest.raises(ValueError, match=names("k_base")):
        ThinFilm(**with_value(GOOD_FILM, "k_base", value))


@pytest.mark.parametrize("value", BAD_THICKNESSES)
def test_film_rejects_bad_thickness(value):
    with pytest.raises(ValueError, match=names("d")):
        ThinFilm(**with_value(GOOD_FILM, "d", value))


@pytest.mark.parametrize("thing", [BraggMirror(**GOOD_MIRROR), ThinFilm(**GOOD_FILM)])
def test_materials_are_frozen(thing):
    field = dataclasses.fields(thing)[0].name
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(thing, field, 2.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        thing.host = 1.2


# --------------------------------------------------------------------------- reflectance calls

THINGS = [BraggMirror(**GOOD_MIRROR), BraggMirror(1.59, 1.67, 81.6, 78.4, 8),
          ThinFilm(**GOOD_FILM)]
BAD_CALLS = [
    # (wavelength_nm, theta, polarization, backend, parameter named in the message)
    (0.0, 0.1, "s", "numpy", "wavelength_nm"),
    (0.999, 0.1, "s", "numpy", "wavelength_nm"),
    (1e-300, 0.1, "s", "gpu", "wavelength_nm"),
    (1.0000001e6, 0.1, "s", "numpy", "wavelength_nm"),
    (-500.0, 0.1, "s", "numpy", "wavelength_nm"),
    (math.inf, 0.1, "s", "numpy", "wavelength_nm"),
    (math.nan, 0.1, "s", "numpy", "wavelength_nm"),
    ([500.0, math.nan, 600.0], 0.1, "s", "numpy", "wavelength_nm"),
    ([[500.0], [0.0]], 0.1, "p", "numpy", "wavelength_nm"),
    (500.0, -1e-12, "s", "numpy", "theta"),
    # Up to float32's pi/2 (1.5707964) is accepted and clipped to pi/2; beyond, refused.
    (500.0, np.nextafter(float(np.float32(math.pi / 2)), 4.0), "s", "numpy", "theta"),
    (500.0, 2.0, "unpolarized", "numpy", "theta"),
    (500.0, math.nan, "s", "numpy", "theta"),
    (500.0, [0.1, math.nan], "s", "numpy", "theta"),
    (500.0, math.inf, "s", "numpy", "theta"),
    (500.0, 0.1, "x", "numpy", "polarization"),
    (500.0, 0.1, "S", "numpy", "polarization"),
    (500.0, 0.1, None, "numpy", "polarization"),
    (500.0, 0.1, "s", "cuda", "backend"),
    (500.0, 0.1, "s", None, "backend"),
    ([500.0, 600.0, 700.0], [0.1, 0.2], "s", "numpy", "broadcast"),
    (np.ones((3, 4)) * 500, np.ones((3,)) * 0.1, "s", "numpy", "broadcast"),
]


@pytest.mark.parametrize("wavelength, theta, polarization, backend, name", BAD_CALLS)
@pytest.mark.parametrize("thing", THINGS, ids=["mirror", "mirror-host", "film"])
def test_reflectance_rejects_bad_arguments(thing, wavelength, theta, polarization, backend,
                                           name):
    with pytest.raises(ValueError, match=names(name)):
        thing.reflectance(wavelength, theta, polarization=polarization, backend=backend)


@pytest.mark.parametrize("wavelength, theta, polarization, backend, name",
                         [call for call in BAD_CALLS if call[3] == "numpy"])
@pytest.mark.parametrize("thing", THINGS, ids=["mirror", "mirror-host", "film"])
def test_gpu_backend_validates_before_touching_the_device(thing, wavelength, theta,
                                                          polarization, backend, name,
                                                          monkeypatch):
    """backend="gpu" checks the same things first: the kernels are never reached."""
    from wgbragg import gpu
    from wgbragg.optics import thin_film_gpu, yeh_gpu

    def forbidden(*args, **kwargs):
        raise AssertionError("the GPU was reached with invalid input")

    monkeypatch.setattr(yeh_gpu, "bragg_reflectance", forbidden)
    monkeypatch.setattr(thin_film_gpu, "thin_film_reflectance", forbidden)
    # Wherever the device is looked up: by callers of gpu.get_device and inside the harness.
    for module in (gpu, gpu.device, gpu.pipelines, gpu.timing):
        monkeypatch.setattr(module, "get_device", forbidden)
    monkeypatch.setattr(gpu, "compute_pipeline", forbidden)
    with pytest.raises(ValueError, match=names(name)):
        thing.reflectance(wavelength, theta, polarization=polarization, backend="gpu")


@pytest.mark.gpu
def test_gpu_backend_rejects_bad_arguments_on_a_real_device():
    mirror, film = BraggMirror(**GOOD_MIRROR), ThinFilm(**GOOD_FILM)
    for thing in (mirror, film):
        with pytest.raises(ValueError, match="theta"):
            thing.reflectance(500.0, [0.1, 1.6], backend="gpu")
        with pytest.raises(ValueError, match="wavelength_nm"):
            thing.reflectance([500.0, -1.0], 0.1, backend="gpu")
        assert np.isfinite(thing.reflectance([500.0, 600.0], 0.1, backend="gpu")).all()


@pytest.mark.parametrize("backend", ["numpy", pytest.param("gpu", marks=pytest.mark.gpu)])
def test_reflectance_accepts_the_edges_of_its_domain(backend):
    for thing in THINGS:
        R = thing.reflectance([1.0, 1e6], [[0.0], [math.pi / 2]], polarization="p",
                              backend=backend)
        assert R.shape == (2, 2)
        assert np.all((R >= 0) & (R <= 1))


# --------------------------------------------------------------------------- transfer matrices

GOOD_STACK = ([1.0, 1.5, 1.2 + 0.1j, 1.0], [100.0, 50.0])
BAD_STACKS = [
    (([1.0], []), "indices"),
    (([], []), "indices"),
    (([1.0, 1.5, 1.0], []), "thicknesses_nm"),
    (([1.0, 1.5, 1.0], [10.0, 20.0]), "thicknesses_nm"),
    (([1.0, 1.5, 1.2, 1.0], [10.0, 20.0, 30.0]), "thicknesses_nm"),
    (([1.0, 1.5, 1.0], [np.inf, 10.0, 5.0]), "thicknesses_nm"),  # tmm style needs inf ends
    (([1.0, 1.5, 1.0], [-1.0]), "thicknesses_nm"),
    (([1.0, 1.5, 1.0], [math.nan]), "thicknesses_nm"),
    (([1.0, 1.5, 1.0], [math.inf]), "thicknesses_nm"),
    (([1.0, 0.0, 1.0], [10.0]), "indices"),
    (([1.0, -1.5 + 0.1j, 1.0], [10.0]), "indices"),
    (([1.0, 1.5, -2.0], [10.0]), "indices"),
    (([1.0, 1.5 - 0.1j, 1.0], [10.0]), "indices"),
    (([0.0, 1.5, 1.0], [10.0]), "indices"),
    (([1.0, math.nan, 1.0], [10.0]), "indices"),
    (([1.0 + 0.1j, 1.5, 1.0], [10.0]), "incident"),
]


@pytest.mark.parametrize("stack, name", BAD_STACKS)
def test_transfer_matrix_rejects_bad_stacks(stack, name):
    with pytest.raises(ValueError, match=names(name)):
        transfer_matrix_reflectance(*stack, 500.0, 0.1, "s")


@pytest.mark.parametrize("wavelength, theta, polarization, backend, name",
                         [call for call in BAD_CALLS if call[3] == "numpy"])
def test_transfer_matrix_rejects_bad_arguments(wavelength, theta, polarization, backend, name):
    with pytest.raises(ValueError, match=names(name)):
        transfer_matrix_reflectance(*GOOD_STACK, wavelength, theta, polarization)


def test_transfer_matrix_accepts_its_domain():
    R = transfer_matrix_reflectance([1.0, 1.5 + 2j], [], [400.0, 500.0], [[0.0], [math.pi / 2]])
    assert R.shape == (2, 2)
    assert np.all((R >= 0) & (R <= 1))
    assert wgbragg.optics.transfer_matrix_reflectance is transfer_matrix_reflectance


# --------------------------------------------------------------------------- broadcasting


def _broadcast_calls():
    from wgbragg import LayeredBragg, RoughBraggLayer, RoughThinFilm
    from wgbragg.bsdf import microfacet

    layered = LayeredBragg([RoughBraggLayer(BraggMirror(1.0, 1.5, 250.0, 250.0, 10), 0.1)])
    film = RoughThinFilm(ThinFilm(**GOOD_FILM), 0.3)
    wi, wo = np.tile([0.0, 0.0, 1.0], (3, 1)), np.tile([0.0, 0.6, 0.8], (2, 1))
    return [
        (lambda: layered.brdf(wi, wo), "wi (3,) and wo (2,)"),
        (lambda: layered.pdf(wi, wo), "wi (3,) and wo (2,)"),
        (lambda: layered.sample(wi, np.zeros((2, 3))), "wi (3,) and u (2,)"),
        (lambda: layered.albedo(np.zeros(3), np.full(2, 500.0)),
         "theta_i (3,) and wavelength_nm (2,)"),
        (lambda: layered.layers[0].transmissivity(np.zeros(3), np.full(2, 500.0)),
         "theta_i (3,) and wavelength_nm (2,)"),
        (lambda: film.brdf(wi, wo, 550.0), "wi (3,) and wo (2,)"),
        (lambda: film.pdf(wi, wo), "wi (3,) and wo (2,)"),
        (lambda: film.sample(wi, np.zeros((2, 2)), 550.0), "wi (3,) and u (2,)"),
        (lambda: microfacet.ggx_D(np.ones(3), np.full(2, 0.3)), "cos_theta_m (3,) and alpha"),
        (lambda: microfacet.ggx_G1(np.ones(3), np.full(2, 0.3)), "cos_theta (3,) and alpha"),
    ]


@pytest.mark.parametrize("index", range(10))
def test_shapes_that_do_not_broadcast_are_named(index):
    call, named = _broadcast_calls()[index]
    with pytest.raises(ValueError, match=re.escape(named) + ".* do not broadcast"):
        call()


# --------------------------------------------------------------------------- fuzz audit

HALF_PI_FLOAT32 = np.float32(math.pi / 2)  # 1.5707964, above pi/2 in float64


def test_float32_half_pi_is_accepted_and_clipped():
    from wgbragg.common.validation import check_angle

    assert float(HALF_PI_FLOAT32) > math.pi / 2
    assert check_angle(HALF_PI_FLOAT32) == math.pi / 2
    clipped = check_angle(np.array([0.0, 0.5, HALF_PI_FLOAT32], np.float32))
    assert clipped.dtype == np.float64 and clipped[-1] == math.pi / 2
    assert check_angle(0.5).shape == ()
    for thing in THINGS:
        R = thing.reflectance(500.0, HALF_PI_FLOAT32)
        np.testing.assert_array_equal(R, thing.reflectance(500.0, math.pi / 2))
    mirror = THINGS[0]
    np.testing.assert_array_equal(mirror.rgb(HALF_PI_FLOAT32), mirror.rgb(math.pi / 2))
    # The next float32 above is still refused.
    with pytest.raises(ValueError, match=names("theta")):
        mirror.reflectance(500.0, np.nextafter(HALF_PI_FLOAT32, np.float32(4.0)))


@pytest.mark.parametrize("value", [np.int64(7), np.int32(7), np.uint8(7), np.int16(7)])
def test_integer_checks_accept_numpy_integers(value):
    from wgbragg.common.validation import check_count, check_integer

    assert check_integer("k", value, 1, 10) == 7 and type(check_integer("k", value, 1)) is int
    assert check_count("k", value) == 7


@pytest.mark.parametrize("value", [True, np.True_, 7.0, np.float64(7.0), "7", None, 0, 11,
                                   np.int64(11)])
def test_check_integer_refuses_bools_floats_and_out_of_range(value):
    from wgbragg.common.validation import check_integer

    with pytest.raises(ValueError, match=r"\bk must be an integer in \[1, 10\]"):
        check_integer("k", value, 1, 10)


@pytest.mark.parametrize("samples", [0, -1, 100_001, 2**31])
def test_spectral_samples_message_states_the_real_range(samples):
    with pytest.raises(ValueError, match=r"\bsamples must be an integer in \[1, 100000\]"):
        THINGS[0].xyz(0.1, method="spectral", samples=samples)
    with pytest.raises(ValueError, match=r"\bsamples\b.* \[1, 100000\]"):
        THINGS[2].xyz(0.1, method="spectral", samples=samples)


def test_spectral_samples_accept_numpy_integers():
    mirror = THINGS[0]
    np.testing.assert_array_equal(mirror.xyz(0.1, method="spectral", samples=np.int64(8)),
                                  mirror.xyz(0.1, method="spectral", samples=8))


@pytest.mark.parametrize("seed", [-1, "a", 1.5, True])
def test_spectral_seed_is_named(seed):
    with pytest.raises(ValueError, match=names("seed")):
        THINGS[0].xyz(0.1, method="spectral", seed=seed)


@pytest.mark.parametrize("polarization", [np.array("s"), np.array(["s", "p"]), ["s"], ("s",)])
@pytest.mark.parametrize("backend", ["numpy", "gpu"])
@pytest.mark.parametrize("thing", THINGS, ids=["mirror", "mirror-host", "film"])
def test_polarization_must_be_one_string(thing, polarization, backend, monkeypatch):
    """An array compared elementwise: "s" == np.array("s") passed the check, then the GPU
    kernel's dict lookup raised TypeError (unhashable), and two elements numpy's ambiguous
    truth value."""
    from wgbragg import gpu
    from wgbragg.optics import pointwise_gpu, thin_film_gpu, yeh_gpu

    def forbidden(*args, **kwargs):
        raise AssertionError("the GPU was reached with invalid input")

    monkeypatch.setattr(gpu, "compute_pipeline", forbidden)
    for module in (pointwise_gpu, yeh_gpu, thin_film_gpu):
        monkeypatch.setattr(module, "evaluate_pointwise", forbidden, raising=False)
    with pytest.raises(ValueError, match=names("polarization")):
        thing.reflectance(550.0, 0.1, polarization, backend)


@pytest.mark.parametrize("backend", [np.array("numpy"), np.array(["numpy", "gpu"]), ["gpu"]])
def test_backend_must_be_one_string(backend):
    with pytest.raises(ValueError, match=names("backend")):
        THINGS[0].reflectance(550.0, 0.1, "s", backend)


@pytest.mark.parametrize(
    ("wavelength", "theta", "name"),
    [(np.array([True]), 0.0, "wavelength_nm"), (550.0, np.array([False]), "theta"),
     (np.array(True), 0.0, "wavelength_nm"), (550.0, np.zeros((2, 2), bool), "theta")],
)
def test_bool_arrays_are_refused(wavelength, theta, name):
    with pytest.raises(ValueError, match=names(name) + " must be a real number"):
        THINGS[0].reflectance(wavelength, theta)


@pytest.mark.parametrize("material", ["x", None, 1.5, np.ones(3)])
def test_reflectance_map_names_a_material_without_reflectance(material):
    from wgbragg.app.maps import reflectance_map

    with pytest.raises(ValueError, match=r"\bmaterial must have a reflectance.*BraggMirror"):
        reflectance_map(material, backend="numpy")


@pytest.mark.parametrize(("options", "name"), [
    ({"theta": "x"}, "theta"), ({"wavelength_nm": ["a"]}, "wavelength_nm"),
    ({"theta": [0.1, 2.0]}, "theta"), ({"polarization": np.array("s")}, "polarization"),
])
def test_reflectance_map_names_bad_grids(options, name):
    from wgbragg.app.maps import reflectance_map

    with pytest.raises(ValueError, match=names(name)):
        reflectance_map(THINGS[0], backend="numpy", **options)
