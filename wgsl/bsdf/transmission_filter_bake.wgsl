// Entry point: the transmission filter table, one invocation per (theta_i, theta_d) cell,
// row-major (row = theta_i). Angles are (cos, sin, cos/2, sin/2) as bsdf/transmission_filter.wgsl
// expects. One dispatch sums the psi samples first_sample .. first_sample + sample_count - 1
// (transmission_filter.PSI_SAMPLES_PER_DISPATCH, within the device's loop budget); the host adds
// the parts.
//! include "gpu/harness.wgsl"
//! include "gpu/numerics.wgsl"
//! include "bsdf/microfacet.wgsl"
//! include "bsdf/transmission_filter.wgsl"

struct BakeParams {
    alpha: f32,
    psi_samples: u32,
    first_sample: u32,
    sample_count: u32,
}

@group(0) @binding(0) var<storage, read> incident: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> difference: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> values: array<f32>;
@group(0) @binding(3) var<uniform> params: BakeParams;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let cell = global_index(gid, nwg);
    if (cell >= arrayLength(&values)) {
        return;
    }
    let n_d = arrayLength(&difference);
    values[cell] = transmission_filter(incident[cell / n_d], difference[cell % n_d],
                                       params.alpha, params.psi_samples, params.first_sample,
                                       params.sample_count);
}
