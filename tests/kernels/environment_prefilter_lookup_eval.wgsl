// Test kernel: prefiltered_lookup of lighting/environment_prefilter_lookup.wgsl, for comparison with
// PrefilteredEnvironment.lookup. Per query (d.xyz, level), four vec4: (radiance, 0),
// (mean, 0), (xx, yy, zz, 0), (xy, yz, zx, 0).
//! include "gpu/harness.wgsl"
//! include "gpu/numerics.wgsl"
//! include "lighting/environment_prefilter_lookup.wgsl"

@group(0) @binding(0) var<storage, read> prefiltered_levels: array<PrefilteredLevel>;
@group(0) @binding(1) var<storage, read> prefiltered_texels: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> queries: array<vec4<f32>>;  // (d, level)
@group(0) @binding(3) var<storage, read_write> looked_up: array<vec4<f32>>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = global_index(gid, nwg);
    if (i >= arrayLength(&queries)) {
        return;
    }
    let query = queries[i];
    let p = prefiltered_lookup(u32(query.w), query.xyz);
    looked_up[4u * i] = vec4<f32>(p.radiance, 0.0);
    looked_up[4u * i + 1u] = vec4<f32>(p.mean, 0.0);
    looked_up[4u * i + 2u] = vec4<f32>(p.second_diagonal, 0.0);
    looked_up[4u * i + 3u] = vec4<f32>(p.second_off, 0.0);
}
