// Colour of a Bragg mirror from its spectral landmarks in float32: the twin of
// wgbragg/colour_methods.py ("approx", "subdivided", "averaged"). Requires numerics, complex,
// layer, yeh and landmarks.wgsl. No bindings: the entry point provides the tables through
//   cmf_density(j)        XYZ density (per nm) at the 1 nm node 360 + j nm, j = 0..470,
//   cmf_cumulative(j)     colorimetry.cumulative_xyz at that node,
//   moment_record(L, g, j, i)   vec4 i of the moment record of cell j (see below).
//
// One call integrates one polarisation at one angle: the landmarks are visited in increasing
// omega and each landmark interval is integrated as soon as both its ends are known, so
// nothing is stored and the cost is O(1) in N. The pieces, nodes and weights are those of the
// numpy twin; with host == n1 and a propagating n2 the cell terms at a node come from the
// closed form in the mode coordinate (landmarks.wgsl, mode_terms): two reduced sin/cos pairs.
//
// "averaged" integrates, per piece, the quadratic through three Chebyshev nodes against the
// piecewise-linear XYZ density (colorimetry.xyz_density). The numpy twin forms the moments of
// v = (lambda - middle) / half from cumulative tables of u^k, u = (lambda - 595) / 235:
// (m2 - 2 um m1 + um^2 m0) / h^2 cancels by (|um| / h)^2, 1e4 .. 1e7 for pieces of 5 to
// 0.5 nm, far beyond float32. Here every moment is taken about a nearby centre:
// - a piece up to 1 nm wide lies in one or two 1 nm cells, where the density is linear: its
//   moments are closed forms about its own middle (exact at any width, down to 1e-5 nm);
// - a wider piece of width w lies inside one block of the smallest size B = 2^L >= 2 w on one
//   of two block grids offset by B / 2; the tables (built in float64 by
//   wgbragg/colour_landmarks_gpu.py) hold, per level, grid and cell, the cumulative moments of
//   (lambda - c)^k from the block start to the cell's node about the block centre c, and the
//   cell's density and slope for the exact partial cell. The difference of the two ends is
//   moved to the piece's middle, at most 2.5 w away: a cancellation of ~25 at most.
// The result is the exact integral against the piecewise-linear density, within 1e-6 in XYZ
// of a float64 evaluation (the numpy twin interpolates 0.05 nm tables linearly).

const SQRT3: f32 = 1.7320508;
const HALF_SQRT3: f32 = 0.8660254;
// colour_methods._MAX_PIECE_NM and AVERAGING_MIN_PERIODS.
const MAX_PIECE_NM: f32 = 40.0;
const AVERAGING_MIN_PERIODS: u32 = 16u;
// Levels of the moment tables: blocks of 2^1 .. 2^MOMENT_LEVELS nm, for pieces up to 64 nm.
const MOMENT_LEVELS: u32 = 7u;
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

// Moments of the density over a piece: m0 = int rho, m1 = int (lambda - centre) rho,
// m2 = int (lambda - centre)^2 rho, about some centre.
struct PieceMoments {
    m0: vec3<f32>,
    m1: vec3<f32>,
    m2: vec3<f32>,
}

// The same moments about centre - shift: lambda - (centre - shift) = (lambda - centre) + shift.
// For a centre within a few piece widths, no catastrophic cancellation.
fn shifted(mom: PieceMoments, shift: f32) -> PieceMoments {
    var out: PieceMoments;
    out.m0 = mom.m0;
    out.m1 = mom.m1 + shift * mom.m0;
    out.m2 = mom.m2 + 2.0 * shift * mom.m1 + (shift * shift) * mom.m0;
    return out;
}

// Cell j = min(floor(p), 469) of p in the level-`level` block of grid `grid` holding it: the
// density there and, with `prefix`, the table's cumulative moments from the block start to
// node j (about the block centre), which only the block path reads.
struct CellRecord {
    j: u32,
    t: f32,           // p - j, in [0, 1]
    d0: vec3<f32>,    // density at node j
    slope: vec3<f32>, // density slope on cell j (per nm)
    e: f32,           // node j - block centre
    prefix: PieceMoments,
}

fn cell_record(level: u32, grid: u32, p: f32, prefix: bool) -> CellRecord {
    var out: CellRecord;
    out.j = min(u32(p), 469u);
    out.t = p - f32(out.j);
    let half = 1u << (level - 1u);
    let block = (out.j + grid * half) >> level;
    // Node j minus the block centre (block start + half), exact.
    out.e = f32(out.j) - (f32(block << level) - f32(grid * half) + f32(half));
    let r0 = moment_record(level, grid, out.j, 0u);
    let r1 = moment_record(level, grid, out.j, 1u);
    out.d0 = r0.xyz;
    out.slope = r1.xyz;
    if (prefix) {
        let r2 = moment_record(level, grid, out.j, 2u);
        let r3 = moment_record(level, grid, out.j, 3u);
        out.prefix = PieceMoments(r2.xyz, r3.xyz, vec3<f32>(r0.w, r1.w, r2.w));
    }
    return out;
}

// Cumulative moments from the block start to p, about the block centre: the record's prefix
// plus int_0^t (e + tau)^k (d0 + s tau) dtau, from I_k = int_0^t tau^k (d0 + s tau) dtau.
fn block_moments(r: CellRecord) -> PieceMoments {
    let t = r.t;
    let t2 = t * t;
    let i0 = t * (r.d0 + (0.5 * t) * r.slope);
    let i1 = t2 * (0.5 * r.d0 + (t / 3.0) * r.slope);
    let i2 = t2 * t * (r.d0 / 3.0 + (0.25 * t) * r.slope);
    return PieceMoments(r.prefix.m0 + i0, r.prefix.m1 + r.e * i0 + i1,
                        r.prefix.m2 + r.e * (r.e * i0 + 2.0 * i1) + i2);
}

// Moments of [p, q] inside the cell of a record, about (p + q) / 2 moved to mu: closed form
// for the linear density there, no cancellation at any width.
fn cell_segment_moments(r: CellRecord, p: f32, q: f32, mu: f32) -> PieceMoments {
    let g = 0.5 * (q - p);
    let middle = 0.5 * (p + q);
    let density = r.d0 + (middle - f32(r.j)) * r.slope;
    let g3 = (2.0 / 3.0) * g * g * g;
    return shifted(PieceMoments(2.0 * g * density, g3 * r.slope, g3 * density), middle - mu);
}

// The three integrals of a piece's quadratic over [lo, hi] (nm, inside 360..830):
// (int rho, int v rho, int v^2 rho) with v = (lambda - middle) / half width.
// Up to 1 nm wide, the piece lies in one or two cells: closed forms. Wider, it lies in one
// block of one of the two grids of the smallest level with 2^level >= 2 (hi - lo) (the grids
// are offset by half a block), whose centre is within 2.5 piece widths of the middle; its
// moments are the difference of the cumulative ones at the ends, moved to the middle.
fn piece_moments(lo: f32, hi: f32) -> PieceMoments {
    let pa = clamp(lo - LAMBDA_LO_NM, 0.0, 470.0);   // exact for lambda in 360..830
    let pb = clamp(hi - LAMBDA_LO_NM, 0.0, 470.0);
    let width = pb - pa;
    let mu = 0.5 * (pa + pb);
    var level = u32(max(ceil(log2(2.0 * width)), 1.0));
    level = min(level + select(0u, 1u, f32(1u << level) < 2.0 * width), MOMENT_LEVELS);
    let ja = min(u32(pa), 469u);
    let jb = min(u32(pb), 469u);
    let grid = select(1u, 0u, (ja >> level) == (jb >> level));
    let narrow = width <= 1.0;
    let a = cell_record(level, grid, pa, !narrow);
    let b = cell_record(level, grid, pb, !narrow);
    var mom: PieceMoments;
    if (narrow) {
        let split = min(f32(a.j + 1u), pb);
        mom = cell_segment_moments(a, pa, split, mu);
        if (pb > split) {
            let rest = cell_segment_moments(b, split, pb, mu);
            mom = PieceMoments(mom.m0 + rest.m0, mom.m1 + rest.m1, mom.m2 + rest.m2);
        }
    } else {
        let ma = block_moments(a);
        let mb = block_moments(b);
        let centre = f32(a.j) - a.e;
        mom = shifted(PieceMoments(mb.m0 - ma.m0, mb.m1 - ma.m1, mb.m2 - ma.m2), centre - mu);
    }
    let inv_h = 2.0 / width;
    mom.m1 = mom.m1 * inv_h;
    mom.m2 = mom.m2 * (inv_h * inv_h);
    return mom;
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
fn node_reflectance(c: ColourSetup, wavelength_nm: f32) -> f32 {
    if (c.fast) {
        let t = 2.0 * c.frame.n_plus / wavelength_nm;
        let terms = mode_terms(c.frame, t);
        if (c.mirror.periods >= AVERAGING_MIN_PERIODS && terms.sin2 > 0.0) {
            let w = min(abs(terms.W), MAX_AMPLITUDE);
            return clamp(1.0 - sqrt(terms.sin2 / (w * w + terms.sin2)), 0.0, 1.0);
        }
        return matched_reflectance(terms, 0.5 * t, c.mirror.periods);  // delta1 + delta2 = pi t
    }
    let g = geometry_at(c.mirror, c.angle, wavelength_nm);
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

// The quadratic through the three Chebyshev nodes of [lo, hi], integrated exactly.
fn averaged_piece(c: ColourSetup, lo: f32, hi: f32) -> vec3<f32> {
    if (!(hi > lo)) {
        return vec3<f32>(0.0);
    }
    let middle = 0.5 * (lo + hi);
    let offset = HALF_SQRT3 * (0.5 * (hi - lo));
    let r0 = node_reflectance(c, middle - offset);
    let r1 = node_reflectance(c, middle);
    let r2 = node_reflectance(c, middle + offset);
    let mom = piece_moments(lo, hi);
    let c1 = (r2 - r0) * (1.0 / SQRT3);
    let c2 = (r0 + r2 - 2.0 * r1) * (2.0 / 3.0);
    return r1 * mom.m0 + c1 * mom.m1 + c2 * mom.m2;
}

// Grading fractions of an interval next to a band edge (colour_methods._EDGE_GRADING), the
// lower three at the short-wavelength end, the upper three at the long one.
fn grading_cut(k: u32) -> f32 {
    switch k {
        case 0u: { return 1.0 / 64.0; }
        case 1u: { return 1.0 / 16.0; }
        case 2u: { return 0.25; }
        case 3u: { return 0.75; }
        case 4u: { return 15.0 / 16.0; }
        default: { return 63.0 / 64.0; }
    }
}

// The first enabled grading cut from k on (6: none): the lower three next to an edge at the
// short-wavelength end, the upper three next to one at the long end.
fn next_grading(k: u32, lower: bool, upper: bool) -> u32 {
    var next = k;
    if (next < 3u && !lower) {
        next = 3u;
    }
    if (next >= 3u && !upper) {
        next = 6u;
    }
    return next;
}

// "averaged" over [a, b] (nm): the pieces of colour_methods._pieces, i.e. the union of
// ceil((b - a) / 40) equal pieces (2N at least in pass bands below AVERAGING_MIN_PERIODS) and
// the grading cuts towards an end that is a band edge, walked in order without storing them.
fn averaged_interval(c: ColourSetup, a: f32, b: f32, edge_a: bool, edge_b: bool,
                     pass_band: bool) -> vec3<f32> {
    if (b - a < MIN_INTERVAL_NM) {
        return vec3<f32>(0.0);
    }
    var count = u32(ceil((b - a) / MAX_PIECE_NM));
    if (pass_band && c.mirror.periods < AVERAGING_MIN_PERIODS) {
        count = max(count, 2u * c.mirror.periods);
    }
    let lower = pass_band && edge_a;
    let upper = pass_band && edge_b;
    let inv_count = 1.0 / f32(count);
    var acc = vec3<f32>(0.0);
    var next_even = 1u;                              // the next equal cut is next_even / count
    var k = next_grading(0u, lower, upper);          // the next grading cut
    var lambda_prev = a;
    loop {
        let even_cut = f32(next_even) * inv_count;
        let graded = select(2.0, grading_cut(k), k < 6u);
        let cut = min(even_cut, graded);
        // Coincident cuts are merged (numpy.unique), up to float32 rounding.
        if (even_cut <= cut + 1e-6) {
            next_even += 1u;
        }
        if (graded <= cut + 1e-6) {
            k = next_grading(k + 1u, lower, upper);
        }
        let last = cut >= 1.0 - 1e-6;
        let lambda = select(a + (b - a) * cut, b, last);
        acc += averaged_piece(c, lambda_prev, lambda);
        if (last) {
            break;
        }
        lambda_prev = lambda;
    }
    return acc;
}

// ----------------------------------------------------------------------------- the sweep

// Landmarks visited in increasing omega; the interval since the previous one is integrated.
struct Sweep {
    xyz: vec3<f32>,
    omega_prev: f32,
    lambda_prev: f32,
    edge_prev: bool,    // the previous landmark is a band edge (graded towards)
    pass_band: bool,    // the zone since the previous landmark
    mode: i32,          // its mode number (subdivided)
}

fn sweep_start() -> Sweep {
    return Sweep(vec3<f32>(0.0), OMEGA_LO, LAMBDA_HI_NM, false, false, 0);
}

// The interval from the previous landmark to (omega, lambda_nm), in which is_edge is the kind
// of this landmark.
fn integrate_interval(c: ColourSetup, sweep: ptr<function, Sweep>, omega: f32, lambda_nm: f32,
                      is_edge: bool) {
    if (c.method == METHOD_AVERAGED) {
        (*sweep).xyz += averaged_interval(c, lambda_nm, (*sweep).lambda_prev, is_edge,
                                          (*sweep).edge_prev, (*sweep).pass_band);
    } else {
        (*sweep).xyz += approx_interval(c, (*sweep).omega_prev, omega, (*sweep).pass_band,
                                        (*sweep).mode);
    }
}

// A landmark at omega (wavelength lambda_nm), followed by a zone of status pass_after.
fn sweep_visit(c: ColourSetup, sweep: ptr<function, Sweep>, omega: f32, lambda_nm: f32,
               is_edge: bool, pass_after: bool, mode: i32) {
    if (omega >= OMEGA_HI) {
        return;  // beyond the range: the zone of the range's end is already known
    }
    if (omega > OMEGA_LO) {
        integrate_interval(c, sweep, omega, lambda_nm, is_edge);
        (*sweep).omega_prev = omega;
        (*sweep).lambda_prev = lambda_nm;
        (*sweep).edge_prev = is_edge;
    }
    (*sweep).pass_band = pass_after;
    (*sweep).mode = mode;
}

// A landmark at mode coordinate t.
fn sweep_visit_t(c: ColourSetup, f: ModeFrame, sweep: ptr<function, Sweep>, t: f32,
                 is_edge: bool, pass_after: bool, mode: i32) {
    if (t <= f.t_lo) {
        (*sweep).pass_band = pass_after;
        (*sweep).mode = mode;
        return;
    }
    if (t >= f.t_hi) {
        return;
    }
    sweep_visit(c, sweep, PI * t / f.n_plus, 2.0 * f.n_plus / t, is_edge, pass_after, mode);
}

fn sweep_finish(c: ColourSetup, sweep: ptr<function, Sweep>) {
    integrate_interval(c, sweep, OMEGA_HI, LAMBDA_LO_NM, false);
}

// XYZ of one polarisation at one angle by `method`.
fn landmark_colour(m: BraggMirror, theta: f32, polarization: u32, method: u32,
                   subdivisions: i32, host_matched: bool) -> vec3<f32> {
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
    if (m.bulk != 0u) {
        // No n2 layer: no landmarks, one pass-band interval.
        sweep.pass_band = true;
    } else if (c.angle.q2sq > 0.0) {
        let f = mode_frame(m, c.angle, polarization);
        c.frame = f;
        c.fast = host_matched;
        c.subdivide = method == METHOD_SUBDIVIDED;
        let first = i32(floor(f.t_lo));
        let last = i32(ceil(f.t_hi));
        for (var k = first; k < last; k++) {
            let iv = mode_interval(f, k);
            // In increasing t: mode, rising edge, [zero], Airy point, [zero], falling edge.
            // A closed gap's falling edge sorts after its mode in the numpy twin: not graded.
            var t_at = array<f32, 6>(f32(k), iv.rising, -1.0, iv.airy, -1.0, iv.falling);
            var edge_at = array<bool, 6>(false, true, false, false, false, !iv.falling_closed);
            var pass_at = array<bool, 6>(false, true, true, true, true, false);
            if (iv.zero > 0.0) {
                t_at[select(4, 2, iv.zero < iv.airy)] = iv.zero;
            }
            for (var j = 0; j < 6; j++) {
                if (t_at[j] >= 0.0) {
                    sweep_visit_t(c, f, &sweep, t_at[j], edge_at[j], pass_at[j], k);
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
        sweep.pass_band = previous;
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
                sweep_visit(c, &sweep, edge, TWO_PI / edge, true, pass_after, 0);
            }
            if (next >= SCAN_POINTS) {
                break;
            }
        }
    }
    sweep_finish(c, &sweep);
    return sweep.xyz;
}
