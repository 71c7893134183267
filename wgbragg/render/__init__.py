"""The progressive path tracer: the BVH (:mod:`~wgbragg.render.bvh`), the GPU buffers a scene packs
into (:mod:`~wgbragg.render.packing`), the :class:`Renderer` (:mod:`~wgbragg.render.renderer`)
and the display transform (:mod:`~wgbragg.render.display`)."""

from wgbragg.render.display import display_transform, save_png
from wgbragg.render.packing import PARAMS_DTYPE, SHARED_LAYERS, ibl_levels
from wgbragg.render.renderer import (
    MAX_BOUNCES,
    PATHS_PER_DISPATCH,
    Renderer,
    WorldGeometry,
    check_size,
    max_lights,
)

__all__ = [
    "MAX_BOUNCES",
    "PARAMS_DTYPE",
    "PATHS_PER_DISPATCH",
    "SHARED_LAYERS",
    "Renderer",
    "WorldGeometry",
    "check_size",
    "display_transform",
    "ibl_levels",
    "max_lights",
    "save_png",
]
