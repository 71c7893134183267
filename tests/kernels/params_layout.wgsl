// Test kernel: copies every field of a mixed-layout uniform into a u32 array
// (bit patterns, so the round trip is exact). Mirrors test_gpu_harness.PARAMS_FIELDS.
//! include "gpu/harness.wgsl"

struct Params {
    a: f32,
    v3: vec3<f32>,
    k: u32,
    v2: vec2<f32>,
    i: i32,
}

@group(0) @binding(0) var<storage, read_write> out: array<u32>;
@group(0) @binding(1) var<uniform> params: Params;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x != 0u) { return; }
    out[0] = bitcast<u32>(params.a);
    out[1] = bitcast<u32>(params.v3.x);
    out[2] = bitcast<u32>(params.v3.y);
    out[3] = bitcast<u32>(params.v3.z);
    out[4] = params.k;
    out[5] = bitcast<u32>(params.v2.x);
    out[6] = bitcast<u32>(params.v2.y);
    out[7] = bitcast<u32>(params.i);
}
