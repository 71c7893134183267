// Entry point: transmittance T = 1 - R of a rough Bragg layer's mirror at the difference angles
// of a transmission filter, laid out for bsdf/rough_layer_transmissivity.wgsl: [quad][wavelength][4],
// four consecutive angles per vec4. It writes straight into the buffer the product pass reads,
// so the two passes share one submission.
//! include "gpu/harness.wgsl"
//! include "gpu/numerics.wgsl"
//! include "gpu/complex.wgsl"
//! include "optics/layer.wgsl"
//! include "optics/yeh.wgsl"
//! include "bsdf/rough_layer_cells.wgsl"

// Rough layers see unpolarized light.
const UNPOLARIZED: u32 = 2u;
// host == n1 (a ballistic layer): Appendix D's complex host amplitude is compiled out.
override HOST_MATCHED: bool = true;
// A ballistic layer with an n2 layer: T averaged over each node's cell.
override CELL_MEANS: bool = true;

@group(0) @binding(0) var<storage, read> wavelength_nm: array<f32>;
@group(0) @binding(1) var<storage, read> theta: array<f32>;
// Bloch phases (s, p) at the cells' ends, [end][wavelength] (bsdf/rough_layer_phases.wgsl), where
// CELL_MEANS; a placeholder otherwise.
@group(0) @binding(2) var<storage, read> cell_phases: array<vec2<f32>>;
// 4 ceil(len(theta) / 4) x len(wavelength_nm) entries.
@group(0) @binding(3) var<storage, read_write> transmittance: array<f32>;
@group(0) @binding(4) var<uniform> mirror: BraggMirror;

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
    let node = min(angle, count - 1u);
    let column = (i % per_quad) / 4u;
    let wavelength = wavelength_nm[column];
    var value: f32;
    if (CELL_MEANS && mirror.bulk == 0u) {
        let columns = arrayLength(&wavelength_nm);
        value = cell_transmittance(mirror, cell_geometry(mirror, wavelength, theta[node]),
                                   cell_phases[node * columns + column],
                                   cell_phases[(node + 1u) * columns + column]);
    } else {
        value = 1.0 - bragg_reflectance(mirror, wavelength, theta[node], UNPOLARIZED,
                                        HOST_MATCHED);
    }
    transmittance[i] = select(0.0, value, angle < count);
}
