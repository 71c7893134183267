// Transmission filter F_alpha(theta_i, theta_d) of a rough Bragg layer (Fourneau et al. 2024,
// eqs 24-29): the float32 twin of wgbragg.bsdf.transmission_filter.F_alpha. Needs gpu/numerics.wgsl and
// bsdf/microfacet.wgsl. No bindings.

// Angles arrive as (cos t, sin t, cos t/2, sin t/2), computed by the host in float64: f32(pi/2)
// lies above pi/2, so cos of the rounded angle would be negative at grazing incidence.
// The midpoint samples first .. first + count - 1 of psi_samples: F is the sum of these parts
// over a partition of 0 .. psi_samples - 1, which lets the host keep count within the device's
// loop budget (wgbragg/gpu/loops.py, "Loop budget") whatever psi_samples is.
fn transmission_filter(incident: vec4<f32>, difference: vec4<f32>, alpha: f32,
                       psi_samples: u32, first: u32, count: u32) -> f32 {
    let ci = incident.x;
    let si = incident.y;
    let cd = difference.x;
    let sd = difference.y;
    // cos(theta_i -+ theta_d): the endpoints of cos theta_m over psi in [0, pi] (eq 24).
    let cos_delta = ci * cd + si * sd;
    let cos_sigma = ci * cd - si * sd;
    if (cos_delta <= 0.0) {
        return 0.0;
    }
    // Eq 26 as tan(psi_max / 2) = sqrt(cos_delta / -cos_sigma); it is pi when cos_sigma >= 0
    // and has no 1/(tan tan) to overflow at grazing angles.
    let psi_max = 2.0 * TWO_PI
        * atan2_cycles_positive(sqrt(cos_delta), sqrt(max(-cos_sigma, 0.0)));
    // 1 - cos theta_m = 2 sin^2((ti - td)/2) + 2 si sd sin^2(psi/2): eq 24 without the
    // cancellation of 1 - cos near the peak of D, where theta_m is of the order of alpha.
    let sin_half_delta = incident.w * difference.z - incident.z * difference.w;
    let base = 2.0 * sin_half_delta * sin_half_delta;
    let slope = 2.0 * si * sd;
    let a2 = alpha * alpha;
    // Midpoint rule in psi. D~ depends on cos^2 theta_m, which is even about psi = 0 and, to
    // first order, about psi_max (where cos theta_m = 0): the rule's h^2 term vanishes at both
    // ends. Half-angles advance by a rotation from the part's first sample: error ~ k ulp after
    // k steps, smallest near the peak at psi = 0.
    let half_step = 0.5 * psi_max / f32(psi_samples);
    let rotation = sin_cos_reduced(half_step);
    var half = sin_cos_reduced((f32(first) + 0.5) * half_step);
    var sum = 0.0;
    for (var k = 0u; k < count; k++) {
        let one_minus_cos = base + slope * half.x * half.x;
        let c = 1.0 - one_minus_cos;
        // D~ = alpha^2 / (pi d^2), d = alpha^2 cos^2 + sin^2 (eq 18 without chi+).
        let d = a2 * c * c + one_minus_cos * (2.0 - one_minus_cos);
        sum += 1.0 / (d * d);
        half = vec2<f32>(half.x * rotation.y + half.y * rotation.x,
                         half.y * rotation.y - half.x * rotation.x);
    }
    let psi_integral = a2 / PI * sum * (psi_max / f32(psi_samples));
    // Eq 29; G1^2 / cos theta_i as G1 * (G1 / cos), which is 0 rather than 0/0 at 90 degrees.
    return ggx_G1(ci, alpha) * ggx_G1_over_cos(ci, alpha) * 2.0 * cd * sd * psi_integral;
}
