// Entry point: transmittance T = 1 - R of a rough Bragg layer's mirror at the difference angles
// of a transmission filter, laid out for integrate_transmissivity.wgsl: [quad][wavelength][4],
// four consecutive angles per vec4. It writes straight into the buffer the product pass reads,
// so the two passes share one submission.
//! include "harness.wgsl"
//! include "numerics.wgsl"
//! include "complex.wgsl"
//! include "layer.wgsl"
//! include "yeh.wgsl"

// Rough layers see unpolarized light.
const UNPOLARIZED: u32 = 2u;
// host == n1 (a ballistic layer): Appendix D's complex host amplitude is compiled out.
override HOST_MATCHED: bool = true;

@group(0) @binding(0) var<storage, read> wavelength_nm: array<f32>;
@group(0) @binding(1) var<storage, read> theta: array<f32>;
// 4 ceil(len(theta) / 4) x len(wavelength_nm) entries.
@group(0) @binding(2) var<storage, read_write> transmittance: array<f32>;
@group(0) @binding(3) var<uniform> mirror: BraggMirror;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = global_index(gid, nwg);
    if (i >= arrayLength(&transmittance)) {
        return;
    }
    let per_quad = 4u * arrayLength(&wavelength_nm);
    let angle = 4u * (i / per_quad) + i % 4u;
    let count = arrayLength(&theta);
    // Angles past the last one only pad the final quad: they meet zero weights. A clamped
    // index and a select rather than a branch, which lavapipe would run masked anyway.
    let reflectance = bragg_reflectance(mirror, wavelength_nm[(i % per_quad) / 4u],
                                        theta[min(angle, count - 1u)], UNPOLARIZED, HOST_MATCHED);
    transmittance[i] = select(0.0, 1.0 - reflectance, angle < count);
}
