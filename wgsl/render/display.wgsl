// The display transform of wgbragg/render/display.py in float32: exposure, Reinhard's tone map
// of the luminance keeping the chromaticity, gamut mapping by desaturation towards the
// pixel's luminance, and the sRGB transfer function. No bindings here.
// Needs nothing; the rasterizer's resolve pass (render/rasterizer_resolve.wgsl) calls it.

// Rec. 709 luminance of linear sRGB (display.LUMINANCE_WEIGHTS).
const DISPLAY_LUMINANCE = vec3<f32>(0.2126, 0.7152, 0.0722);

// display.gamut_map: into the unit cube along the line to the grey of the same luminance.
fn display_gamut_map(rgb: vec3<f32>) -> vec3<f32> {
    if (all(rgb >= vec3<f32>(0.0)) && all(rgb <= vec3<f32>(1.0))) {
        return rgb;
    }
    let luminance = clamp(dot(rgb, DISPLAY_LUMINANCE), 0.0, 1.0);
    let chroma = rgb - vec3<f32>(luminance);
    var t = 1.0;
    for (var c = 0u; c < 3u; c++) {
        if (rgb[c] < 0.0) {
            t = min(t, luminance / -chroma[c]);
        } else if (rgb[c] > 1.0) {
            t = min(t, (1.0 - luminance) / chroma[c]);
        }
    }
    return clamp(vec3<f32>(luminance) + clamp(t, 0.0, 1.0) * chroma, vec3<f32>(0.0),
                 vec3<f32>(1.0));
}

// display.encode_srgb of values in [0, 1].
fn display_encode_srgb(linear: vec3<f32>) -> vec3<f32> {
    let curve = 1.055 * pow(max(linear, vec3<f32>(0.0031308)), vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(curve, 12.92 * linear, linear <= vec3<f32>(0.0031308));
}

// Linear radiance times 2^exposure (`scale`) to encoded sRGB in [0, 1] (display_transform
// before its rounding to 8 bits); NaN and infinite pixels and luminance <= 0 show black.
fn display_transform(linear: vec3<f32>, scale: f32) -> vec3<f32> {
    let scaled = linear * scale;
    let luminance = dot(scaled, DISPLAY_LUMINANCE);
    // NaN fails every comparison, and an infinite channel makes the luminance infinite.
    if (!(luminance > 0.0) || !(luminance < 3.4e38) || any(scaled != scaled)) {
        return vec3<f32>(0.0);
    }
    return display_encode_srgb(display_gamut_map(scaled / (1.0 + luminance)));
}
