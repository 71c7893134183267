// Equirectangular environment map in float32: the twin of EnvironmentMap.radiance_at, .pdf and
// .sample (wgbragg/lighting/environment_map.py, which states the convention, Mitsuba 3's:
// u = atan2(d.x, -d.z) / (2 pi) in [0, 1), v = acos(d.y) / pi, +y up, row 0 at +y, the image
// centre along +z, u = 1/4 along +x, the seam u = 0 (-z) in column 0, u = 1/2 at the poles).
//   environment_map_radiance(d) -> vec3<f32>   radiance at d, bilinear between texel centres
//                                              (u wraps, v clamps), times the intensity
//   environment_map_pdf(d) -> f32              density of environment_map_sample (1/sr):
//                                              constant over d's texel, read from the table
//                                              (from the mean luminance of the bilinear
//                                              radiance over the texel, plus a floor)
//   environment_map_sample(u) -> vec3<f32>     a unit direction drawn with that density
// d is a unit vector towards the environment; u is in [0, 1)^2 (1 is clamped just below).
// Never NaN or infinite for such inputs, the poles and the seam included.
//
// Requires gpu/numerics.wgsl.
//
// Buffers. No bindings here: the including entry point declares, under this name,
//   environment_texels: array<vec4<f32>>   EnvironmentMap.packed(), with theta_y = pi y / H:
//     [0]                        (W, H, intensity, 0)
//     [1 + y]                    (marginal CDF at the end of row y, sin^2(theta_y / 2),
//                                (cos theta_y - cos theta_(y+1)) / 2, cos^2(theta_(y+1) / 2))
//     [1 + H + y W + x]          (r, g, b, conditional CDF at the end of texel x within row y)
//     [1 + H + H W + i / 4][i % 4], i = y W + x: the density of texel (x, y) (1/sr), the
//                                last row padded with zeros

// The header rows above (checked against environment_map.py by tests/test_wgsl_layouts.py).
const ENVIRONMENT_ROWS: u32 = 1u;
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

// (u, v) of d, both in [0, 1]: u = 1/2 - atan2(d.x, d.z) / (2 pi), the convention's
// atan2(d.x, -d.z) / (2 pi) wrapped (1 only across the seam from d.x < 0), and v = acos(d.y) / pi.
// atan2 in cycles from gpu/numerics.wgsl (lavapipe's built-in is off by 2e-5 rad, which would
// move texel edges), folded from the nearer axis.
fn environment_map_coordinates(d: vec3<f32>) -> vec2<f32> {
    // Angles from the nearer axis, in [0, 1/4] turn. The azimuth of a pole is 0 (u = 1/2);
    // the test is on d.xz itself because length(d.xz) underflows to 0 beside the poles.
    var azimuth = 0.0;
    if (any(d.xz != vec2<f32>(0.0))) {
        azimuth = atan2_cycles_positive(abs(d.x), abs(d.z));
    }
    var polar = atan2_cycles_positive(length(d.xz), abs(d.y));
    polar = select(polar, 0.5 - polar, d.y < 0.0);
    azimuth = select(azimuth, 0.5 - azimuth, d.z < 0.0);   // atan2(d.x, d.z) in cycles,
    azimuth = select(azimuth, -azimuth, d.x < 0.0);        // in [-1/2, 1/2]
    return vec2<f32>(0.5 - azimuth, 2.0 * polar);
}

// Index y W + x of the texel (x, y) holding d, whose density environment_map_pdf returns.
fn environment_map_texel(d: vec3<f32>) -> u32 {
    let size = environment_map_size();
    let uv = environment_map_coordinates(d);
    let row = min(u32(uv.y * f32(size.y)), size.y - 1u);
    // u = 1 (the seam approached from the right edge) wraps to column 0.
    var column = u32(uv.x * f32(size.x));
    column = select(column, 0u, column >= size.x);
    return row * size.x + column;
}

fn environment_map_radiance(d: vec3<f32>) -> vec3<f32> {
    let size = environment_map_size();
    let uv = environment_map_coordinates(d);
    // Texel centres sit at integer coordinates: u = (x + 1/2) / W, v = (y + 1/2) / H.
    let s = uv.x * f32(size.x) - 0.5;   // in [-1/2, W - 1/2]
    let column = floor(s);
    let fx = s - column;
    // column >= -1 wraps to the last column across the seam.
    let x0 = u32(i32(column) + i32(size.x)) % size.x;
    let x1 = select(x0 + 1u, 0u, x0 + 1u == size.x);
    let t = clamp(uv.y * f32(size.y) - 0.5, 0.0, f32(size.y - 1u));
    let y0 = min(u32(t), max(size.y, 2u) - 2u);
    let fy = t - f32(y0);
    let y1 = min(y0 + 1u, size.y - 1u);
    let top = ENVIRONMENT_ROWS + size.y + y0 * size.x;
    let bottom = ENVIRONMENT_ROWS + size.y + y1 * size.x;
    let a = environment_texels[top + x0].xyz;
    let b = environment_texels[bottom + x0].xyz;
    let upper = a + fx * (environment_texels[top + x1].xyz - a);
    let lower = b + fx * (environment_texels[bottom + x1].xyz - b);
    return (upper + fy * (lower - upper)) * environment_texels[0].z;
}

fn environment_map_pdf(d: vec3<f32>) -> f32 {
    let size = environment_map_size();
    let texel = environment_map_texel(d);
    let densities = ENVIRONMENT_ROWS + size.y + size.y * size.x;
    return environment_texels[densities + texel / 4u][texel % 4u];
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
    // Uniform in u across the column; from the image centre (+z), u - 1/2 in [-1/2, 1/2]
    // cycles, d = (-sin theta sin, cos theta, sin theta cos) of that angle.
    let from_centre = (f32(column.index) + column.residual) / f32(size.x) - 0.5;
    return vec3<f32>(-sin_theta * sin_cycles(from_centre), cos2_half - sin2_half,
                     sin_theta * sin_cycles(from_centre + 0.25));
}
