// Equirectangular environment map in float32: the twin of EnvironmentMap.radiance_at, .pdf and
// .sample (wgbragg/lighting/environment_map.py, which states the convention: +y up, the image centre
// along +z, row 0 at +y, phi from +z towards +x, the seam phi = +-pi in column 0).
//   environment_map_radiance(d) -> vec3<f32>   radiance of d's texel times the intensity
//   environment_map_pdf(d) -> f32              density of environment_map_sample (1/sr)
//   environment_map_sample(u) -> vec3<f32>     a unit direction drawn with that density
// d is a unit vector towards the environment; u is in [0, 1)^2 (1 is clamped just below).
// Never NaN or infinite for such inputs, the poles and the seam included.
//
// Requires gpu/numerics.wgsl.
//
// Buffers. No bindings here: the including entry point declares, under this name,
//   environment_texels: array<vec4<f32>>   EnvironmentMap.packed(), with theta_y = pi y / H:
//     [0]                  (W, H, intensity, 0)
//     [1]                  (pdf_scale, pdf_floor, 0, 0): a texel's density is
//                          pdf_scale * luminance + pdf_floor
//     [2 + y]              (marginal CDF at the end of row y, sin^2(theta_y / 2),
//                          (cos theta_y - cos theta_(y+1)) / 2, cos^2(theta_(y+1) / 2))
//     [2 + H + y W + x]    (r, g, b, conditional CDF at the end of texel x within row y)

// The header rows above, and EnvironmentMap's luminance weights (checked against
// environment_map.py by tests/test_wgsl_layouts.py).
const ENVIRONMENT_ROWS: u32 = 2u;
const ENVIRONMENT_LUMINANCE: vec3<f32> = vec3<f32>(0.2126, 0.7152, 0.0722);
// The largest float32 below 1: u = 1 still falls inside the last CDF step.
const ENVIRONMENT_BELOW_ONE: f32 = 0.99999994;

struct EnvironmentStep {
    index: u32,
    residual: f32,   // where u lies within the chosen step, in [0, 1]
}

// (W, H) of the map.
fn environment_map_size() -> vec2<u32> {
    return vec2<u32>(environment_texels[0].xy);
}

// Index in environment_texels of the texel that d sees. atan2 in cycles from gpu/numerics.wgsl
// (lavapipe's built-in is off by 2e-5 rad, which would move texel edges).
fn environment_map_texel(d: vec3<f32>) -> u32 {
    let size = environment_map_size();
    // Angles from the nearer axis, in [0, 1/4] turn. The azimuth of a pole is 0; the test is
    // on d.xz itself because length(d.xz) underflows to 0 beside the poles.
    var azimuth = 0.0;
    if (any(d.xz != vec2<f32>(0.0))) {
        azimuth = atan2_cycles_positive(abs(d.x), abs(d.z));
    }
    var polar = atan2_cycles_positive(length(d.xz), abs(d.y));
    polar = select(polar, 0.5 - polar, d.y < 0.0);
    azimuth = select(azimuth, 0.5 - azimuth, d.z < 0.0);
    azimuth = select(azimuth, -azimuth, d.x < 0.0);
    let row = min(u32(2.0 * polar * f32(size.y)), size.y - 1u);
    // phi = +pi (azimuth 1/2) is the seam, where column 0 starts.
    var column = u32((azimuth + 0.5) * f32(size.x));
    column = select(column, 0u, column >= size.x);
    return ENVIRONMENT_ROWS + size.y + row * size.x + column;
}

fn environment_map_radiance(d: vec3<f32>) -> vec3<f32> {
    return environment_texels[environment_map_texel(d)].xyz * environment_texels[0].z;
}

fn environment_map_pdf(d: vec3<f32>) -> f32 {
    let density = environment_texels[1];
    let rgb = environment_texels[environment_map_texel(d)].xyz;
    return density.x * dot(ENVIRONMENT_LUMINANCE, rgb) + density.y;
}

// The first of `count` records from `first` whose CDF (`component`) exceeds u < 1, by
// bisection: ceil(log2 count) rounds, at most 32. Steps of zero width are never chosen.
fn environment_map_invert(first: u32, count: u32, component: u32, u: f32) -> EnvironmentStep {
    var low = 0u;
    var high = count - 1u;
    for (var rounds = 0u; rounds < 32u && low < high; rounds++) {
        let middle = (low + high) / 2u;
        if (environment_texels[first + middle][component] > u) {
            high = middle;
        } else {
            low = middle + 1u;
        }
    }
    var start = 0.0;
    if (low > 0u) {
        start = environment_texels[first + low - 1u][component];
    }
    let end = environment_texels[first + low][component];
    return EnvironmentStep(low, clamp((u - start) / (end - start), 0.0, 1.0));
}

fn environment_map_sample(u: vec2<f32>) -> vec3<f32> {
    let size = environment_map_size();
    let v = clamp(u, vec2<f32>(0.0), vec2<f32>(ENVIRONMENT_BELOW_ONE));
    let row = environment_map_invert(ENVIRONMENT_ROWS, size.y, 0u, v.x);
    let column = environment_map_invert(ENVIRONMENT_ROWS + size.y + row.index * size.x, size.x,
                                        3u, v.y);
    // Uniform in cos theta = 1 - 2 sin^2(theta / 2) across the row; sin^2 and cos^2 of
    // theta / 2 each grow from the nearer pole, so sin theta keeps its accuracy at both.
    let ring = environment_texels[ENVIRONMENT_ROWS + row.index];
    let sin2_half = ring.y + row.residual * ring.z;
    let cos2_half = ring.w + (1.0 - row.residual) * ring.z;
    let sin_theta = 2.0 * sqrt(sin2_half * cos2_half);
    let azimuth = (f32(column.index) + column.residual) / f32(size.x) - 0.5;   // phi / (2 pi)
    return vec3<f32>(sin_theta * sin_cycles(azimuth), cos2_half - sin2_half,
                     sin_theta * sin_cycles(azimuth + 0.25));
}
