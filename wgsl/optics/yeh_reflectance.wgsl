// Entry point: Bragg-mirror reflectance (or transmittance) at point i by Yeh's closed form,
// from the point's geometry and phases formed on the host in float64
// (wgbragg/optics/yeh_gpu.py, point_inputs; optics/yeh.wgsl, point_geometry).
//! include "gpu/harness.wgsl"
//! include "gpu/numerics.wgsl"
//! include "gpu/complex.wgsl"
//! include "optics/layer.wgsl"
//! include "optics/yeh.wgsl"

// 0 = s, 1 = p, 2 = unpolarized.
override POLARIZATION: u32 = 2u;
// host == n1: eqs 2 and 9 need no complex amplitude (Appendix D is compiled out).
override HOST_MATCHED: bool = true;
// Write the transmittance T into the n1 substrate instead of the reflectance R.
override TRANSMITTANCE: bool = false;

// Per point, formed on the host in float64: s, cos theta and the layers' phases in turns
// reduced to [-1/2, 1/2] (optics/yeh.wgsl, point_geometry); and 1 / lambda.
@group(0) @binding(0) var<storage, read> points: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> inv_wavelength: array<f32>;
@group(0) @binding(2) var<storage, read_write> result: array<f32>;
@group(0) @binding(3) var<uniform> mirror: BraggMirror;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = global_index(gid, nwg);
    if (i >= arrayLength(&result)) {
        return;
    }
    let g = point_geometry(mirror, points[i], inv_wavelength[i]);
    let terms = bragg_point_terms(mirror, g, POLARIZATION, HOST_MATCHED);
    result[i] = select(terms.x, terms.y, TRANSMITTANCE);
}
