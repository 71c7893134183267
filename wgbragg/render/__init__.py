"""The progressive path tracer: BVH, the buffers it uploads, the renderer and the display
transform."""
