// The rasterizer's resolve pass (wgbragg/render/rasterizer.py): each frame is averaged into the
// running mean of the frames since the view last changed (temporal antialiasing over the
// jittered frames), and the mean goes through the display transform (render/display.wgsl) to
// an 8-bit target, so that a viewer reads back or presents display-ready pixels.
//! include "render/display.wgsl"

struct Resolve {
    weight: f32,          // 1 / frames averaged, this one included (1: the first frame)
    scale: f32,           // 2^exposure
    _pad0: f32,
    _pad1: f32,
}

@group(0) @binding(0) var frame_texels: texture_2d<f32>;
@group(0) @binding(1) var history_texels: texture_2d<f32>;
@group(0) @binding(2) var<uniform> resolve: Resolve;

struct Resolved {
    @location(0) mean: vec4<f32>,
    @location(1) display: vec4<f32>,
}

@vertex
fn resolve_vertex(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    return vec4<f32>(select(-1.0, 3.0, i == 1u), select(-1.0, 3.0, i == 2u), 0.0, 1.0);
}

@fragment
fn resolve_fragment(@builtin(position) position: vec4<f32>) -> Resolved {
    let texel = vec2<u32>(position.xy);
    let latest = textureLoad(frame_texels, texel, 0);
    let old = textureLoad(history_texels, texel, 0);
    let mean = select(old + resolve.weight * (latest - old), latest, resolve.weight >= 1.0);
    return Resolved(mean, vec4<f32>(display_transform(mean.xyz, resolve.scale), 1.0));
}
