// Yeh's closed-form Bragg-mirror reflectance in float32: the twin of wgbragg/optics/yeh.py.
// Stack: host | (n1 d1, n2 d2) x N | n1. Requires numerics, complex and optics/layer.wgsl. No bindings.
//
// The cell matrix is written A = e^{-i delta1} (P + i Q), C = e^{i delta1} i W with real P, Q, W,
// so cos(K Lambda) = Re(A) and |C|^2 = W^2 need no complex arithmetic. 1 - cos^2(K Lambda) is a
// product of four factors, each vanishing at one kind of band edge, so it keeps its relative
// accuracy where cos(K Lambda) = +-1 (docs/design.md, "Float32 numerics"). Phases are reduced in
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
    cell_cycles: f32,   // the phase in turns whose rounding the layer phases carry: scales
                        // the rounding error of x (|delta1| + |delta2|, or see split_cycles)
}

fn cell_geometry(m: BraggMirror, wavelength_nm: f32, theta: f32) -> CellGeometry {
    return geometry_at(m, angle_geometry(m, theta), wavelength_nm);
}

// The angle fields of a CellGeometry (s, cos_theta, q1, q2sq); the rest is left 0 for
// geometry_at. Without dispersion they serve every wavelength at that angle.
fn angle_geometry(m: BraggMirror, theta: f32) -> CellGeometry {
    var g: CellGeometry;
    let sc = sin_cos_angle(theta);
    g.s = m.host * sc.x;
    g.cos_theta = sc.y;
    // (n - s)(n + s) instead of n^2 - s^2: no cancellation near the critical angle.
    g.q1 = select(sqrt(max((m.n1 - g.s) * (m.n1 + g.s), 0.0)), m.n1 * sc.y, m.host == m.n1);
    g.q2sq = (m.n2 - g.s) * (m.n2 + g.s);
    return g;
}

// The angle fields of a CellGeometry given on the host (s, cos theta, q1, q2^2): formed in
// float64 from the float64 angle, they keep their relative accuracy at grazing incidence,
// where cos(theta) from a float32 angle carries its absolute rounding (3e-6 relative at 89
// degrees).
fn angle_geometry_given(fields: vec4<f32>) -> CellGeometry {
    var g: CellGeometry;
    g.s = fields.x;
    g.cos_theta = fields.y;
    g.q1 = fields.z;
    g.q2sq = fields.w;
    return g;
}

// The wavelength-dependent fields of a CellGeometry whose angle fields (angle_geometry) are
// already set: one angle's setup serves every wavelength of a sweep.
fn geometry_at(m: BraggMirror, angle: CellGeometry, wavelength_nm: f32) -> CellGeometry {
    let inv_wavelength = 1.0 / wavelength_nm;
    let q2 = sqrt(abs(angle.q2sq));
    let cycles = vec2<f32>(angle.q1 * m.d1_nm * inv_wavelength, q2 * (m.d2_nm * inv_wavelength));
    return geometry_of_cycles(m, angle, inv_wavelength, cycles, cycles,
                              cycles.x + q2 * m.d2_nm * inv_wavelength);
}

// The layer phases q d / lambda (cycles) from optical paths q d split on the host into a head
// of 12 significant bits and the rest (paths = (head1, rest1, head2, rest2), nm; those of n2
// 0 where it is evanescent), and 1 / lambda split alike (wgbragg/colour/reference_gpu.py, split_float32):
// head x head is exact in float32, so its fraction is, and the other three products are below
// 2^-10 of the phase, so their rounding is too. The fraction then carries float32's rounding of
// a number below 1 + 2^-10 phase instead of that of the phase: at N = 100 one ulp of a 2-cycle
// phase moved R by 1e-2 next to a transmission resonance (docs/design.md, 'Float32
// numerics'). Nothing here cancels algebraically: a reassociating driver cannot fold it away.
fn split_cycles(path: vec2<f32>, inv_wavelength: vec2<f32>) -> f32 {
    let head = path.x * inv_wavelength.x;
    return (head - floor(head))
        + (path.x * inv_wavelength.y + path.y * inv_wavelength.x + path.y * inv_wavelength.y);
}

// geometry_at from split optical paths and 1 / lambda (see split_cycles).
fn geometry_at_split(m: BraggMirror, angle: CellGeometry, inv_wavelength: vec2<f32>,
                     paths: vec4<f32>) -> CellGeometry {
    let inv = inv_wavelength.x + inv_wavelength.y;
    let cycles = vec2<f32>(angle.q1 * m.d1_nm, sqrt(abs(angle.q2sq)) * m.d2_nm) * inv;
    let fractions = vec2<f32>(split_cycles(paths.xy, inv_wavelength),
                              split_cycles(paths.zw, inv_wavelength));
    // The fractions' rounding: of a number below 2 + 2^-10 of the phases; an evanescent n2
    // layer's decay is float32's whole.
    let n2_rounding = select(cycles.y * (1.0 / 1024.0), cycles.y, angle.q2sq < 0.0);
    let rounding = 2.0 + cycles.x * (1.0 / 1024.0) + n2_rounding;
    return geometry_of_cycles(m, angle, inv, cycles, fractions, rounding);
}

// cycles: q1 d1 / lambda and |q2| d2 / lambda; fractions: the same up to whole turns (of n2
// only where it propagates), possibly more accurate; rounding_cycles: the phase, in turns,
// whose float32 rounding the fractions carry (CellGeometry.cell_cycles).
fn geometry_of_cycles(m: BraggMirror, angle: CellGeometry, inv_wavelength: f32,
                      cycles: vec2<f32>, fractions: vec2<f32>,
                      rounding_cycles: f32) -> CellGeometry {
    var g = angle;
    g.delta1_cycles = fractions.x;
    let sc_a = half_phase_sin_cos(fractions.x);
    g.sa = sc_a.x;
    g.ca = sc_a.y;
    g.half2 = layer_half_phase_of(sqrt(abs(g.q2sq)), g.q2sq < 0.0, m.d2_nm * inv_wavelength,
                                  cycles.y, fractions.y);
    g.cell_cycles = rounding_cycles;
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

// A phase error above this (radians) leaves sin^2(N K Lambda) no better than a guess. The
// estimate grows with N (1 + 2 pi cell cycles): thin cells reach it beyond N = 1000, cells of
// thousands of cycles (micrometres at lambda = 1 nm) at N = 20-50.
const PHASE_TOLERANCE: f32 = 0.25;

// Where float32 cannot resolve the phase psi = N K Lambda of the pass-band oscillation, the
// kernel returns R averaged over psi: what any measurement wider than one oscillation sees, and
// the numpy twin's method="phase-averaged". The phase error is estimated from the rounding of
// x = cos(K Lambda), dx ~ 6e-8 (|P| + |Q|)(1 + cell phase), through d(phi) = dx / sin(phi),
// plus the rounding of N phi itself; at least one full oscillation must lie below it.
fn phase_unresolved(t: CellTerms, cell_cycles: f32, turns: f32, root: f32, n: f32) -> bool {
    let dx = 6e-8 * (abs(t.P) + abs(t.Q)) * (1.0 + TWO_PI * cell_cycles);
    let phase_error = n * dx / root + TWO_PI * turns * 1.2e-7;
    return turns > 1.0 && phase_error > PHASE_TOLERANCE;
}

// Eq 9 (host == n1) inside a band gap (sin2 <= 0) or at a band edge: 1/U = sinh(mu) /
// sinh(N mu) with sinh(mu) = sqrt(-sin2), scaled by e^{-N mu}; U = N at the edge. Apart from
// matched_reflectance for callers that know the node is not in a pass band (lavapipe runs
// both sides of every branch, so leaving the pass band's out saves its cost).
fn gap_reflectance(t: CellTerms, periods: u32) -> f32 {
    let w = min(abs(t.W), MAX_AMPLITUDE);
    let w2 = w * w;
    let n = f32(periods);
    let root = sqrt(max(-t.sin2, 0.0));
    let y = 2.0 * n * asinh_accurate(root);
    let e = exp(-0.5 * y);
    let one_minus = select(1.0 - e * e, y * (1.0 - y * (0.5 - y * (1.0 / 6.0 - y * (1.0 / 24.0)))),
                           y < 0.03);
    let numerator = w2 * one_minus * one_minus;
    let denominator = numerator + 4.0 * root * root * e * e;
    // The edge itself (root = 0): U = N.
    let edge = w2 * n * n;
    return clamp(select(numerator / max(denominator, 1e-37), edge / (1.0 + edge), root < 1e-30),
                 0.0, 1.0);
}

// Eq 9 (host == n1) in a pass band (sin2 > 0; NaN elsewhere), averaged over psi = N K Lambda:
// the mean of W^2 sin^2 psi / (sin^2 phi + W^2 sin^2 psi) is 1 - sin phi / sqrt(W^2 + sin^2 phi).
fn phase_averaged_matched(t: CellTerms) -> f32 {
    let w = min(abs(t.W), MAX_AMPLITUDE);
    return clamp(1.0 - sqrt(t.sin2 / (w * w + t.sin2)), 0.0, 1.0);
}

// Eqs 2 and 9 (host == n1): R = |C|^2 U^2 / (1 + |C|^2 U^2), U = U_{N-1}(x), formed as one
// quotient that never overflows. Pass band: U = sin(N phi) / sin(phi), sin^2(phi) = sin2;
// gaps and band edges: gap_reflectance.
fn matched_reflectance(t: CellTerms, cell_cycles: f32, periods: u32) -> f32 {
    let root = sqrt(abs(t.sin2));
    if (t.sin2 > 0.0 && root >= 1e-30) {
        let w_capped = min(abs(t.W), MAX_AMPLITUDE);
        let w2 = w_capped * w_capped;
        let n = f32(periods);
        let turns = n * atan2_cycles_positive(root, abs(t.x));
        if (phase_unresolved(t, cell_cycles, turns, root, n)) {
            return phase_averaged_matched(t);
        }
        let s = sin_cycles(turns);
        let numerator = w2 * s * s;
        return clamp(numerator / max(t.sin2 + numerator, 1e-37), 0.0, 1.0);
    }
    return gap_reflectance(t, periods);
}

// Largest |x| - 1 (x = cos K Lambda) the recurrence sees: U_14(256) is below float32's
// range. Only impedance ratios beyond 500 reach it, where R rounds to 1 anyway.
const RECURRENCE_MAX_EXCESS: f32 = 255.0;

// Eq 9 with U_{N-1}(x) from its three-term recurrence: one formula for pass bands, band edges
// and gaps, with no branch and no transcendental, for the few periods (below
// AVERAGING_MIN_PERIODS) where the loop is short; `periods` is a pipeline constant, so the
// loop unrolls. R needs U^2 only, and U_k(-x) = (-1)^k U_k(x), so the recurrence runs at |x|
// in Reinsch's form, driven by d = |x| - 1 = -sin^2 K Lambda / (1 + |x|): sin^2 keeps its
// relative accuracy at band edges (mode_terms_at), where x itself is rounded by up to
// rho ulp, far from 1 ulp at grazing incidence.
fn recurrence_reflectance(t: CellTerms, periods: u32) -> f32 {
    let d = min(-t.sin2 / (1.0 + abs(t.x)), RECURRENCE_MAX_EXCESS);
    var u = 1.0;        // U_k
    var change = 1.0;   // U_k - U_{k-1}
    for (var k = 1u; k < periods; k++) {
        change += 2.0 * d * u;
        u += change;
    }
    let a = min(min(abs(t.W), MAX_AMPLITUDE) * abs(u), 1e18);
    let a2 = a * a;
    return a2 / (1.0 + a2);
}

// phase_averaged_matched in pass bands, gap_reflectance in gaps, branch-free and cheaper: the
// grid quadrature (colour/grid_bragg.wgsl) evaluates both at every node, and lavapipe runs both
// sides of a branch. The gap's R = W^2 u^2 / (W^2 u^2 + e^{-y}) with u = (1 - e^{-y}) / (2 a),
// a = sinh(mu) = sqrt(-sin2), y = 2 N mu: u -> N at the band edge (a = 0) with no 0 / 0.
fn averaged_matched_reflectance(t: CellTerms, periods: u32) -> f32 {
    let w = min(abs(t.W), MAX_AMPLITUDE);
    let w2 = w * w;
    let a2 = abs(t.sin2);
    let a = sqrt(a2);
    let n = f32(periods);
    // asinh(a) / a; its log form loses a's digits to 1 + a below 0.01.
    let mu_over_a = select(log(a + sqrt(1.0 + a2)) / a, 1.0 - a2 * (1.0 / 6.0), a < 0.01);
    let y = 2.0 * n * mu_over_a * a;
    let e = exp(-y);
    // (1 - e^{-y}) / y = 1 - y / 2 + y^2 / 6 - y^3 / 24 below 0.03 (truncation < 1e-8).
    let series = 1.0 - y * (0.5 - y * (1.0 / 6.0 - y * (1.0 / 24.0)));
    let u = select((1.0 - e) / (2.0 * a), n * mu_over_a * series, y < 0.03);
    let wu2 = w2 * u * u;
    let gap = wu2 / max(wu2 + e, 1e-37);
    // phase_averaged_matched is NaN in gaps, where select drops it.
    return select(clamp(gap, 0.0, 1.0), phase_averaged_matched(t), t.sin2 > 0.0);
}

// Appendix D host, averaged over psi: with z = e^{2 i psi} the host reflection is a Moebius map
// f(z) = (a z + b) / (c z + d) and the mean of |f|^2 on |z| = 1 is, by Parseval,
// |b|^2/|d|^2 + |ad - bc|^2 / (|d|^2 (|d|^2 - |c|^2)) (z -> 1/z when |c| > |d|), with
// ad - bc = 2 i sin(phi) C (1 - r_h1^2). See _phase_averaged_host_reflectance in yeh.py.
fn phase_averaged_host(t: CellTerms, e1: vec2<f32>, root: f32, r_h1: f32) -> f32 {
    let scale = max(max(abs(t.P), abs(t.Q)), max(abs(t.W), 1.0));
    let a_matrix = c_mul(c_conj(e1), vec2<f32>(t.P, t.Q) / scale);
    let c_matrix = c_mul(e1, vec2<f32>(0.0, t.W / scale));
    let x = t.x / scale;
    let band = root / scale;
    let alpha = vec2<f32>(a_matrix.x - x, a_matrix.y + band);
    let beta = vec2<f32>(x - a_matrix.x, band - a_matrix.y);
    let a = c_matrix + r_h1 * alpha;
    let b = r_h1 * beta - c_matrix;
    let c = alpha + r_h1 * c_matrix;
    let d = beta - r_h1 * c_matrix;
    let determinant = 2.0 * band * (t.W / scale) * (1.0 - r_h1 * r_h1);
    let c2 = c_abs2(c);
    let d2 = c_abs2(d);
    var mean: f32;
    if (d2 > c2) {
        mean = c_abs2(b) / d2 + determinant * determinant / (d2 * (d2 - c2));
    } else {
        mean = c_abs2(a) / c2 + determinant * determinant / (c2 * (c2 - d2));
    }
    return clamp(mean, 0.0, 1.0);
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
        return matched_reflectance(t, g.cell_cycles, m.periods);
    }
    let e1 = c_exp_i(TWO_PI * centered_fraction(g.delta1_cycles));
    let r_h1 = fresnel_host_n1(m, g, polarization);
    if (t.sin2 > 0.0) {
        let root = sqrt(t.sin2);
        let n = f32(m.periods);
        let turns = n * atan2_cycles_positive(root, abs(t.x));
        if (phase_unresolved(t, g.cell_cycles, turns, root, n)) {
            return phase_averaged_host(t, e1, root, r_h1);
        }
    }
    // Appendix D: r_N = C U1 / (A U1 - U0), times e^{i delta1} above and below, then the
    // host | n1 interface r = (r_N + r_h1) / (1 + r_h1 r_N).
    let c = chebyshev_terms(t.x, t.sin2, m.periods);
    let scale = max(max(abs(t.P), abs(t.Q)), max(abs(t.W), 1.0)) * max(abs(c.u1), 1.0);
    let numerator = c_mul(vec2<f32>(0.0, t.W * c.u1 / scale), c_mul(e1, e1));
    let denominator = vec2<f32>(t.P, t.Q) * (c.u1 / scale) - e1 * (c.u0 / scale);
    let r_n = c_div(numerator, denominator);
    let top = r_n + vec2<f32>(r_h1, 0.0);
    let bottom = vec2<f32>(1.0, 0.0) + r_h1 * r_n;
    return clamp(c_abs2(top) / max(c_abs2(bottom), 1e-37), 0.0, 1.0);
}

// polarization: 0 = s, 1 = p, 2 = unpolarized (mean of s and p, sharing the geometry).
fn bragg_reflectance(m: BraggMirror, wavelength_nm: f32, theta: f32, polarization: u32,
                     host_matched: bool) -> f32 {
    return bragg_reflectance_at(m, cell_geometry(m, wavelength_nm, theta), polarization,
                                host_matched);
}

// bragg_reflectance at a geometry built by the caller: a sweep over wavelengths at one angle
// calls angle_geometry once, then geometry_at per wavelength.
fn bragg_reflectance_at(m: BraggMirror, g: CellGeometry, polarization: u32,
                        host_matched: bool) -> f32 {
    if (polarization == 2u) {
        return 0.5 * (yeh_polarized(m, g, 0u, host_matched)
            + yeh_polarized(m, g, 1u, host_matched));
    }
    return yeh_polarized(m, g, polarization, host_matched);
}
