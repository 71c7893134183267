// Yeh's closed-form Bragg-mirror reflectance in float32: the twin of wgbragg/optics/yeh.py.
// Stack: host | (n1 d1, n2 d2) x N | n1. Requires numerics.wgsl and complex.wgsl. No bindings.
//
// The cell matrix is written A = e^{-i delta1} (P + i Q), C = e^{i delta1} i W with real P, Q, W,
// so cos(K Lambda) = Re(A) and |C|^2 = W^2 need no complex arithmetic. 1 - cos^2(K Lambda) is a
// product of four factors, each vanishing at one kind of band edge, so it keeps its relative
// accuracy where cos(K Lambda) = +-1 (shared/notes/physics.md sec. 2).

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

// Evanescent n2 layers decaying by more than this many e-folds transmit < e^-40, so R rounds
// to 1 in float32; clamping keeps the cosh/sinh products finite.
const MAX_DECAY: f32 = 20.0;
// Caps |C|^2 and U^2 so their product stays finite; R has rounded to 1 long before.
const MAX_SQUARE: f32 = 1e18;

// Quantities shared by both polarisations at one (wavelength, angle).
struct CellGeometry {
    s: f32,          // Snell invariant host sin(theta)
    q1: f32,         // n1 cos(theta_1), 0 at grazing
    q2: f32,         // |n2^2 - s^2|^(1/2)
    evanescent: bool,
    sa: f32,         // sin(delta1 / 2), reduced
    ca: f32,         // cos(delta1 / 2), reduced
    sb: f32,         // sin(delta2 / 2) or sinh(kappa / 2) when evanescent
    cb: f32,         // cos(delta2 / 2) or cosh(kappa / 2) when evanescent
    delta1_cycles: f32,
}

fn cell_geometry(m: BraggMirror, wavelength_nm: f32, theta: f32) -> CellGeometry {
    var g: CellGeometry;
    g.s = m.host * sin(theta);
    // (n - s)(n + s) instead of n^2 - s^2: no cancellation near the critical angle.
    g.q1 = sqrt(max((m.n1 - g.s) * (m.n1 + g.s), 0.0));
    if (m.host == m.n1) {
        g.q1 = max(m.n1 * cos(theta), 0.0);  // exact near grazing; cos(f32(pi/2)) < 0
    }
    let q2sq = (m.n2 - g.s) * (m.n2 + g.s);
    g.evanescent = q2sq < 0.0;
    g.q2 = sqrt(abs(q2sq));
    g.delta1_cycles = g.q1 * m.d1_nm / wavelength_nm;
    let a = half_phase(g.delta1_cycles);
    g.sa = sin(a);
    g.ca = cos(a);
    let cycles2 = g.q2 * m.d2_nm / wavelength_nm;
    if (g.evanescent) {
        let half_kappa = min(PI * cycles2, 0.5 * MAX_DECAY);
        let e = exp(half_kappa);
        g.sb = 0.5 * (e - 1.0 / e);
        g.cb = 0.5 * (e + 1.0 / e);
    } else {
        let b = half_phase(cycles2);
        g.sb = sin(b);
        g.cb = cos(b);
    }
    return g;
}

// Real coefficients of the cell matrix for one polarisation, and 1 - x^2.
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
    // ratio = q2/q1 (s) or n1^2 q2 / (n2^2 q1) (p); i * ratio when n2 is evanescent.
    var ratio = g.q2 / g.q1;
    if (polarization == 1u) {
        ratio = ratio * (n1s / n2s);
    }
    let sin_d1 = 2.0 * g.sa * g.ca;
    let cos_d1 = (g.ca - g.sa) * (g.ca + g.sa);
    if (g.evanescent) {
        let beta = ratio;
        let sinh_k = 2.0 * g.sb * g.cb;
        t.P = g.cb * g.cb + g.sb * g.sb;
        t.Q = 0.5 * (beta - 1.0 / beta) * sinh_k;
        t.W = -0.5 * (beta + 1.0 / beta) * sinh_k;
        let f1 = g.ca * g.sb / beta + g.sa * g.cb;
        let f2 = g.sa * g.cb - beta * g.ca * g.sb;
        let f3 = g.ca * g.cb - g.sa * g.sb / beta;
        let f4 = g.ca * g.cb + beta * g.sa * g.sb;
        t.sin2 = 4.0 * f1 * f2 * f3 * f4;
    } else {
        // gamma = (ratio - 1/ratio) / 2 from the indices: exact differences, Brewster zero.
        var gamma = (n2s - n1s) / (2.0 * g.q1 * g.q2);
        if (polarization == 1u) {
            gamma = (n1s - n2s) * (n1s * n2s - g.s * g.s * (n1s + n2s))
                / (2.0 * n1s * n2s * g.q1 * g.q2);
        }
        let sin_d2 = 2.0 * g.sb * g.cb;
        t.P = (g.cb - g.sb) * (g.cb + g.sb);
        t.Q = -sqrt(1.0 + gamma * gamma) * sin_d2;
        t.W = gamma * sin_d2;
        let f1 = g.ca * g.sb / ratio + g.sa * g.cb;
        let f2 = g.sa * g.cb + ratio * g.ca * g.sb;
        let f3 = g.ca * g.cb - g.sa * g.sb / ratio;
        let f4 = g.ca * g.cb - ratio * g.sa * g.sb;
        t.sin2 = 4.0 * f1 * f2 * f3 * f4;
    }
    t.x = cos_d1 * t.P + sin_d1 * t.Q;
    return t;
}

// U_{N-1}(x), U_{N-2}(x) up to a common positive factor, and 1/U_{N-1}^2 inside gaps.
struct Chebyshev {
    u1: f32,
    u0: f32,
    inv_u1_sq: f32,
    in_gap: bool,
}

fn chebyshev_terms(x: f32, sin2: f32, periods: u32) -> Chebyshev {
    var c: Chebyshev;
    let n = f32(periods);
    let negative = x < 0.0;
    let odd = ((periods - 1u) & 1u) == 1u;
    let sign1 = select(1.0, -1.0, negative && odd);
    let sign0 = select(1.0, -1.0, negative && !odd);
    c.in_gap = sin2 < 0.0;
    if (!c.in_gap) {
        // phi in [0, pi/2] via the parity of U: sin(N phi) keeps its relative accuracy.
        let sin_phi = sqrt(sin2);
        let phi_cycles = atan2_accurate(sin_phi, abs(x)) / (2.0 * PI);
        if (sin_phi < 1e-30) {
            c.u1 = sign1 * n;
            c.u0 = sign0 * (n - 1.0);
        } else {
            c.u1 = sign1 * sin_cycles(n * phi_cycles) / sin_phi;
            c.u0 = sign0 * sin_cycles((n - 1.0) * phi_cycles) / sin_phi;
        }
        c.inv_u1_sq = 0.0;
    } else {
        // K Lambda = m pi + i mu; sinh(mu)/sinh(N mu) in scaled form underflows to 0, never inf.
        let mu = asinh_accurate(sqrt(-sin2));
        if (mu < 1e-30) {
            c.u0 = sign0 * (n - 1.0) / n;
            c.inv_u1_sq = 1.0 / (n * n);
        } else {
            let full = one_minus_exp_neg(2.0 * n * mu);
            c.u0 = sign0 * exp(-mu) * one_minus_exp_neg(2.0 * (n - 1.0) * mu) / full;
            let inv_u1 = exp(-(n - 1.0) * mu) * one_minus_exp_neg(2.0 * mu) / full;
            c.inv_u1_sq = inv_u1 * inv_u1;
        }
        c.u1 = sign1;
    }
    return c;
}

// Fresnel reflection host -> n1 (both real, s < n1).
fn fresnel_host_n1(m: BraggMirror, g: CellGeometry, theta: f32, polarization: u32) -> f32 {
    let qh = m.host * cos(theta);
    if (polarization == 1u) {
        let a = m.n1 * m.n1 * qh;
        let b = m.host * m.host * g.q1;
        return (a - b) / max(a + b, 1e-30);
    }
    return (qh - g.q1) / max(qh + g.q1, 1e-30);
}

fn yeh_polarized(m: BraggMirror, g: CellGeometry, theta: f32, polarization: u32,
                 host_matched: bool) -> f32 {
    if (!host_matched && g.s >= m.n1) {
        return 1.0;  // evanescent in n1 and in the n1 substrate: nothing is transmitted
    }
    if (m.bulk != 0u) {
        let r = fresnel_host_n1(m, g, theta, polarization);
        return clamp(r * r, 0.0, 1.0);
    }
    if (g.q1 <= 0.0) {
        return 1.0;  // grazing in n1: r12 = -1
    }
    let t = cell_terms(m, g, polarization);
    let c = chebyshev_terms(t.x, t.sin2, m.periods);
    if (host_matched) {
        // Eqs 2 and 9: R = |C|^2 U^2 / (1 + |C|^2 U^2).
        let c2 = min(t.W * t.W, MAX_SQUARE);
        if (c.in_gap) {
            return clamp(c2 / max(c2 + c.inv_u1_sq, 1e-37), 0.0, 1.0);
        }
        let c2u2 = c2 * min(c.u1 * c.u1, MAX_SQUARE);
        return clamp(c2u2 / (1.0 + c2u2), 0.0, 1.0);
    }
    // Appendix D: r_N = C U1 / (A U1 - U0), times e^{i delta1} above and below, then the
    // host | n1 interface r = (r_N + r_h1) / (1 + r_h1 r_N).
    let e1 = c_exp_i(2.0 * PI * (g.delta1_cycles - round(g.delta1_cycles)));
    let scale = max(max(abs(t.P), abs(t.Q)), max(abs(t.W), 1.0)) * max(abs(c.u1), 1.0);
    let numerator = c_mul(vec2<f32>(0.0, t.W * c.u1 / scale), c_mul(e1, e1));
    let denominator = vec2<f32>(t.P, t.Q) * (c.u1 / scale) - e1 * (c.u0 / scale);
    let r_n = c_div(numerator, denominator);
    let r_h1 = fresnel_host_n1(m, g, theta, polarization);
    let top = r_n + vec2<f32>(r_h1, 0.0);
    let bottom = vec2<f32>(1.0, 0.0) + r_h1 * r_n;
    return clamp(c_abs2(top) / max(c_abs2(bottom), 1e-37), 0.0, 1.0);
}

// polarization: 0 = s, 1 = p, 2 = unpolarized (mean of s and p, sharing the geometry).
fn bragg_reflectance(m: BraggMirror, wavelength_nm: f32, theta: f32, polarization: u32,
                     host_matched: bool) -> f32 {
    let g = cell_geometry(m, wavelength_nm, theta);
    if (polarization == 2u) {
        return 0.5 * (yeh_polarized(m, g, theta, 0u, host_matched)
            + yeh_polarized(m, g, theta, 1u, host_matched));
    }
    return yeh_polarized(m, g, theta, polarization, host_matched);
}
