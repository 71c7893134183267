// Entry point: the "averaged" colour (D65 XYZ, both polarisations averaged) of a population of
// Bragg mirrors at shared angles, one invocation per (mirror, angle), in one dispatch
// (wgbragg/design/population_gpu.py, population_xyz). The physics is
// colour/landmark_methods.wgsl's landmark_colour_unpolarized, unchanged: N, the host and the
// layer flags are read per member at run time instead of specialising a pipeline per mirror.
//! include "gpu/harness.wgsl"
//! include "design/population.wgsl"
//! include "gpu/numerics.wgsl"
//! include "gpu/complex.wgsl"
//! include "optics/layer.wgsl"
//! include "optics/yeh.wgsl"
//! include "optics/landmarks.wgsl"
//! include "colour/landmark_methods.wgsl"
//! include "colour/landmark_methods_cmf.wgsl"

@group(0) @binding(0) var<storage, read> mirrors: array<BraggMirror>;
// 1 where the member's host equals its n1 in float64 (eqs 2 and 9, no host interface).
@group(0) @binding(1) var<storage, read> matched: array<u32>;
// Angle in the host (radians) of each point.
@group(0) @binding(2) var<storage, read> theta: array<f32>;
@group(0) @binding(3) var<storage, read> cmf: array<vec4<u32>>;
// w = 1 where the device's loop budget cut the loops short.
@group(0) @binding(4) var<storage, read_write> xyz: array<vec4<f32>>;
@group(0) @binding(5) var<uniform> population: Population;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = global_index(gid, nwg);
    if (i >= arrayLength(&xyz)) {
        return;
    }
    let at = member_and_point(population, i);
    let m = mirrors[at.x];
    let host_matched = matched[at.x] != 0u;
    // landmark_methods_gpu's MATCHED_LAYERS: host == n1 <= n2 with an n2 layer.
    let matched_layers = host_matched && m.bulk == 0u && m.n2 >= m.n1;
    let colour = landmark_colour_unpolarized(m, theta[at.y], METHOD_AVERAGED, 0,
                                             host_matched, matched_layers);
    xyz[i] = vec4<f32>(colour, f32(loops_were_cut(m.periods)));
}
