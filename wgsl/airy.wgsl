// Airy reflectance of a film over a (possibly conducting) base in float32: the twin of
// wgbragg/optics/thin_film.py. Requires numerics.wgsl and complex.wgsl. No bindings.

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

// Fresnel amplitude i -> j from the complex normal components q and squared indices.
fn fresnel_amplitude(n_i2: vec2<f32>, q_i: vec2<f32>, n_j2: vec2<f32>, q_j: vec2<f32>,
                     polarization: u32) -> vec2<f32> {
    var top = q_i - q_j;
    var bottom = q_i + q_j;
    if (polarization == 1u) {
        top = c_mul(n_j2, q_i) - c_mul(n_i2, q_j);
        bottom = c_mul(n_j2, q_i) + c_mul(n_i2, q_j);
    }
    if (c_abs2(bottom) == 0.0) {
        return vec2<f32>(0.0, 0.0);  // index-matched at grazing incidence: no interface
    }
    return c_div(top, bottom);
}

fn airy_polarized(f: ThinFilm, wavelength_nm: f32, theta: f32, polarization: u32) -> f32 {
    let s = f.host * sin(theta);
    let host2 = vec2<f32>(f.host * f.host, 0.0);
    let film2 = vec2<f32>(f.n_film * f.n_film, 0.0);
    let base2 = vec2<f32>(f.n_base * f.n_base - f.k_base * f.k_base, 2.0 * f.n_base * f.k_base);
    let q_host = vec2<f32>(max(f.host * cos(theta), 0.0), 0.0);
    let film_q2 = (f.n_film - s) * (f.n_film + s);
    let film_q = sqrt(abs(film_q2));
    var q_film = vec2<f32>(film_q, 0.0);
    // e^{2 i delta}, delta = 2 pi q_film d / lambda: a phase, or a decay when evanescent.
    var round_trip = vec2<f32>(0.0, 0.0);
    let cycles = film_q * f.d_nm / wavelength_nm;
    if (film_q2 < 0.0) {
        q_film = vec2<f32>(0.0, film_q);
        round_trip = vec2<f32>(exp(-4.0 * PI * cycles), 0.0);
    } else {
        round_trip = c_exp_i(TWO_PI * centered_fraction(2.0 * cycles));
    }
    let q_base = c_sqrt(base2 - vec2<f32>(s * s, 0.0));
    let r12 = fresnel_amplitude(host2, q_host, film2, q_film, polarization);
    let r23 = fresnel_amplitude(film2, q_film, base2, q_base, polarization);
    let r23e = c_mul(r23, round_trip);
    let top = r12 + r23e;
    let bottom = vec2<f32>(1.0, 0.0) + c_mul(r12, r23e);
    let bottom2 = c_abs2(bottom);
    if (bottom2 < 1e-30) {
        return 1.0;  // grazing incidence: r12 = -1 reflects everything
    }
    return clamp(c_abs2(top) / bottom2, 0.0, 1.0);
}

// polarization: 0 = s, 1 = p, 2 = unpolarized.
fn thin_film_reflectance(f: ThinFilm, wavelength_nm: f32, theta: f32, polarization: u32) -> f32 {
    if (polarization == 2u) {
        return 0.5 * (airy_polarized(f, wavelength_nm, theta, 0u)
            + airy_polarized(f, wavelength_nm, theta, 1u));
    }
    return airy_polarized(f, wavelength_nm, theta, polarization);
}
