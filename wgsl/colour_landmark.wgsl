// Colour of a Bragg mirror from its spectral landmarks in float32: the twin of
// wgbragg/colour_methods.py ("approx", "subdivided", "averaged"). Requires numerics, complex,
// layer, yeh and landmarks.wgsl. No bindings: the entry point provides the tables through
//   cmf_density(j)        XYZ density (per nm) at the 1 nm node 360 + j nm, j = 0..470,
//   cmf_cumulative(j)     colorimetry.cumulative_xyz at that node,
//
// One call integrates one polarisation at one angle: the landmarks are visited in increasing
// omega and each landmark interval is integrated as soon as both its ends are known, so
// nothing is stored and the cost is O(1) in N. The pieces, nodes and weights are those of the
// numpy twin; with host == n1 and a propagating n2 the cell terms at a node come from the
// closed form in the mode coordinate (landmarks.wgsl, mode_terms): two reduced sin/cos pairs.
//
// "averaged" integrates each zone between band edges (or the range ends) with three-point
// Gauss-Legendre panels in the variable u of colour_methods._zone_map, which clusters nodes
// quadratically at band edges (the square-root edge of the averaged spectrum is then smooth
// in u), against the piecewise-linear XYZ density (colorimetry.xyz_density): the nodes and
// weights of the numpy twin.

// colour_methods.PANEL_NM and AVERAGING_MIN_PERIODS.
const PANEL_NM: f32 = 40.0;
const AVERAGING_MIN_PERIODS: u32 = 16u;
// Three-point Gauss-Legendre on [0, 1] (colour_methods._GAUSS_NODES, _GAUSS_WEIGHTS).
const GAUSS_OFFSET: f32 = 0.38729833;   // sqrt(0.6) / 2
const GAUSS_OUTER: f32 = 0.27777778;    // 5 / 18
const GAUSS_INNER: f32 = 0.44444444;    // 8 / 18
// Evanescent n2: sign changes recorded per scan batch (a batch ends early when full).
const EVANESCENT_BATCH: u32 = 16u;
// Landmark intervals shorter than this (nm) are skipped, as in the numpy twin.
const MIN_INTERVAL_NM: f32 = 1e-6;

const METHOD_APPROX: u32 = 0u;
const METHOD_SUBDIVIDED: u32 = 1u;
const METHOD_AVERAGED: u32 = 2u;

// What every landmark interval of one (angle, polarisation) needs.
struct ColourSetup {
    mirror: BraggMirror,
    angle: CellGeometry,    // wavelength-independent fields only (see geometry_at)
    polarization: u32,
    method: u32,
    subdivisions: i32,      // s of "subdivided"
    host_matched: bool,
    correction: f32,        // Appendix B: w~(theta1)
    subdivide: bool,        // "subdivided" with modes (propagating n2)
    frame: ModeFrame,       // propagating n2: the dispersion in the mode coordinate
    fast: bool,             // host == n1, propagating n2, an n2 layer: cell terms from frame
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

// colorimetry.xyz_density: linear between the 1 nm nodes.
fn density_xyz(wavelength_nm: f32) -> vec3<f32> {
    let p = clamp(wavelength_nm - LAMBDA_LO_NM, 0.0, LAMBDA_HI_NM - LAMBDA_LO_NM);
    let j = min(u32(p), 469u);
    return mix(cmf_density(j), cmf_density(j + 1u), p - f32(j));
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
    let root = sqrt(t.sin2);
    if (host_matched) {
        let w = min(abs(t.W), MAX_AMPLITUDE);
        return clamp(1.0 - root / sqrt(w * w + t.sin2), 0.0, 1.0);
    }
    let e1 = c_exp_i(TWO_PI * centered_fraction(g.delta1_cycles));
    return phase_averaged_host(t, e1, root, fresnel_host_n1(m, g, polarization));
}

// R at one quadrature node of "averaged": exact below AVERAGING_MIN_PERIODS, else averaged.
fn node_reflectance(c: ColourSetup, omega: f32) -> f32 {
    if (c.fast) {
        let t = omega * c.frame.n_plus * (1.0 / PI);
        let terms = mode_terms(c.frame, t);
        if (c.mirror.periods >= AVERAGING_MIN_PERIODS && terms.sin2 > 0.0) {
            let w = min(abs(terms.W), MAX_AMPLITUDE);
            return clamp(1.0 - sqrt(terms.sin2 / (w * w + terms.sin2)), 0.0, 1.0);
        }
        return matched_reflectance(terms, 0.5 * t, c.mirror.periods);  // delta1 + delta2 = pi t
    }
    let g = geometry_at(c.mirror, c.angle, TWO_PI / omega);
    if (c.mirror.periods < AVERAGING_MIN_PERIODS) {
        return yeh_polarized(c.mirror, g, c.polarization, c.host_matched);
    }
    return averaged_pass_band_reflectance(c.mirror, g, c.polarization, c.host_matched);
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

// colour_methods._zone_map: (s, ds/du) clustering the nodes at the ends that are band edges.
fn zone_map(u: f32, lower_edge: bool, upper_edge: bool) -> vec2<f32> {
    if (lower_edge && upper_edge) {
        let q = sin_cos_cycles(0.25 * u);   // pi u / 2
        return vec2<f32>(q.x * q.x, PI * q.x * q.y);
    }
    if (lower_edge) {
        let h = sin_cos_cycles(0.125 * u);  // pi u / 4
        return vec2<f32>(2.0 * h.x * h.x, PI * h.x * h.y);
    }
    if (upper_edge) {
        let q = sin_cos_cycles(0.25 * u);
        return vec2<f32>(q.x, HALF_PI * q.y);
    }
    return vec2<f32>(u, 1.0);
}

// "averaged" over the zone [lo, hi] (rad/nm) between band edges or range ends: the panels of
// colour_methods._panel_count, three Gauss nodes each.
fn averaged_zone(c: ColourSetup, lo: f32, hi: f32, lower_edge: bool, upper_edge: bool,
                 pass_band: bool) -> vec3<f32> {
    if (!(hi > lo)) {
        return vec3<f32>(0.0);
    }
    var panels = u32(max(ceil((TWO_PI / lo - TWO_PI / hi) * (1.0 / PANEL_NM)), 1.0));
    if (pass_band && c.mirror.periods < AVERAGING_MIN_PERIODS) {
        panels = max(panels, 2u * c.mirror.periods);
    }
    let span = hi - lo;
    let inv_panels = 1.0 / f32(panels);
    var rule = vec3<f32>(0.0);      // sum w R density
    var rule_white = vec3<f32>(0.0); // sum w density
    var rule_r = 0.0;               // sum w R
    // One loop over every node keeps a single inlined copy of the reflectance.
    for (var n = 0u; n < 3u * panels; n++) {
        let k = n % 3u;
        let offset = select(select(GAUSS_OFFSET, -GAUSS_OFFSET, k == 0u), 0.0, k == 1u);
        let map = zone_map((f32(n / 3u) + 0.5 + offset) * inv_panels, lower_edge, upper_edge);
        let omega = lo + span * map.x;
        let wavelength = TWO_PI / omega;
        // The rule's weight times d lambda = 2 pi / omega^2 d omega = lambda^2 / (2 pi) d omega.
        let weight = select(GAUSS_OUTER, GAUSS_INNER, k == 1u) * inv_panels * span * map.y
            * wavelength * wavelength * (1.0 / TWO_PI);
        let r = weight * node_reflectance(c, omega);
        let density = density_xyz(wavelength);
        rule += r * density;
        rule_white += weight * density;
        rule_r += r;
    }
    // As the numpy twin: the zone's mean R times its exact box, plus the rule on the rest.
    let lambda_lo = TWO_PI / hi;
    let lambda_hi = TWO_PI / lo;
    let mean = rule_r / (lambda_hi - lambda_lo);
    return rule + mean * (cumulative_xyz(lambda_hi) - cumulative_xyz(lambda_lo) - rule_white);
}

// ----------------------------------------------------------------------------- the sweep

// Landmarks visited in increasing omega. "approx" integrates the interval since the previous
// landmark; "averaged" the zone since the previous band edge.
struct Sweep {
    xyz: vec3<f32>,
    omega_prev: f32,
    pass_band: bool,    // the interval since the previous landmark
    mode: i32,          // its mode number (subdivided)
    zone_lo: f32,       // "averaged": the zone's start, a band edge iff zone_edge
    zone_edge: bool,
    zone_pass: bool,
}

fn sweep_start() -> Sweep {
    return Sweep(vec3<f32>(0.0), OMEGA_LO, false, 0, OMEGA_LO, false, false);
}

// The status of the range's start: what follows a landmark below the range.
fn sweep_status(sweep: ptr<function, Sweep>, pass_after: bool, mode: i32) {
    (*sweep).pass_band = pass_after;
    (*sweep).zone_pass = pass_after;
    (*sweep).mode = mode;
}

// A landmark at omega, followed by a zone of status pass_after.
fn sweep_visit(c: ColourSetup, sweep: ptr<function, Sweep>, omega: f32, is_edge: bool,
               pass_after: bool, mode: i32) {
    if (omega >= OMEGA_HI) {
        return;  // beyond the range: the zone of the range's end is already known
    }
    if (omega <= OMEGA_LO) {
        sweep_status(sweep, pass_after, mode);
        return;
    }
    if (c.method != METHOD_AVERAGED) {
        (*sweep).xyz += approx_interval(c, (*sweep).omega_prev, omega, (*sweep).pass_band,
                                        (*sweep).mode);
    } else if (is_edge) {
        (*sweep).xyz += averaged_zone(c, (*sweep).zone_lo, omega, (*sweep).zone_edge, true,
                                      (*sweep).zone_pass);
        (*sweep).zone_lo = omega;
        (*sweep).zone_edge = true;
        (*sweep).zone_pass = pass_after;
    }
    (*sweep).omega_prev = omega;
    (*sweep).pass_band = pass_after;
    (*sweep).mode = mode;
}

// A landmark at mode coordinate t.
fn sweep_visit_t(c: ColourSetup, f: ModeFrame, sweep: ptr<function, Sweep>, t: f32,
                 is_edge: bool, pass_after: bool, mode: i32) {
    if (t <= f.t_lo) {
        sweep_status(sweep, pass_after, mode);
        return;
    }
    if (t >= f.t_hi) {
        return;
    }
    sweep_visit(c, sweep, PI * t / f.n_plus, is_edge, pass_after, mode);
}

fn sweep_finish(c: ColourSetup, sweep: ptr<function, Sweep>) {
    if (c.method == METHOD_AVERAGED) {
        (*sweep).xyz += averaged_zone(c, (*sweep).zone_lo, OMEGA_HI, (*sweep).zone_edge, false,
                                      (*sweep).zone_pass);
    } else {
        (*sweep).xyz += approx_interval(c, (*sweep).omega_prev, OMEGA_HI, (*sweep).pass_band,
                                        (*sweep).mode);
    }
}

// XYZ of one polarisation at one angle by `method`.
// matched_layers: the caller guarantees host == n1 <= n2 and an n2 layer, so every angle takes
// the mode-coordinate path and the other paths are compiled out.
fn landmark_colour(m: BraggMirror, theta: f32, polarization: u32, method: u32,
                   subdivisions: i32, host_matched: bool, matched_layers: bool) -> vec3<f32> {
    var c: ColourSetup;
    c.mirror = m;
    c.polarization = polarization;
    c.method = method;
    c.subdivisions = subdivisions;
    c.host_matched = host_matched;
    // The angle's fields of cell_geometry (the wavelength only sets the phases).
    c.angle = cell_geometry(m, 1.0, theta);
    // Grazing in n1, or beyond its critical angle: total reflection. With host == n1, q1 =
    // n1 cos(theta) decides: s = n1 sin(theta) rounds to n1 within 2e-4 rad of grazing.
    if (c.angle.q1 <= 0.0 || (!host_matched && c.angle.s >= m.n1)) {
        return white_xyz();
    }
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
            // (j = 0..5; a closed gap's edges coincide with its mode: an empty zone for
            // "averaged"). Picked by selects, not from a private array: lavapipe would keep a
            // dynamically indexed array in memory, and the loop keeps one copy of the sweep.
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
                    sweep_visit_t(c, f, &sweep, t, j == 1 || j == 5, j >= 1 && j <= 4, k);
                }
            }
        }
    } else {
        // Evanescent n2: edges at the sign changes of sin^2 K Lambda on the numpy grid. The
        // scan records the grid cells where the sign changes, up to EVANESCENT_BATCH at a
        // time; the edges are then refined and integrated in loops of their own, so that
        // invocations meeting edges at different grid points stay in step.
        let ef = evanescent_frame(m, c.angle, polarization);
        c.subdivide = false;  // no modes to subdivide by (as the numpy twin)
        var previous = evanescent_pass(ef, OMEGA_LO);
        sweep_status(&sweep, previous, 0);
        var next = 1u;
        loop {
            var cells: array<u32, EVANESCENT_BATCH>;
            var count = 0u;
            for (; next < SCAN_POINTS && count < EVANESCENT_BATCH; next++) {
                let in_band = evanescent_pass(ef, scan_omega(next));
                if (in_band != previous) {
                    cells[count] = next;
                    count += 1u;
                }
                previous = in_band;
            }
            for (var k = 0u; k < count; k++) {
                let i = cells[k];
                let lo = scan_omega(i - 1u);
                let hi = scan_omega(i);
                // The status alternates at each edge; lo is in a gap iff the zone after is a
                // pass band (scan_edge's lo_negative).
                let pass_after = !sweep.pass_band;
                let edge = scan_edge(m, c.angle, polarization, lo, hi, pass_after);
                sweep_visit(c, &sweep, edge, true, pass_after, 0);
            }
            if (next >= SCAN_POINTS) {
                break;
            }
        }
    }
    sweep_finish(c, &sweep);
    return sweep.xyz;
}
