// Isotropic GGX (Trowbridge-Reitz) microfacets: the float32 twins of wgbragg/bsdf/microfacet.py.
// The macro-normal is +z, alpha is in [1e-4, 1]. Needs gpu/numerics.wgsl (PI, TWO_PI). No bindings.

// 1 - c^2 as a product: 1 - c is exact near c = 1, where the narrow lobes live.
fn ggx_sin2(c: f32) -> f32 {
    return (1.0 - c) * (1.0 + c);
}

// D(m) of eq 18 in 1/sr, 0 for cos_theta_m <= 0. cos^4 (alpha^2 + tan^2)^2 is written as
// (alpha^2 cos^2 + sin^2)^2: no tangent, finite at the horizon.
fn ggx_D(cos_theta_m: f32, alpha: f32) -> f32 {
    if (cos_theta_m <= 0.0) {
        return 0.0;
    }
    // A normalised float32 vector can have z = 1 + 1 ulp, which would make sin^2 negative.
    let c = min(cos_theta_m, 1.0);
    let a2 = alpha * alpha;
    let d = a2 * c * c + ggx_sin2(c);
    return a2 / (PI * d * d);
}

// G1 / cos theta: finite at grazing incidence, where G1 and cos theta both vanish.
fn ggx_G1_over_cos(cos_theta: f32, alpha: f32) -> f32 {
    return 2.0 / (cos_theta + sqrt(cos_theta * cos_theta + alpha * alpha * ggx_sin2(cos_theta)));
}

// Smith masking of eq 19 without its chi+ factor, 0 at and below the horizon.
fn ggx_G1(cos_theta: f32, alpha: f32) -> f32 {
    if (cos_theta <= 0.0) {
        return 0.0;
    }
    let c = min(cos_theta, 1.0);
    return c * ggx_G1_over_cos(c, alpha);
}

// Heitz 2018, listing 1: a micro-normal distributed as the normals visible from wi (z >= 0).
fn ggx_sample_visible_normal(wi: vec3<f32>, u: vec2<f32>, alpha: f32) -> vec3<f32> {
    let v = normalize(vec3<f32>(alpha * wi.x, alpha * wi.y, wi.z));
    let lensq = v.x * v.x + v.y * v.y;
    // At normal incidence any tangent will do; the frame only orients the sampled disk.
    var t1 = vec3<f32>(1.0, 0.0, 0.0);
    if (lensq > 0.0) {
        t1 = vec3<f32>(-v.y, v.x, 0.0) * inverseSqrt(lensq);
    }
    let t2 = cross(v, t1);
    let r = sqrt(u.x);
    let phi = TWO_PI * u.y;
    let p1 = r * cos(phi);
    let s = 0.5 * (1.0 + v.z);
    let p2 = (1.0 - s) * sqrt(max(0.0, 1.0 - p1 * p1)) + s * r * sin(phi);
    let p3 = sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2));
    let n = p1 * t1 + p2 * t2 + p3 * v;
    return normalize(vec3<f32>(alpha * n.x, alpha * n.y, max(n.z, 0.0)));
}

// Density of ggx_sample_visible_normal w.r.t. the solid angle of m: G1(wi) max(0, wi.m) D(m) / wi_z.
fn ggx_visible_normal_pdf(wi: vec3<f32>, m: vec3<f32>, alpha: f32) -> f32 {
    let c = clamp(wi.z, 0.0, 1.0);
    return ggx_G1_over_cos(c, alpha) * max(dot(wi, m), 0.0) * ggx_D(m.z, alpha);
}
