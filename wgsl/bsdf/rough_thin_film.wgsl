// A rough thin film in float32: GGX microfacets each coated by the same film (Belcour & Barla
// 2017), its BRDF film_eval and the density film_pdf of visible-normal sampling (the
// renderer's film_sample draws from it): the float32 twin of wgbragg/bsdf/rough_thin_film.py.
//
// Requires numerics, landmarks (LAMBDA_LO_NM), bsdf/microfacet.wgsl, optics/thin_film.wgsl and
// colour/thin_film.wgsl. The includer declares the overrides SPECTRAL and FILM_PREFILTERED,
//   var<private> wavelengths: vec4<f32>   the path's hero wavelengths (nm, spectral mode)
// sets film_thickness (below) at each shading point, and provides
//   fn film_base_index(f: FilmMaterial, wavelength_nm: f32) -> vec2<f32>
// the film's base index (n, k) at a wavelength, from wherever it keeps it (render/renderer.wgsl:
// the film's rows of its `film_base` buffer).
//
// No bindings here.

// GGX microfacets coated by a thin film (Belcour & Barla 2017), in air: the float32 twin of
// wgbragg.bsdf.rough_thin_film.RoughThinFilm. The film's reflectance at the microfacet is its
// Fourier-series colour (linear sRGB: the XYZ matrix is folded into colour.adapt) in RGB mode,
// and its Airy reflectance at the hero wavelengths in spectral mode.
struct FilmMaterial {
    colour: FilmColourParams,   // d_nm is the film's own thickness
    alpha: f32,
    thickness_map: u32,         // index in map_records (FILM_MAPS), 0 for none
    first_base: u32,            // its first row of film_base
    _pad: u32,
}

// The film thickness at the current shading point, nm (a thickness map varies it).
var<private> film_thickness: f32;

// Reflectance of the film at the incidence cosine cos_d on a microfacet; sigma_nm: standard
// deviation of the thickness (prefiltering, RGB mode with FILM_PREFILTERED only).
fn film_reflectance(f: FilmMaterial, cos_d: f32, sigma_nm: f32) -> vec4<f32> {
    let theta = acos(clamp(cos_d, 0.0, 1.0));
    //! if !SPECTRAL
    var p = f.colour;
    p.d_nm = film_thickness;
    p.sigma_nm = sigma_nm;
    return vec4<f32>(film_colour(theta, p, false, FILM_PREFILTERED), 0.0);
    //! else
    var film: ThinFilm;
    film.host = f.colour.host;
    film.n_film = f.colour.n_film;
    film.d_nm = film_thickness;
    var out = vec4<f32>(0.0);
    for (var k = 0u; k < 4u; k++) {
        let base = film_base_index(f, wavelengths[k]);
        film.n_base = base.x;
        film.k_base = base.y;
        out[k] = thin_film_reflectance(film, wavelengths[k], theta, 2u);
    }
    return out;
    //! endif
}

fn film_eval(f: FilmMaterial, wi: vec3<f32>, wo: vec3<f32>) -> vec4<f32> {
    if (wi.z <= 0.0 || wo.z <= 0.0) {
        return vec4<f32>(0.0);
    }
    let h = half_vector(wi, wo);
    // D G1(wi) G1(wo) / (4 cos_i cos_o), with the cosines divided out of G1 where it is exact.
    let shape = ggx_D(h.z, f.alpha) * ggx_G1_over_cos(min(wi.z, 1.0), f.alpha)
        * ggx_G1_over_cos(min(wo.z, 1.0), f.alpha) * 0.25;
    return film_reflectance(f, dot(wi, h), 0.0) * shape;
}

fn film_pdf(f: FilmMaterial, wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    if (wi.z <= 0.0 || wo.z <= 0.0) {
        return 0.0;
    }
    let h = half_vector(wi, wo);
    let c = dot(wi, h);
    return select(0.0, ggx_visible_normal_pdf(wi, h, f.alpha) / (4.0 * c), c > 0.0);
}

