// Shading shared by the path tracer (render/renderer.wgsl) and the rasterizer
// (render/rasterizer.wgsl): spectra, the environment, the materials' BSDFs (bsdf_eval,
// bsdf_pdf, bsdf_sample), their filtered image-based lighting (ibl_radiance) and the
// per-point material set-up (prepare_material). Both renderers see materials only through
// these functions. No bindings: it reads those of render/renderer_bindings.wgsl.

// The scene holds layered Bragg materials: otherwise their code is never reached.
override LAYERED: bool = false;
// Hero-wavelength transport: layered materials by their spectral model.
override SPECTRAL: bool = false;
// The environment is an equirectangular image (environment_texels), not procedural.
override ENVIRONMENT_MAP: bool = false;
// The scene holds thin-film materials; FILM_MAPS: some of them vary their thickness over uv;
// FILM_PREFILTERED: film_table has the prefiltering axis (filtered image-based lighting).
override THIN_FILMS: bool = false;
override FILM_MAPS: bool = false;
override FILM_PREFILTERED: bool = false;
// How the environment lights surfaces: IBL_MONTE_CARLO traces paths; the filtered modes shade
// each camera hit once from prefiltered environments, without environment visibility or
// bounces (RGB mode; thin films, layered Bragg materials in air, Lambertian materials).
override IBL: u32 = 0u;
const IBL_MONTE_CARLO: u32 = 0u;
const IBL_SPLIT_SUM: u32 = 1u;
const IBL_KNEIPHOF: u32 = 2u;

const MATERIAL_LAMBERTIAN: u32 = 0u;
const MATERIAL_LAYERED: u32 = 1u;
const MATERIAL_THIN_FILM: u32 = 2u;
const FAR: f32 = 3.4e38;

// ----------------------------------------------------------------------------- spectra

const SPECTRUM_NODES: u32 = 471u;

var<private> wavelengths: vec4<f32>;
// 1 / (4 pdf) of each hero wavelength (per nm).
var<private> lane_scale: vec4<f32>;

fn spectra_at(first_row: u32, wavelength_nm: f32) -> vec3<f32> {
    let at = clamp(wavelength_nm - LAMBDA_LO_NM, 0.0, f32(SPECTRUM_NODES - 1u));
    let lower = min(u32(at), SPECTRUM_NODES - 2u);
    return mix(spectra[first_row + lower], spectra[first_row + lower + 1u],
               at - f32(lower)).xyz;
}

// bsdf/layered/model.wgsl's transmissivity lookup: the layer's table in `tables`.
fn layer_transmissivity(layer: RoughLayer, row: Lerp, column: Lerp) -> f32 {
    return table_bilinear(layer.transmissivity, row, column);
}

fn hero_cdf_node(j: u32) -> f32 {
    return spectra[2u * SPECTRUM_NODES + j].x;
}

fn start_wavelengths(u: f32) {
    let hero = hero_wavelengths(u);
    wavelengths = hero.nm;
    lane_scale = hero.scale;
}

// An RGB quantity as the path carries it.
fn upsample(rgb: vec3<f32>) -> vec4<f32> {
    if (!SPECTRAL) {
        return vec4<f32>(rgb, 0.0);
    }
    return vec4<f32>(dot(rgb, spectra_at(0u, wavelengths.x)),
                     dot(rgb, spectra_at(0u, wavelengths.y)),
                     dot(rgb, spectra_at(0u, wavelengths.z)),
                     dot(rgb, spectra_at(0u, wavelengths.w)));
}

// Linear sRGB of a path's result: the hero wavelengths' estimate of the colour integral.
fn to_rgb(value: vec4<f32>) -> vec3<f32> {
    if (!SPECTRAL) {
        return value.xyz;
    }
    let w = value * lane_scale;
    return w.x * spectra_at(SPECTRUM_NODES, wavelengths.x)
        + w.y * spectra_at(SPECTRUM_NODES, wavelengths.y)
        + w.z * spectra_at(SPECTRUM_NODES, wavelengths.z)
        + w.w * spectra_at(SPECTRUM_NODES, wavelengths.w);
}

fn lanes_max(value: vec4<f32>) -> f32 {
    let rgb = max(max(value.x, value.y), value.z);
    return select(rgb, max(rgb, value.w), SPECTRAL);
}

// ----------------------------------------------------------------------------- environment

fn sky_radiance(e: Environment, d: vec3<f32>) -> vec3<f32> {
    //! if ENVIRONMENT_MAP
    return environment_map_radiance(d);
    //! else
    return environment_radiance(e, d);
    //! endif
}

fn sky_pdf(e: Environment, d: vec3<f32>) -> f32 {
    //! if ENVIRONMENT_MAP
    return environment_map_pdf(d);
    //! else
    return environment_pdf(e, d);
    //! endif
}

fn sky_sample(e: Environment, u: vec3<f32>) -> vec3<f32> {
    //! if ENVIRONMENT_MAP
    return environment_map_sample(u.xy);
    //! else
    return environment_sample(e, u);
    //! endif
}

// ----------------------------------------------------------------------------- materials

const FILM_BASE_STEP_NM: f32 = 10.0;
const FILM_BASE_ROWS: u32 = 48u;

// bsdf/rough_thin_film.wgsl's base index: the film's rows of `film_base`.
fn film_base_index(f: FilmMaterial, wavelength_nm: f32) -> vec2<f32> {
    let at = clamp((wavelength_nm - LAMBDA_LO_NM) / FILM_BASE_STEP_NM, 0.0,
                   f32(FILM_BASE_ROWS - 1u));
    let lower = min(u32(at), FILM_BASE_ROWS - 2u);
    return mix(film_base[f.first_base + lower], film_base[f.first_base + lower + 1u],
               at - f32(lower)).xy;
}

// Visible normals (Heitz 2018): the weight f cos / pdf is R G1(wo).
fn film_sample(f: FilmMaterial, wi: vec3<f32>, u: vec2<f32>) -> BsdfSample {
    let m = ggx_sample_visible_normal(wi, u, f.alpha);
    let c = dot(wi, m);
    let wo = 2.0 * c * m - wi;
    if (c <= 0.0 || wo.z <= 0.0) {
        return BsdfSample(wo, vec4<f32>(0.0), 0.0, false);
    }
    let pdf = ggx_visible_normal_pdf(wi, m, f.alpha) / (4.0 * c);
    return BsdfSample(wo, film_reflectance(f, c, 0.0) * ggx_G1(wo.z, f.alpha), pdf, false);
}

struct BsdfSample {
    wo: vec3<f32>,
    weight: vec4<f32>,    // f cos / pdf, or the Dirac lobe's weight
    pdf: f32,             // 0 for a Dirac lobe
    dirac: bool,
}

fn layered_eval(s: LayeredStructure, p: LayeredPair) -> vec4<f32> {
    //! if SPECTRAL
    return layered_eval_spectral4(s, p, wavelengths);
    //! else
    return vec4<f32>(layered_eval_rgb(s, p), 0.0);
    //! endif
}

// f (1/sr) for local directions, +z the shading normal.
fn bsdf_eval(m: Material, wi: vec3<f32>, wo: vec3<f32>) -> vec4<f32> {
    //! if THIN_FILMS
    if (m.kind == MATERIAL_THIN_FILM) {
        return film_eval(films[m.structure], wi, wo);
    }
    //! endif
    //! if LAYERED
    if (m.kind == MATERIAL_LAYERED) {
        let s = structures[m.structure];
        return layered_eval(s, layered_pair(s, wi, wo));
    }
    //! endif
    return select(vec4<f32>(0.0), upsample(m.albedo / PI), wi.z > 0.0 && wo.z > 0.0);
}

fn bsdf_pdf(m: Material, wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    //! if THIN_FILMS
    if (m.kind == MATERIAL_THIN_FILM) {
        return film_pdf(films[m.structure], wi, wo);
    }
    //! endif
    //! if LAYERED
    if (m.kind == MATERIAL_LAYERED) {
        return layered_pdf(structures[m.structure], wi, wo);
    }
    //! endif
    return select(0.0, wo.z / PI, wi.z > 0.0 && wo.z > 0.0);
}

fn bsdf_sample(m: Material, wi: vec3<f32>, u: vec3<f32>) -> BsdfSample {
    //! if THIN_FILMS
    if (m.kind == MATERIAL_THIN_FILM) {
        return film_sample(films[m.structure], wi, u.yz);
    }
    //! endif
    //! if LAYERED
    if (m.kind == MATERIAL_LAYERED) {
        let s = structures[m.structure];
        let drawn = layered_sample(s, wi, u);
        // The coating's Fresnel reflectance is the same at every wavelength.
        var weight = vec4<f32>(drawn.dirac);
        if (drawn.cos_over_pdf > 0.0) {
            weight += layered_eval(s, layered_pair(s, wi, drawn.wo)) * drawn.cos_over_pdf;
        }
        return BsdfSample(drawn.wo, weight, drawn.pdf, drawn.dirac > 0.0);
    }
    //! endif
    let wo = cosine_direction(u.yz);
    return BsdfSample(wo, upsample(m.albedo), wo.z / PI, false);
}

// ----------------------------------------------------------------------------- filtered IBL

// lighting/ibl.wgsl's table of microfacet albedos: node i of `ibl_albedo`.
fn ibl_albedo_node(i: u32) -> f32 {
    return ibl_albedo[i];
}

// Radiance towards v (world, unit) of a surface with shading normal n, lit by the
// prefiltered environment: Lbar(r) E(cos_v) Rbar (split sum: Rbar at the ideal reflection).
fn ibl_radiance(m: Material, n: vec3<f32>, v: vec3<f32>) -> vec4<f32> {
    if (m.kind == MATERIAL_LAMBERTIAN) {
        return upsample(m.albedo * prefiltered_lookup(m.ibl_level, n).radiance);
    }
    let cos_v = clamp(dot(n, v), 0.0, 1.0);
    //! if LAYERED
    if (m.kind == MATERIAL_LAYERED) {
        let s = structures[m.structure];
        var layered = layered_ibl(s, m.ibl_level, m.ibl_layers, n, v, cos_v);
        if (COATING) {
            // The smooth coating mirrors the environment itself.
            layered += coating_reflectance(cos_v, s.host)
                * sky_radiance(params.environment, 2.0 * cos_v * n - v);
        }
        return vec4<f32>(layered, 0.0);
    }
    //! endif
    var reflectance = vec4<f32>(0.0);
    let p = prefiltered_lookup(m.ibl_level, 2.0 * cos_v * n - v);
    //! if THIN_FILMS
    if (m.kind == MATERIAL_THIN_FILM) {
        let f = films[m.structure];
        //! if IBL == IBL_KNEIPHOF
        reflectance = film_kneiphof(f, light_spread(p, v));
        //! else
        reflectance = film_reflectance(f, cos_v, 0.0);
        //! endif
    }
    //! endif
    return upsample(p.radiance) * microfacet_albedo(m.ibl_level, cos_v) * reflectance;
}
// ----------------------------------------------------------------------------- shading point

// What a material needs set before bsdf_* or ibl_radiance at a point of texture
// coordinates uv: a mapped layer's period and delta, a thin film's thickness.
fn prepare_material(m: Material, uv: vec2<f32>) {
    if (VARYING_LAYERS && m.kind == MATERIAL_LAYERED) {
        varying_layer = vec2<f32>(parameter_map_value(m.period_map, uv),
                                  parameter_map_value(m.delta_map, uv));
    }
    if (THIN_FILMS && m.kind == MATERIAL_THIN_FILM) {
        let f = films[m.structure];
        film_thickness = f.colour.d_nm;
        if (FILM_MAPS && f.thickness_map != 0u) {
            film_thickness = parameter_map_value(f.thickness_map, uv);
        }
    }
}
