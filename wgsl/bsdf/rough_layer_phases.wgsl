// Entry point: Bloch phases K Lambda (s, p), in turns, of a rough Bragg layer's mirror at the
// ends of the cells of a transmission filter's difference angles, [end][wavelength]: what
// bsdf/rough_layer_transmittance.wgsl's cell means read. Neighbouring cells share an end, so each is
// computed once (the cell means would otherwise evaluate both ends of every cell).
//! include "gpu/harness.wgsl"
//! include "gpu/numerics.wgsl"
//! include "gpu/complex.wgsl"
//! include "optics/layer.wgsl"
//! include "optics/yeh.wgsl"
//! include "bsdf/rough_layer_cells.wgsl"

@group(0) @binding(0) var<storage, read> wavelength_nm: array<f32>;
// rough_layer.cell_edges: len(theta_d) + 1 ends.
@group(0) @binding(1) var<storage, read> cell_ends: array<f32>;
@group(0) @binding(2) var<storage, read_write> phases: array<vec2<f32>>;
@group(0) @binding(3) var<uniform> mirror: BraggMirror;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = global_index(gid, nwg);
    if (i >= arrayLength(&phases)) {
        return;
    }
    let columns = arrayLength(&wavelength_nm);
    let g = cell_geometry(mirror, wavelength_nm[i % columns], cell_ends[i / columns]);
    phases[i] = vec2<f32>(bloch_turns(cell_terms(mirror, g, 0u)),
                          bloch_turns(cell_terms(mirror, g, 1u)));
}
