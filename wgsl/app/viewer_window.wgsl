// The demo window's picture (wgbragg/app/viewer_window.py): one triangle that covers the viewport
// and samples the rendered image over it, before the controls are drawn on top.
// The image holds display-ready sRGB bytes in an rgba8unorm-srgb texture: sampling decodes
// them and an sRGB target encodes them again, so pixels drawn at 1:1 keep their bytes, and
// filtering in between happens on linear values.

@group(0) @binding(0) var picture: texture_2d<f32>;
@group(0) @binding(1) var picture_sampler: sampler;

struct Varyings {
    @builtin(position) position: vec4<f32>,
    @location(0) uv: vec2<f32>,
};

@vertex
fn vertex(@builtin(vertex_index) index: u32) -> Varyings {
    // uv (0, 0), (2, 0), (0, 2): the triangle's [0, 1]^2 part is the viewport, uv's y down.
    let uv = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    var out: Varyings;
    out.position = vec4<f32>(2.0 * uv.x - 1.0, 1.0 - 2.0 * uv.y, 0.0, 1.0);
    out.uv = uv;
    return out;
}

@fragment
fn fragment(in: Varyings) -> @location(0) vec4<f32> {
    return vec4<f32>(textureSample(picture, picture_sampler, in.uv).rgb, 1.0);
}
