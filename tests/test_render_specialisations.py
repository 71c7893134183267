"""Every kind of scene the renderer specialises for compiles: render/renderer.wgsl's specialisation
blocks (``//! if``, wgbragg/gpu/specialise.py) leave a valid kernel for each combination of its
override constants, not only for the presets' (a block that removes a function's last
``return`` in one combination compiles in every other)."""

from __future__ import annotations

import itertools

import pytest

from wgbragg import gpu

pytestmark = pytest.mark.gpu

# Layered configurations as wgbragg.render.packing.layered_buffers sets them (LUT from the cache,
# or
# an in-kernel colour by each factored method; period maps force in-kernel mirrors).
LAYERED = [
    {"LUT": True, "LAYERS": 2, "BASE": 1},
    {"LUT": False, "COLOUR_METHOD": 0, "COATING": True, "HOST_MATCHED": False},
    {"LUT": False, "COLOUR_METHOD": 1, "VARYING_LAYERS": True},
    {"LUT": False, "COLOUR_METHOD": 2, "MATCHED_LAYERS": True, "BASE": 1},
    {"LUT": False, "COLOUR_METHOD": 3, "INTEGRATED": False},
    {"LUT": False, "INTEGRATED": True, "LAYERS": 3},
]


def _configurations() -> list[dict]:
    """Every combination of mode, lighting mode, thin films and environment map (24), each
    with one of the layered configurations in turn or, every fourth, none."""
    configurations = []
    for k, (spectral, ibl, films, environment_map) in enumerate(
            itertools.product((False, True), (0, 1, 2), (False, True), (False, True))):
        layered = LAYERED[k % len(LAYERED)] if k % 4 != 3 else None
        constants = {"SPECTRAL": spectral, "IBL": ibl, "THIN_FILMS": films,
                     "FILM_MAPS": films and k % 3 == 0, "FILM_PREFILTERED": ibl == 2,
                     "ENVIRONMENT_MAP": environment_map, "CONVEX_ALONE": k % 5 == 0,
                     "LAYERED": layered is not None, **(layered or {})}
        configurations.append(constants)
    return configurations


@pytest.mark.parametrize("constants", _configurations(),
                         ids=lambda c: ",".join(k for k, v in c.items() if v is True))
def test_every_configuration_compiles(constants):
    for entry in ("render", "accumulate", "primary_hits"):
        kernel = gpu.compute_pipeline("render/renderer.wgsl", entry, constants)
        assert kernel.entry == entry
