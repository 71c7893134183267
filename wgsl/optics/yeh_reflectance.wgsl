// Entry point: Bragg-mirror reflectance R(wavelength[i], theta[i]) by Yeh's closed form.
//! include "gpu/harness.wgsl"
//! include "gpu/numerics.wgsl"
//! include "gpu/complex.wgsl"
//! include "optics/layer.wgsl"
//! include "optics/yeh.wgsl"

// 0 = s, 1 = p, 2 = unpolarized.
override POLARIZATION: u32 = 2u;
// host == n1: eqs 2 and 9 need no complex amplitude (Appendix D is compiled out).
override HOST_MATCHED: bool = true;

@group(0) @binding(0) var<storage, read> wavelength_nm: array<f32>;
@group(0) @binding(1) var<storage, read> theta: array<f32>;
@group(0) @binding(2) var<storage, read_write> reflectance: array<f32>;
@group(0) @binding(3) var<uniform> mirror: BraggMirror;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = global_index(gid, nwg);
    if (i >= arrayLength(&reflectance)) {
        return;
    }
    reflectance[i] = bragg_reflectance(mirror, wavelength_nm[i], theta[i], POLARIZATION,
                                       HOST_MATCHED);
}
