// Entry point: integrated transmissivity of a rough Bragg layer (Fourneau, Pacanowski & Barla
// 2024, eq 28), f_t(theta_i) cos(theta_i) = sum_d weights[i, d] T[d, l], for every row i of a
// transmission filter (wgbragg/transmission_filter.py) and every wavelength l, given the
// transmittances T = 1 - R at the filter's difference angles (bragg_reflectance.wgsl).
// On lavapipe this product is bound by loads whose address differs between invocations
// (gathers) rather than by arithmetic. Each invocation therefore computes a 4 x 4 block:
// ROWS rows, the same for the whole workgroup, times four wavelengths WORKGROUP_SIZE apart;
// per step it loads four weight and four transmittance vec4s (four difference angles each,
// zero-padded to a multiple of 4) for sixteen dot products.
//! include "harness.wgsl"

const ROWS: u32 = 4u;  // wgbragg.rough_layer._ROWS_PER_GROUP
const SPAN: u32 = 4u;  // wavelengths per invocation (wgbragg.rough_layer._WAVELENGTHS_PER_LANE)

struct TransmissivityParams {
    rows: u32,          // theta_i entries
    quads: u32,         // theta_d entries / 4
    wavelengths: u32,
    blocks: u32,        // ceil(wavelengths / (SPAN WORKGROUP_SIZE)): workgroups per row block
}

@group(0) @binding(0) var<storage, read> weights: array<vec4<f32>>;        // [rows][quads]
@group(0) @binding(1) var<storage, read> transmittance: array<vec4<f32>>;  // [quads][wavelengths]
@group(0) @binding(2) var<storage, read_write> transmissivity: array<f32>;  // [rows][wavelengths]
@group(0) @binding(3) var<uniform> params: TransmissivityParams;

// Rows and wavelengths past the table's end read entry 0 (their sums are discarded).
fn row_offset(i: u32) -> u32 {
    return select(0u, i * params.quads, i < params.rows);
}

fn column(l: u32) -> u32 {
    return select(0u, l, l < params.wavelengths);
}

fn store(i: u32, l: u32, value: f32) {
    if (i < params.rows && l < params.wavelengths) {
        transmissivity[i * params.wavelengths + l] = value;
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(local_invocation_index) lane: u32,
        @builtin(workgroup_id) group: vec3<u32>,
        @builtin(num_workgroups) groups: vec3<u32>) {
    let g = group.x + group.y * groups.x;
    let first = (g / params.blocks) * ROWS;
    let l0 = (g % params.blocks) * (SPAN * WORKGROUP_SIZE) + lane;
    if (first >= params.rows || l0 >= params.wavelengths) {
        return;
    }
    let r0 = row_offset(first);
    let r1 = row_offset(first + 1u);
    let r2 = row_offset(first + 2u);
    let r3 = row_offset(first + 3u);
    let c0 = column(l0);
    let c1 = column(l0 + WORKGROUP_SIZE);
    let c2 = column(l0 + 2u * WORKGROUP_SIZE);
    let c3 = column(l0 + 3u * WORKGROUP_SIZE);
    // acc_k: the four rows at wavelength k.
    var acc0 = vec4<f32>(0.0);
    var acc1 = vec4<f32>(0.0);
    var acc2 = vec4<f32>(0.0);
    var acc3 = vec4<f32>(0.0);
    for (var q = 0u; q < params.quads; q++) {
        let w = mat4x4<f32>(weights[r0 + q], weights[r1 + q], weights[r2 + q], weights[r3 + q]);
        let base = q * params.wavelengths;
        // t * w = (dot(w[0], t), ..., dot(w[3], t)).
        acc0 += transmittance[base + c0] * w;
        acc1 += transmittance[base + c1] * w;
        acc2 += transmittance[base + c2] * w;
        acc3 += transmittance[base + c3] * w;
    }
    let sums = array<vec4<f32>, 4>(acc0, acc1, acc2, acc3);
    for (var k = 0u; k < SPAN; k++) {
        let l = l0 + k * WORKGROUP_SIZE;
        store(first, l, sums[k].x);
        store(first + 1u, l, sums[k].y);
        store(first + 2u, l, sums[k].z);
        store(first + 3u, l, sums[k].w);
    }
}
