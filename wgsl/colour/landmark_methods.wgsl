// Colour of a Bragg mirror from its spectral landmarks in float32: the twin of
// wgbragg/colour/landmark_methods.py ("approx", "subdivided", "averaged"). Requires numerics, complex,
// layer, yeh and optics/landmarks.wgsl. No bindings: the entry point provides the tables through
//   cmf_density(j)        XYZ density (per nm) at the 1 nm node 360 + j nm, j = 0..470,
//   cmf_cumulative(j)     colorimetry.cumulative_xyz at that node,
//   cmf_cell(j)           DensityCell of the cell [j, j + 1], j = 0..469: what a quadrature
//                         node reads, in one load where the table packs it
//                         (density_slope_from_bits),
//
// The landmarks are visited in increasing omega and each interval is integrated as soon as
// both its ends are known, so nothing is stored and the cost is O(1) in N. The pieces, nodes
// and weights are those of the numpy twin; with host == n1 and a propagating n2 the cell terms
// at a node come from the closed form in the mode coordinate (optics/landmarks.wgsl, mode_terms): two
// reduced sin/cos pairs.
//
// "approx" and "subdivided" sweep one polarisation per call (landmark_colour). "averaged"
// (averaged_colour) sweeps both at once: its zones lie between consecutive band edges of
// either polarisation, so both spectra are smooth in each and share its nodes, and with them
// the sin/cos pairs and table reads. Each zone is integrated with three-point Gauss-Legendre
// panels in the variable u of landmark_methods._zone_map, which clusters nodes quadratically at
// band edges (the square-root edge of the averaged spectrum is then smooth in u), against the
// piecewise-linear XYZ density (colorimetry.xyz_density).
//
// Cost on lavapipe, which runs the invocations of a SIMD group in lockstep: it executes both
// sides of every branch, masked, whatever the lanes take, but skips a loop that no lane
// enters. So a node's formulas are branch-free and chosen per zone by which loop runs
// (averaged_zone): exact, averaged, or averaged in the pass bands of both polarisations (no
// gap formula); below N = 16 the exact R comes from an unrolled recurrence (EXACT_PERIODS)
// instead of matched_reflectance's three branches. A panel's three Gauss points are one per
// iteration, not written out in one: the loop's bookkeeping costs next to nothing, a larger
// body does (docs/performance.md, "How the landmark kernel was made fast").

// wgbragg.colour.landmark_methods.PANEL_NM, PANEL_MARGIN, PHASE_SNAP and
// EXACT_MIN_OSCILLATION_NM; these constants and the override defaults below are checked against
// it by tests/test_wgsl_layouts.py.
const PANEL_NM: f32 = 40.0;
const PANEL_MARGIN: f32 = 0.05;
const PHASE_SNAP: f32 = 0.15;
const EXACT_MIN_OSCILLATION_NM: f32 = 0.1;
// The options of "averaged" (landmark_methods.averaged_xyz): N below AVERAGING_MIN_PERIODS is
// integrated exactly (the host passes 2 where averaging_from <= N < 16, so that those
// settings share a pipeline); panels_per_oscillation. The defaults are landmark_methods'.
override AVERAGING_MIN_PERIODS: u32 = 16u;
override PANELS_PER_OSCILLATION: f32 = 3.0;
// N compiled into the exact spectrum's recurrence (recurrence_reflectance): set by pipelines
// whose zones are all exact and in the mode coordinate (N below AVERAGING_MIN_PERIODS, host
// == n1 <= n2); 0 reads N at run time.
override EXACT_PERIODS: u32 = 0u;
// Three-point Gauss-Legendre on [0, 1] (landmark_methods._GAUSS_NODES, _GAUSS_WEIGHTS).
const GAUSS_OFFSET: f32 = 0.38729833;   // sqrt(0.6) / 2
const GAUSS_OUTER: f32 = 0.27777778;    // 5 / 18
const GAUSS_INNER: f32 = 0.44444444;    // 8 / 18

// landmark_methods_gpu.GPU_LANDMARK_METHODS.
const METHOD_APPROX: u32 = 0u;
const METHOD_SUBDIVIDED: u32 = 1u;
const METHOD_AVERAGED: u32 = 2u;

// What the landmark intervals of one angle need: of one polarisation ("approx", "subdivided"),
// or of both ("averaged": frame is the s frame, frame_p the p one; polarization is unused).
struct ColourSetup {
    mirror: BraggMirror,
    angle: CellGeometry,    // wavelength-independent fields only (see geometry_at)
    polarization: u32,
    subdivisions: i32,      // s of "subdivided"
    host_matched: bool,
    correction: f32,        // Appendix B: w~(theta1)
    subdivide: bool,        // "subdivided" with modes (propagating n2)
    frame: ModeFrame,       // propagating n2: the dispersion in the mode coordinate
    frame_p: ModeFrame,     // "averaged": the p frame (frame is then the s one)
    fast: bool,             // host == n1, propagating n2, an n2 layer: cell terms from frame
    evanescent: bool,       // "averaged" with n2 evanescent (EXACT_MIN_OSCILLATION_NM applies)
}

// ----------------------------------------------------------------------------- colorimetry

// colorimetry.cumulative_xyz: the integral of the density from 360 nm, exact within a cell.
fn cumulative_xyz(wavelength_nm: f32) -> vec3<f32> {
    let p = clamp(wavelength_nm - LAMBDA_LO_NM, 0.0, LAMBDA_HI_NM - LAMBDA_LO_NM);
    let j = min(u32(p), 469u);
    let t = p - f32(j);
    let d0 = cmf_density(j);
    let d1 = cmf_density(j + 1u);
    return cmf_cumulative(j) + t * (d0 + (0.5 * t) * (d1 - d0));
}

fn white_xyz() -> vec3<f32> {
    return cmf_cumulative(470u) - cmf_cumulative(0u);
}

// The XYZ density on one 1 nm cell: at its lower node, and its change across the cell.
struct DensityCell {
    density: vec3<f32>,
    slope: vec3<f32>,
}

// A cell's slope packed into one word (landmark_methods_gpu.packed_cmf_table): X and Y in
// 11-bit and Z in 10-bit two's complement, in steps of DENSITY_SLOPE_STEP per nm, which hold
// the CIE 1931 x D65 slopes (|X'|, |Y'| <= 2.1e-4, |Z'| <= 7.2e-4 per nm) to within half a
// step: the density is off by at most 1e-6 per nm (5e-5 of its peak). With the density at
// the lower node in float32, a node reads one vec4 instead of two (docs/performance.md,
// "How the landmark kernel was made fast").
const DENSITY_SLOPE_STEP: vec3<f32> = vec3<f32>(2.384185791015625e-7, 2.384185791015625e-7,
                                                1.9073486328125e-6);  // 2^-22, 2^-22, 2^-19

fn density_slope_from_bits(bits: u32) -> vec3<f32> {
    let word = bitcast<i32>(bits);
    let steps = vec3<i32>(extractBits(word, 0u, 11u), extractBits(word, 11u, 11u),
                          extractBits(word, 22u, 10u));
    return vec3<f32>(steps) * DENSITY_SLOPE_STEP;
}

// colorimetry.xyz_density: linear between the 1 nm nodes (the slope as cmf_cell has it).
fn density_xyz(wavelength_nm: f32) -> vec3<f32> {
    let p = clamp(wavelength_nm - LAMBDA_LO_NM, 0.0, LAMBDA_HI_NM - LAMBDA_LO_NM);
    let j = min(u32(p), 469u);
    let cell = cmf_cell(j);
    return cell.density + (p - f32(j)) * cell.slope;
}

// ----------------------------------------------------------------------------- reflectance

// The numpy twin's method="phase-averaged" unconditionally: in pass bands the mean of R over
// the phase psi = N K Lambda of its oscillation (host == n1: 1 - |sin K Lambda| /
// sqrt(|C|^2 + sin^2 K Lambda); Appendix D hosts: phase_averaged_host), elsewhere the exact
// finite-N value (yeh_polarized only averages where float32 cannot resolve psi).
fn averaged_pass_band_reflectance(m: BraggMirror, g: CellGeometry, polarization: u32,
                                  host_matched: bool) -> f32 {
    if ((!host_matched && g.s >= m.n1) || m.bulk != 0u || g.q1 <= 0.0) {
        return yeh_polarized(m, g, polarization, host_matched);
    }
    let t = cell_terms(m, g, polarization);
    if (t.sin2 <= 0.0) {
        if (host_matched) {
            return matched_reflectance(t, g.cell_cycles, m.periods);
        }
        return yeh_polarized(m, g, polarization, host_matched);
    }
    if (host_matched) {
        return phase_averaged_matched(t);
    }
    let e1 = c_exp_i(TWO_PI * centered_fraction(g.delta1_cycles));
    return phase_averaged_host(t, e1, sqrt(t.sin2), fresnel_host_n1(m, g, polarization));
}

// R of one polarisation at a node of "averaged", from its frame and the node's mode_phases:
// exact in an exact zone (landmark_methods._quadrature), else averaged in pass bands; gaps:
// whether the zone may hold a band gap of either polarisation (else the gap formula, which
// a zone between band edges of both pass bands never needs, is left out). exact and gaps
// are literals at every call, so each variant compiles only its own formulas.
fn mode_node_reflectance(f: ModeFrame, phases: vec4<f32>, t: f32, periods: u32,
                         exact: bool, gaps: bool) -> f32 {
    let terms = mode_terms_at(f, phases);
    if (exact) {
        if (EXACT_PERIODS > 0u) {
            return recurrence_reflectance(terms, EXACT_PERIODS);
        }
        return matched_reflectance(terms, 0.5 * t, periods);  // delta1 + delta2 = pi t
    }
    let averaged = phase_averaged_matched(terms);
    if (!gaps) {
        // A node a rounding error past a band edge: R -> 1 there.
        return select(1.0, averaged, terms.sin2 > 0.0);
    }
    return select(gap_reflectance(terms, periods), averaged, terms.sin2 > 0.0);
}

fn geometry_node_reflectance(c: ColourSetup, g: CellGeometry, polarization: u32,
                             exact: bool) -> f32 {
    if (exact) {
        return yeh_polarized(c.mirror, g, polarization, c.host_matched);
    }
    return averaged_pass_band_reflectance(c.mirror, g, polarization, c.host_matched);
}

// Unpolarised R at one quadrature node of "averaged" (exact, gaps: mode_node_reflectance;
// only the mode-coordinate path leaves the gap formula out, so !gaps implies c.fast).
fn node_reflectance(c: ColourSetup, omega: f32, exact: bool, gaps: bool) -> f32 {
    if (c.fast || !gaps) {
        let t = omega * c.frame.n_plus * (1.0 / PI);
        let phases = mode_phases(c.frame, t);
        return 0.5 * (mode_node_reflectance(c.frame, phases, t, c.mirror.periods, exact, gaps)
            + mode_node_reflectance(c.frame_p, phases, t, c.mirror.periods, exact, gaps));
    }
    let g = geometry_at(c.mirror, c.angle, TWO_PI / omega);
    return 0.5 * (geometry_node_reflectance(c, g, 0u, exact)
        + geometry_node_reflectance(c, g, 1u, exact));
}

// (cos K Lambda of s, of p, sin^2 K Lambda of s, of p) at omega.
fn dispersion_pair(c: ColourSetup, omega: f32) -> vec4<f32> {
    var s_terms: CellTerms;
    var p_terms: CellTerms;
    if (c.fast) {
        let phases = mode_phases(c.frame, omega * c.frame.n_plus * (1.0 / PI));
        s_terms = mode_terms_at(c.frame, phases);
        p_terms = mode_terms_at(c.frame_p, phases);
    } else {
        let g = geometry_at(c.mirror, c.angle, TWO_PI / omega);
        s_terms = cell_terms(c.mirror, g, 0u);
        p_terms = cell_terms(c.mirror, g, 1u);
    }
    return vec4<f32>(s_terms.x, p_terms.x, s_terms.sin2, p_terms.sin2);
}

// Bloch phases K Lambda in [0, pi] of s and p at omega (0 or pi inside band gaps), from
// sin^2 K Lambda, which keeps its relative accuracy at band edges where acos(x) would not. At
// a band edge (at_edge) snapped as landmark_methods._snap_edge_phases.
fn bloch_phases(c: ColourSetup, omega: f32, at_edge: bool) -> vec2<f32> {
    let d = dispersion_pair(c, omega);
    let phase = atan2(sqrt(max(d.zw, vec2<f32>(0.0))), d.xy);
    let near_pi = phase > vec2<f32>(PI - PHASE_SNAP);
    let snap = vec2<bool>(at_edge) & (near_pi | (phase < vec2<f32>(PHASE_SNAP)));
    return select(phase, select(vec2<f32>(0.0), vec2<f32>(PI), near_pi), snap);
}

// Eq 11: the envelope |C|^2 / (|C|^2 + sin^2 K Lambda), 1 inside band gaps.
fn envelope(c: ColourSetup, omega: f32) -> f32 {
    var t: CellTerms;
    if (c.fast) {
        t = mode_terms(c.frame, omega * c.frame.n_plus * (1.0 / PI));
    } else {
        t = cell_terms(c.mirror, geometry_at(c.mirror, c.angle, TWO_PI / omega), c.polarization);
    }
    if (t.sin2 <= 0.0) {
        return 1.0;
    }
    let w = min(abs(t.W), MAX_AMPLITUDE);
    return (w * w) / (w * w + t.sin2);
}

// Appendix B: w~(theta1) = w0 + (1 - w0)(1 - cos theta1)^5, w0 = 0.735 R12 + 0.532.
fn angular_correction(m: BraggMirror, angle: CellGeometry) -> f32 {
    let r = (m.n1 - m.n2) / (m.n1 + m.n2);
    let w0 = 0.735 * r * r + 0.532;
    let one_minus = 1.0 - clamp(angle.q1 / m.n1, 0.0, 1.0);
    let square = one_minus * one_minus;
    return w0 + (1.0 - w0) * square * square * one_minus;
}

// ----------------------------------------------------------------------------- intervals

// "approx" / "subdivided" over the box [omega_lo, omega_hi] (sec. 3.2.2, eq 15): 1 inside
// band gaps, else w~ times the envelope at the middle of each of max(1, s - mode) sub-boxes.
fn approx_interval(c: ColourSetup, omega_lo: f32, omega_hi: f32, pass_band: bool,
                   mode: i32) -> vec3<f32> {
    if (!pass_band) {
        return cumulative_xyz(TWO_PI / omega_lo) - cumulative_xyz(TWO_PI / omega_hi);
    }
    var pieces = 1;
    if (c.subdivide) {
        pieces = max(1, c.subdivisions - mode);
    }
    let width = (omega_hi - omega_lo) / f32(pieces);
    var acc = vec3<f32>(0.0);
    for (var i = 0; i < pieces; i++) {
        let lo = omega_lo + f32(i) * width;
        let hi = lo + width;
        let box = cumulative_xyz(TWO_PI / lo) - cumulative_xyz(TWO_PI / hi);
        acc += (c.correction * envelope(c, 0.5 * (lo + hi))) * box;
    }
    return acc;
}

// landmark_methods._zone_map: (s, ds/du) clustering the nodes at the ends that are band edges.
fn zone_map(u: f32, lower_edge: bool, upper_edge: bool) -> vec2<f32> {
    if (lower_edge && upper_edge) {
        return vec2<f32>(u * u * (3.0 - 2.0 * u), 6.0 * u * (1.0 - u));
    }
    if (lower_edge) {
        return vec2<f32>(u * u, 2.0 * u);
    }
    if (upper_edge) {
        return vec2<f32>(u * (2.0 - u), 2.0 - 2.0 * u);
    }
    return vec2<f32>(u, 1.0);
}

// Sums of averaged_zone's Gauss rule.
struct ZoneSums {
    rule: vec3<f32>,        // sum w R density
    rule_white: vec3<f32>,  // sum w density
    rule_r: f32,            // sum w R
}

// Node n of averaged_zone (panel n / 3, Gauss point n % 3).
fn zone_node(c: ColourSetup, sums: ptr<function, ZoneSums>, n: u32, lo: f32, span: f32,
             inv_panels: f32, lower_edge: bool, upper_edge: bool, exact: bool, gaps: bool) {
    let k = n % 3u;
    let offset = select(select(GAUSS_OFFSET, -GAUSS_OFFSET, k == 0u), 0.0, k == 1u);
    let map = zone_map((f32(n / 3u) + 0.5 + offset) * inv_panels, lower_edge, upper_edge);
    let omega = lo + span * map.x;
    let wavelength = TWO_PI / omega;
    // The rule's weight times d lambda = 2 pi / omega^2 d omega = lambda^2 / (2 pi) d omega.
    let weight = select(GAUSS_OUTER, GAUSS_INNER, k == 1u) * inv_panels * span * map.y
        * wavelength * wavelength * (1.0 / TWO_PI);
    let r = weight * node_reflectance(c, omega, exact, gaps);
    let density = density_xyz(wavelength);
    (*sums).rule += r * density;
    (*sums).rule_white += weight * density;
    (*sums).rule_r += r;
}

// "averaged" over the zone [lo, hi] (rad/nm) between band edges or range ends, which holds
// `share` of a pass band: the panels and exact flag of landmark_methods._quadrature, three
// Gauss nodes a panel. both_pass: both polarisations are in a pass band across the zone;
// box: the density's integral over the zone, cumulative_xyz(2 pi / lo) minus
// cumulative_xyz(2 pi / hi).
fn averaged_zone(c: ColourSetup, lo: f32, hi: f32, lower_edge: bool, upper_edge: bool,
                 share: f32, both_pass: bool, box: vec3<f32>) -> vec3<f32> {
    // Empty, or narrower than float32 resolves in wavelength: s and p edges a few ulps apart.
    let lambda_lo = TWO_PI / hi;
    let lambda_hi = TWO_PI / lo;
    if (!(lambda_hi > lambda_lo)) {
        return vec3<f32>(0.0);
    }
    let width_nm = TWO_PI / lo - TWO_PI / hi;
    var panels = u32(max(ceil(width_nm * (1.0 / PANEL_NM)), 1.0));
    let oscillations = f32(c.mirror.periods) * share;
    // EXACT_PERIODS: every zone is exact, and the averaged loop compiles out.
    let exact = EXACT_PERIODS > 0u
        || (c.mirror.periods < AVERAGING_MIN_PERIODS
            && (!c.evanescent || width_nm >= EXACT_MIN_OSCILLATION_NM * oscillations))
        || (share > 0.0 && width_nm > PANEL_NM * oscillations);
    if (exact) {
        panels = max(panels, u32(max(ceil(PANELS_PER_OSCILLATION * oscillations - PANEL_MARGIN),
                                         0.0)));
    }
    let span = hi - lo;
    let inv_panels = 1.0 / f32(panels);
    var sums: ZoneSums;
    // Three loops, of which each zone enters one: lavapipe runs both sides of a branch but
    // skips a loop that no invocation enters. Most of the averaged nodes lie in zones in the
    // pass bands of both polarisations, and skip the gap formula (docs/performance.md).
    let nodes = 3u * panels;
    // (The geometry path has no gap formula to skip.)
    let pass_loop = both_pass && c.fast;
    for (var n = 0u; n < select(0u, nodes, !exact && pass_loop); n++) {
        zone_node(c, &sums, n, lo, span, inv_panels, lower_edge, upper_edge, false, false);
    }
    for (var n = 0u; n < select(0u, nodes, !exact && !pass_loop); n++) {
        zone_node(c, &sums, n, lo, span, inv_panels, lower_edge, upper_edge, false, true);
    }
    for (var n = 0u; n < select(0u, nodes, exact); n++) {
        zone_node(c, &sums, n, lo, span, inv_panels, lower_edge, upper_edge, true, true);
    }
    // As the numpy twin: the zone's mean R times its exact box, plus the rule on the rest.
    let mean = sums.rule_r / (lambda_hi - lambda_lo);
    return sums.rule + mean * (box - sums.rule_white);
}

// ----------------------------------------------------------------------------- the sweeps

// "approx" / "subdivided": landmarks visited in increasing omega, each integrating the
// interval since the previous one.
struct Sweep {
    xyz: vec3<f32>,
    omega_prev: f32,
    pass_band: bool,    // the interval since the previous landmark
    mode: i32,          // its mode number (subdivided)
}

fn sweep_start() -> Sweep {
    return Sweep(vec3<f32>(0.0), OMEGA_LO, false, 0);
}

// The status of the range's start: what follows a landmark below the range.
fn sweep_status(sweep: ptr<function, Sweep>, pass_after: bool, mode: i32) {
    (*sweep).pass_band = pass_after;
    (*sweep).mode = mode;
}

// A landmark at omega, followed by an interval of status pass_after.
fn sweep_visit(c: ColourSetup, sweep: ptr<function, Sweep>, omega: f32, pass_after: bool,
               mode: i32) {
    if (omega >= OMEGA_HI) {
        return;  // beyond the range: the interval of the range's end is already known
    }
    if (omega <= OMEGA_LO) {
        sweep_status(sweep, pass_after, mode);
        return;
    }
    (*sweep).xyz += approx_interval(c, (*sweep).omega_prev, omega, (*sweep).pass_band,
                                    (*sweep).mode);
    (*sweep).omega_prev = omega;
    (*sweep).pass_band = pass_after;
    (*sweep).mode = mode;
}

// A landmark at mode coordinate t.
fn sweep_visit_t(c: ColourSetup, f: ModeFrame, sweep: ptr<function, Sweep>, t: f32,
                 pass_after: bool, mode: i32) {
    if (t <= f.t_lo) {
        sweep_status(sweep, pass_after, mode);
        return;
    }
    if (t >= f.t_hi) {
        return;
    }
    sweep_visit(c, sweep, PI * t / f.n_plus, pass_after, mode);
}

fn sweep_finish(c: ColourSetup, sweep: ptr<function, Sweep>) {
    (*sweep).xyz += approx_interval(c, (*sweep).omega_prev, OMEGA_HI, (*sweep).pass_band,
                                    (*sweep).mode);
}

// "averaged": the zone open since the last band edge (of either polarisation).
struct Zones {
    xyz: vec3<f32>,
    lo: f32,              // the open zone's start, rad/nm
    lo_edge: bool,        // whether that is a band edge (else the range's start)
    lo_phases: vec2<f32>, // bloch_phases there
    lo_cumulative: vec3<f32>, // cumulative_xyz there (read once per zone end)
}

fn zones_start(c: ColourSetup) -> Zones {
    return Zones(vec3<f32>(0.0), OMEGA_LO, false, bloch_phases(c, OMEGA_LO, false),
                 cumulative_xyz(TWO_PI / OMEGA_LO));
}

// Integrates the open zone up to omega (a band edge iff is_edge) and opens the next there.
// in_gap: polarisations known to be in a gap across the zone (see evanescent_gaps).
fn zone_close(c: ColourSetup, zones: ptr<function, Zones>, omega: f32, is_edge: bool,
              in_gap: vec2<bool>) {
    // The share of a pass band: see landmark_methods._zones.
    let phases = bloch_phases(c, omega, is_edge);
    let sweep = select(abs(phases - (*zones).lo_phases), vec2<f32>(0.0), in_gap);
    let share = max(sweep.x, sweep.y) * (1.0 / PI);
    let cumulative = cumulative_xyz(TWO_PI / omega);
    // A polarisation in a gap across the zone has the same phase, 0 or pi, at both ends, up
    // to rounding where an end is the range's (not snapped): calling a zone in a pass band
    // mixed costs only time, the other way round R = 1 at its gap's nodes.
    let both_pass = all(sweep > vec2<f32>(PHASE_SNAP));
    (*zones).xyz += averaged_zone(c, (*zones).lo, omega, (*zones).lo_edge, is_edge, share,
                                  both_pass, (*zones).lo_cumulative - cumulative);
    (*zones).lo = omega;
    (*zones).lo_edge = true;
    (*zones).lo_phases = phases;
    (*zones).lo_cumulative = cumulative;
}

// With n2 evanescent, the polarisations in a gap at the middle of the zone ending at omega:
// their phase changes are rounding (landmark_methods._zones).
fn evanescent_gaps(c: ColourSetup, zones: ptr<function, Zones>, omega: f32) -> vec2<bool> {
    return dispersion_pair(c, 0.5 * ((*zones).lo + omega)).zw <= vec2<f32>(0.0);
}

// A band edge at omega; those outside the range only bound zones outside it. check_gaps (a
// literal at each call, so that the propagating sweep compiles without the check, which it
// never takes but would pay for): see evanescent_gaps.
fn zone_edge(c: ColourSetup, zones: ptr<function, Zones>, omega: f32, check_gaps: bool) {
    if (omega > OMEGA_LO && omega < OMEGA_HI) {
        var in_gap = vec2<bool>(false);
        if (check_gaps) {
            in_gap = evanescent_gaps(c, zones, omega);
        }
        zone_close(c, zones, omega, true, in_gap);
    }
}

// The j-th (0 to 3, increasing) of the edges of two bands (rising, falling) with
// rising <= falling each: the lower rising edge comes first, the higher falling edge last.
// Selects, not a private array (see landmark_colour).
fn band_edges_in_order(a: vec2<f32>, b: vec2<f32>, j: i32) -> f32 {
    let rising_hi = max(a.x, b.x);
    let falling_lo = min(a.y, b.y);
    var t = min(a.x, b.x);
    switch j {
        case 1: { t = min(rising_hi, falling_lo); }
        case 2: { t = max(rising_hi, falling_lo); }
        case 3: { t = max(a.y, b.y); }
        default: {}
    }
    return t;
}

// The fields of every method's setup: the angle's fields of the cell geometry (the wavelength
// only sets the phases); false at grazing in n1, or beyond its critical angle (total reflection).
// With host == n1, q1 = n1 cos(theta) decides: s = n1 sin(theta) rounds to n1 within 2e-4 rad
// of grazing.
fn colour_setup(c: ptr<function, ColourSetup>, m: BraggMirror, theta: f32,
                host_matched: bool) -> bool {
    (*c).mirror = m;
    (*c).host_matched = host_matched;
    (*c).angle = angle_geometry(m, theta);
    return (*c).angle.q1 > 0.0 && (host_matched || (*c).angle.s < m.n1);
}

// XYZ of one polarisation at one angle by "approx" or "subdivided".
// matched_layers: the caller guarantees host == n1 <= n2 and an n2 layer, so every angle takes
// the mode-coordinate path and the other paths are compiled out.
fn landmark_colour(m: BraggMirror, theta: f32, polarization: u32, method: u32,
                   subdivisions: i32, host_matched: bool, matched_layers: bool) -> vec3<f32> {
    var c: ColourSetup;
    if (!colour_setup(&c, m, theta, host_matched)) {
        return white_xyz();
    }
    c.polarization = polarization;
    c.subdivisions = subdivisions;
    c.correction = angular_correction(m, c.angle);
    var sweep = sweep_start();
    if (!matched_layers && m.bulk != 0u) {
        // No n2 layer: no landmarks, one pass-band interval.
        sweep_status(&sweep, true, 0);
    } else if (matched_layers || c.angle.q2sq > 0.0) {
        let f = mode_frame(m, c.angle, polarization);
        c.frame = f;
        c.fast = matched_layers || host_matched;
        c.subdivide = method == METHOD_SUBDIVIDED;
        let first = i32(floor(f.t_lo));
        let last = i32(ceil(f.t_hi));
        for (var k = first; k < last; k++) {
            let iv = mode_interval(f, k);
            // In increasing t: mode, rising edge, [zero], Airy point, [zero], falling edge
            // (j = 0..5; a closed gap's edges coincide with its mode). Picked by selects, not
            // from a private array: lavapipe would keep a dynamically indexed array in memory,
            // and the loop keeps one copy of the sweep.
            let zero_low = select(-1.0, iv.zero, iv.zero > 0.0 && iv.zero < iv.airy);
            let zero_high = select(-1.0, iv.zero, iv.zero > 0.0 && iv.zero >= iv.airy);
            for (var j = 0; j < 6; j++) {
                var t = f32(k);
                switch j {
                    case 1: { t = iv.rising; }
                    case 2: { t = zero_low; }
                    case 3: { t = iv.airy; }
                    case 4: { t = zero_high; }
                    case 5: { t = iv.falling; }
                    default: {}
                }
                if (t >= 0.0) {
                    sweep_visit_t(c, f, &sweep, t, j >= 1 && j <= 4, k);
                }
            }
        }
    } else {
        // Evanescent n2: mode k (tau = k of tau = omega q1 d1 / pi), then the pass band of
        // [k, k + 1]: rising edge, Airy point, falling edge.
        let f = evanescent_frame(m, c.angle, polarization);
        c.subdivide = method == METHOD_SUBDIVIDED;
        for (var k = i32(floor(f.tau_lo)); k < i32(ceil(f.tau_hi)); k++) {
            let band = evanescent_band(f, k);
            for (var j = 0; j < 4; j++) {
                var tau = f32(k);
                switch j {
                    case 1: { tau = band.x; }
                    case 2: { tau = band.y; }
                    case 3: { tau = band.z; }
                    default: {}
                }
                if (tau <= f.tau_lo) {
                    sweep_status(&sweep, j >= 1 && j <= 2, k);
                } else if (tau < f.tau_hi) {
                    sweep_visit(c, &sweep, tau / f.scale, j >= 1 && j <= 2, k);
                }
            }
        }
    }
    sweep_finish(c, &sweep);
    return sweep.xyz;
}

// Unpolarised XYZ at one angle by "averaged" (both polarisations in one sweep, see above).
fn averaged_colour(m: BraggMirror, theta: f32, host_matched: bool,
                   matched_layers: bool) -> vec3<f32> {
    var c: ColourSetup;
    if (!colour_setup(&c, m, theta, host_matched)) {
        return white_xyz();
    }
    let bulk = !matched_layers && m.bulk != 0u;
    let propagating = matched_layers || c.angle.q2sq > 0.0;
    if (!bulk && propagating) {
        // n_plus, delta and so the modes and t range are those of both polarisations.
        c.frame = mode_frame(m, c.angle, 0u);
        c.frame_p = mode_frame(m, c.angle, 1u);
        c.fast = matched_layers || host_matched;
    }
    var zones = zones_start(c);
    if (bulk) {
        // No n2 layer: no band edges, one zone.
    } else if (propagating) {
        let f = c.frame;
        let first = i32(floor(f.t_lo));
        let last = i32(ceil(f.t_hi));
        for (var k = first; k < last; k++) {
            let s_interval = mode_interval(c.frame, k);
            let p_interval = mode_interval(c.frame_p, k);
            // Each polarisation's rising edge lies below its Airy point and falling edge.
            let s_band = vec2<f32>(s_interval.rising, s_interval.falling);
            let p_band = vec2<f32>(p_interval.rising, p_interval.falling);
            for (var j = 0; j < 4; j++) {
                let t = band_edges_in_order(s_band, p_band, j);
                if (t > f.t_lo && t < f.t_hi) {
                    zone_edge(c, &zones, PI * t / f.n_plus, false);
                }
            }
        }
    } else {
        // Evanescent n2: as landmark_colour, the bands of both polarisations in each branch
        // (which does not depend on the polarisation), their edges in order as above.
        c.evanescent = true;
        let s_frame = evanescent_frame(m, c.angle, 0u);
        let p_frame = evanescent_frame(m, c.angle, 1u);
        for (var k = i32(floor(s_frame.tau_lo)); k < i32(ceil(s_frame.tau_hi)); k++) {
            let s_band = evanescent_band(s_frame, k).xz;
            let p_band = evanescent_band(p_frame, k).xz;
            for (var j = 0; j < 4; j++) {
                zone_edge(c, &zones, band_edges_in_order(s_band, p_band, j) / s_frame.scale,
                          true);
            }
        }
    }
    var in_gap = vec2<bool>(false);
    if (c.evanescent) {
        in_gap = evanescent_gaps(c, &zones, OMEGA_HI);
    }
    zone_close(c, &zones, OMEGA_HI, false, in_gap);
    return zones.xyz;
}

// Unpolarised XYZ at one angle by `method` (approx, subdivided or averaged).
fn landmark_colour_unpolarized(m: BraggMirror, theta: f32, method: u32, subdivisions: i32,
                               host_matched: bool, matched_layers: bool) -> vec3<f32> {
    if (!matched_layers && m.bulk != 0u) {
        // No n2 layer: the host | n1 reflectance holds at every wavelength, grazing included.
        return bragg_reflectance(m, 550.0, theta, 2u, host_matched) * white_xyz();
    }
    if (method == METHOD_AVERAGED) {
        return averaged_colour(m, theta, host_matched, matched_layers);
    }
    return 0.5 * (landmark_colour(m, theta, 0u, method, subdivisions, host_matched, matched_layers)
        + landmark_colour(m, theta, 1u, method, subdivisions, host_matched, matched_layers));
}
