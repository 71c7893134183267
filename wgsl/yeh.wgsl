// Yeh's closed-form Bragg-mirror reflectance in float32: the twin of wgbragg/optics/yeh.py.
// Stack: host | (n1 d1, n2 d2) x N | n1. Requires numerics, complex and layer.wgsl. No bindings.
//
// The cell matrix is written A = e^{-i delta1} (P + i Q), C = e^{i delta1} i W with real P, Q, W,
// so cos(K Lambda) = Re(A) and |C|^2 = W^2 need no complex arithmetic. 1 - cos^2(K Lambda) is a
// product of four factors, each vanishing at one kind of band edge, so it keeps its relative
// accuracy where cos(K Lambda) = +-1 (shared/notes/physics.md sec. 2). Phases are reduced in
// cycles before any trigonometry, so thick layers lose nothing beyond their input rounding.

struct BraggMirror {
    n1: f32,
    n2: f32,
    d1_nm: f32,
    d2_nm: f32,
    host: f32,
    periods: u32,
    // 1 when n1 == n2 or d2 == 0: no n2 layer, only the host | n1 interface reflects.
    bulk: u32,
    _pad: u32,
}

// Caps |C| so products with it stay finite; R has rounded to 1 long before.
const MAX_AMPLITUDE: f32 = 1e9;

// Quantities shared by both polarisations at one (wavelength, angle).
struct CellGeometry {
    s: f32,             // Snell invariant host sin(theta)
    cos_theta: f32,
    q1: f32,            // n1 cos(theta_1), 0 at grazing
    q2sq: f32,          // n2^2 - s^2, < 0 when n2 is evanescent
    sa: f32,            // sin(delta1 / 2), reduced
    ca: f32,            // cos(delta1 / 2), reduced
    half2: HalfPhase,   // delta2 / 2 of the n2 layer
    delta1_cycles: f32,
}

fn cell_geometry(m: BraggMirror, wavelength_nm: f32, theta: f32) -> CellGeometry {
    var g: CellGeometry;
    let sc = sin_cos_angle(theta);
    g.s = m.host * sc.x;
    g.cos_theta = sc.y;
    // (n - s)(n + s) instead of n^2 - s^2: no cancellation near the critical angle.
    g.q1 = select(sqrt(max((m.n1 - g.s) * (m.n1 + g.s), 0.0)), m.n1 * sc.y, m.host == m.n1);
    g.q2sq = (m.n2 - g.s) * (m.n2 + g.s);
    let inv_wavelength = 1.0 / wavelength_nm;
    g.delta1_cycles = g.q1 * m.d1_nm * inv_wavelength;
    let sc_a = half_phase_sin_cos(g.delta1_cycles);
    g.sa = sc_a.x;
    g.ca = sc_a.y;
    g.half2 = layer_half_phase(sqrt(abs(g.q2sq)), g.q2sq < 0.0, m.d2_nm * inv_wavelength);
    return g;
}

// Real coefficients of the cell matrix for one polarisation, and 1 - x^2. With admittances
// eta = q (s) or q / n^2 (p), S = sin(delta2) / eta2 and eta2^2 real (negative when n2 is
// evanescent), one formula holds at every angle, including q2 = 0:
//   P = cos(delta2), Q = -(eta2^2 + eta1^2) S / (2 eta1), W = (eta2^2 - eta1^2) S / (2 eta1).
struct CellTerms {
    P: f32,
    Q: f32,
    W: f32,
    x: f32,       // cos(K Lambda)
    sin2: f32,    // 1 - x^2, < 0 inside band gaps
}

fn cell_terms(m: BraggMirror, g: CellGeometry, polarization: u32) -> CellTerms {
    var t: CellTerms;
    let n1s = m.n1 * m.n1;
    let n2s = m.n2 * m.n2;
    var eta1 = g.q1;
    var eta2_squared = g.q2sq;
    var s_half = g.half2.s_over_q;      // sin(delta2 / 2) / eta2
    // eta2^2 - eta1^2 from the indices: exact differences, an exact zero at Brewster's angle.
    var difference = n2s - n1s;
    if (polarization == 1u) {
        eta1 = g.q1 / n1s;
        eta2_squared = g.q2sq / (n2s * n2s);
        s_half = s_half * n2s;
        difference = (n1s - n2s) * (n1s * n2s - g.s * g.s * (n1s + n2s)) / (n1s * n1s * n2s * n2s);
    }
    let inv_eta1 = 1.0 / eta1;
    let sb = g.half2.s;
    let cb = g.half2.c;
    let evanescent = g.q2sq < 0.0;
    let S = 2.0 * cb * s_half;
    t.P = select((cb - sb) * (cb + sb), cb * cb + sb * sb, evanescent);
    t.Q = -0.5 * (eta2_squared + eta1 * eta1) * S * inv_eta1;
    t.W = 0.5 * difference * S * inv_eta1;
    let ratio_term = eta2_squared * inv_eta1;
    let f1 = eta1 * g.ca * s_half + g.sa * cb;
    let f2 = g.sa * cb + ratio_term * g.ca * s_half;
    let f3 = g.ca * cb - eta1 * g.sa * s_half;
    let f4 = g.ca * cb - ratio_term * g.sa * s_half;
    t.sin2 = 4.0 * f1 * f2 * f3 * f4;
    let sin_d1 = 2.0 * g.sa * g.ca;
    let cos_d1 = (g.ca - g.sa) * (g.ca + g.sa);
    t.x = cos_d1 * t.P + sin_d1 * t.Q;
    return t;
}

// Eqs 2 and 9 (host == n1): R = |C|^2 U^2 / (1 + |C|^2 U^2), U = U_{N-1}(x), formed as one
// quotient that never overflows. Pass band: U = sin(N phi) / sin(phi), sin^2(phi) = sin2.
// Gap: 1/U = sinh(mu) / sinh(N mu) with sinh(mu) = sqrt(-sin2), scaled by e^{-N mu}.
fn matched_reflectance(w: f32, x: f32, sin2: f32, periods: u32) -> f32 {
    let w_capped = min(abs(w), MAX_AMPLITUDE);
    let w2 = w_capped * w_capped;
    let n = f32(periods);
    let root = sqrt(abs(sin2));
    var numerator: f32;
    var denominator: f32;
    if (root < 1e-30) {
        numerator = w2 * n * n;  // band edge: U = N
        denominator = 1.0 + numerator;
    } else if (sin2 > 0.0) {
        let s = sin_cycles(n * atan2_cycles_positive(root, abs(x)));
        numerator = w2 * s * s;
        denominator = sin2 + numerator;
    } else {
        let y = 2.0 * n * asinh_accurate(root);
        let e = exp(-0.5 * y);
        let one_minus = select(1.0 - e * e, y * (1.0 - y * (0.5 - y * (1.0 / 6.0 - y * (1.0 / 24.0)))),
                               y < 0.03);
        numerator = w2 * one_minus * one_minus;
        denominator = numerator + 4.0 * root * root * e * e;
    }
    return clamp(numerator / max(denominator, 1e-37), 0.0, 1.0);
}

// U_{N-1}(x), U_{N-2}(x) up to a common positive factor (the general host needs both).
struct Chebyshev {
    u1: f32,
    u0: f32,
}

fn chebyshev_terms(x: f32, sin2: f32, periods: u32) -> Chebyshev {
    var c: Chebyshev;
    let n = f32(periods);
    let negative = x < 0.0;
    let odd = ((periods - 1u) & 1u) == 1u;
    let sign1 = select(1.0, -1.0, negative && odd);
    let sign0 = select(1.0, -1.0, negative && !odd);
    let root = sqrt(abs(sin2));
    if (root < 1e-30) {
        c.u1 = sign1 * n;
        c.u0 = sign0 * (n - 1.0);
    } else if (sin2 > 0.0) {
        // phi in [0, pi/2] via the parity of U: sin(N phi) keeps its relative accuracy.
        let phi_cycles = atan2_cycles_positive(root, abs(x));
        c.u1 = sign1 * sin_cycles(n * phi_cycles) / root;
        c.u0 = sign0 * sin_cycles((n - 1.0) * phi_cycles) / root;
    } else {
        // Divided by sinh(N mu)/sinh(mu): U_{N-1} -> +-1, U_{N-2} -> +-sinh((N-1)mu)/sinh(N mu).
        let mu = asinh_accurate(root);
        c.u1 = sign1;
        c.u0 = sign0 * exp(-mu) * one_minus_exp_neg(2.0 * (n - 1.0) * mu)
            / one_minus_exp_neg(2.0 * n * mu);
    }
    return c;
}

// Fresnel reflection host -> n1 (both real, s < n1).
fn fresnel_host_n1(m: BraggMirror, g: CellGeometry, polarization: u32) -> f32 {
    let qh = m.host * g.cos_theta;
    if (polarization == 1u) {
        let a = m.n1 * m.n1 * qh;
        let b = m.host * m.host * g.q1;
        return (a - b) / max(a + b, 1e-30);
    }
    return (qh - g.q1) / max(qh + g.q1, 1e-30);
}

fn yeh_polarized(m: BraggMirror, g: CellGeometry, polarization: u32, host_matched: bool) -> f32 {
    if (!host_matched && g.s >= m.n1) {
        return 1.0;  // evanescent in n1 and in the n1 substrate: nothing is transmitted
    }
    if (m.bulk != 0u) {
        let r = fresnel_host_n1(m, g, polarization);
        return clamp(r * r, 0.0, 1.0);
    }
    if (g.q1 <= 0.0) {
        return 1.0;  // grazing in n1: r12 = -1
    }
    let t = cell_terms(m, g, polarization);
    if (host_matched) {
        return matched_reflectance(t.W, t.x, t.sin2, m.periods);
    }
    // Appendix D: r_N = C U1 / (A U1 - U0), times e^{i delta1} above and below, then the
    // host | n1 interface r = (r_N + r_h1) / (1 + r_h1 r_N).
    let c = chebyshev_terms(t.x, t.sin2, m.periods);
    let e1 = c_exp_i(TWO_PI * centered_fraction(g.delta1_cycles));
    let scale = max(max(abs(t.P), abs(t.Q)), max(abs(t.W), 1.0)) * max(abs(c.u1), 1.0);
    let numerator = c_mul(vec2<f32>(0.0, t.W * c.u1 / scale), c_mul(e1, e1));
    let denominator = vec2<f32>(t.P, t.Q) * (c.u1 / scale) - e1 * (c.u0 / scale);
    let r_n = c_div(numerator, denominator);
    let r_h1 = fresnel_host_n1(m, g, polarization);
    let top = r_n + vec2<f32>(r_h1, 0.0);
    let bottom = vec2<f32>(1.0, 0.0) + r_h1 * r_n;
    return clamp(c_abs2(top) / max(c_abs2(bottom), 1e-37), 0.0, 1.0);
}

// polarization: 0 = s, 1 = p, 2 = unpolarized (mean of s and p, sharing the geometry).
fn bragg_reflectance(m: BraggMirror, wavelength_nm: f32, theta: f32, polarization: u32,
                     host_matched: bool) -> f32 {
    let g = cell_geometry(m, wavelength_nm, theta);
    if (polarization == 2u) {
        return 0.5 * (yeh_polarized(m, g, 0u, host_matched)
            + yeh_polarized(m, g, 1u, host_matched));
    }
    return yeh_polarized(m, g, polarization, host_matched);
}
