"""wgbragg.common.toml_values: values tomllib reads back as written, and refusals."""

from __future__ import annotations

import math
import tomllib

import pytest

from wgbragg.common.toml_values import toml_key, toml_value


def test_values_read_back_as_written():
    value = {"a b": [1, 2.5, -0.0, True, "q\"\x7f\n\u00e9"], "t": (1e300, 3), "n": {"x": 1}}
    read = tomllib.loads(f"{toml_key('key')} = {toml_value(value)}\n")["key"]
    assert read == {"a b": [1, 2.5, -0.0, True, "q\"\x7f\n\u00e9"], "t": [1e300, 3],
                    "n": {"x": 1}}
    specials = tomllib.loads(f"v = {toml_value([math.inf, -math.inf, math.nan])}")["v"]
    assert specials[:2] == [math.inf, -math.inf] and math.isnan(specials[2])


@pytest.mark.parametrize("bad", [None, object(), {1.5}])
def test_what_toml_cannot_hold_is_refused_by_type(bad):
    with pytest.raises(ValueError, match=f"type {type(bad).__name__} has no TOML form"):
        toml_value(bad)
