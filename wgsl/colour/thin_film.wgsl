// Colour of a thin film by spectral integration in Fourier space (Belcour & Barla 2017), float32:
// the twin of wgbragg/colour/thin_film.py (the derivation is in its docstring). Requires
// numerics, complex, layer and optics/thin_film.wgsl. No bindings: the including entry point declares
//   fourier_windows: array<FourierWindow>, evanescent_nodes: array<EvanescentNode> (storage)
//   film_table: texture_2d<f32> (the table method's envelope; any 1 x 1 texture otherwise).
//
//   XYZ = sum_windows (1 - T*) F(0) - 2 T* sum_{m=1}^{M} Re((-w)^m F(m D))   (s and p averaged)
//
// with w = r12 r23, T* = (1 - r12^2)(1 - |r23|^2) / (1 - |w|^2) and D = 2 d n2 cos(theta2).

// One spectral window: where it takes the base index, and its transform F.
struct FourierWindow {
    node: vec4<f32>,   // (wavelength nm, n_base, k_base, channel of a Gaussian lobe)
    shape: vec4<f32>,  // table: carrier frequency (1/nm) per channel; Gaussian: (area, centre, std, 0)
    white: vec4<f32>,  // F(0) per channel
}

// Where an evanescent film (no oscillation) is integrated with the exact Airy reflectance.
struct EvanescentNode {
    node: vec4<f32>,    // (wavelength nm, n_base, k_base, 0)
    weight: vec4<f32>,  // XYZ weight
}

struct FilmColourParams {
    host: f32,
    n_film: f32,
    d_nm: f32,
    sigma_nm: f32,         // standard deviation of the thickness (prefiltering), nm
    order: u32,
    windows: u32,
    nodes: u32,            // evanescent nodes
    samples: u32,          // table columns (OPD samples)
    levels: u32,           // table prefiltering levels
    step_nm: f32,          // OPD step of the table
    level_step_nm: f32,    // OPD standard-deviation step of the levels
    film: u32,             // which film: its windows start at film * windows, its evanescent
                           // nodes at film * nodes (several films share the buffers and table)
    adapt0: vec4<f32>,     // rows of the final XYZ matrix (Bradford E -> D65, or identity)
    adapt1: vec4<f32>,
    adapt2: vec4<f32>,
}

// F of one window at OPD x for the three channels: (X.re, X.im, Y.re, Y.im) and (Z.re, Z.im).
struct Transform {
    xy: vec4<f32>,
    z: vec2<f32>,
}

// (cos, sin) of 2 pi cycles: half the turn through the reduced polynomial, then doubled, so
// the phase is reduced in exact arithmetic whatever its size.
fn cis_cycles(cycles: f32) -> vec2<f32> {
    let h = half_phase_sin_cos(cycles);
    return vec2<f32>((h.y - h.x) * (h.y + h.x), 2.0 * h.x * h.y);
}

// The paper's Gaussian lobe, times exp(-2 pi^2 s^2 nu^2) when prefiltered: again a Gaussian.
fn gaussian_transform(w: FourierWindow, x: f32, spread: f32) -> Transform {
    let k = (TWO_PI * spread) * (TWO_PI * spread);
    let area = w.shape.x;
    let centre = w.shape.y;
    let width = w.shape.z;
    let shrink = 1.0 / (1.0 + k * width * width);
    let amplitude = area * sqrt(shrink) * exp(-0.5 * centre * centre * k * shrink
        - 2.0 * PI * PI * width * width * shrink * x * x);
    let value = amplitude * cis_cycles(centre * shrink * x);
    var t: Transform;
    t.xy = vec4<f32>(0.0);
    t.z = vec2<f32>(0.0);
    let channel = u32(w.node.w);
    if (channel == 0u) {
        t.xy = vec4<f32>(value, 0.0, 0.0);
    } else if (channel == 1u) {
        t.xy = vec4<f32>(0.0, 0.0, value);
    } else {
        t.z = value;
    }
    return t;
}

// Tabulated envelope of one window (rows 2 (level windows + window) + {0, 1}), linear in the
// OPD and, when prefiltered, in its standard deviation; 0 beyond the table. The carrier
// e^{2 pi i x nu_c} is put back per channel.
fn table_transform(w: FourierWindow, window: u32, x: f32, spread: f32, p: FilmColourParams,
                   prefiltered: bool) -> Transform {
    var t: Transform;
    t.xy = vec4<f32>(0.0);
    t.z = vec2<f32>(0.0);
    let position = x / p.step_nm;
    if (position >= f32(p.samples - 1u)) {
        return t;
    }
    let column = min(u32(position), p.samples - 2u);
    let a = position - f32(column);
    var level = 0.0;
    if (prefiltered) {
        level = spread / p.level_step_nm;
        if (level >= f32(p.levels - 1u)) {
            return t;
        }
    }
    let row = min(u32(level), max(p.levels, 2u) - 2u);
    let b = level - f32(row);
    let c = vec2<i32>(i32(column), i32(column + 1u));
    let r0 = i32(2u * (row * p.windows + window));
    var xy = mix(textureLoad(film_table, vec2<i32>(c.x, r0), 0),
                 textureLoad(film_table, vec2<i32>(c.y, r0), 0), a);
    var z = mix(textureLoad(film_table, vec2<i32>(c.x, r0 + 1), 0).xy,
                textureLoad(film_table, vec2<i32>(c.y, r0 + 1), 0).xy, a);
    if (prefiltered) {
        let r1 = r0 + i32(2u * p.windows);
        let xy1 = mix(textureLoad(film_table, vec2<i32>(c.x, r1), 0),
                      textureLoad(film_table, vec2<i32>(c.y, r1), 0), a);
        let z1 = mix(textureLoad(film_table, vec2<i32>(c.x, r1 + 1), 0).xy,
                     textureLoad(film_table, vec2<i32>(c.y, r1 + 1), 0).xy, a);
        xy = mix(xy, xy1, b);
        z = mix(z, z1, b);
    }
    t.xy = vec4<f32>(c_mul(xy.xy, cis_cycles(w.shape.x * x)),
                     c_mul(xy.zw, cis_cycles(w.shape.y * x)));
    t.z = c_mul(z, cis_cycles(w.shape.z * x));
    return t;
}

// (T*, w.re, w.im) of one polarisation (0 = s, 1 = p) with admittances eta = q or q / n^2;
// 1 - |r|^2 = 4 eta_i Re(eta_j) / |eta_i + eta_j|^2 stays exact at grazing incidence.
fn airy_series(host: f32, n_film: f32, q1: f32, q2: f32, base: vec2<f32>,
               polarization: u32) -> vec3<f32> {
    let base2 = vec2<f32>(base.x * base.x - base.y * base.y, 2.0 * base.x * base.y);
    // n^2 - host^2 sin^2 as in optics/thin_film.wgsl: a base matching the host keeps q3 = q1 at grazing.
    let q3 = c_sqrt(vec2<f32>((base.x - host) * (base.x + host) - base.y * base.y + q1 * q1,
                              base2.y));
    var eta1 = q1;
    var eta2 = q2;
    var eta3 = q3;
    if (polarization == 1u) {
        eta1 = q1 / (host * host);
        eta2 = q2 / (n_film * n_film);
        eta3 = c_div(q3, base2);
    }
    let r12 = (eta1 - eta2) / (eta1 + eta2);
    let t12 = 4.0 * eta1 * eta2 / ((eta1 + eta2) * (eta1 + eta2));
    let sum23 = vec2<f32>(eta2, 0.0) + eta3;
    let r23 = c_div(vec2<f32>(eta2, 0.0) - eta3, sum23);
    let t23 = 4.0 * eta2 * eta3.x / c_abs2(sum23);
    let denominator = t12 + r12 * r12 * t23;
    let t_star = select(0.0, t12 * t23 / denominator, denominator > 0.0);
    return vec3<f32>(t_star, r12 * r23);
}

// wgbragg.colour.thin_film.TAIL_RANGE and EXACT_OPD_RANGE_NM (checked by
// tests/test_wgsl_layouts.py): below the film's critical angle, where
// both interfaces reflect almost totally, a film of small OPD is integrated exactly, blended
// with the series in between.
const TAIL_LOW: f32 = 1e-4;
const TAIL_HIGH: f32 = 1e-3;
const EXACT_OPD_SHORT_NM: f32 = 300.0;
const EXACT_OPD_LONG_NM: f32 = 450.0;

// Bound on the tail the series leaves out, 2 T* |w|^(M+1) / (1 - |w|), of one polarisation's
// airy_series (wgbragg.colour.thin_film.series_tail).
fn series_tail(c: vec3<f32>, order: u32) -> f32 {
    let size = length(c.yz);
    if (size >= 1.0) {
        return 3.0e38;
    }
    return 2.0 * c.x * pow(size, f32(order + 1u)) / (1.0 - size);
}

// Share of exact integration of a propagating film (wgbragg.colour.thin_film._exact_share).
fn exact_share(p: FilmColourParams, q1: f32, q2: f32) -> f32 {
    let by_opd = clamp((EXACT_OPD_LONG_NM - 2.0 * q2 * p.d_nm)
                       / (EXACT_OPD_LONG_NM - EXACT_OPD_SHORT_NM), 0.0, 1.0);
    if (by_opd <= 0.0) {
        return 0.0;
    }
    var tail = 0.0;
    for (var b = 0u; b < p.windows; b++) {
        let w = fourier_windows[p.film * p.windows + b];
        tail = max(tail, max(series_tail(airy_series(p.host, p.n_film, q1, q2, w.node.yz, 0u),
                                         p.order),
                             series_tail(airy_series(p.host, p.n_film, q1, q2, w.node.yz, 1u),
                                         p.order)));
    }
    let by_tail = clamp(log(tail / TAIL_LOW) / log(TAIL_HIGH / TAIL_LOW), 0.0, 1.0);
    return by_tail * by_opd;
}

fn add_transform(acc: vec3<f32>, g: vec2<f32>, f: Transform) -> vec3<f32> {
    // Re(g F) per channel.
    return acc + vec3<f32>(g.x * f.xy.x - g.y * f.xy.y, g.x * f.xy.z - g.y * f.xy.w,
                           g.x * f.z.x - g.y * f.z.y);
}

fn film_colour(theta: f32, p: FilmColourParams, gaussian: bool, prefiltered: bool) -> vec3<f32> {
    let sc = sin_cos_angle(theta);
    let q1 = max(p.host * sc.y, 0.0);
    let film_q2 = (p.n_film - p.host) * (p.n_film + p.host) + q1 * q1;
    var acc = vec3<f32>(0.0);
    var exact = 1.0;
    if (film_q2 > 0.0) {
        exact = exact_share(p, q1, sqrt(film_q2));
    }
    if (exact > 0.0) {
        var film: ThinFilm;
        film.host = p.host;
        film.n_film = p.n_film;
        film.d_nm = p.d_nm;
        for (var i = 0u; i < p.nodes; i++) {
            let node = evanescent_nodes[p.film * p.nodes + i];
            film.n_base = node.node.y;
            film.k_base = node.node.z;
            acc += thin_film_reflectance(film, node.node.x, theta, 2u) * node.weight.xyz;
        }
        acc *= exact;
    }
    if (exact < 1.0) {
        var series = vec3<f32>(0.0);
        let q2 = sqrt(film_q2);
        let opd_per_nm = 2.0 * q2;
        let opd = opd_per_nm * p.d_nm;
        for (var b = 0u; b < p.windows; b++) {
            let w = fourier_windows[p.film * p.windows + b];
            let cs = airy_series(p.host, p.n_film, q1, q2, w.node.yz, 0u);
            let cp = airy_series(p.host, p.n_film, q1, q2, w.node.yz, 1u);
            series += (1.0 - 0.5 * (cs.x + cp.x)) * w.white.xyz;
            var power_s = vec2<f32>(1.0, 0.0);
            var power_p = vec2<f32>(1.0, 0.0);
            for (var m = 1u; m <= p.order; m++) {
                power_s = c_mul(power_s, -cs.yz);
                power_p = c_mul(power_p, -cp.yz);
                // 2 Re(g F) with g = -(T*_s (-w_s)^m + T*_p (-w_p)^m) / 2.
                let g = -(cs.x * power_s + cp.x * power_p);
                let x = f32(m) * opd;
                let spread = f32(m) * opd_per_nm * p.sigma_nm;
                if (gaussian) {
                    series = add_transform(series, g, gaussian_transform(w, x, spread));
                } else {
                    series = add_transform(series, g,
                                           table_transform(w, b, x, spread, p, prefiltered));
                }
            }
        }
        acc += (1.0 - exact) * series;
    }
    return vec3<f32>(dot(p.adapt0.xyz, acc), dot(p.adapt1.xyz, acc), dot(p.adapt2.xyz, acc));
}
