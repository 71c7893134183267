// The single-reflection model of a layered Bragg structure in float32 (Fourneau, Pacanowski &
// Barla 2024, sec. 4.3): the twin of LayeredBragg.brdf, .sample and .pdf (wgbragg/bsdf/layered/model.py).
// An integrator sees the material only through
//   layered_pair(s, wi, wo) -> LayeredPair          what eq 34 needs of (wi, wo), per pair
//   layered_eval_spectral(s, pair, wavelength_nm)   f (1/sr) at one wavelength (eq 34)
//   layered_eval_spectral4(s, pair, wavelengths)    the same at four (a path's hero wavelengths)
//   layered_eval_spectral4_over(s, pair, wavelengths, base_albedo)
//                                                   the same with the base's albedo given
//   layered_eval_rgb(s, pair)                       f as linear sRGB
//   layered_pdf(s, wi, wo)                          density (1/sr) of layered_sample's lobes
//   layered_sample(s, wi, u) -> LayeredSample       eq 35, then the chosen lobe
// A sample's weight is f(wi, wo) cos_over_pdf + dirac, per wavelength or channel: one pair
// serves every wavelength a path carries (wavelength multiplexing). Directions are unit
// vectors in air, +z the normal, pointing away from the surface; s is the structure's
// LayeredStructure, read by the caller from wherever it keeps its materials.
//
// Requires numerics, complex, layer, yeh, landmarks, colour_landmark, ggx and bsdf/layered/coating.wgsl.
// Provides colour_landmark's cmf_density, cmf_cumulative and cmf_cell (from `tables`, in
// float32: two loads a cell). The includer provides
//   fn layer_transmissivity(layer: RoughLayer, row: Lerp, column: Lerp) -> f32
// the layer's transmissivity table (below) bilinear at (row, column), from wherever it keeps
// it: `tables` at RoughLayer.transmissivity (render/renderer.wgsl), or a table of cell corners, one
// load per lookup (bsdf/layered/model_eval.wgsl).
//
// Buffers. No bindings here: the including entry point declares, under these names,
//   layers: array<RoughLayer>  one record per rough layer, top down; the structure's layers
//                              are layers[s.first_layer .. s.first_layer + LAYERS).
//   tables: array<f32>         float32 tables; offsets below are in floats.
//     [0, 3768)     the CMF block of landmark_methods_gpu: 471 vec4 (xyz, 0) of the XYZ
//                   density at 360, 361, ..., 830 nm, then 471 of its cumulative integral.
//     [3768, 3780)  XYZ -> linear sRGB: three rows, each a vec4 (xyz, 0).
//     [3780, 5193)  the D65-weighted XYZ weights of the 1 nm nodes in linear sRGB (471 x 3,
//                   colorimetry.xyz_weights times XYZ -> linear sRGB): the "reference"
//                   colour, INTEGRATED and the hero colour of bsdf/layered/model_eval.wgsl, summed
//                   in sRGB (no matrix per colour).
//     [5193, 5706)  the hero wavelengths' inverse CDF (colorimetry.hero_inverse_cdf: 513
//                   wavelengths, nm), read by an includer's hero_cdf_node at HERO_INVERSE_CDF.
//     At the offsets of a RoughLayer (each a row-major table, "rows" its filter's theta_i
//     rows, uniform over [0, pi/2]; a wavelength axis has 471 nodes, 360..830 nm):
//       transmissivity        rows x 471   f_t cos (eq 28)                   spectral (read
//                                                                    by layer_transmissivity)
//       transmissivity_mean   rows         its mean over wavelength (eq 33)  always
//       transmissivity_rgb    rows x 3     its linear sRGB                   factored RGB
//       reflectance           lut x 471    R over theta_d (LUT rows)         spectral, LUT
//       reflectance_rgb       lut x 3      the mirror's linear sRGB          factored, LUT
//     At s.base_spectrum: 471 albedos of the base, 360..830 nm (spectral and INTEGRATED,
//     Lambertian base).
//   Only the tables a specialisation reads need to exist. Between the 1 nm nodes tables are
//   linear in wavelength (outside 360..830 nm their end values hold) and, as the numpy twin,
//   linear in angle.
//
// RGB is either INTEGRATED, the colour of the spectral model (its 471 nodes, as the numpy
// twin's colour_method="integrated"), or factored: the colours of eq 34's factors multiplied
// channel by channel, as an RGB renderer does, each layer's reflectance colour by
// COLOUR_METHOD (or from its LUT).
//
// Specialisation: override constants, so that a pipeline holds only what a structure uses.
// A scene with several configurations compiles one pipeline per configuration.

// Rough layers, top down.
override LAYERS: u32 = 1u;
// A smooth air / n1 coating over the layers (n1 != 1).
override COATING: bool = false;
// BASE_ABSORBING or BASE_LAMBERTIAN.
override BASE: u32 = 0u;
// The mirrors sit in their own n1 (host == n1); else one layer seen from the structure's
// medium (Appendix D).
override HOST_MATCHED: bool = true;
// Mirror reflectances from the tables over theta_d (LayeredBragg "single-reflection-lut")
// instead of Yeh's formula (spectral) or an in-kernel colour (factored RGB).
override LUT: bool = false;
// RGB: the colour of the spectral model rather than factored.
override INTEGRATED: bool = true;
// Factored RGB without LUT: each layer's colour by colour/landmark_methods.wgsl's METHOD_APPROX,
// METHOD_SUBDIVIDED, METHOD_AVERAGED, or COLOUR_REFERENCE (the 1 nm sum).
override COLOUR_METHOD: u32 = 2u;
// Landmark colours: every layer has host == n1 <= n2 and an n2 layer, so only the
// mode-coordinate path of the landmark colours is compiled.
override MATCHED_LAYERS: bool = false;

// Every layer's period and d1 / period vary over the surface (the renderer's period and delta
// maps): its caller sets varying_layer before evaluating. Mirror reflectances then come from
// Yeh's formula or an in-kernel colour (LUT false); the transmissivity tables stay the
// layer's own, so only the last layer over an absorbing base is exact (Bragg paper, sec. 7).
override VARYING_LAYERS: bool = false;
// (period nm, d1 / period) at the shading point when VARYING_LAYERS.
var<private> varying_layer: vec2<f32>;

const BASE_ABSORBING: u32 = 0u;
const BASE_LAMBERTIAN: u32 = 1u;
// Nodes of a wavelength axis: 360..830 nm at 1 nm (colorimetry.xyz_weights), and the offsets of
// the tables' header (model_gpu._header); checked by tests/test_wgsl_layouts.py, as are
// COLOUR_REFERENCE and SUBDIVISIONS.
const VISIBLE_NODES: u32 = 471u;
const SRGB_MATRIX: u32 = 8u * VISIBLE_NODES;
const RGB_WEIGHTS: u32 = SRGB_MATRIX + 12u;
const HERO_INVERSE_CDF: u32 = RGB_WEIGHTS + 3u * VISIBLE_NODES;
const COLOUR_REFERENCE: u32 = 3u;
// s of "subdivided": the default of BraggMirror.rgb.
const SUBDIVISIONS: i32 = 3;

// One rough Bragg layer (RoughBraggLayer): 20 words.
struct RoughLayer {
    mirror: BraggMirror,
    alpha: f32,
    rows: u32,               // filter rows over theta_i in [0, pi/2]
    rows_per_radian: f32,    // (rows - 1) / (pi / 2)
    transmissivity: u32,
    transmissivity_mean: u32,
    transmissivity_rgb: u32,
    reflectance: u32,
    reflectance_rgb: u32,
    // Where an includer keeps the transmissivity table elsewhere (layer_transmissivity): its
    // own offset there. Three words pad the record to 20: storage lays out an all-scalar
    // struct at a 4-byte stride (17 words: 68 bytes), gpu.struct_dtype at a multiple of 16.
    transmissivity_elsewhere: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// What a structure holds beyond its layers: 48 bytes (uniform and storage layouts agree).
struct LayeredStructure {
    base_rgb: vec3<f32>,        // linear sRGB albedo of a Lambertian base
    host: f32,                  // n1: the coating's index and the medium between layers
    base_mean: f32,             // the base's albedo averaged over 360..830 nm (eq 35)
    first_layer: u32,
    base_spectrum: u32,         // offset in tables
    lut_rows: u32,              // rows of the reflectance LUTs over theta_d in [0, pi/2]
    lut_rows_per_radian: f32,
}

// ----------------------------------------------------------------------------- tables

fn table_vec3(offset: u32) -> vec3<f32> {
    return vec3<f32>(tables[offset], tables[offset + 1u], tables[offset + 2u]);
}

fn cmf_density(j: u32) -> vec3<f32> {
    return table_vec3(4u * j);
}

fn cmf_cumulative(j: u32) -> vec3<f32> {
    return table_vec3(4u * (VISIBLE_NODES + j));
}

fn cmf_cell(j: u32) -> DensityCell {
    let density = cmf_density(j);
    return DensityCell(density, cmf_density(j + 1u) - density);
}

fn xyz_to_linear_srgb(xyz: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(table_vec3(SRGB_MATRIX), xyz), dot(table_vec3(SRGB_MATRIX + 4u), xyz),
                     dot(table_vec3(SRGB_MATRIX + 8u), xyz));
}

// A position on a uniform grid of `nodes` (>= 2): the lower node, clamped to the grid as in
// the numpy twin, and the fraction beyond it (not clamped).
struct Lerp {
    index: u32,
    fraction: f32,
}

fn lerp_at(position: f32, nodes: u32) -> Lerp {
    let lower = clamp(floor(position), 0.0, f32(nodes - 2u));
    return Lerp(u32(lower), position - lower);
}

fn wavelength_lerp(wavelength_nm: f32) -> Lerp {
    return lerp_at(clamp(wavelength_nm - LAMBDA_LO_NM, 0.0, f32(VISIBLE_NODES - 1u)),
                   VISIBLE_NODES);
}

fn table_lerp(offset: u32, at: Lerp) -> f32 {
    return mix(tables[offset + at.index], tables[offset + at.index + 1u], at.fraction);
}

fn table_lerp_rgb(offset: u32, at: Lerp) -> vec3<f32> {
    return mix(table_vec3(offset + 3u * at.index), table_vec3(offset + 3u * at.index + 3u),
               at.fraction);
}

// A rows x VISIBLE_NODES table at (row, column).
fn table_bilinear(offset: u32, row: Lerp, column: Lerp) -> f32 {
    let a = offset + row.index * VISIBLE_NODES + column.index;
    let b = a + VISIBLE_NODES;
    return mix(mix(tables[a], tables[a + 1u], column.fraction),
               mix(tables[b], tables[b + 1u], column.fraction), row.fraction);
}

fn filter_row(layer: RoughLayer, theta: f32) -> Lerp {
    return lerp_at(theta * layer.rows_per_radian, layer.rows);
}

fn lut_row(s: LayeredStructure, theta_d: f32) -> Lerp {
    return lerp_at(theta_d * s.lut_rows_per_radian, s.lut_rows);
}

// ----------------------------------------------------------------------------- eq 34

// Polar angle from its cosine c >= 0 and sine s >= 0 (not both 0): acos would keep only half
// the digits of c near normal incidence, where the tables are read at theta / step.
fn angle_from(c: f32, s: f32) -> f32 {
    return TWO_PI * atan2_cycles_positive(s, c);
}

// The wavelength-independent part of eq 34 for one (wi, wo), inside n1.
struct LayeredPair {
    scale: f32,      // T_c(wi) T_c(wo) / n1^2; 0 when wi or wo is not above the horizon
    ci: f32,         // cosines of the refracted directions
    co: f32,
    h: vec3<f32>,    // their unit half vector
    theta_i: f32,    // radians
    theta_o: f32,
    theta_d: f32,    // between the refracted wi and the half vector
}

fn layered_pair(s: LayeredStructure, wi: vec3<f32>, wo: vec3<f32>) -> LayeredPair {
    var p: LayeredPair;
    let up = wi.z > 0.0 && wo.z > 0.0;
    // Below the horizon f is 0; the pair (n, n) keeps every term finite meanwhile.
    let normal = vec3<f32>(0.0, 0.0, 1.0);
    var i = select(normal, wi, up);
    var o = select(normal, wo, up);
    var scale = 1.0;
    if (COATING) {
        let n = s.host;
        scale = (1.0 - coating_reflectance(i.z, n)) * (1.0 - coating_reflectance(o.z, n))
            / (n * n);
        i = refract_in(i, n);
        o = refract_in(o, n);
    }
    let h = half_vector(i, o);
    p.scale = select(0.0, scale, up);
    p.ci = i.z;
    p.co = o.z;
    p.h = h;
    p.theta_i = angle_from(i.z, length(i.xy));
    p.theta_o = angle_from(o.z, length(o.xy));
    p.theta_d = angle_from(dot(i, h), length(cross(i, h)));
    return p;
}

fn layer_mirror(layer: RoughLayer) -> BraggMirror {
    if (!VARYING_LAYERS) {
        return layer.mirror;
    }
    var m = layer.mirror;
    m.d1_nm = varying_layer.x * varying_layer.y;
    m.d2_nm = varying_layer.x - m.d1_nm;
    m.bulk = u32(m.n1 == m.n2 || m.d2_nm <= 0.0);
    return m;
}

fn layer_reflectance(s: LayeredStructure, layer: RoughLayer, theta_d: f32,
                     wavelength_nm: f32, column: Lerp) -> f32 {
    //! if LUT
    return table_bilinear(layer.reflectance, lut_row(s, theta_d), column);
    //! else
    return bragg_reflectance(layer_mirror(layer), wavelength_nm, theta_d, 2u, HOST_MATCHED);
    //! endif
}

fn node_wavelength(j: u32) -> f32 {
    return LAMBDA_LO_NM + f32(j);
}

fn node_rgb_weights(j: u32) -> vec3<f32> {
    return table_vec3(RGB_WEIGHTS + 3u * j);
}

fn layer_colour(s: LayeredStructure, layer: RoughLayer, theta_d: f32) -> vec3<f32> {
    //! if LUT
    return table_lerp_rgb(layer.reflectance_rgb, lut_row(s, theta_d));
    //! else
    //! if COLOUR_METHOD == COLOUR_REFERENCE
    let m = layer_mirror(layer);
    let angle = angle_geometry(m, theta_d);
    var rgb = vec3<f32>(0.0);
    for (var j = 0u; j < VISIBLE_NODES; j++) {
        let g = geometry_at(m, angle, node_wavelength(j));
        rgb += bragg_reflectance_at(m, g, 2u, HOST_MATCHED) * node_rgb_weights(j);
    }
    return rgb;
    //! else
    return xyz_to_linear_srgb(landmark_colour_unpolarized(
        layer_mirror(layer), theta_d, COLOUR_METHOD, SUBDIVISIONS, HOST_MATCHED, MATCHED_LAYERS));
    //! endif
    //! endif
}

fn layered_eval_spectral(s: LayeredStructure, p: LayeredPair, wavelength_nm: f32) -> f32 {
    if (p.scale == 0.0) {
        return 0.0;
    }
    let column = wavelength_lerp(wavelength_nm);
    var total = 0.0;
    var through = 1.0;  // prod_{k<l} t_k(i') t_k(o')
    for (var l = 0u; l < LAYERS; l++) {
        let layer = layers[s.first_layer + l];
        let shape = layer_lobe(p.ci, p.co, p.h, layer.alpha);
        total += shape * layer_reflectance(s, layer, p.theta_d, wavelength_nm, column) * through;
        // Nothing lies below the last layer over an absorbing base.
        if (l + 1u < LAYERS || BASE == BASE_LAMBERTIAN) {
            through *= layer_transmissivity(layer, filter_row(layer, p.theta_i), column)
                * layer_transmissivity(layer, filter_row(layer, p.theta_o), column);
        }
    }
    if (BASE == BASE_LAMBERTIAN) {
        total += table_lerp(s.base_spectrum, column) / PI * through;
    }
    return total * p.scale;
}

// layered_eval_spectral at the four wavelengths a path carries: the lobes and the tables' rows,
// which do not depend on wavelength, are computed once. Yeh's angle setup is not: sharing it
// (angle_geometry), or unrolling the wavelength loop, is slower on lavapipe
// (docs/performance.md, "Layered structures").
fn layered_eval_spectral4(s: LayeredStructure, p: LayeredPair, wavelength_nm: vec4<f32>)
    -> vec4<f32> {
    var albedo = vec4<f32>(0.0);
    if (BASE == BASE_LAMBERTIAN && p.scale != 0.0) {
        for (var k = 0u; k < 4u; k++) {
            albedo[k] = table_lerp(s.base_spectrum, wavelength_lerp(wavelength_nm[k]));
        }
    }
    return layered_eval_spectral4_over(s, p, wavelength_nm, albedo);
}

// layered_eval_spectral4 with the base's albedo at the four wavelengths given (read by the
// caller wherever it keeps it; ignored over an absorbing base).
fn layered_eval_spectral4_over(s: LayeredStructure, p: LayeredPair, wavelength_nm: vec4<f32>,
                               base_albedo: vec4<f32>) -> vec4<f32> {
    if (p.scale == 0.0) {
        return vec4<f32>(0.0);
    }
    var columns: array<Lerp, 4>;
    for (var k = 0u; k < 4u; k++) {
        columns[k] = wavelength_lerp(wavelength_nm[k]);
    }
    var total = vec4<f32>(0.0);
    var through = vec4<f32>(1.0);
    for (var l = 0u; l < LAYERS; l++) {
        let layer = layers[s.first_layer + l];
        let shape = layer_lobe(p.ci, p.co, p.h, layer.alpha);
        let below = l + 1u < LAYERS || BASE == BASE_LAMBERTIAN;
        let row_i = filter_row(layer, p.theta_i);
        let row_o = filter_row(layer, p.theta_o);
        var reflectance: vec4<f32>;
        var transmitted = vec4<f32>(1.0);
        for (var k = 0u; k < 4u; k++) {
            reflectance[k] = layer_reflectance(s, layer, p.theta_d, wavelength_nm[k], columns[k]);
            if (below) {
                transmitted[k] = layer_transmissivity(layer, row_i, columns[k])
                    * layer_transmissivity(layer, row_o, columns[k]);
            }
        }
        total += shape * reflectance * through;
        through *= transmitted;
    }
    if (BASE == BASE_LAMBERTIAN) {
        total += base_albedo / PI * through;
    }
    return total * p.scale;
}

fn layered_eval_rgb(s: LayeredStructure, p: LayeredPair) -> vec3<f32> {
    if (p.scale == 0.0) {
        return vec3<f32>(0.0);
    }
    //! if INTEGRATED
    var rgb = vec3<f32>(0.0);
    for (var j = 0u; j < VISIBLE_NODES; j++) {
        rgb += layered_eval_spectral(s, p, node_wavelength(j)) * node_rgb_weights(j);
    }
    return rgb;
    //! else
    var total = vec3<f32>(0.0);
    var through = vec3<f32>(1.0);
    for (var l = 0u; l < LAYERS; l++) {
        let layer = layers[s.first_layer + l];
        let shape = layer_lobe(p.ci, p.co, p.h, layer.alpha);
        total += shape * layer_colour(s, layer, p.theta_d) * through;
        if (l + 1u < LAYERS || BASE == BASE_LAMBERTIAN) {
            through *= table_lerp_rgb(layer.transmissivity_rgb, filter_row(layer, p.theta_i))
                * table_lerp_rgb(layer.transmissivity_rgb, filter_row(layer, p.theta_o));
        }
    }
    if (BASE == BASE_LAMBERTIAN) {
        total += s.base_rgb / PI * through;
    }
    return total * p.scale;
    //! endif
}

// ----------------------------------------------------------------------------- eq 35

// Eq 31 with f_t cos averaged over wavelength (eq 33): the chance that a multiplexed path at
// theta (cosine c) inside n1 crosses the layer.
fn transmission_probability(layer: RoughLayer, theta: f32, c: f32) -> f32 {
    let mean = table_lerp(layer.transmissivity_mean, filter_row(layer, theta));
    return clamp(2.0 * mean / (1.0 + ggx_G1(c, layer.alpha)), 0.0, 1.0);
}

// The components' probabilities of eq 35 (each layer, then a Lambertian base weighted by its
// mean albedo) add up to this before normalisation.
fn component_total(s: LayeredStructure, theta: f32, c: f32) -> f32 {
    var total = 0.0;
    var remaining = 1.0;
    for (var l = 0u; l < LAYERS; l++) {
        let p = transmission_probability(layers[s.first_layer + l], theta, c);
        total += remaining * (1.0 - p);
        remaining *= p;
    }
    if (BASE == BASE_LAMBERTIAN) {
        total += remaining * s.base_mean;
    }
    return total;
}

fn component_count() -> u32 {
    return LAYERS + select(0u, 1u, BASE == BASE_LAMBERTIAN);
}

fn layered_pdf(s: LayeredStructure, wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    if (!(wi.z > 0.0 && wo.z > 0.0)) {
        return 0.0;
    }
    var i = wi;
    var o = wo;
    var factor = 1.0;
    if (COATING) {
        let n = s.host;
        i = refract_in(wi, n);
        o = refract_in(wo, n);
        // What enters the coating, times Snell's d omega' / d omega = cos_o / (n^2 cos_o').
        factor = (1.0 - coating_reflectance(wi.z, n)) * wo.z / (n * n * o.z);
    }
    let h = half_vector(i, o);
    if (component_count() == 1u) {
        // The one layer's share is 1, whatever the probabilities (as (1 - p) / (1 - p) is).
        return factor * layer_lobe_pdf(i.z, h, layers[s.first_layer].alpha);
    }
    let theta = angle_from(i.z, length(i.xy));
    let total = component_total(s, theta, i.z);
    // No component has weight (transparent layers over an absorbing base): the numpy twin's
    // uniform choice.
    let weighted = total > 0.0;
    let uniform = 1.0 / f32(component_count());
    var density = 0.0;
    var remaining = 1.0;
    for (var l = 0u; l < LAYERS; l++) {
        let layer = layers[s.first_layer + l];
        let p = transmission_probability(layer, theta, i.z);
        let share = select(uniform, remaining * (1.0 - p) / total, weighted);
        density += share * layer_lobe_pdf(i.z, h, layer.alpha);
        remaining *= p;
    }
    if (BASE == BASE_LAMBERTIAN) {
        let share = select(uniform, remaining * s.base_mean / total, weighted);
        density += share * o.z / PI;
    }
    return factor * density;
}

struct LayeredSample {
    wo: vec3<f32>,       // (0, 0, 1) when rejected
    pdf: f32,            // layered_pdf(wo); 0 for the Dirac lobe and rejected directions
    cos_over_pdf: f32,   // wo.z / pdf, 0 where the weight has no continuous part
    dirac: f32,          // 1 when the coating's mirror reflection was chosen (weight 1)
}

// u in [0, 1]^3: u.x picks the component, u.yz the direction. wi.z <= 0, a direction below
// the horizon, and one trapped inside the coating by total internal reflection give a zero
// weight.
fn layered_sample(s: LayeredStructure, wi: vec3<f32>, u: vec3<f32>) -> LayeredSample {
    var r = LayeredSample(vec3<f32>(0.0, 0.0, 1.0), 0.0, 0.0, 0.0);
    if (!(wi.z > 0.0)) {
        return r;
    }
    var pick = u.x;
    var i = wi;
    if (COATING) {
        let fresnel = coating_reflectance(wi.z, s.host);
        if (u.x < fresnel) {
            r.wo = vec3<f32>(-wi.x, -wi.y, wi.z);
            r.dirac = 1.0;
            return r;
        }
        pick = (u.x - fresnel) / (1.0 - fresnel);
        i = refract_in(wi, s.host);
    }
    let components = component_count();
    var chosen = components - 1u;
    let theta = angle_from(i.z, length(i.xy));
    var total = 0.0;
    // One component (one layer over an absorbing base) needs no probabilities: the pick is
    // that layer either way.
    if (components > 1u) {
        total = component_total(s, theta, i.z);
    }
    if (total > 0.0) {
        let goal = pick * total;
        var cumulative = 0.0;
        var remaining = 1.0;
        for (var l = 0u; l < LAYERS; l++) {
            let p = transmission_probability(layers[s.first_layer + l], theta, i.z);
            cumulative += remaining * (1.0 - p);
            remaining *= p;
            if (goal < cumulative) {
                chosen = l;
                break;
            }
        }
    } else {
        chosen = min(u32(pick * f32(components)), components - 1u);
    }
    var o: vec3<f32>;
    if (chosen < LAYERS) {
        let m = ggx_sample_visible_normal(i, u.yz, layers[s.first_layer + chosen].alpha);
        o = reflect_about(i, m);
    } else {
        let radius = sqrt(u.y);
        let phi = TWO_PI * u.z;
        o = vec3<f32>(radius * cos(phi), radius * sin(phi), sqrt(max(0.0, 1.0 - radius * radius)));
    }
    if (!(o.z > 0.0)) {
        return r;
    }
    var wo = normalize(o);
    if (COATING) {
        let escaped = refract_out(wo, s.host);
        if (escaped.w == 0.0) {
            return r;
        }
        wo = escaped.xyz;
    }
    r.wo = wo;
    r.pdf = layered_pdf(s, wi, wo);
    if (r.pdf > 0.0) {
        r.cos_over_pdf = wo.z / r.pdf;
    }
    return r;
}
