// Entry point: the reflectance of a population of planar stacks at shared (wavelength, angle)
// points, one invocation per (stack, point), in one dispatch (wgbragg/design/stack_gpu.py).
// Every stack has `layers` layers (shorter ones padded with d = 0, an identity matrix); the
// physics is design/stack.wgsl.
//! include "gpu/harness.wgsl"
//! include "design/population.wgsl"
//! include "gpu/numerics.wgsl"
//! include "gpu/complex.wgsl"
//! include "optics/layer.wgsl"
//! include "design/stack.wgsl"

// 0 = s, 1 = p, 2 = unpolarized.
override POLARIZATION: u32 = 2u;

// (n, d in nm) of every layer, stack-major, from the host down.
@group(0) @binding(0) var<storage, read> layers: array<vec2<f32>>;
// (host index, base n, base k, 0) of each stack.
@group(0) @binding(1) var<storage, read> media: array<vec4<f32>>;
// (1 / wavelength in 1/nm, sin theta, cos theta, 0) of each point, formed in float64.
@group(0) @binding(2) var<storage, read> light: array<vec4<f32>>;
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
    let medium = media[at.x];
    let host = medium.x;
    var seen: StackLight;
    seen.s = host * point.y;
    seen.host_cos = host * point.z;
    seen.inv_wavelength = point.x;
    var a = stack_base(host, medium.y, medium.z, seen);
    let first = at.x * population.layers;
    for (var j = population.layers; j > 0u; j--) {
        let layer = layers[first + j - 1u];
        a = stack_layer(a, host, layer.x, layer.y, seen);
    }
    result[i] = stack_reflectance(a, host, seen, POLARIZATION);
}
