// Entry point: D65-weighted XYZ of a thin film, one invocation per angle theta[i]:
//   xyz[i] = sum_k R(wavelength_nm[k], theta[i]) weights[k].xyz,  R unpolarized (mean of s, p).
// Twin of colour/reference_bragg.wgsl for wgbragg.ThinFilm, chunked alike (at most
// reference_gpu.chunk_nodes() nodes per dispatch). Plain float32 sum, as there
// (docs/performance.md, '"spectral": samples against error').
//! include "gpu/harness.wgsl"
//! include "gpu/numerics.wgsl"
//! include "gpu/complex.wgsl"
//! include "optics/layer.wgsl"
//! include "optics/thin_film.wgsl"

// A dispersive base: its index (n, k) at node k in base_index, replacing the uniform's.
override DISPERSIVE: bool = false;

@group(0) @binding(0) var<storage, read> wavelength_nm: array<f32>;
@group(0) @binding(1) var<storage, read> weights: array<vec4<f32>>;  // xyz weight, w unused
@group(0) @binding(2) var<storage, read> base_index: array<vec2<f32>>;  // one dummy if constant
@group(0) @binding(3) var<storage, read> theta: array<f32>;
@group(0) @binding(4) var<storage, read_write> xyz: array<vec4<f32>>;  // w = 0
@group(0) @binding(5) var<uniform> film: ThinFilm;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = global_index(gid, nwg);
    if (i >= arrayLength(&xyz)) {
        return;
    }
    let angle = theta[i];
    var f = film;
    var acc = vec3<f32>(0.0);
    for (var k = 0u; k < arrayLength(&wavelength_nm); k++) {
        if (DISPERSIVE) {
            f.n_base = base_index[k].x;
            f.k_base = base_index[k].y;
        }
        let r = thin_film_reflectance(f, wavelength_nm[k], angle, 2u);
        acc += r * weights[k].xyz;
    }
    xyz[i] = vec4<f32>(acc, 0.0);
}
