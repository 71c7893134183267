// Entry points of the single-reflection model (bsdf/layered/model.wgsl), one invocation per pair
// (wi, wo) or sample (wi, u), run by wgbragg/bsdf/layered/model_gpu.py:
//   evaluate:  f(wi, wo) at WAVELENGTHS wavelengths, or as linear sRGB  -> value
//   sample:    eq 35 from (wi, u = operand.xyz) -> directions = (wo, pdf), value = weights
//              (HERO: the colour from hero wavelengths offset by operand.w)
//   density:   pdf(wi, wo)                                             -> value
// value holds WAVELENGTHS floats per invocation (spectral) or 3 (RGB, WAVELENGTHS = 0); cut[0]
// becomes 1 if the device ended any invocation's loops early (wgbragg.gpu.loops), which
// the host refuses (one word for the dispatch, as bsdf/layered/simulation.wgsl, not one per
// invocation, which would add to the readback): the batching keeps the planned loops within budget, but a landmark
// colour's loops grow with the mirror's thickness in a way the host does not model.
//! include "gpu/harness.wgsl"
//! include "gpu/numerics.wgsl"
//! include "gpu/complex.wgsl"
//! include "optics/layer.wgsl"
//! include "optics/yeh.wgsl"
//! include "optics/landmarks.wgsl"
//! include "colour/landmark_methods.wgsl"
//! include "bsdf/microfacet.wgsl"
//! include "bsdf/layered/coating.wgsl"
//! include "bsdf/layered/model.wgsl"
//! include "colour/colorimetry_hero.wgsl"

// Wavelengths per invocation, sharing its directions (multiplexing); 0: RGB.
override WAVELENGTHS: u32 = 0u;
// sample in RGB: the colour from four hero wavelengths offset by u.w, not the 471 nodes.
override HERO: bool = false;
// sample: u comes as a point set digitally shifted per group of operand_repeat consecutive
// invocations (wgbragg.common.sampling.ShiftedPoints): operand rows 0 .. operand_repeat - 1 hold the
// points' digits, the rows after them one shift per group, as u32 bits.
override SHIFTED_OPERAND: bool = false;
// Spectral: the layers' transmissivity tables read as cell corners (transmissivity_quads),
// where they fit gpu.bilinear_quads_fit; else from `tables`, four loads per lookup.
override TRANSMISSIVITY_QUADS: bool = true;

struct Params {
    structure: LayeredStructure,
    count: u32,               // invocations
    wavelength_stride: u32,   // WAVELENGTHS, or 0 when every invocation has the same ones
    incoming_repeat: u32,     // consecutive invocations sharing one wi (e.g. a pixel's samples)
    operand_repeat: u32,      // ... sharing one wo or u (SHIFTED_OPERAND: points per group)
}

@group(0) @binding(0) var<storage, read> incoming: array<vec4<f32>>;   // wi (xyz)
// wo, or u of sample: f32 bits, or SHIFTED_OPERAND's digits (u32 words, so that no digit
// pattern is ever loaded as a float: some would be NaNs, which WGSL may assume away).
@group(0) @binding(1) var<storage, read> operand: array<vec4<u32>>;
@group(0) @binding(2) var<storage, read> wavelengths: array<f32>;      // nm
@group(0) @binding(3) var<storage, read> layers: array<RoughLayer>;
@group(0) @binding(4) var<storage, read> tables: array<f32>;
// Per 1 nm node (360..830 nm): its linear sRGB weights (node_rgb_weights) and the base's albedo
// (0 over an absorbing base), one load for what `tables` holds in four.
@group(0) @binding(5) var<storage, read> node_colours: array<vec4<f32>>;
// Each layer's transmissivity table (rows x 471) as the corners of its cells, from the quad at
// RoughLayer.transmissivity_elsewhere: a bilinear lookup in one load, not four.
@group(0) @binding(6) var<storage, read> transmissivity_quads: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> value: array<f32>;
@group(0) @binding(8) var<storage, read_write> directions: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read_write> cut: array<u32>;
@group(0) @binding(10) var<uniform> params: Params;

// Every writer stores the same value, so the race is harmless.
fn report_cut() {
    if (loops_were_cut(params.count)) {
        cut[0] = 1u;
    }
}

fn layer_transmissivity(layer: RoughLayer, row: Lerp, column: Lerp) -> f32 {
    if (!TRANSMISSIVITY_QUADS) {
        return table_bilinear(layer.transmissivity, row, column);
    }
    let q = transmissivity_quads[layer.transmissivity_elsewhere
                                 + row.index * (VISIBLE_NODES - 1u) + column.index];
    return mix(mix(q.x, q.y, column.fraction), mix(q.z, q.w, column.fraction), row.fraction);
}

fn wavelength_at(index: u32, k: u32) -> f32 {
    return wavelengths[index * params.wavelength_stride + k];
}

fn incoming_at(index: u32) -> vec3<f32> {
    return incoming[index / params.incoming_repeat].xyz;
}

fn operand_at(index: u32) -> vec4<f32> {
    if (SHIFTED_OPERAND) {
        // The top 23 bits of the shifted digits as the mantissa of a float in [1, 2), minus 1:
        // exactly ShiftedPoints.values.
        let points = params.operand_repeat;
        let digits = operand[index % points] ^ operand[points + index / points];
        return bitcast<vec4<f32>>((digits >> vec4<u32>(9u)) | vec4<u32>(0x3f800000u)) - 1.0;
    }
    return bitcast<vec4<f32>>(operand[index / params.operand_repeat]);
}

fn store_rgb(index: u32, rgb: vec3<f32>) {
    value[3u * index] = rgb.x;
    value[3u * index + 1u] = rgb.y;
    value[3u * index + 2u] = rgb.z;
}

fn hero_cdf_node(j: u32) -> f32 {
    return tables[HERO_INVERSE_CDF + j];
}

fn node_colour(wavelength_nm: f32) -> vec4<f32> {
    let at = wavelength_lerp(wavelength_nm);
    return mix(node_colours[at.index], node_colours[at.index + 1u], at.fraction);
}

// The colour of the spectral f at four hero wavelengths: an unbiased estimate of
// layered_eval_rgb's INTEGRATED colour. Each wavelength's rgb weights and base albedo come in
// one vec4 pair rather than scalar loads from `tables`; four named values, not a private array
// (docs/performance.md, "Layered structures").
fn layered_eval_hero(s: LayeredStructure, pair: LayeredPair, offset: f32) -> vec3<f32> {
    let hero = hero_wavelengths(offset);
    let c0 = node_colour(hero.nm.x);
    let c1 = node_colour(hero.nm.y);
    let c2 = node_colour(hero.nm.z);
    let c3 = node_colour(hero.nm.w);
    let albedo = vec4<f32>(c0.w, c1.w, c2.w, c3.w);
    let f = layered_eval_spectral4_over(s, pair, hero.nm, albedo) * hero.scale;
    return f.x * c0.xyz + f.y * c1.xyz + f.z * c2.xyz + f.w * c3.xyz;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn evaluate(@builtin(global_invocation_id) gid: vec3<u32>,
            @builtin(num_workgroups) nwg: vec3<u32>) {
    let index = global_index(gid, nwg);
    if (index >= params.count) {
        return;
    }
    let s = params.structure;
    let pair = layered_pair(s, incoming_at(index), operand_at(index).xyz);
    if (WAVELENGTHS == 0u) {
        store_rgb(index, layered_eval_rgb(s, pair));
    } else {
        for (var k = 0u; k < WAVELENGTHS; k++) {
            value[index * WAVELENGTHS + k] =
                layered_eval_spectral(s, pair, wavelength_at(index, k));
        }
    }
    report_cut();
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn sample(@builtin(global_invocation_id) gid: vec3<u32>,
          @builtin(num_workgroups) nwg: vec3<u32>) {
    let index = global_index(gid, nwg);
    if (index >= params.count) {
        return;
    }
    let s = params.structure;
    let wi = incoming_at(index);
    let u = operand_at(index);
    let drawn = layered_sample(s, wi, u.xyz);
    directions[index] = vec4<f32>(drawn.wo, drawn.pdf);
    // The Dirac lobe and rejected directions need no evaluation.
    let continuous = drawn.cos_over_pdf > 0.0;
    let pair = layered_pair(s, wi, drawn.wo);
    if (WAVELENGTHS == 0u) {
        var weight = vec3<f32>(drawn.dirac);
        if (continuous && HERO) {
            weight += layered_eval_hero(s, pair, u.w) * drawn.cos_over_pdf;
        } else if (continuous) {
            weight += layered_eval_rgb(s, pair) * drawn.cos_over_pdf;
        }
        store_rgb(index, weight);
    } else {
        for (var k = 0u; k < WAVELENGTHS; k++) {
            var weight = drawn.dirac;
            if (continuous) {
                weight += layered_eval_spectral(s, pair, wavelength_at(index, k))
                    * drawn.cos_over_pdf;
            }
            value[index * WAVELENGTHS + k] = weight;
        }
    }
    report_cut();
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn density(@builtin(global_invocation_id) gid: vec3<u32>,
           @builtin(num_workgroups) nwg: vec3<u32>) {
    let index = global_index(gid, nwg);
    if (index >= params.count) {
        return;
    }
    value[index] = layered_pdf(params.structure, incoming_at(index), operand_at(index).xyz);
    report_cut();
}
