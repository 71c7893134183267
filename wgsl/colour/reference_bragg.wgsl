// Entry point: D65-weighted XYZ of a Bragg mirror, one invocation per angle theta_i:
//   xyz[i] = sum_k R(lambda_k, theta_i) weights[k].xyz,  R unpolarized (mean of s, p).
// The host passes the quadrature: 1 nm nodes for the reference, K strata for "spectral"
// (wgbragg/colour/reference.py), at most reference_gpu.chunk_nodes() per dispatch: a device with a
// loop budget would end a longer loop early (wgbragg/gpu/loops.py), so wgbragg/colour/reference_gpu.py
// sums chunks of nodes.
// The angle's fields come from the host in float64 (optics/yeh.wgsl, angle_geometry_given), the layer
// phases from optical paths and 1 / lambda split on the host (split_cycles), so their fractions
// keep float32's accuracy whatever the phase, which matters with a few heavily weighted nodes
// ("spectral") at a sharp resonance. Plain float32 sum: its rounding (bound 470 ulp relative)
// is far below the reflectance's own float32 error, and a Kahan carry would be folded away by
// the driver's float reassociation (docs/performance.md, '"spectral": samples against
// error').
//! include "gpu/harness.wgsl"
//! include "gpu/numerics.wgsl"
//! include "gpu/complex.wgsl"
//! include "optics/layer.wgsl"
//! include "optics/yeh.wgsl"

// host == n1: eqs 2 and 9 need no complex amplitude (Appendix D is compiled out).
override HOST_MATCHED: bool = true;

@group(0) @binding(0) var<storage, read> inv_wavelength: array<vec2<f32>>;  // 1 / lambda, split
@group(0) @binding(1) var<storage, read> weights: array<vec4<f32>>;  // xyz weight, w unused
// Per angle, formed on the host in float64 (wgbragg/colour/reference_gpu.py, angle_inputs).
struct AngleInputs {
    geometry: vec4<f32>,  // s, cos theta, q1, q2^2
    paths: vec4<f32>,     // q1 d1 and q2 d2 (nm), split as split_cycles reads them
}

@group(0) @binding(2) var<storage, read> angles: array<AngleInputs>;
@group(0) @binding(3) var<storage, read_write> xyz: array<vec4<f32>>;  // w = 0
@group(0) @binding(4) var<uniform> mirror: BraggMirror;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = global_index(gid, nwg);
    if (i >= arrayLength(&xyz)) {
        return;
    }
    let inputs = angles[i];
    let angle = angle_geometry_given(inputs.geometry);
    let paths = inputs.paths;
    var acc = vec3<f32>(0.0);
    for (var k = 0u; k < arrayLength(&inv_wavelength); k++) {
        let g = geometry_at_split(mirror, angle, inv_wavelength[k], paths);
        let r = bragg_reflectance_at(mirror, g, 2u, HOST_MATCHED);
        acc += r * weights[k].xyz;
    }
    xyz[i] = vec4<f32>(acc, 0.0);
}
