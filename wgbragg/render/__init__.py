"""The progressive path tracer: the BVH (:mod:`~wgbragg.render.bvh`), the GPU buffers a scene packs
into (:mod:`~wgbragg.render.packing`), the :class:`Renderer` (:mod:`~wgbragg.render.renderer`),
the display transform (:mod:`~wgbragg.render.display`) and the denoiser
(:mod:`~wgbragg.render.denoise`)."""

from wgbragg.render.denoise import denoise_image
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
    "denoise_image",
    "display_transform",
    "ibl_levels",
    "max_lights",
    "save_png",
]
