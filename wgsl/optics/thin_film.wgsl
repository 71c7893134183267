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

// With admittances eta = q (s) or q / n^2 (p), c = cos(delta) and S = sin(delta) / eta_film
// (sinc form: finite where the film turns evanescent, real beyond it):
//   r = [c (eta0 - eta2) + i S (eta1^2 - eta0 eta2)] / [c (eta0 + eta2) - i S (eta1^2 + eta0 eta2)]
fn airy_polarized(f: ThinFilm, wavelength_nm: f32, theta: f32, polarization: u32) -> f32 {
    let sc = sin_cos_angle(theta);
    let base2 = vec2<f32>(f.n_base * f.n_base - f.k_base * f.k_base, 2.0 * f.n_base * f.k_base);
    // q^2 = n^2 - host^2 sin^2 = (n - host)(n + host) + (host cos)^2: near grazing host sin
    // rounds to host, and a medium matching the host would get q = 0 instead of host cos.
    let host_q = f.host * sc.y;
    let q_base = c_sqrt(vec2<f32>((f.n_base - f.host) * (f.n_base + f.host)
                                  - f.k_base * f.k_base + host_q * host_q, base2.y));
    let film_q2 = (f.n_film - f.host) * (f.n_film + f.host) + host_q * host_q;
    let evanescent = film_q2 < 0.0;
    let h = layer_half_phase(sqrt(abs(film_q2)), evanescent, f.d_nm / wavelength_nm);
    var eta0 = host_q;
    var eta2 = q_base;
    var eta1_squared = film_q2;
    var S = 2.0 * h.c * h.s_over_q;
    if (polarization == 1u) {
        eta0 = eta0 / (f.host * f.host);
        eta2 = c_div(q_base, base2);
        let film2 = f.n_film * f.n_film;
        eta1_squared = film_q2 / (film2 * film2);
        S = S * film2;
    }
    let c = select((h.c - h.s) * (h.c + h.s), h.c * h.c + h.s * h.s, evanescent);
    let eta02 = eta0 * eta2;
    let top = c * (vec2<f32>(eta0, 0.0) - eta2)
        + S * vec2<f32>(eta02.y, eta1_squared - eta02.x);
    let bottom = c * (vec2<f32>(eta0, 0.0) + eta2)
        - S * vec2<f32>(-eta02.y, eta1_squared + eta02.x);
    let bottom2 = c_abs2(bottom);
    if (bottom2 == 0.0) {
        return 0.0;  // host, film and base index-matched at grazing incidence
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
