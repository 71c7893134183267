// Entry point of scene/parameter_maps.wgsl, run by tests/test_parameter_maps.py against the numpy
// twin: one invocation per point, value[i] = parameter_map_value(map_index[i], uv[i]).
//! include "gpu/harness.wgsl"
//! include "scene/parameter_maps.wgsl"

@group(0) @binding(0) var<storage, read> map_records: array<ParameterMapRecord>;
@group(0) @binding(1) var<storage, read> map_texels: array<f32>;
@group(0) @binding(2) var<storage, read> uv: array<vec2<f32>>;
@group(0) @binding(3) var<storage, read> map_index: array<u32>;
@group(0) @binding(4) var<storage, read_write> value: array<f32>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let index = global_index(gid, nwg);
    if (index >= arrayLength(&value)) {
        return;
    }
    value[index] = parameter_map_value(map_index[index], uv[index]);
}
