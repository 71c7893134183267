// Entry point: integrated transmissivity of a rough Bragg layer (Fourneau, Pacanowski & Barla
// 2024, eq 28), f_t(theta_i) cos(theta_i) = sum_d weights[i, d] T[d, l], for every row i of a
// transmission filter (wgbragg/bsdf/transmission_filter.py) and every wavelength l, given the
// transmittances T = 1 - R at the filter's difference angles (bsdf/rough_layer_transmittance.wgsl).
// On lavapipe this product is bound by loads whose address differs between invocations (each
// is a loop over the SIMD lanes) rather than by arithmetic, so each invocation computes a
// block of ROWS x SPAN sums: ROWS rows, the same for the whole workgroup, times SPAN
// wavelengths WORKGROUP_SIZE apart. Per step it loads ROWS weight texels and SPAN transmittance
// vec4s (four difference angles each, zero-padded to a multiple of 4) for 4 ROWS SPAN
// multiply-adds. The weights are a texture because a texel fetch reads a whole vec4 per lane
// at once, which makes it cheaper there than a storage load. The block is written out: as
// arrays indexed by loop counters, lavapipe keeps the sums in memory, which is slower
// (docs/performance.md, "Rough Bragg layers").
//! include "gpu/harness.wgsl"

// Rows per workgroup and wavelengths per invocation: written out below (four weight matrices,
// twelve sums), so they cannot be override constants. tests/test_wgsl_layouts.py checks them
// against rough_layer._ROWS_PER_GROUP and _WAVELENGTHS_PER_LANE and against the written-out code.
const ROWS: u32 = 16u;
const SPAN: u32 = 12u;

struct TransmissivityParams {
    rows: u32,          // theta_i entries
    quads: u32,         // theta_d entries / 4
    wavelengths: u32,
    blocks: u32,        // ceil(wavelengths / (SPAN WORKGROUP_SIZE)): workgroups per row block
}

@group(0) @binding(0) var weights: texture_2d<f32>;                       // texel (quad, row)
@group(0) @binding(1) var<storage, read> transmittance: array<vec4<f32>>;  // [quads][wavelengths]
@group(0) @binding(2) var<storage, read_write> transmissivity: array<f32>;  // [rows][wavelengths]
@group(0) @binding(3) var<uniform> params: TransmissivityParams;

// Column k holds the weights of row first + k at quad q. Rows past the table's end repeat the
// last one (their sums are discarded).
fn weight_rows(q: u32, first: u32) -> mat4x4<f32> {
    let last = params.rows - 1u;
    return mat4x4<f32>(textureLoad(weights, vec2<u32>(q, min(first, last)), 0),
                       textureLoad(weights, vec2<u32>(q, min(first + 1u, last)), 0),
                       textureLoad(weights, vec2<u32>(q, min(first + 2u, last)), 0),
                       textureLoad(weights, vec2<u32>(q, min(first + 3u, last)), 0));
}

// Wavelengths past the table's end read entry 0 (their sums are discarded).
fn column(l: u32) -> u32 {
    return select(0u, l, l < params.wavelengths);
}

// One quad's contribution to the ROWS sums of one wavelength: column j holds rows 4j .. 4j + 3
// (t * w = (dot(w[0], t), ..., dot(w[3], t))).
fn quad_sums(t: vec4<f32>, w0: mat4x4<f32>, w1: mat4x4<f32>, w2: mat4x4<f32>,
             w3: mat4x4<f32>) -> mat4x4<f32> {
    return mat4x4<f32>(t * w0, t * w1, t * w2, t * w3);
}

fn store(first: u32, l: u32, sums: mat4x4<f32>) {
    if (l >= params.wavelengths) {
        return;
    }
    for (var k = 0u; k < ROWS; k++) {
        let i = first + k;
        if (i < params.rows) {
            transmissivity[i * params.wavelengths + l] = sums[k / 4u][k % 4u];
        }
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
    let c0 = column(l0);
    let c1 = column(l0 + WORKGROUP_SIZE);
    let c2 = column(l0 + 2u * WORKGROUP_SIZE);
    let c3 = column(l0 + 3u * WORKGROUP_SIZE);
    let c4 = column(l0 + 4u * WORKGROUP_SIZE);
    let c5 = column(l0 + 5u * WORKGROUP_SIZE);
    let c6 = column(l0 + 6u * WORKGROUP_SIZE);
    let c7 = column(l0 + 7u * WORKGROUP_SIZE);
    let c8 = column(l0 + 8u * WORKGROUP_SIZE);
    let c9 = column(l0 + 9u * WORKGROUP_SIZE);
    let c10 = column(l0 + 10u * WORKGROUP_SIZE);
    let c11 = column(l0 + 11u * WORKGROUP_SIZE);
    // s_k: the ROWS sums at wavelength l0 + k WORKGROUP_SIZE.
    var s0 = mat4x4<f32>();
    var s1 = mat4x4<f32>();
    var s2 = mat4x4<f32>();
    var s3 = mat4x4<f32>();
    var s4 = mat4x4<f32>();
    var s5 = mat4x4<f32>();
    var s6 = mat4x4<f32>();
    var s7 = mat4x4<f32>();
    var s8 = mat4x4<f32>();
    var s9 = mat4x4<f32>();
    var s10 = mat4x4<f32>();
    var s11 = mat4x4<f32>();
    for (var q = 0u; q < params.quads; q++) {
        let w0 = weight_rows(q, first);
        let w1 = weight_rows(q, first + 4u);
        let w2 = weight_rows(q, first + 8u);
        let w3 = weight_rows(q, first + 12u);
        let base = q * params.wavelengths;
        s0 += quad_sums(transmittance[base + c0], w0, w1, w2, w3);
        s1 += quad_sums(transmittance[base + c1], w0, w1, w2, w3);
        s2 += quad_sums(transmittance[base + c2], w0, w1, w2, w3);
        s3 += quad_sums(transmittance[base + c3], w0, w1, w2, w3);
        s4 += quad_sums(transmittance[base + c4], w0, w1, w2, w3);
        s5 += quad_sums(transmittance[base + c5], w0, w1, w2, w3);
        s6 += quad_sums(transmittance[base + c6], w0, w1, w2, w3);
        s7 += quad_sums(transmittance[base + c7], w0, w1, w2, w3);
        s8 += quad_sums(transmittance[base + c8], w0, w1, w2, w3);
        s9 += quad_sums(transmittance[base + c9], w0, w1, w2, w3);
        s10 += quad_sums(transmittance[base + c10], w0, w1, w2, w3);
        s11 += quad_sums(transmittance[base + c11], w0, w1, w2, w3);
    }
    store(first, l0, s0);
    store(first, l0 + WORKGROUP_SIZE, s1);
    store(first, l0 + 2u * WORKGROUP_SIZE, s2);
    store(first, l0 + 3u * WORKGROUP_SIZE, s3);
    store(first, l0 + 4u * WORKGROUP_SIZE, s4);
    store(first, l0 + 5u * WORKGROUP_SIZE, s5);
    store(first, l0 + 6u * WORKGROUP_SIZE, s6);
    store(first, l0 + 7u * WORKGROUP_SIZE, s7);
    store(first, l0 + 8u * WORKGROUP_SIZE, s8);
    store(first, l0 + 9u * WORKGROUP_SIZE, s9);
    store(first, l0 + 10u * WORKGROUP_SIZE, s10);
    store(first, l0 + 11u * WORKGROUP_SIZE, s11);
}
