// Reflectance of any planar stack by characteristic (Abeles) matrices in float32: the twin of
// wgbragg/design/stack.py (the float64 transfer-matrix solver, wgbragg/optics/transfer_matrix.py).
// Stack: a real host | lossless layers (real n, thickness d) | a real or absorbing base. The
// entry point walks the layers from the base up, one stack_layer call each, carrying the
// vector (B, C) = M_1 ... M_m (1, eta_base) for both polarisations at once. Requires
// gpu/numerics.wgsl, gpu/complex.wgsl and optics/layer.wgsl. No bindings.
//
// A lossless layer's matrix [[cos delta, -i S], [-i eta^2 S, cos delta]] has real cos delta,
// S = f sin(delta) / q and eta^2 S = q^2 sin(delta) / (q f) (f = 1 for s, n^2 for p) whether
// the layer propagates (q real) or is evanescent (q imaginary: cosh and sinh / kappa), so a
// step is two real scalars times complex amplitudes. Half phases come from layer_half_phase
// (reduced in turns, sinc form at q = 0, the decay clamped): cos delta = 1 -+ 2 sin^2(delta/2)
// and sin(delta) / q = 2 cos(delta/2) sin(delta/2) / q, exact as delta -> 0.

// The point as the stack's host sees it: s = host sin(theta), host_cos = host cos(theta), 1 / lambda.
struct StackLight {
    s: f32,
    host_cos: f32,
    inv_wavelength: f32,
}

// (B, C) of s (xy, zw of bc_s) and p (bc_p), rescaled at every layer (R is a ratio) so that
// evanescent layers cannot overflow them.
struct StackAmplitudes {
    bc_s: vec4<f32>,
    bc_p: vec4<f32>,
}

// -i z.
fn stack_minus_i(z: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(z.y, -z.x);
}

// The amplitudes under the base n + i k: (1, eta_base), eta = q (s) or q / (n + i k)^2 (p),
// q the decaying root of (n + i k)^2 - s^2 (its real part without cancellation, normal_square).
fn stack_base(host: f32, n: f32, k: f32, light: StackLight) -> StackAmplitudes {
    let q2 = vec2<f32>(normal_square(n, host, light.s, light.host_cos) - k * k, 2.0 * n * k);
    let q = c_sqrt(q2);
    let eps = vec2<f32>((n - k) * (n + k), 2.0 * n * k);
    var a: StackAmplitudes;
    a.bc_s = vec4<f32>(1.0, 0.0, q);
    a.bc_p = vec4<f32>(1.0, 0.0, c_div(q, eps));
    return a;
}

fn stack_step(bc: vec4<f32>, cos_d: f32, upper: f32, lower: f32) -> vec4<f32> {
    // B' = cos d B - i upper C, C' = -i lower B + cos d C.
    let b = cos_d * bc.xy + upper * stack_minus_i(bc.zw);
    let c = lower * stack_minus_i(bc.xy) + cos_d * bc.zw;
    let out = vec4<f32>(b, c);
    let scale = max(max(abs(out.x), abs(out.y)), max(abs(out.z), abs(out.w)));
    return select(out, out / scale, scale > 0.0);
}

// One layer of index n (real) and thickness d_nm, above the amplitudes so far.
fn stack_layer(a: StackAmplitudes, host: f32, n: f32, d_nm: f32,
               light: StackLight) -> StackAmplitudes {
    let q2 = normal_square(n, host, light.s, light.host_cos);
    let evanescent = q2 < 0.0;
    let h = layer_half_phase(sqrt(abs(q2)), evanescent, d_nm * light.inv_wavelength);
    let cos_d = select(1.0 - 2.0 * h.s * h.s, 1.0 + 2.0 * h.s * h.s, evanescent);
    let sin_over_q = 2.0 * h.c * h.s_over_q;
    let f = n * n;
    var out: StackAmplitudes;
    out.bc_s = stack_step(a.bc_s, cos_d, sin_over_q, q2 * sin_over_q);
    out.bc_p = stack_step(a.bc_p, cos_d, f * sin_over_q, q2 * sin_over_q / f);
    return out;
}

// R of one polarisation from the amplitudes at the top and the host's admittance eta0:
// |(eta0 B - C) / (eta0 B + C)|^2; 1 at grazing incidence (eta0 = 0), 0 where nothing
// reflects (a stack index-matched to the host at grazing incidence).
fn stack_finish(bc: vec4<f32>, eta0: f32) -> f32 {
    let top = eta0 * bc.xy - bc.zw;
    let bottom = eta0 * bc.xy + bc.zw;
    let bottom2 = c_abs2(bottom);
    var r = select(c_abs2(top) / bottom2, 0.0, bottom2 == 0.0);
    r = select(r, 1.0, eta0 == 0.0);
    return clamp(r, 0.0, 1.0);
}

// R for polarisation 0 = s, 1 = p, 2 = unpolarized (the mean).
fn stack_reflectance(a: StackAmplitudes, host: f32, light: StackLight, polarization: u32) -> f32 {
    let rs = stack_finish(a.bc_s, light.host_cos);
    let rp = stack_finish(a.bc_p, light.host_cos / (host * host));
    return select(select(0.5 * (rs + rp), rp, polarization == 1u), rs, polarization == 0u);
}
