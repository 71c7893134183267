"""The renderers: the progressive path tracer (:class:`Renderer`, :mod:`~wgbragg.render.renderer`,
with its BVH, :mod:`~wgbragg.render.bvh`) and the real-time rasterizer (:class:`Rasterizer`,
:mod:`~wgbragg.render.rasterizer`), which share the GPU buffers a scene packs into
(:mod:`~wgbragg.render.packing`, :mod:`~wgbragg.render.scene_resources`) and the WGSL
materials; the display transform (:mod:`~wgbragg.render.display`) and the denoiser
(:mod:`~wgbragg.render.denoise`)."""

from wgbragg.render.denoise import denoise_image
from wgbragg.render.display import display_transform, save_png
from wgbragg.render.packing import PARAMS_DTYPE, SHARED_LAYERS, ibl_levels
from wgbragg.render.rasterizer import Rasterizer
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
    "Rasterizer",
    "Renderer",
    "WorldGeometry",
    "check_size",
    "denoise_image",
    "display_transform",
    "ibl_levels",
    "max_lights",
    "save_png",
]
