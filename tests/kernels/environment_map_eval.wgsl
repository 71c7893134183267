// Entry point of the environment map (lighting/environment_map.wgsl) for its tests, one invocation per
// (u, d) pair:
//   evaluate:  sampled = (environment_map_sample(u), environment_map_pdf of that direction),
//              looked_up = (environment_map_radiance(d), environment_map_pdf(d))
//! include "gpu/harness.wgsl"
//! include "gpu/numerics.wgsl"
//! include "lighting/environment_map.wgsl"

@group(0) @binding(0) var<storage, read> environment_texels: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> uniforms: array<vec2<f32>>;    // u in [0, 1)^2
@group(0) @binding(2) var<storage, read> directions: array<vec4<f32>>;  // d (xyz), unit
@group(0) @binding(3) var<storage, read_write> sampled: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> looked_up: array<vec4<f32>>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn evaluate(@builtin(global_invocation_id) gid: vec3<u32>,
            @builtin(num_workgroups) nwg: vec3<u32>) {
    let index = global_index(gid, nwg);
    if (index >= arrayLength(&sampled)) {
        return;
    }
    let wo = environment_map_sample(uniforms[index]);
    sampled[index] = vec4<f32>(wo, environment_map_pdf(wo));
    let d = directions[index].xyz;
    looked_up[index] = vec4<f32>(environment_map_radiance(d), environment_map_pdf(d));
}
