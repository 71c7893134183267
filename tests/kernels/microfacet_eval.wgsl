// Test kernel: the GGX functions of bsdf/microfacet.wgsl at one roughness, for comparison with
// wgbragg.bsdf.microfacet. Per element: values = (D(m_z), G1(wi_z), pdf(wi, m), 0) and
// sampled = (m(wi, u), 0). Directions are vec4 with w unused (the storage stride of vec3).
//! include "gpu/harness.wgsl"
//! include "gpu/numerics.wgsl"
//! include "bsdf/microfacet.wgsl"

struct Params { alpha: f32 }

@group(0) @binding(0) var<storage, read> wi: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> m: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> u: array<vec2<f32>>;
@group(0) @binding(3) var<storage, read_write> values: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> sampled: array<vec4<f32>>;
@group(0) @binding(5) var<uniform> params: Params;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = global_index(gid, nwg);
    if (i >= arrayLength(&values)) {
        return;
    }
    let a = params.alpha;
    let w = wi[i].xyz;
    values[i] = vec4<f32>(ggx_D(m[i].z, a), ggx_G1(w.z, a), ggx_visible_normal_pdf(w, m[i].xyz, a),
                          0.0);
    sampled[i] = vec4<f32>(ggx_sample_visible_normal(w, u[i], a), 0.0);
}
