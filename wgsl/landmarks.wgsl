// Spectral landmarks of a Bragg mirror in float32: the twin of wgbragg/landmarks.py (Fourneau,
// Pacanowski & Barla 2024, sec. 3.2.1 and Appendix A). Requires numerics, layer and yeh.wgsl.
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
// sin^2 K Lambda = 4 f1 f2 f3 f4 (yeh.wgsl, cell_terms), which in t read, up to positive
// factors (1 - x = 2 f1 f2, 1 + x = 2 f3 f4):
//   g = (1 + r) sin(pi t / 2) -+ (1 - r) sin(pi t delta / 2)   near even modes (x = +1),
//   g = (1 + r) cos(pi t / 2) +- (1 - r) cos(pi t delta / 2)   near odd modes (x = -1).
// Each g is a smooth sum of two sinusoids with a simple root at its edge, so Newton on g keeps
// float32's relative accuracy where x itself rounds to +-1. At a mode the first sinusoid
// vanishes exactly, which gives the sign of g there, hence the bracket [mode, Airy point] (or
// [Airy point, next mode]) holding exactly one edge, and a closed gap (Brewster's angle, or
// sin(pi m delta / 2) = 0) exactly where its second term vanishes.
//
// Evanescent n2 (no modes): as the numpy twin, sign changes of sin^2 K Lambda on the same
// 512-point omega grid, refined by bisection.

// The visible range 360..830 nm as angular wavenumbers (rad/nm): landmarks.VISIBLE_OMEGA.
const OMEGA_LO: f32 = 0.0075701028;   // 2 pi / 830
const OMEGA_HI: f32 = 0.0174532925;   // 2 pi / 360
const LAMBDA_LO_NM: f32 = 360.0;
const LAMBDA_HI_NM: f32 = 830.0;
// landmarks._SCAN_POINTS: grid of the evanescent-n2 edge scan.
const SCAN_POINTS: u32 = 512u;
// Bisection steps refining an evanescent edge: the grid cell (2e-5 rad/nm) shrinks below one
// float32 ulp of omega (9e-10) in 15 steps.
const SCAN_BISECTIONS: u32 = 18u;
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

// The cell terms of cell_terms (yeh.wgsl) from mode_phases: delta1 = pi t / 2 - pi t delta / 2,
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

// Root of the dispersion (kind 0) or of an edge factor (kind 1) in [lo, hi], whose value at lo
// is positive iff lo_positive, from the first guess t0.
fn bracketed_root(f: ModeFrame, kind: u32, cos_type: bool, sigma: f32, lo_in: f32, hi_in: f32,
                  lo_positive: bool, t0: f32) -> f32 {
    var lo = lo_in;
    var hi = hi_in;
    var t = select(0.5 * (lo + hi), t0, t0 >= lo && t0 <= hi);
    for (var step = 0u; step < NEWTON_STEPS; step++) {
        var value: vec2<f32>;
        if (kind == 0u) {
            value = dispersion_value(f, t);
        } else {
            value = edge_factor_value(f, t, cos_type, sigma);
        }
        if (value.x == 0.0) {
            break;
        }
        if ((value.x > 0.0) == lo_positive) {
            lo = t;
        } else {
            hi = t;
        }
        // Safeguarded Newton (rtsafe): the midpoint whenever Newton leaves the bracket (or
        // divides by 0); done once the step is below the evaluation noise. The bracket ends
        // are admitted: a nearly closed gap has its edge within rounding of the mode.
        let step = value.x / value.y;
        if (abs(step) <= NEWTON_TOL * max(t, 1.0)) {
            t = clamp(t - step, lo, hi);
            break;
        }
        let next = t - step;
        t = select(0.5 * (lo + hi), next, next >= lo && next <= hi);
    }
    return t;
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

// Evanescent n2, per angle and polarisation: cos K Lambda = cos(delta1) cosh(kappa)
// + c sin(delta1) sinh(kappa), c = (1/r - r) / 2 with r = eta1 / |eta2| (cell_terms with
// sin -> sinh), delta1 = omega q1 d1 and kappa = omega |q2| d2.
struct EvanescentFrame {
    phase1: f32,   // q1 d1 / (2 pi): delta1 in turns per rad/nm
    decay: f32,    // |q2| d2: kappa per rad/nm
    c: f32,
}

fn evanescent_frame(m: BraggMirror, angle: CellGeometry, polarization: u32) -> EvanescentFrame {
    var f: EvanescentFrame;
    let q2 = sqrt(-angle.q2sq);
    f.phase1 = angle.q1 * m.d1_nm * (1.0 / TWO_PI);
    f.decay = q2 * m.d2_nm;
    let r = select(angle.q1 / q2, (angle.q1 * m.n2 * m.n2) / (q2 * m.n1 * m.n1),
                   polarization == 1u);
    f.c = 0.5 * (1.0 / r - r);
    return f;
}

// Whether omega lies in a pass band (|cos K Lambda| < 1): the scan's test, cheaper than
// cell_terms. Beyond MAX_DECAY e-folds the layer is opaque and every omega is in a gap.
fn evanescent_pass(f: EvanescentFrame, omega: f32) -> bool {
    let kappa = min(omega * f.decay, MAX_DECAY);
    let e = exp(kappa);
    let inv_e = 1.0 / e;
    let sc = sin_cos_cycles(omega * f.phase1);
    let x = 0.5 * (sc.y * (e + inv_e) + f.c * sc.x * (e - inv_e));
    return abs(x) < 1.0;
}

// sin^2 K Lambda at angular wavenumber omega (any n2: the product form of cell_terms).
fn dispersion_sin2(m: BraggMirror, angle: CellGeometry, omega: f32, polarization: u32) -> f32 {
    return cell_terms(m, geometry_at(m, angle, TWO_PI / omega), polarization).sin2;
}

// The omega grid of the evanescent scan: numpy.linspace(OMEGA_LO, OMEGA_HI, SCAN_POINTS).
fn scan_omega(i: u32) -> f32 {
    let step = (OMEGA_HI - OMEGA_LO) / f32(SCAN_POINTS - 1u);
    return select(OMEGA_LO + f32(i) * step, OMEGA_HI, i == SCAN_POINTS - 1u);
}

// The sign change of sin^2 K Lambda in [lo, hi] by bisection (lo_negative: sin2(lo) <= 0).
fn scan_edge(m: BraggMirror, angle: CellGeometry, polarization: u32, lo_in: f32, hi_in: f32,
             lo_negative: bool) -> f32 {
    var lo = lo_in;
    var hi = hi_in;
    for (var step = 0u; step < SCAN_BISECTIONS; step++) {
        let mid = 0.5 * (lo + hi);
        let negative = dispersion_sin2(m, angle, mid, polarization) <= 0.0;
        if (negative == lo_negative) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return 0.5 * (lo + hi);
}
