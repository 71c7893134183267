// Entry point: the reflectance of a population of Bragg mirrors at shared (wavelength, angle)
// points, one invocation per (mirror, point), in one dispatch (wgbragg/design/population_gpu.py).
// The physics is optics/yeh.wgsl's bragg_reflectance, unchanged; only the mirror varies per
// invocation, read from storage instead of a uniform.
//! include "gpu/harness.wgsl"
//! include "design/population.wgsl"
//! include "gpu/numerics.wgsl"
//! include "gpu/complex.wgsl"
//! include "optics/layer.wgsl"
//! include "optics/yeh.wgsl"

// 0 = s, 1 = p, 2 = unpolarized.
override POLARIZATION: u32 = 2u;

@group(0) @binding(0) var<storage, read> mirrors: array<BraggMirror>;
// 1 where the member's host equals its n1 in float64 (eqs 2 and 9, no host interface).
@group(0) @binding(1) var<storage, read> matched: array<u32>;
// (wavelength nm, angle in the host in radians) of each point.
@group(0) @binding(2) var<storage, read> light: array<vec2<f32>>;
@group(0) @binding(3) var<storage, read_write> result: array<f32>;
@group(0) @binding(4) var<uniform> population: Population;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = global_index(gid, nwg);
    if (i >= arrayLength(&result)) {
        return;
    }
    let at = member_and_point(population, i);
    let point = light[at.y];
    result[i] = bragg_reflectance(mirrors[at.x], point.x, point.y, POLARIZATION,
                                  matched[at.x] != 0u);
}
