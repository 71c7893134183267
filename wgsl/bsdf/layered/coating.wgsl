// Layered Bragg structures: the float32 twin of wgbragg/bsdf/layered/coating.py
// (coating, refraction, a rough layer's reflection lobe). Directions are unit vectors in the
// surface frame, +z the normal, pointing away from the surface. Needs gpu/numerics.wgsl and
// bsdf/microfacet.wgsl. No bindings: entry points bring the tables (transmissivity, reflectance LUTs).

// Unpolarized Fresnel reflectance of the smooth air / n interface (n >= 1) seen from air at
// cos_theta; 0 for n = 1.
fn coating_reflectance(cos_theta: f32, n: f32) -> f32 {
    let c = clamp(cos_theta, 0.0, 1.0);
    // n cos' = sqrt(n^2 - sin^2) is real for n >= 1: no total internal reflection from air.
    let q = sqrt(max(n * n - ggx_sin2(c), 0.0));
    let s_den = c + q;
    if (s_den <= 0.0) {
        return 0.0;
    }
    let rs = (c - q) / s_den;
    let rp = (n * n * c - q) / (n * n * c + q);
    return 0.5 * (rs * rs + rp * rp);
}

// Reflectance of the same interface seen from inside n at cos_inner: 1 past the critical
// angle (total internal reflection). Equal to coating_reflectance at the refracted angle.
fn coating_reflectance_inside(cos_inner: f32, n: f32) -> f32 {
    let sin2_out = n * n * ggx_sin2(clamp(cos_inner, 0.0, 1.0));
    if (sin2_out >= 1.0) {
        return 1.0;
    }
    return coating_reflectance(sqrt(1.0 - sin2_out), n);
}

// A direction in air (z >= 0) refracted into n >= 1.
fn refract_in(w: vec3<f32>, n: f32) -> vec3<f32> {
    // Without a coating the direction is kept as is: 1 - |t|^2 rounds to 0 near grazing.
    if (n == 1.0) {
        return w;
    }
    let t = w.xy / n;
    return vec3<f32>(t, sqrt(max(0.0, 1.0 - dot(t, t))));
}

// A direction inside n (z >= 0) refracted out into air; w = 0 marks total internal reflection.
fn refract_out(w: vec3<f32>, n: f32) -> vec4<f32> {
    let t = w.xy * n;
    let sin2 = dot(t, t);
    if (sin2 >= 1.0) {
        return vec4<f32>(0.0, 0.0, 1.0, 0.0);
    }
    return vec4<f32>(t, sqrt(1.0 - sin2), 1.0);
}

// Unit half vector of i and o above the horizon, scaled before normalising: at grazing i + o
// can be 1e-40, whose square underflows; exactly 0 (z flushed to zero) leaves the normal, its
// limit.
fn half_vector(i: vec3<f32>, o: vec3<f32>) -> vec3<f32> {
    let h = i + o;
    let largest = max(abs(h.x), max(abs(h.y), abs(h.z)));
    if (largest == 0.0) {
        return vec3<f32>(0.0, 0.0, 1.0);
    }
    return normalize(h / largest);
}

// Mirror reflection of i about the unit normal m.
fn reflect_about(i: vec3<f32>, m: vec3<f32>) -> vec3<f32> {
    return 2.0 * dot(i, m) * m - i;
}

// GGX D (eq 18) of a unit half vector, its sin^2 from h.xy: the float32 rounding of h.z
// (6e-8) is 1e-3 of sin^2 = (1 - h.z)(1 + h.z) ~ alpha^2 at alpha = 0.01, which ggx_D(h.z)
// would pass on to the peak of a narrow lobe.
fn half_vector_D(h: vec3<f32>, alpha: f32) -> f32 {
    if (h.z <= 0.0) {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let d = a2 * h.z * h.z + dot(h.xy, h.xy);
    return a2 / (PI * d * d);
}

// D(h) G1(i) G1(o) / (4 cos_i cos_o) of eq 17 (all but the mirror's reflectance), with the
// G1 / cos form that stays finite at grazing angles. ci, co > 0; h the unit half vector.
fn layer_lobe(ci: f32, co: f32, h: vec3<f32>, alpha: f32) -> f32 {
    return 0.25 * half_vector_D(h, alpha) * ggx_G1_over_cos(ci, alpha)
        * ggx_G1_over_cos(co, alpha);
}

// Density of reflecting i into o = reflect_about(i, h) with h a visible GGX normal (1/sr).
fn layer_lobe_pdf(ci: f32, h: vec3<f32>, alpha: f32) -> f32 {
    return 0.25 * ggx_G1_over_cos(ci, alpha) * half_vector_D(h, alpha);
}
