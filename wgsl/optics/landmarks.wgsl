// Spectral landmarks of a Bragg mirror in float32: the twin of wgbragg/optics/landmarks.py (Fourneau,
// Pacanowski & Barla 2024, sec. 3.2.1 and Appendix A). Requires numerics, layer and optics/yeh.wgsl.
// No bindings.
//
// Propagating n2. Landmarks are searched in the mode coordinate t = omega n_plus / pi, in which
// the modes are the integers and, with half phases A = delta1 / 2, B = delta2 / 2,
// A + B = pi t / 2 and B - A = pi t delta / 2 (delta = (q2 d2 - q1 d1) / n_plus, |delta| <= 1):
//   cos K Lambda = a cos(pi t) + b cos(pi t delta),  a = (1 + rho) / 2, b = (1 - rho) / 2,
//   rho = (r + 1/r) / 2, r = eta1 / eta2  (App. A eq 36),
// a closed form whose omega-independent coefficients are set once per angle. The Airy point
// of each mode interval [m, m + 1] is its zero, found by safeguarded Newton (2 to 4 steps
// instead of 60 bisections). The band edges are zeros of the four factors of
// sin^2 K Lambda = 4 f1 f2 f3 f4 (optics/yeh.wgsl, cell_terms), which in t read, up to positive
// factors (1 - x = 2 f1 f2, 1 + x = 2 f3 f4):
//   g = (1 + r) sin(pi t / 2) -+ (1 - r) sin(pi t delta / 2)   near even modes (x = +1),
//   g = (1 + r) cos(pi t / 2) +- (1 - r) cos(pi t delta / 2)   near odd modes (x = -1).
// Each g is a smooth sum of two sinusoids with a simple root at its edge, so Newton on g keeps
// float32's relative accuracy where x itself rounds to +-1. At a mode the first sinusoid
// vanishes exactly, which gives the sign of g there, hence the bracket [mode, Airy point] (or
// [Airy point, next mode]) holding exactly one edge, and a closed gap (Brewster's angle, or
// sin(pi m delta / 2) = 0) exactly where its second term vanishes.
//
// Evanescent n2: as the numpy twin (landmarks._evanescent_landmarks), in tau = omega q1 d1 / pi
// each integer is a gap (a mode of n_plus = q1 d1) and [k, k + 1] holds one pass band, whose
// edges lie on either side of its zero of cos K Lambda (its Airy point); the three roots by
// safeguarded Newton.

// The visible range 360..830 nm as angular wavenumbers (rad/nm): landmarks.VISIBLE_OMEGA (these
// and the kind codes below are checked by tests/test_wgsl_layouts.py).
const OMEGA_LO: f32 = 0.0075701028;   // 2 pi / 830
const OMEGA_HI: f32 = 0.0174532925;   // 2 pi / 360
const LAMBDA_LO_NM: f32 = 360.0;
const LAMBDA_HI_NM: f32 = 830.0;
// Safeguarded Newton: at most this many steps, stopping once a step is below NEWTON_TOL
// relative (a few float32 ulps: the evaluation noise of the functions).
const NEWTON_STEPS: u32 = 16u;
const NEWTON_TOL: f32 = 4e-7;

// Landmark kinds (landmarks.KINDS order).
const KIND_MODE: u32 = 0u;
const KIND_AIRY: u32 = 1u;
const KIND_EDGE: u32 = 2u;
const KIND_ZERO: u32 = 3u;

// (sin, cos) of 2 pi * cycles, reduced exactly to [-1/4, 1/4] turn (signs kept, unlike
// half_phase_sin_cos): sin(pi - x) = sin x, cos(pi - x) = -cos x.
fn sin_cos_cycles(cycles: f32) -> vec2<f32> {
    let r = centered_fraction(cycles);
    let fold = abs(r) > 0.25;
    let folded = select(r, select(-0.5, 0.5, r > 0.0) - r, fold);
    let sc = sin_cos_reduced(TWO_PI * folded);
    return vec2<f32>(sc.x, select(sc.y, -sc.y, fold));
}

// Per angle and polarisation: the closed-form dispersion in the mode coordinate t.
struct ModeFrame {
    n_plus: f32,       // q1 d1 + q2 d2, nm: omega = pi t / n_plus, lambda = 2 n_plus / t
    delta: f32,        // (q2 d2 - q1 d1) / n_plus
    r: f32,            // eta1 / eta2
    a: f32,            // cos K Lambda = a cos(pi t) + b cos(pi t delta)
    b: f32,
    zero_period: f32,  // zero points at t = z * zero_period (eq 12): n_plus / (q2 d2)
    rho: f32,          // (r + 1/r) / 2: Q = -rho sin(delta2)
    w_factor: f32,     // (1/r - r) / 2: W = w_factor sin(delta2)
    sin2_factor: f32,  // 1 / (4 r^2): sin^2 K Lambda = g1 g2 g3 g4 sin2_factor
    t_lo: f32,         // the visible range, 830 nm
    t_hi: f32,         // 360 nm
}

// Needs a propagating n2 (angle.q2sq > 0), q1 > 0 and d2 > 0.
fn mode_frame(m: BraggMirror, angle: CellGeometry, polarization: u32) -> ModeFrame {
    var f: ModeFrame;
    let q2 = sqrt(angle.q2sq);
    let phase1 = angle.q1 * m.d1_nm;
    let phase2 = q2 * m.d2_nm;
    f.n_plus = phase1 + phase2;
    f.delta = (phase2 - phase1) / f.n_plus;
    // eta = q (s) or q / n^2 (p).
    f.r = select(angle.q1 / q2, (angle.q1 * m.n2 * m.n2) / (q2 * m.n1 * m.n1), polarization == 1u);
    // rho = (r + 1/r) / 2 = 1 + (1 - r)^2 / (2 r): b = -(1 - r)^2 / (4 r) exactly 0 at r = 1.
    let excess = (1.0 - f.r) * (1.0 - f.r) / (4.0 * f.r);
    f.a = 1.0 + excess;
    f.b = -excess;
    f.zero_period = f.n_plus / phase2;
    f.rho = f.a - f.b;
    f.w_factor = 0.5 * (1.0 / f.r - f.r);
    f.sin2_factor = 0.25 / (f.r * f.r);
    f.t_lo = 2.0 * f.n_plus / LAMBDA_HI_NM;
    f.t_hi = 2.0 * f.n_plus / LAMBDA_LO_NM;
    return f;
}

// (cos K Lambda, its t-derivative) at t.
fn dispersion_value(f: ModeFrame, t: f32) -> vec2<f32> {
    let e1 = sin_cos_cycles(0.25 * t);            // pi t / 2
    let e2 = sin_cos_cycles(0.25 * t * f.delta);  // pi t delta / 2
    let x = f.a * (e1.y - e1.x) * (e1.y + e1.x) + f.b * (e2.y - e2.x) * (e2.y + e2.x);
    let dx = -TWO_PI * (f.a * e1.x * e1.y + f.b * f.delta * e2.x * e2.y);
    return vec2<f32>(x, dx);
}

// (g, dg/dt) of the edge factor g = (1 + r) u(pi t / 2) + sigma (1 - r) u(pi t delta / 2),
// u = cos (cos_type) or sin.
fn edge_factor_value(f: ModeFrame, t: f32, cos_type: bool, sigma: f32) -> vec2<f32> {
    let e1 = sin_cos_cycles(0.25 * t);
    let e2 = sin_cos_cycles(0.25 * t * f.delta);
    let p = 1.0 + f.r;
    let q = sigma * (1.0 - f.r);
    let u1 = select(e1.x, e1.y, cos_type);
    let u2 = select(e2.x, e2.y, cos_type);
    let du1 = select(e1.y, -e1.x, cos_type);
    let du2 = select(e2.y, -e2.x, cos_type);
    return vec2<f32>(p * u1 + q * u2, HALF_PI * (p * du1 + q * f.delta * du2));
}

// The two reduced (sin, cos) pairs of mode_terms at mode coordinate t, (e1, e2) with
// e1 = (sin, cos)(pi t / 2) and e2 = (sin, cos)(pi t delta / 2): they do not depend on the
// polarisation (n_plus and delta do not), so both polarisations share them.
fn mode_phases(f: ModeFrame, t: f32) -> vec4<f32> {
    return vec4<f32>(sin_cos_cycles(0.25 * t), sin_cos_cycles(0.25 * t * f.delta));
}

// The cell terms of cell_terms (optics/yeh.wgsl) from mode_phases: delta1 = pi t / 2 - pi t delta / 2,
// delta2 = pi t / 2 + pi t delta / 2; the four edge factors g (see above) give
// sin^2 K Lambda = g1 g2 g3 g4 / (4 r^2) with their relative accuracy at band edges.
fn mode_terms_at(f: ModeFrame, phases: vec4<f32>) -> CellTerms {
    var terms: CellTerms;
    let e1 = phases.xy;
    let e2 = phases.zw;
    let p = 1.0 + f.r;
    let q = 1.0 - f.r;
    let sin_d2 = e1.x * e2.y + e1.y * e2.x;
    terms.P = e1.y * e2.y - e1.x * e2.x;
    terms.Q = -f.rho * sin_d2;
    terms.W = f.w_factor * sin_d2;
    terms.x = f.a * (e1.y - e1.x) * (e1.y + e1.x) + f.b * (e2.y - e2.x) * (e2.y + e2.x);
    let g12 = (p * e1.x - q * e2.x) * (p * e1.x + q * e2.x);
    let g34 = (p * e1.y + q * e2.y) * (p * e1.y - q * e2.y);
    terms.sin2 = (g12 * g34) * f.sin2_factor;
    return terms;
}

// The cell terms at mode coordinate t, from the frame: two reduced sin/cos pairs per
// wavelength instead of a full cell geometry.
fn mode_terms(f: ModeFrame, t: f32) -> CellTerms {
    return mode_terms_at(f, mode_phases(f, t));
}

// Safeguarded Newton (rtsafe) on a bracket [lo, hi] holding one root, from the iterate t.
struct Rtsafe {
    lo: f32,
    hi: f32,
    t: f32,
    done: bool,
}

fn rtsafe_start(lo: f32, hi: f32, t0: f32) -> Rtsafe {
    return Rtsafe(lo, hi, select(0.5 * (lo + hi), t0, t0 >= lo && t0 <= hi), false);
}

// One step, given (value, derivative) at r.t; the value at lo is positive iff lo_positive.
fn rtsafe_step(r: ptr<function, Rtsafe>, value: vec2<f32>, lo_positive: bool) {
    let t = (*r).t;
    if (value.x == 0.0) {
        (*r).done = true;
        return;
    }
    if ((value.x > 0.0) == lo_positive) {
        (*r).lo = t;
    } else {
        (*r).hi = t;
    }
    // The midpoint whenever Newton leaves the bracket (or divides by 0); done once the step
    // is below the evaluation noise. The bracket ends are admitted: a nearly closed gap has
    // its edge within rounding of the mode.
    let step = value.x / value.y;
    if (abs(step) <= NEWTON_TOL * max(t, 1.0)) {
        (*r).t = clamp(t - step, (*r).lo, (*r).hi);
        (*r).done = true;
        return;
    }
    let next = t - step;
    (*r).t = select(0.5 * ((*r).lo + (*r).hi), next, next >= (*r).lo && next <= (*r).hi);
}

// Root of the dispersion (kind 0) or of an edge factor (kind 1) in [lo, hi], whose value at lo
// is positive iff lo_positive, from the first guess t0.
fn bracketed_root(f: ModeFrame, kind: u32, cos_type: bool, sigma: f32, lo: f32, hi: f32,
                  lo_positive: bool, t0: f32) -> f32 {
    var r = rtsafe_start(lo, hi, t0);
    for (var step = 0u; step < NEWTON_STEPS; step++) {
        var value: vec2<f32>;
        if (kind == 0u) {
            value = dispersion_value(f, r.t);
        } else {
            value = edge_factor_value(f, r.t, cos_type, sigma);
        }
        rtsafe_step(&r, value, lo_positive);
        if (r.done) {
            break;
        }
    }
    return r.t;
}

// The landmarks of the mode interval [m, m + 1] (t coordinates).
struct ModeInterval {
    rising: f32,           // band edge above mode m (= m when that gap is closed)
    airy: f32,
    falling: f32,          // band edge below mode m + 1 (= m + 1 when closed)
    zero: f32,             // the zero point inside the pass band, or -1
}

// Sign of u(pi t / 2) for t in (m, m + 1): quadrant m mod 4 of pi t / 2.
fn quadrant_sign(m: i32, cos_type: bool) -> f32 {
    let q = m & 3;
    let positive = select(q < 2, q == 0 || q == 3, cos_type);
    return select(-1.0, 1.0, positive);
}

// Band edge next to the mode `mode`, on the side of the Airy point `airy` (inside the mode
// interval [m, m + 1], which fixes the sign of the factors there); the mode itself when the
// gap is closed.
fn band_edge(f: ModeFrame, mode: i32, m: i32, airy: f32) -> f32 {
    let cos_type = (mode & 1) == 1;
    let tm = f32(mode);
    // At the mode u(pi tm / 2) = 0 and u'(pi tm / 2) = +-1 exactly.
    let e2 = sin_cos_cycles(0.25 * tm * f.delta);
    let u2 = select(e2.x, e2.y, cos_type);
    let du2 = select(e2.y, -e2.x, cos_type);
    let q4 = mode & 3;
    let du1 = select(select(-1.0, 1.0, q4 == 0), select(-1.0, 1.0, q4 == 3), cos_type);
    let second = (1.0 - f.r) * u2;
    if (second == 0.0) {
        return tm;  // closed gap: both factors vanish on the mode
    }
    // The factor with the sign change between the mode and the Airy point, where both
    // factors share the sign of their first term.
    let at_airy = quadrant_sign(m, cos_type);
    let sigma = select(1.0, -1.0, (second > 0.0) == (at_airy > 0.0));
    let g = sigma * second;
    let dg = HALF_PI * ((1.0 + f.r) * du1 + sigma * (1.0 - f.r) * f.delta * du2);
    let t0 = tm - g / dg;
    var root: f32;
    if (mode == m) {
        root = bracketed_root(f, 1u, cos_type, sigma, tm, airy, g > 0.0, t0);
    } else {
        root = bracketed_root(f, 1u, cos_type, sigma, airy, tm, at_airy > 0.0, t0);
    }
    return root;
}

fn mode_interval(f: ModeFrame, m: i32) -> ModeInterval {
    var iv: ModeInterval;
    let tm = f32(m);
    // Airy point: cos K Lambda has the sign (-1)^m at t = m and changes sign once before m + 1.
    // First guess: t = m + 1/2 + tau linearised in tau.
    let parity = select(1.0, -1.0, (m & 1) == 1);
    let c_mid = sin_cos_cycles(0.5 * (tm + 0.5) * f.delta).y;
    let tau = clamp(parity * f.b * c_mid / (f.a * PI), -0.45, 0.45);
    iv.airy = bracketed_root(f, 0u, false, 1.0, tm, tm + 1.0, parity > 0.0, tm + 0.5 + tau);
    iv.rising = band_edge(f, m, m, iv.airy);
    iv.falling = band_edge(f, m + 1, m, iv.airy);
    // Zero point (eq 12): spacing zero_period >= 1, so at most one inside (m, m + 1); only
    // kept inside the pass band, as the numpy twin keeps those with sin^2 K Lambda > 0.
    let z = floor(tm / f.zero_period) + 1.0;
    let tz = z * f.zero_period;
    iv.zero = select(-1.0, tz, tz > iv.rising && tz < iv.falling);
    return iv;
}

// Evanescent n2, per angle and polarisation (landmarks._evanescent_landmarks): in
// tau = omega q1 d1 / pi, with the decay kappa = pi rho tau, cos K Lambda = cosh(kappa) h and
//   h = cos(pi tau) + (a tanh(kappa) - b tanh(kappa) / (pi rho)) sin(pi tau),
// finite where q2 -> 0. Written with sech(kappa) instead of cosh(kappa), nothing overflows: the
// edges of a band narrower than float32 resolves coincide with its zero of h.
struct EvanescentFrame {
    scale: f32,   // tau per omega (rad/nm): q1 d1 / pi
    rho: f32,     // |q2| d2 / (q1 d1)
    a: f32,       // |eta2| / (2 eta1)
    b: f32,       // pi eta1 d2 / (2 q1 d1 e2), e2 = |eta2| / |q2|
    tau_lo: f32,  // the visible range
    tau_hi: f32,
}

// Needs an evanescent (or grazing) n2, angle.q2sq <= 0, and q1 > 0.
fn evanescent_frame(m: BraggMirror, angle: CellGeometry, polarization: u32) -> EvanescentFrame {
    var f: EvanescentFrame;
    let q2 = sqrt(max(-angle.q2sq, 0.0));
    let p = polarization == 1u;
    let eta1 = select(angle.q1, angle.q1 / (m.n1 * m.n1), p);
    let e2 = select(1.0, 1.0 / (m.n2 * m.n2), p);
    let phase1 = angle.q1 * m.d1_nm;
    f.scale = phase1 * (1.0 / PI);
    f.rho = q2 * m.d2_nm / phase1;
    f.a = 0.5 * q2 * e2 / eta1;
    f.b = 0.5 * PI * eta1 * m.d2_nm / (phase1 * e2);
    f.tau_lo = OMEGA_LO * f.scale;
    f.tau_hi = OMEGA_HI * f.scale;
    return f;
}

// (h, dh/dtau, sech kappa, d sech kappa / dtau) at tau >= 0.
fn evanescent_terms(f: EvanescentFrame, tau: f32) -> vec4<f32> {
    let kappa = PI * f.rho * tau;
    let e = exp(-2.0 * kappa);
    let sech = 2.0 * exp(-kappa) / (1.0 + e);
    // tanh(kappa) / kappa by its series where 1 - e would cancel (error below 6e-8).
    let small = kappa < 0.1;
    let k2 = kappa * kappa;
    let tanhc = 1.0 - k2 * (1.0 / 3.0 - k2 * (2.0 / 15.0));
    let tanh = select((1.0 - e) / (1.0 + e), kappa * tanhc, small);
    let tanh_over = select(tanh / (PI * f.rho), tau * tanhc, small);  // tanh(kappa) / (pi rho)
    let sc = sin_cos_cycles(0.5 * tau);                                 // pi tau
    let c = f.a * tanh - f.b * tanh_over;
    let dc = (f.a * PI * f.rho - f.b) * sech * sech;
    return vec4<f32>(sc.y + c * sc.x, (dc - PI) * sc.x + PI * c * sc.y, sech,
                     -PI * f.rho * sech * tanh);
}

// The root of parity h + sigma sech in [lo, hi] (decreasing through it), from t0: sigma = 0:
// the zero of h; -1: the edge below it; +1: the edge above it.
fn evanescent_root(f: EvanescentFrame, parity: f32, sigma: f32, lo: f32, hi: f32,
                   t0: f32) -> f32 {
    var r = rtsafe_start(lo, hi, t0);
    for (var step = 0u; step < NEWTON_STEPS; step++) {
        let terms = evanescent_terms(f, r.t);
        rtsafe_step(&r, vec2<f32>(parity * terms.x + sigma * terms.z,
                                  parity * terms.y + sigma * terms.w), true);
        if (r.done) {
            break;
        }
    }
    return r.t;
}

// The landmarks of branch k in tau: (edge below, Airy point, edge above). An edge below the
// visible range is returned as -1 and one beyond it as 2 tau_hi + 1, so that it falls outside
// the range exactly (the numpy twin drops them too).
fn evanescent_band(f: EvanescentFrame, k: i32) -> vec3<f32> {
    let tk = f32(k);
    let parity = select(1.0, -1.0, (k & 1) == 1);
    // First guess: h = 0 with its coefficient of sin(pi tau) frozen at the branch's middle,
    // where h = parity c.
    let c_mid = parity * evanescent_terms(f, tk + 0.5).x;
    let airy = evanescent_root(f, parity, 0.0, tk, tk + 1.0,
                               tk + atan2(1.0, -c_mid) * (1.0 / PI));
    let at_airy = evanescent_terms(f, airy);
    let half_width = at_airy.z / max(abs(at_airy.y), 1e-30);
    let below_range = -1.0;
    let beyond_range = 2.0 * f.tau_hi + 1.0;
    var edges = vec2<f32>(below_range, beyond_range);
    // One loop over both sides keeps a single inlined copy of the root finder.
    for (var side = 0; side < 2; side++) {
        let above = side == 1;
        let sigma = select(-1.0, 1.0, above);
        let lo = select(max(tk, f.tau_lo), max(airy, f.tau_lo), above);
        let hi = select(min(airy, f.tau_hi), min(tk + 1.0, f.tau_hi), above);
        var edge: f32;
        if (hi <= lo) {
            // The band's zero lies outside the range, and this edge with it.
            edge = select(below_range, beyond_range, above);
        } else {
            let at_lo = evanescent_terms(f, lo);
            let at_hi = evanescent_terms(f, hi);
            if (parity * at_lo.x + sigma * at_lo.z <= 0.0) {
                // Past the edge already: the range starts there, or the gap closes at lo.
                edge = select(below_range, lo, lo > f.tau_lo);
            } else if (parity * at_hi.x + sigma * at_hi.z > 0.0) {
                // Not yet at the edge: the range ends first, or (where sech(kappa) is below
                // the rounding of h) the edge is within rounding of the zero of h at hi.
                edge = select(beyond_range, hi, hi < f.tau_hi);
            } else {
                edge = evanescent_root(f, parity, sigma, lo, hi, airy + sigma * half_width);
            }
        }
        if (above) {
            edges.y = edge;
        } else {
            edges.x = edge;
        }
    }
    return vec3<f32>(edges.x, airy, edges.y);
}
