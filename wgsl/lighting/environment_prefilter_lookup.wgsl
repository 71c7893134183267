// Prefiltered environment lookups in float32: the twin of PrefilteredEnvironment.lookup
// (wgbragg/lighting/environment_prefilter.py, which defines the prefiltered quantities and states the
// equirectangular convention of wgbragg/lighting/environment_map.py: +y up, the image centre along +z,
// row 0 at +y, phi from +z towards +x, the seam phi = +-pi at the left edge of column 0).
//   prefiltered_lookup(level, d) -> Prefiltered   bilinear between texel centres, wrapping
//                                                 in phi, clamped in theta
// d is a unit vector towards the environment; level indexes prefiltered_levels. Never NaN or
// infinite for such inputs, the poles and the seam included.
//
// Requires gpu/numerics.wgsl.
//
// Buffers. No bindings here: the including entry point declares, under these names, the two
// tables of PrefilteredEnvironment.packed():
//   prefiltered_levels: array<PrefilteredLevel>   per level (width W, height H, first, 0)
//   prefiltered_texels: array<vec4<f32>>          4 vec4 per texel; texel (x, y) of a level,
//                                                 row 0 at the top, is at 4 (first + y W + x):
//     [+0]  (radiance.rgb, 0)     linear sRGB, the kernel-weighted mean radiance
//     [+1]  (mean.xyz, 0)         luminance-weighted mean direction, length <= 1
//     [+2]  (xx, yy, zz, 0)       luminance-weighted second moments of the direction
//     [+3]  (xy, yz, zx, 0)

struct PrefilteredLevel {
    width: u32,
    height: u32,
    first: u32,      // index of the level's texel (0, 0) among all levels' texels
    _pad: u32,
}

struct Prefiltered {
    radiance: vec3<f32>,
    mean: vec3<f32>,
    second_diagonal: vec3<f32>,   // (xx, yy, zz)
    second_off: vec3<f32>,        // (xy, yz, zx)
}

// The image coordinates (u, v) of d, both in [0, 1] (lighting/environment_map.wgsl's convention:
// u = 1/2 - atan2(d.x, d.z) / (2 pi), 1/2 at the poles; v = theta / pi). atan2 in cycles from
// gpu/numerics.wgsl (lavapipe's built-in is off by 2e-5 rad), folded as
// environment_map_coordinates does.
fn prefiltered_angles(d: vec3<f32>) -> vec2<f32> {
    // The azimuth of a pole is 0; the test is on d.xz itself because length(d.xz) underflows
    // to 0 beside the poles.
    var azimuth = 0.0;
    if (any(d.xz != vec2<f32>(0.0))) {
        azimuth = atan2_cycles_positive(abs(d.x), abs(d.z));
    }
    var polar = atan2_cycles_positive(length(d.xz), abs(d.y));
    polar = select(polar, 0.5 - polar, d.y < 0.0);
    azimuth = select(azimuth, 0.5 - azimuth, d.z < 0.0);
    azimuth = select(azimuth, -azimuth, d.x < 0.0);
    return vec2<f32>(0.5 - azimuth, 2.0 * polar);
}

fn prefiltered_texel(index: u32) -> Prefiltered {
    let at = 4u * index;
    return Prefiltered(prefiltered_texels[at].xyz, prefiltered_texels[at + 1u].xyz,
                       prefiltered_texels[at + 2u].xyz, prefiltered_texels[at + 3u].xyz);
}

fn prefiltered_mix(a: Prefiltered, b: Prefiltered, t: f32) -> Prefiltered {
    return Prefiltered(a.radiance + t * (b.radiance - a.radiance), a.mean + t * (b.mean - a.mean),
                       a.second_diagonal + t * (b.second_diagonal - a.second_diagonal),
                       a.second_off + t * (b.second_off - a.second_off));
}

fn prefiltered_lookup(level: u32, d: vec3<f32>) -> Prefiltered {
    let record = prefiltered_levels[level];
    let angles = prefiltered_angles(d);
    // Texel centres sit at integer coordinates: (x + 1/2) / W of a turn, (y + 1/2) / H.
    let u = angles.x * f32(record.width) - 0.5;
    let v = clamp(angles.y * f32(record.height) - 0.5, 0.0, f32(record.height - 1u));
    let column = floor(u);
    let fx = u - column;
    // u >= -1/2, so column >= -1 wraps to the last column across the seam.
    let x0 = u32(i32(column) + i32(record.width)) % record.width;
    let x1 = select(x0 + 1u, 0u, x0 + 1u == record.width);
    let y0 = min(u32(v), max(record.height, 2u) - 2u);
    let fy = v - f32(y0);
    let y1 = min(y0 + 1u, record.height - 1u);
    let top = record.first + y0 * record.width;
    let bottom = record.first + y1 * record.width;
    let upper = prefiltered_mix(prefiltered_texel(top + x0), prefiltered_texel(top + x1), fx);
    let lower = prefiltered_mix(prefiltered_texel(bottom + x0), prefiltered_texel(bottom + x1),
                                fx);
    return prefiltered_mix(upper, lower, fy);
}
