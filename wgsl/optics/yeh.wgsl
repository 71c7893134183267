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
    cycles1: f32,       // q1 d1 / lambda unreduced (point_geometry only: box_spans_oscillation)
    d2_over_wavelength: f32,  // d2 / lambda (likewise)
    inv_wavelength: f32,      // 1 / lambda (likewise)
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
    // Without cancellation at critical angles and at grazing incidence (normal_square).
    let host_cos = m.host * sc.y;
    g.q1 = select(sqrt(max(normal_square(m.n1, m.host, g.s, host_cos), 0.0)), m.n1 * sc.y,
                  m.host == m.n1);
    g.q2sq = normal_square(m.n2, m.host, g.s, host_cos);
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

// A whole CellGeometry for one (wavelength, angle) point from what the host formed in float64
// from the float64 inputs (wgbragg/optics/yeh_gpu.py, point_inputs): fields = (s, cos theta,
// q1 d1 / lambda and q2 d2 / lambda in turns reduced to [-1/2, 1/2]; the last 0 where n2 is
// evanescent) and 1 / lambda. Reduced in float64, the phases carry only float32's rounding
// of a fraction of a turn whatever the layers' thickness (the colour kernels split them
// instead: geometry_at_split); q1 and q2^2 follow from s and cos theta without cancellation
// (normal_square), and the unreduced phases, which only need their relative accuracy (the
// sinc form, an evanescent layer's decay, box_spans_oscillation), from 1 / lambda. Five words
// a point: lavapipe loads storage one word and one lane at a time, and eight (q1, q2^2 and
// the unreduced phases too) halved the kernel's rate.
fn point_geometry(m: BraggMirror, fields: vec4<f32>, inv_wavelength: f32) -> CellGeometry {
    var g: CellGeometry;
    g.s = fields.x;
    g.cos_theta = fields.y;
    let host_cos = m.host * fields.y;
    g.q1 = sqrt(max(normal_square(m.n1, m.host, g.s, host_cos), 0.0));
    g.q2sq = normal_square(m.n2, m.host, g.s, host_cos);
    g.delta1_cycles = fields.z;
    let sc_a = half_phase_sin_cos(fields.z);
    g.sa = sc_a.x;
    g.ca = sc_a.y;
    let q2 = sqrt(abs(g.q2sq));
    let d2_over_wavelength = m.d2_nm * inv_wavelength;
    g.half2 = layer_half_phase_of(q2, g.q2sq < 0.0, d2_over_wavelength, q2 * d2_over_wavelength,
                                  fields.w);
    // The rounding the phases carry: of two fractions of a turn.
    g.cell_cycles = 1.0;
    g.cycles1 = g.q1 * m.d1_nm * inv_wavelength;
    g.d2_over_wavelength = d2_over_wavelength;
    g.inv_wavelength = inv_wavelength;
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

// n1^2 n2^2 - s^2 (n1^2 + n2^2), the factor of eta2^2 - eta1^2 (p) that vanishes at
// Brewster's angle, without cancellation anywhere else (wgbragg/optics/yeh.py,
// _brewster_factor): n1^2 q2^2 - n2^2 s^2, two terms <= 0, where n2 is evanescent;
// (n1 q2 - n2 s)(n1 q2 + n2 s) for a propagating n2 < n1; (n2 q1 - n1 s)(n2 q1 + n1 s) for
// n2 >= n1. Its direct form lost every digit near grazing incidence with n2 / n1 = 1e4 (R 0
// for 0.89), and the q1 form with a host equal to n2 << n1 (0.02 for 5e-9).
fn brewster_factor(m: BraggMirror, g: CellGeometry) -> f32 {
    if (g.q2sq < 0.0) {
        return m.n1 * m.n1 * g.q2sq - m.n2 * m.n2 * g.s * g.s;
    }
    if (m.n2 < m.n1) {
        let q2 = sqrt(g.q2sq);
        return (m.n1 * q2 - m.n2 * g.s) * (m.n1 * q2 + m.n2 * g.s);
    }
    return (m.n2 * g.q1 - m.n1 * g.s) * (m.n2 * g.q1 + m.n1 * g.s);
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
        difference = (n1s - n2s) * brewster_factor(m, g) / (n1s * n1s * n2s * n2s);
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
    return gap_terms(t, periods).x;
}

// gap_reflectance and the transmittance T = 1 - R, formed directly: 4 sinh^2(mu) e^{-y}
// over the same denominator, 1 / (1 + W^2 N^2) at the edge.
fn gap_terms(t: CellTerms, periods: u32) -> vec2<f32> {
    let w = min(abs(t.W), MAX_AMPLITUDE);
    let w2 = w * w;
    let n = f32(periods);
    let root = sqrt(max(-t.sin2, 0.0));
    let y = 2.0 * n * asinh_accurate(root);
    let e = exp(-0.5 * y);
    let one_minus = select(1.0 - e * e, y * (1.0 - y * (0.5 - y * (1.0 / 6.0 - y * (1.0 / 24.0)))),
                           y < 0.03);
    let numerator = w2 * one_minus * one_minus;
    let transmitted = 4.0 * root * root * e * e;
    let denominator = max(numerator + transmitted, 1e-37);
    // The edge itself (root = 0): U = N.
    let edge = w2 * n * n;
    let at_edge = vec2<f32>(edge, 1.0) / (1.0 + edge);
    return clamp(select(vec2<f32>(numerator, transmitted) / denominator, at_edge, root < 1e-30),
                 vec2<f32>(0.0), vec2<f32>(1.0));
}

// Eq 9 (host == n1) in a pass band (sin2 > 0; NaN elsewhere), averaged over psi = N K Lambda:
// the mean of W^2 sin^2 psi / (sin^2 phi + W^2 sin^2 psi) is 1 - sin phi / sqrt(W^2 + sin^2 phi).
fn phase_averaged_matched(t: CellTerms) -> f32 {
    let w = min(abs(t.W), MAX_AMPLITUDE);
    return clamp(1.0 - sqrt(t.sin2 / (w * w + t.sin2)), 0.0, 1.0);
}

// phase_averaged_matched and its transmittance sin phi / sqrt(W^2 + sin^2 phi).
fn phase_averaged_matched_terms(t: CellTerms) -> vec2<f32> {
    let w = min(abs(t.W), MAX_AMPLITUDE);
    let transmitted = clamp(sqrt(t.sin2 / (w * w + t.sin2)), 0.0, 1.0);
    return vec2<f32>(1.0 - transmitted, transmitted);
}

// Eqs 2 and 9 (host == n1): R = |C|^2 U^2 / (1 + |C|^2 U^2), U = U_{N-1}(x), formed as one
// quotient that never overflows. Pass band: U = sin(N phi) / sin(phi), sin^2(phi) = sin2;
// gaps and band edges: gap_reflectance.
fn matched_reflectance(t: CellTerms, cell_cycles: f32, periods: u32) -> f32 {
    return matched_terms(t, cell_cycles, periods).x;
}

// matched_reflectance and the transmittance T = 1 / (1 + |C|^2 U^2), formed directly.
fn matched_terms(t: CellTerms, cell_cycles: f32, periods: u32) -> vec2<f32> {
    var g: CellGeometry;
    g.cell_cycles = cell_cycles;
    var m: BraggMirror;
    m.periods = periods;
    return matched_terms_by(m, g, t, 0u, false);
}

// Whether N turns of the cell's phase are unresolved where R is evaluated: by the inputs'
// +-2-ulp box (box_rule: box_spans_oscillation; the point kernels) or by the rounding of the
// phases (phase_unresolved).
fn oscillation_unresolved(m: BraggMirror, g: CellGeometry, t: CellTerms, polarization: u32,
                          root: f32, n: f32, turns: f32, box_rule: bool) -> bool {
    if (box_rule) {
        return box_spans_oscillation(m, g, t, polarization, root, n, turns);
    }
    return phase_unresolved(t, g.cell_cycles, turns, root, n);
}

// matched_terms, deciding where to average by the rounding of the phases (box_rule false:
// g.cell_cycles is all it reads of g and m.periods of m) or by the inputs' +-2-ulp box
// (true: box_spans_oscillation; the point kernels).
fn matched_terms_by(m: BraggMirror, g: CellGeometry, t: CellTerms, polarization: u32,
                    box_rule: bool) -> vec2<f32> {
    let root = sqrt(abs(t.sin2));
    if (t.sin2 > 0.0 && root >= 1e-30) {
        let w_capped = min(abs(t.W), MAX_AMPLITUDE);
        let w2 = w_capped * w_capped;
        let n = f32(m.periods);
        let turns = n * atan2_cycles_positive(root, abs(t.x));
        if (oscillation_unresolved(m, g, t, polarization, root, n, turns, box_rule)) {
            return phase_averaged_matched_terms(t);
        }
        let s = sin_cycles(turns);
        let numerator = w2 * s * s;
        let total = max(t.sin2 + numerator, 1e-37);
        return clamp(vec2<f32>(numerator, t.sin2) / total, vec2<f32>(0.0), vec2<f32>(1.0));
    }
    return gap_terms(t, m.periods);
}

// |d cos(K Lambda) / d ln(lambda)| in a pass band: the indices are constant and every phase
// goes as 1 / lambda, so it is delta1 dx/d(delta1) + delta2 dx/d(delta2) with the unreduced
// phases (kappa for an evanescent n2). Needs g.cycles1 and g.d2_over_wavelength
// (point_geometry).
fn wavelength_slope(m: BraggMirror, g: CellGeometry, t: CellTerms, polarization: u32) -> f32 {
    var eta1 = g.q1;
    var eta2_squared = g.q2sq;
    var factor = 1.0;  // q2 / eta2
    if (polarization == 1u) {
        let n1s = m.n1 * m.n1;
        factor = m.n2 * m.n2;
        eta1 = g.q1 / n1s;
        eta2_squared = g.q2sq / (factor * factor);
    }
    let sin_d1 = 2.0 * g.sa * g.ca;
    let cos_d1 = (g.ca - g.sa) * (g.ca + g.sa);
    let evanescent = g.q2sq < 0.0;
    let delta2 = TWO_PI * sqrt(abs(g.q2sq)) * g.d2_over_wavelength;
    // delta2 dP/d(delta2): -delta2 sin(delta2), or kappa sinh(kappa) when evanescent.
    let d_p = select(-1.0, 1.0, evanescent) * 2.0 * g.half2.c * g.half2.s * delta2;
    // delta2 dQ/d(delta2) = -(eta2^2 + eta1^2) / (2 eta1) delta2 dS/d(delta2), with
    // delta2 dS/d(delta2) = P delta2 / eta2 = 2 pi P factor d2 / lambda: finite at q2 = 0.
    let d_q = -0.5 * (eta2_squared + eta1 * eta1) / eta1 * t.P * TWO_PI * factor
        * g.d2_over_wavelength;
    let delta1 = TWO_PI * g.cycles1;
    return abs(delta1 * (cos_d1 * t.Q - sin_d1 * t.P) + cos_d1 * d_p + sin_d1 * d_q);
}

// Whether R is unresolved at float32 input spacing, so that the phase average is as good a
// value as any: the wavelength moved by 2 float32 ulps either way moves x by dx, and so the
// Bloch phase by dx / sin(phi), or sqrt(dx) next to a band edge, where x = cos(phi) is
// quadratic in phi; where psi = N phi spans pi or more over the box, the box spans a whole
// oscillation of R (sin^2 psi), and the average lies inside its range. The ulp is that of
// lambda (1 / g.inv_wavelength) taken a little low, so that a wavelength just above a power
// of 2 is not given the binade above's; the estimate is a lower one (the angle and the
// material's parameters move psi too), after at least one full oscillation. Elsewhere the
// exact value: its float32 phase error stays inside the box (the rounding of psi, 2^-24 of
// it, is below the box's 2^-23 or more where the phase grows at least as fast as 1 / lambda).
// Estimated with 2^-23 for every wavelength instead, it was up to 2 times low: half of the
// points next to a band edge at N = 10^6 whose box spans 3-10 radians stayed exact.
fn box_spans_oscillation(m: BraggMirror, g: CellGeometry, t: CellTerms, polarization: u32,
                         root: f32, n: f32, turns: f32) -> bool {
    let wavelength = 1.0 / g.inv_wavelength;
    let ulp = exp2(floor(log2(wavelength * (1.0 - 4.8e-7))) - 23.0);
    let dx = wavelength_slope(m, g, t, polarization) * (2.0 * ulp / wavelength);
    let dphi = dx / (root + sqrt(dx));
    return turns > 1.0 && 2.0 * n * dphi >= PI;
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

// Appendix D host, averaged over psi (the numpy twin: _phase_averaged_host_reflectance in
// yeh.py, by Parseval's theorem on a Moebius map). With host_psi_terms' form,
// T(psi) = (1 - r_h1^2) sin^2(phi) / |sin(phi) cos(psi) + i G sin(psi)|^2 with
// G = Im(A) + r_h1 W e^{i delta1}: the denominator is a quadratic form in (cos psi, sin psi)
// of determinant sin^2(phi) Re(G)^2, and the mean of its inverse over the circle is one over
// the root of that, so the mean transmittance is (1 - r_h1^2) sin(phi) / |Re(G)| and
// R = 1 - T. No difference of nearly equal terms (|d|^2 - |c|^2 of the Moebius form left R
// 0.990 for 0.99999 in float32); |Re(G)| >= |Im(A)| (1 - |r_h1|).
fn phase_averaged_host(t: CellTerms, e1: vec2<f32>, root: f32, r_h1: f32) -> f32 {
    return phase_averaged_host_terms(t, e1, root, vec2<f32>(r_h1, (1.0 - r_h1) * (1.0 + r_h1))).x;
}

// (R, T) of phase_averaged_host; host_interface = (r_h1, 1 - r_h1^2) (interface_terms).
fn phase_averaged_host_terms(t: CellTerms, e1: vec2<f32>, root: f32,
                             host_interface: vec2<f32>) -> vec2<f32> {
    let h = host_g(t, e1, root, host_interface);
    let transmitted = clamp(host_interface.y * h.z / max(abs(h.x), 1e-37), 0.0, 1.0);
    return vec2<f32>(1.0 - transmitted, transmitted);
}

// G = Im(A) + r_h1 W e^{i delta1} and sin(phi), all divided by max(|Im(A)|, |W|, sin(phi)):
// (Re G, Im G, sin(phi)). Im(A) is taken as +-sqrt(W^2 + sin^2 phi) (host_psi_terms), and
// |Re(G)| = |Im(A) + r_h1 W cos(delta1)|, where the two terms have opposite signs, as
// (Im(A)^2 - W^2 cos^2) / (|Im(A)| + |W cos|) + (1 - |r_h1|) |W cos|, with
// Im(A)^2 - W^2 cos^2 = W^2 sin^2(delta1) + sin^2(phi) and 1 - |r_h1| = (1 - r_h1^2) /
// (1 + |r_h1|): no difference of nearly equal terms at a critical angle of n1, where
// r_h1 -> 1 (the direct sum left R 0 for 1). Re(G) has the sign of Im(A), |Im(A)| >= |W|.
fn host_g(t: CellTerms, e1: vec2<f32>, root: f32, host_interface: vec2<f32>) -> vec3<f32> {
    let raw_im_a = e1.x * t.Q - e1.y * t.P;
    let scale = max(max(abs(raw_im_a), abs(t.W)), root);
    let w = t.W / scale;
    let band = root / scale;
    let im_a = select(1.0, -1.0, raw_im_a < 0.0) * sqrt(w * w + band * band);
    let r_h1 = host_interface.x;
    let w_cos = w * e1.x;
    let w_sin = w * e1.y;
    let opposite = im_a * r_h1 * w_cos < 0.0;
    let apart = (w_sin * w_sin + band * band) / (abs(im_a) + abs(w_cos))
        + host_interface.y / (1.0 + abs(r_h1)) * abs(w_cos);
    let real_g = select(abs(im_a) + abs(r_h1 * w_cos), apart, opposite);
    return vec3<f32>(select(real_g, -real_g, im_a < 0.0), r_h1 * w_sin, band);
}

// Fresnel reflection host -> n1 (both real, s < n1).
fn fresnel_host_n1(m: BraggMirror, g: CellGeometry, polarization: u32) -> f32 {
    return interface_terms(m, g, polarization).x;
}

// (r, 1 - r^2) of the host | n1 interface, 1 - r^2 = 4 eta_h eta_1 / (eta_h + eta_1)^2 formed
// directly; (0, 1) where both admittances vanish (a host matching n1 at grazing incidence:
// no interface).
fn interface_terms(m: BraggMirror, g: CellGeometry, polarization: u32) -> vec2<f32> {
    var a = m.host * g.cos_theta;
    var b = g.q1;
    if (polarization == 1u) {
        a = m.n1 * m.n1 * a;
        b = m.host * m.host * b;
    }
    let sum = a + b;
    if (sum <= 0.0) {
        return vec2<f32>(0.0, 1.0);
    }
    return vec2<f32>((a - b) / sum, 4.0 * (a / sum) * (b / sum));
}

fn yeh_polarized(m: BraggMirror, g: CellGeometry, polarization: u32, host_matched: bool) -> f32 {
    return yeh_terms(m, g, polarization, host_matched).x;
}

// (R, T) of one polarisation, T the transmittance into the n1 substrate (tmm's T; the layers
// are lossless, so T = 1 - R, formed directly so that it keeps its relative accuracy in gaps).
fn yeh_terms(m: BraggMirror, g: CellGeometry, polarization: u32,
             host_matched: bool) -> vec2<f32> {
    return yeh_terms_by(m, g, polarization, host_matched, false);
}

// yeh_terms, deciding where to average as matched_terms_by.
fn yeh_terms_by(m: BraggMirror, g: CellGeometry, polarization: u32, host_matched: bool,
                box_rule: bool) -> vec2<f32> {
    if (!host_matched && g.q1 <= 0.0) {
        return vec2<f32>(1.0, 0.0);  // evanescent in n1 and in the n1 substrate
    }
    if (m.bulk != 0u) {
        let rt = interface_terms(m, g, polarization);
        return clamp(vec2<f32>(rt.x * rt.x, rt.y), vec2<f32>(0.0), vec2<f32>(1.0));
    }
    if (g.q1 <= 0.0) {
        return vec2<f32>(1.0, 0.0);  // grazing in n1: r12 = -1
    }
    let t = cell_terms(m, g, polarization);
    if (host_matched) {
        return matched_terms_by(m, g, t, polarization, box_rule);
    }
    // e^{i delta1} from the half phases cell_terms used, so that Im(A) below matches x.
    let e1 = vec2<f32>((g.ca - g.sa) * (g.ca + g.sa), 2.0 * g.sa * g.ca);
    let host_interface = interface_terms(m, g, polarization);
    let r_h1 = host_interface.x;
    if (host_interface.y <= 0.0) {
        return vec2<f32>(1.0, 0.0);  // grazing in the host: r_h1 = -1 whatever r_N (0 / 0 at 1)
    }
    if (t.sin2 > 0.0) {
        let root = sqrt(t.sin2);
        let n = f32(m.periods);
        let turns = n * atan2_cycles_positive(root, abs(t.x));
        if (oscillation_unresolved(m, g, t, polarization, root, n, turns, box_rule)) {
            return phase_averaged_host_terms(t, e1, root, host_interface);
        }
        // (sin, cos) of psi up to a common sign (half_phase_sin_cos reduces by half turns);
        // phi = pi - atan2(root, |x|) for x < 0 flips the sign of sin(psi) against cos(psi).
        let sc = half_phase_sin_cos(2.0 * turns);
        return host_psi_terms(t, e1, select(sc.x, -sc.x, t.x < 0.0) / root, sc.y, 1.0,
                              host_interface);
    }
    let n = f32(m.periods);
    if (t.sin2 == 0.0) {
        // A band edge: U_{N-1}(+-1) = (+-1)^{N-1} N, cos(psi) = (+-1)^N.
        return host_psi_terms(t, e1, select(n, -n, t.x < 0.0), 1.0, 1.0, host_interface);
    }
    // A gap, psi = N (m pi + i mu): U_{N-1} = +-sinh(N mu) / sinh(mu) and cos(psi) =
    // +-cosh(N mu), both divided by cosh(N mu) (squared: 1 - |r_N|^2 gains sech^2(N mu)).
    // Near the gap's edge at large N, U_{N-2} = x U_{N-1} - cos(psi) from its own exponentials
    // subtracted two numbers near 1 (R 0.79 for 0.81 at N = 10^6, mu = 8e-7).
    let a = sqrt(-t.sin2);
    let mu = asinh_accurate(a);
    let one_minus = one_minus_exp_neg(2.0 * n * mu);
    let e = exp(-n * mu);
    let tanh_n = one_minus / (2.0 - one_minus);
    let sech = 2.0 * e / (1.0 + e * e);
    return host_psi_terms(t, e1, select(tanh_n, -tanh_n, t.x < 0.0) / a, 1.0, sech * sech,
                          host_interface);
}

// Appendix D from psi = N K Lambda alone, in pass bands, at band edges and in gaps: with
// U_{N-2} = x U_{N-1} - cos(psi) and A - x = i Im(A), r_N = C U_{N-1} / (A U_{N-1} - U_{N-2})
// times e^{i delta1} is
//   r_N = i W e^{i delta1} u / (c + i Im(A) u),   u = U_{N-1}, c = cos(psi),
// and 1 - |r_N|^2 = 1 / |c + i Im(A) u|^2, with Im(A) = +-sqrt(W^2 + sin^2 K Lambda), the
// size the cell's unimodularity gives it (Im(A) itself carries an error of eps Im(A), and
// Im(A)^2 - W^2 can be far smaller). For any psi this is a lossless stack's reflection, so
// float32's rounding of psi (1e-7 of it: radians at large N) moves r_N along its own curve,
// as an input would. U_{N-1} and U_{N-2} from sin(N phi) and sin((N - 1) phi) each carry
// their own rounding instead, and r_N then left that curve: where R barely depends on psi (a
// host matching n2 over d1 = 0 reflects as the bare host | n1 interface) R was off by psi's
// error, and at a band edge U_{N-2} = N - 1 rounds to N beyond 2^24 (0 / 0). (u, c) up to a
// common sign, and both divided by `norm` where 1 - |r_N|^2 then gains `norm2` = norm^2
// (gaps: norm = cosh(N mu)).
fn host_psi_terms(t: CellTerms, e1: vec2<f32>, u: f32, c: f32, norm2: f32,
                  host_interface: vec2<f32>) -> vec2<f32> {
    let raw_im_a = e1.x * t.Q - e1.y * t.P;
    // |Im(A)| = sqrt(W^2 + sin^2 K Lambda), in gaps sqrt((|W| - sinh mu)(|W| + sinh mu)).
    let b = sqrt(abs(t.sin2));
    let amplitude = max(abs(t.W), b);
    let wn = abs(t.W) / amplitude;
    let bn = b / amplitude;
    let im_size = amplitude * sqrt(max(select((wn - bn) * (wn + bn), wn * wn + bn * bn,
                                              t.sin2 >= 0.0), 0.0));
    let im_a = select(1.0, -1.0, raw_im_a < 0.0) * select(im_size, 0.0, amplitude == 0.0);
    let scale = max(abs(c), abs(u) * max(abs(im_a), abs(t.W)));
    let v = u / scale;
    let denominator = vec2<f32>(c / scale, im_a * v);
    let r_n = c_div(c_mul(vec2<f32>(0.0, t.W * v), e1), denominator);
    let r_h1 = host_interface.x;
    let top = r_n + vec2<f32>(r_h1, 0.0);
    let bottom = vec2<f32>(1.0, 0.0) + r_h1 * r_n;
    let bottom2 = max(c_abs2(bottom), 1e-37);
    let inv = 1.0 / scale;
    let transmitted = host_interface.y * norm2 * inv * inv
        / (max(c_abs2(denominator), 1e-37) * bottom2);
    return balanced(c_abs2(top) / bottom2, transmitted);
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

// (R, T) at a point_geometry: the pointwise entry point, averaging only where the inputs'
// box spans an oscillation (box_spans_oscillation).
fn bragg_point_terms(m: BraggMirror, g: CellGeometry, polarization: u32,
                     host_matched: bool) -> vec2<f32> {
    if (polarization == 2u) {
        return 0.5 * (yeh_terms_by(m, g, 0u, host_matched, true)
            + yeh_terms_by(m, g, 1u, host_matched, true));
    }
    return yeh_terms_by(m, g, polarization, host_matched, true);
}
