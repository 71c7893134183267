// The colour-matching table of the landmark colour kernels, as colour/landmark_methods.wgsl
// reads it (landmark_methods_gpu.cmf_table, packed by packed_cmf_table):
//   cmf[j] = density at node 360 + j nm (per nm, float32 bits) with w the slope of the cell
//   [j, j + 1] (density_slope_from_bits), cmf[471 + j] = the cumulative integral.
// No bindings: the entry point binds `cmf: array<vec4<u32>>`.

// Rows of the density block (checked by tests/test_wgsl_layouts.py).
const CMF_NODES: u32 = 471u;

fn cmf_density(j: u32) -> vec3<f32> {
    return bitcast<vec3<f32>>(cmf[j].xyz);
}

fn cmf_cumulative(j: u32) -> vec3<f32> {
    return bitcast<vec3<f32>>(cmf[CMF_NODES + j].xyz);
}

fn cmf_cell(j: u32) -> DensityCell {
    let row = cmf[j];
    return DensityCell(bitcast<vec3<f32>>(row.xyz), density_slope_from_bits(row.w));
}
