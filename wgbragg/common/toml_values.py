"""Values written as TOML text, for the scenes wgbragg composes (glTF imports, sweep frames)
and reads back with :mod:`tomllib`: the standard library reads TOML but does not write it."""

from __future__ import annotations

import json
import math

__all__ = ["toml_key", "toml_value"]


def toml_key(name) -> str:
    """A key (or string) as a TOML basic string: JSON's escapes, which TOML shares, and DEL
    escaped as TOML requires."""
    return json.dumps(str(name), ensure_ascii=False).replace("\x7f", "\\u007f")


def toml_value(value) -> str:
    """A number, boolean, string, array or table as an inline TOML value (non-finite floats
    as ``nan``, ``inf``, ``-inf``).

    Raises
    ------
    ValueError
        For a value TOML cannot hold (None, another type), naming its type.
    """
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else ("nan" if value != value else
                                                         ("inf" if value > 0 else "-inf"))
    if isinstance(value, str):
        return toml_key(value)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{toml_key(k)} = {toml_value(v)}" for k, v in value.items()) + "}"
    raise ValueError(f"a value of type {type(value).__name__} has no TOML form: {value!r}"[:200])
