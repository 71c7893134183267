// Entry point: integrated transmissivity of a rough Bragg layer (Fourneau, Pacanowski & Barla
// 2024, eq 28), f_t(theta_i) cos(theta_i) = sum_d weights[i, d] T[d, l], for every row i of a
// transmission filter (wgbragg/transmission_filter.py) and every wavelength l, given the
// transmittances T = 1 - R at the filter's difference angles (bragg_reflectance.wgsl).
// On lavapipe this product is bound by loads whose address differs between invocations
// (gathers). Each workgroup therefore holds a block of ROWS rows, the same for all its
// invocations (their weight reads are single loads), and a block of consecutive
// wavelengths, stored consecutively: each invocation reads its transmittances once, four
// difference angles at a time (angles zero-padded to a multiple of 4), and uses them for all
// ROWS rows.
//! include "harness.wgsl"

const ROWS: u32 = 8u;  // wgbragg.rough_layer._ROWS_PER_GROUP

struct TransmissivityParams {
    rows: u32,          // theta_i entries
    quads: u32,         // theta_d entries / 4
    wavelengths: u32,
    blocks: u32,        // ceil(wavelengths / WORKGROUP_SIZE): workgroups per block of rows
}

@group(0) @binding(0) var<storage, read> weights: array<vec4<f32>>;        // [rows][quads]
@group(0) @binding(1) var<storage, read> transmittance: array<vec4<f32>>;  // [quads][wavelengths]
@group(0) @binding(2) var<storage, read_write> transmissivity: array<f32>;  // [rows][wavelengths]
@group(0) @binding(3) var<uniform> params: TransmissivityParams;

// Rows past the table's end read row 0 (their sums are discarded).
fn row_offset(i: u32) -> u32 {
    return select(0u, i * params.quads, i < params.rows);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(local_invocation_index) lane: u32,
        @builtin(workgroup_id) group: vec3<u32>,
        @builtin(num_workgroups) groups: vec3<u32>) {
    let g = group.x + group.y * groups.x;
    let first = (g / params.blocks) * ROWS;
    let l = (g % params.blocks) * WORKGROUP_SIZE + lane;
    if (first >= params.rows || l >= params.wavelengths) {
        return;
    }
    let r0 = row_offset(first);
    let r1 = row_offset(first + 1u);
    let r2 = row_offset(first + 2u);
    let r3 = row_offset(first + 3u);
    let r4 = row_offset(first + 4u);
    let r5 = row_offset(first + 5u);
    let r6 = row_offset(first + 6u);
    let r7 = row_offset(first + 7u);
    var low = vec4<f32>(0.0);   // rows first .. first + 3
    var high = vec4<f32>(0.0);  // rows first + 4 .. first + 7
    for (var q = 0u; q < params.quads; q++) {
        let t = transmittance[q * params.wavelengths + l];
        low += vec4<f32>(dot(weights[r0 + q], t), dot(weights[r1 + q], t),
                         dot(weights[r2 + q], t), dot(weights[r3 + q], t));
        high += vec4<f32>(dot(weights[r4 + q], t), dot(weights[r5 + q], t),
                          dot(weights[r6 + q], t), dot(weights[r7 + q], t));
    }
    let sums = array<f32, 8>(low.x, low.y, low.z, low.w, high.x, high.y, high.z, high.w);
    for (var r = 0u; r < ROWS; r++) {
        if (first + r < params.rows) {
            transmissivity[(first + r) * params.wavelengths + l] = sums[r];
        }
    }
}
