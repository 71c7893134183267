"""Image metrics (wgbragg.common.metrics)."""

import numpy as np
import pytest

from wgbragg.common.metrics import smape


def test_smape_values():
    assert smape([1.0, 0.0], [1.0, 0.0]) == 0.0
    assert smape([1.0], [3.0]) == pytest.approx(0.5)
    # Entries zero in both are left out of the mean, not counted as perfect.
    assert smape([1.0, 0.0], [3.0, 0.0]) == pytest.approx(0.5)
    assert smape(np.zeros((2, 2)), np.zeros((2, 2))) == 0.0
    # Out-of-gamut negative channels: by magnitude.
    assert smape([-1.0], [1.0]) == pytest.approx(1.0)


def test_smape_is_symmetric_and_bounded():
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=(4, 5, 3)), rng.normal(size=(4, 5, 3))
    assert smape(a, b) == pytest.approx(smape(b, a))
    assert 0.0 <= smape(a, b) <= 1.0


@pytest.mark.parametrize(("a", "b", "match"), [
    ([1.0, 2.0], [1.0], "same shape"),
    ([np.nan], [1.0], "finite"),
    ([1.0], [np.inf], "finite"),
])
def test_smape_refuses_bad_input(a, b, match):
    with pytest.raises(ValueError, match=match):
        smape(a, b)
