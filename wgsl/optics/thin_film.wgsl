// Airy reflectance of a film over a (possibly conducting) base in float32: the twin of
// wgbragg/optics/thin_film.py. Requires numerics, complex and optics/layer.wgsl. No bindings.

struct ThinFilm {
    host: f32,
    n_film: f32,
    d_nm: f32,
    n_base: f32,
    k_base: f32,
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
}

// What the Airy sum needs at one (wavelength, angle): the host's normal component
// q0 = host cos(theta), the film's q^2 (< 0 when evanescent), the base's complex q and the
// film's half phase. Built on the device from float32 inputs (film_geometry) or from s, cos
// theta and the reduced phase given by the host in float64 (film_point_geometry): one
// evaluation path either way (airy_terms).
struct FilmGeometry {
    q0: f32,
    film_q2: f32,
    q_base: vec2<f32>,
    half: HalfPhase,
}

// The geometry from the float32 angle and wavelength, every q^2 without cancellation
// (normal_square): host cos(theta) keeps its relative accuracy at grazing incidence, and a
// rare film under a dense host keeps its q^2 at the film's critical angle.
fn film_geometry(f: ThinFilm, wavelength_nm: f32, theta: f32) -> FilmGeometry {
    var g: FilmGeometry;
    let sc = sin_cos_angle(theta);
    let s = f.host * sc.x;
    g.q0 = f.host * max(sc.y, 0.0);  // float32(pi/2) lies above pi/2
    g.film_q2 = normal_square(f.n_film, f.host, s, g.q0);
    let base_q2 = normal_square(f.n_base, f.host, s, g.q0) - f.k_base * f.k_base;
    g.q_base = c_sqrt(vec2<f32>(base_q2, 2.0 * f.n_base * f.k_base));
    g.half = layer_half_phase(sqrt(abs(g.film_q2)), g.film_q2 < 0.0, f.d_nm / wavelength_nm);
    return g;
}

// The geometry from what the host formed in float64 from the float64 inputs
// (wgbragg/optics/thin_film_gpu.py, point_inputs): fields = (s, cos theta, the film's phase
// q d / lambda in turns reduced to [-1/2, 1/2] (0 where it is evanescent), 1 / lambda). Every
// q follows from s and cos theta without cancellation (normal_square, and c_sqrt keeps a
// metal's Re(q)); the unreduced phase needs only its relative accuracy.
fn film_point_geometry(f: ThinFilm, fields: vec4<f32>) -> FilmGeometry {
    var g: FilmGeometry;
    let s = fields.x;
    g.q0 = f.host * fields.y;
    g.film_q2 = normal_square(f.n_film, f.host, s, g.q0);
    let base_q2 = normal_square(f.n_base, f.host, s, g.q0) - f.k_base * f.k_base;
    g.q_base = c_sqrt(vec2<f32>(base_q2, 2.0 * f.n_base * f.k_base));
    let q = sqrt(abs(g.film_q2));
    let d_over_wavelength = f.d_nm * fields.w;
    g.half = layer_half_phase_of(q, g.film_q2 < 0.0, d_over_wavelength, q * d_over_wavelength,
                                 fields.z);
    return g;
}

// (R, T) of one polarisation. With admittances eta = q (s) or q / n^2 (p), c = cos(delta) and
// S = sin(delta) / eta_film (sinc form: finite where the film turns evanescent, real beyond):
//   r = [c (eta0 - eta2) + i S (eta1^2 - eta0 eta2)] / [c (eta0 + eta2) - i S (eta1^2 + eta0 eta2)]
//   T = 4 eta0 Re(eta2) / |denominator|^2   (tmm's T: the flux entering the base)
// Both are homogeneous in the admittances (S scales inversely), so they are divided by the
// largest first: near grazing incidence eta0 ~ 1e-17 and products of admittances left
// float32's range.
fn airy_terms(f: ThinFilm, g: FilmGeometry, polarization: u32) -> vec2<f32> {
    let h = g.half;
    let evanescent = g.film_q2 < 0.0;
    var eta0 = g.q0;
    var eta2 = g.q_base;
    var eta1_squared = g.film_q2;
    var S = 2.0 * h.c * h.s_over_q;
    if (polarization == 1u) {
        let base2 = vec2<f32>((f.n_base - f.k_base) * (f.n_base + f.k_base),
                              2.0 * f.n_base * f.k_base);
        eta0 = eta0 / (f.host * f.host);
        eta2 = c_div(g.q_base, base2);
        let film2 = f.n_film * f.n_film;
        eta1_squared = g.film_q2 / (film2 * film2);
        S = S * film2;
    }
    let scale = max(max(abs(eta0), max(abs(eta2.x), abs(eta2.y))), sqrt(abs(eta1_squared)));
    if (scale == 0.0) {
        return vec2<f32>(0.0, 1.0);  // host, film and base index-matched at grazing incidence
    }
    eta0 = eta0 / scale;
    eta2 = eta2 / scale;
    eta1_squared = (eta1_squared / scale) / scale;
    S = S * scale;
    let c = select((h.c - h.s) * (h.c + h.s), h.c * h.c + h.s * h.s, evanescent);
    let eta02 = eta0 * eta2;
    let top = c * (vec2<f32>(eta0, 0.0) - eta2)
        + S * vec2<f32>(eta02.y, eta1_squared - eta02.x);
    let bottom = c * (vec2<f32>(eta0, 0.0) + eta2)
        - S * vec2<f32>(-eta02.y, eta1_squared + eta02.x);
    // Rescaled so that |bottom|^2 neither overflows (cosh of a thick evanescent film) nor
    // underflows.
    let bottom_scale = max(abs(bottom.x), abs(bottom.y));
    if (bottom_scale == 0.0) {
        return vec2<f32>(0.0, 1.0);
    }
    let b = bottom / bottom_scale;
    let bottom2 = dot(b, b);
    let r = top / bottom_scale;
    let transmitted = 4.0 * (eta0 / bottom_scale) * (eta2.x / bottom_scale) / bottom2;
    return balanced(dot(r, r) / bottom2, transmitted);
}

fn airy_polarized(f: ThinFilm, wavelength_nm: f32, theta: f32, polarization: u32) -> f32 {
    return airy_terms(f, film_geometry(f, wavelength_nm, theta), polarization).x;
}

// polarization: 0 = s, 1 = p, 2 = unpolarized.
fn thin_film_reflectance(f: ThinFilm, wavelength_nm: f32, theta: f32, polarization: u32) -> f32 {
    if (polarization == 2u) {
        return 0.5 * (airy_polarized(f, wavelength_nm, theta, 0u)
            + airy_polarized(f, wavelength_nm, theta, 1u));
    }
    return airy_polarized(f, wavelength_nm, theta, polarization);
}

// (R, T) at a geometry built by the caller (film_point_geometry for the entry point).
fn thin_film_terms_at(f: ThinFilm, g: FilmGeometry, polarization: u32) -> vec2<f32> {
    if (polarization == 2u) {
        return 0.5 * (airy_terms(f, g, 0u) + airy_terms(f, g, 1u));
    }
    return airy_terms(f, g, polarization);
}
