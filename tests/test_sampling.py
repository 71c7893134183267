"""wgbragg.ShiftedPoints: uniform numbers as a point set digitally shifted per group."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from wgbragg import ShiftedPoints
from wgbragg.common.sampling import MANTISSA_BITS


def test_values_are_the_shifted_digits_top_bits():
    points = np.array([[0, 2**31], [2**32 - 1, 0x12345678]], np.uint32)
    shifts = np.array([[2**31, 0], [0, 0xFFFFFFFF]], np.uint32)
    u = ShiftedPoints(points, shifts)
    assert u.shape == (2, 2, 2) and u.ndim == 3
    expected = np.empty((2, 2, 2))
    for g in range(2):
        for j in range(2):
            for k in range(2):
                digits = int(points[j, k]) ^ int(shifts[g, k])
                expected[g, j, k] = (digits >> (32 - MANTISSA_BITS)) / 2.0**MANTISSA_BITS
    np.testing.assert_array_equal(np.asarray(u), expected)
    # float32 and float64 hold the same values: the kernel's bit cast is exact.
    np.testing.assert_array_equal(u.values(np.float32).astype(np.float64), expected)
    assert np.asarray(u).max() == 1.0 - 2.0**-MANTISSA_BITS and np.asarray(u).min() == 0.0


def test_groups_of_any_shape_and_none():
    points = np.arange(12, dtype=np.uint32).reshape(4, 3) << np.uint32(20)
    u = ShiftedPoints(points, np.zeros((2, 5, 3), np.uint32))
    assert np.asarray(u).shape == (2, 5, 4, 3)
    alone = ShiftedPoints(points, np.zeros(3, np.uint32))
    assert alone.shape == (4, 3)
    np.testing.assert_array_equal(np.asarray(alone), np.asarray(u)[1, 2])


def test_no_groups_give_no_numbers():
    u = ShiftedPoints.sobol(8, 3, (0,), seed=1)
    assert u.shape == (0, 8, 3) and np.asarray(u).shape == (0, 8, 3)


def test_sobol_sets_are_stratified_per_group_and_shifted_apart():
    """Each group's 64 numbers keep one in each of the 64 equal intervals of every axis, and
    one in each cell of an 8 x 8 grid over the first two axes; the groups' first points are
    uniform and distinct."""
    u = np.asarray(ShiftedPoints.sobol(64, 4, (400,), seed=2))
    assert u.shape == (400, 64, 4) and 0.0 <= u.min() and u.max() < 1.0
    for group in u[:100]:
        for axis in range(4):
            assert np.array_equal(np.sort((group[:, axis] * 64).astype(int)), np.arange(64))
        cells = (group[:, 0] * 8).astype(int) * 8 + (group[:, 1] * 8).astype(int)
        assert np.array_equal(np.sort(cells), np.arange(64))
    first = u[:, 0, :]
    assert np.unique(first[:, 0]).size == first.shape[0]
    for axis in range(4):
        assert stats.kstest(first[:, axis], "uniform").pvalue > 1e-3


def test_sobol_is_deterministic_for_a_seed():
    a = ShiftedPoints.sobol(8, 3, (5,), seed=4)
    b = ShiftedPoints.sobol(8, 3, (5,), seed=4)
    c = ShiftedPoints.sobol(8, 3, (5,), seed=5)
    np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    assert not np.array_equal(np.asarray(a), np.asarray(c))
    assert ShiftedPoints.sobol(3, 2).shape == (3, 2)  # not a power of 2: no warning raised


def test_inputs_are_copied_and_read_only():
    points = np.zeros((2, 2), np.uint32)
    u = ShiftedPoints(points, np.zeros(2, np.uint32))
    points[0, 0] = 2**31
    assert np.asarray(u).max() == 0.0
    with pytest.raises(ValueError):
        u.points[0, 0] = 1


@pytest.mark.parametrize(("points", "shifts", "match"), [
    (np.zeros((2, 2)), np.zeros(2, np.uint32), "points must hold uint32"),
    (np.zeros((2, 2), np.uint32), np.zeros(2, np.int64), "shifts must hold uint32"),
    (np.zeros(2, np.uint32), np.zeros(2, np.uint32), "points must have at least 2 axes"),
    (np.zeros((2, 2, 2), np.uint32), np.zeros(2, np.uint32), r"points must have shape \(n, dims\)"),
    (np.zeros((0, 2), np.uint32), np.zeros(2, np.uint32), r"points must have shape \(n, dims\)"),
    (np.zeros((2, 2), np.uint32), np.zeros(3, np.uint32), "shifts must end in an axis of dims = 2"),
])
def test_bad_digits_raise(points, shifts, match):
    with pytest.raises(ValueError, match=match):
        ShiftedPoints(points, shifts)


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"samples": 0, "dims": 2}, "samples must be an integer >= 1"),
    ({"samples": 2.0, "dims": 2}, "samples must be an integer >= 1"),
    ({"samples": True, "dims": 2}, "samples must be an integer >= 1"),
    ({"samples": 4, "dims": 0}, r"dims must be an integer in \[1, 21201\]"),
    ({"samples": 4, "dims": 21202}, r"dims must be an integer in \[1, 21201\]"),
    ({"samples": 4, "dims": 2, "groups": 5}, "groups must be a tuple of sizes >= 0"),
    ({"samples": 4, "dims": 2, "groups": (-1,)}, "groups must be a tuple of sizes >= 0"),
])
def test_bad_sobol_requests_raise(kwargs, match):
    with pytest.raises(ValueError, match=match):
        ShiftedPoints.sobol(**kwargs)


def test_values_dtype_and_copy_requests():
    u = ShiftedPoints(np.zeros((1, 1), np.uint32), np.zeros(1, np.uint32))
    with pytest.raises(ValueError, match="dtype must be float32 or float64"):
        u.values(np.int32)
    with pytest.raises(ValueError, match="copy=False"):
        np.asarray(u, copy=False)
    assert "n=1, dims=1" in repr(u)
