// Pieces of the position-free random walk in a layered Bragg structure (Guo, Hasan & Zhao
// 2018; Fourneau, Pacanowski & Barla 2024, sec. 4.2): random numbers, accurate angles, the
// frame of a layer met from either side, the base's Lambertian directions, a layer's
// reflectance for a path's four wavelengths and its transmission probability.
// wgbragg/bsdf/layered/simulation.py states the estimator. Needs gpu/numerics.wgsl and optics/yeh.wgsl (with
// gpu/complex.wgsl and optics/layer.wgsl). No bindings.

// PCG32 (O'Neill 2014: an LCG with the RXS-M-XS output permutation), one stream for all
// paths, each starting at a state hashed from (seed, query, path), so results do not depend on
// how paths are grouped into invocations. Not a stream (increment) per path: PCG streams that
// differ only in their increment are correlated (Vigna 2018).
fn pcg_output(state: u32) -> u32 {
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

const PCG_MULTIPLIER: u32 = 747796405u;
const PCG_INCREMENT: u32 = 2891336453u;

// Jarzynski & Olano 2020's "pcg" hash: one step of the generator and its output.
fn pcg_hash(x: u32) -> u32 {
    return pcg_output(x * PCG_MULTIPLIER + PCG_INCREMENT);
}

fn pcg_start(seed: u32, query: u32, path: u32) -> u32 {
    return pcg_hash(path + pcg_hash(query + pcg_hash(seed)));
}

// Uniform in [0, 1): 24 random bits, exactly representable in float32. The state is a
// module-scope var<private> of the entry point, from which all the walk's functions draw.
fn pcg_uniform(state: ptr<private, u32>) -> f32 {
    let old = *state;
    *state = old * PCG_MULTIPLIER + PCG_INCREMENT;
    return f32(pcg_output(old) >> 8u) * (1.0 / 16777216.0);
}

// Polar angle of w (w.z >= 0) from +z. acos(z) loses half the digits near 0 and lavapipe's
// atan2 is off by 2e-5 rad, which Bragg reflectances, steep in angle (d ln R / d theta ~ 1e3),
// turn into relative errors of 1e-2.
fn polar_angle(w: vec3<f32>) -> f32 {
    return TWO_PI * atan2_cycles_positive(length(w.xy), max(w.z, 0.0));
}

// Angle between unit vectors with a.b >= 0, accurate for the same reasons.
fn angle_between(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return TWO_PI * atan2_cycles_positive(length(cross(a, b)), max(dot(a, b), 0.0));
}

// The incident direction (pointing back along the path, z > 0) in the frame of the layer a
// path travelling along d meets: from above as it is, from below with the normal flipped.
fn layer_incident(d: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(-d.xy, abs(d.z));
}

// A direction o reflected in that frame (z > 0), back in the structure's frame.
fn layer_reflected(o: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(o.xy, select(o.z, -o.z, d.z > 0.0));
}

// Lambertian reflection: a cosine-distributed direction in the upper hemisphere (z > 0 for
// u.x < 1).
fn cosine_direction(u: vec2<f32>) -> vec3<f32> {
    let r = sqrt(u.x);
    let phi = TWO_PI * u.y;
    return vec3<f32>(r * cos(phi), r * sin(phi), sqrt(1.0 - u.x));
}

// The mirror's unpolarized reflectance at four wavelengths, seen from m.host (the walk's
// medium). The entry point declares HOST_MATCHED.
fn quad_reflectance(m: BraggMirror, wavelength_nm: vec4<f32>, theta: f32) -> vec4<f32> {
    var r: vec4<f32>;
    for (var k = 0u; k < 4u; k++) {
        r[k] = bragg_reflectance(m, wavelength_nm[k], theta, 2u, HOST_MATCHED);
    }
    return r;
}

// Eq 31 with the wavelength-averaged transmissivity (eq 33): at most 2 G1 / (1 + G1) <= 1,
// since t <= G1 (eq 30).
fn transmission_probability(mean_transmissivity: f32, g1: f32) -> f32 {
    return clamp(2.0 * mean_transmissivity / (1.0 + g1), 0.0, 1.0);
}
