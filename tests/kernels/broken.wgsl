// Test kernel: compiles only if broken_helper.wgsl does; it does not.
//! include "gpu/harness.wgsl"
//! include "broken_helper.wgsl"

@group(0) @binding(0) var<storage, read_write> out: array<f32>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    out[gid.x] = helper(1.0);
}
