// Entry point: thin-film reflectance R(wavelength[i], theta[i]) by Airy summation.
//! include "gpu/harness.wgsl"
//! include "gpu/numerics.wgsl"
//! include "gpu/complex.wgsl"
//! include "optics/layer.wgsl"
//! include "optics/thin_film.wgsl"

// 0 = s, 1 = p, 2 = unpolarized.
override POLARIZATION: u32 = 2u;
// A dispersive base: its index (n, k) per element in base_index, replacing the uniform's.
override DISPERSIVE: bool = false;

@group(0) @binding(0) var<storage, read> wavelength_nm: array<f32>;
@group(0) @binding(1) var<storage, read> theta: array<f32>;
@group(0) @binding(2) var<storage, read> base_index: array<vec2<f32>>;  // one dummy if constant
@group(0) @binding(3) var<storage, read_write> reflectance: array<f32>;
@group(0) @binding(4) var<uniform> film: ThinFilm;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = global_index(gid, nwg);
    if (i >= arrayLength(&reflectance)) {
        return;
    }
    var f = film;
    if (DISPERSIVE) {
        f.n_base = base_index[i].x;
        f.k_base = base_index[i].y;
    }
    reflectance[i] = thin_film_reflectance(f, wavelength_nm[i], theta[i], POLARIZATION);
}
