// Entry point: D65-weighted XYZ of a Bragg mirror, one invocation per angle theta[i]:
//   xyz[i] = sum_k R(wavelength_nm[k], theta[i]) weights[k].xyz,  R unpolarized (mean of s, p).
// The host passes the quadrature: 1 nm nodes for the reference, K strata for "spectral"
// (wgbragg/colour_reference.py), at most gpu.SAFE_LOOP_ITERATIONS per dispatch: llvmpipe would end
// a longer loop early (wgbragg/gpu.py, "Loop budget"), so colour_gpu.py sums chunks of nodes.
// Plain float32 sum: its rounding (bound 470 ulp relative, 1.3e-6 measured) is far below the
// reflectance's own float32 error; a Kahan carry would be folded away by the driver's float
// reassociation (measured).
//! include "harness.wgsl"
//! include "numerics.wgsl"
//! include "complex.wgsl"
//! include "layer.wgsl"
//! include "yeh.wgsl"

// host == n1: eqs 2 and 9 need no complex amplitude (Appendix D is compiled out).
override HOST_MATCHED: bool = true;

@group(0) @binding(0) var<storage, read> wavelength_nm: array<f32>;
@group(0) @binding(1) var<storage, read> weights: array<vec4<f32>>;  // xyz weight, w unused
@group(0) @binding(2) var<storage, read> theta: array<f32>;
@group(0) @binding(3) var<storage, read_write> xyz: array<vec4<f32>>;  // w = 0
@group(0) @binding(4) var<uniform> mirror: BraggMirror;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = global_index(gid, nwg);
    if (i >= arrayLength(&xyz)) {
        return;
    }
    let angle = angle_geometry(mirror, theta[i]);
    var acc = vec3<f32>(0.0);
    for (var k = 0u; k < arrayLength(&wavelength_nm); k++) {
        let g = geometry_at(mirror, angle, wavelength_nm[k]);
        let r = bragg_reflectance_at(mirror, g, 2u, HOST_MATCHED);
        acc += r * weights[k].xyz;
    }
    xyz[i] = vec4<f32>(acc, 0.0);
}
