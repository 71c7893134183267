// Entry point: thin-film reflectance (or transmittance) at point i by Airy summation, from
// the point's geometry and phase formed on the host in float64
// (wgbragg/optics/thin_film_gpu.py, point_inputs; optics/thin_film.wgsl, film_point_geometry).
//! include "gpu/harness.wgsl"
//! include "gpu/numerics.wgsl"
//! include "gpu/complex.wgsl"
//! include "optics/layer.wgsl"
//! include "optics/thin_film.wgsl"

// 0 = s, 1 = p, 2 = unpolarized.
override POLARIZATION: u32 = 2u;
// A dispersive base: its index (n, k) per element in base_index, replacing the uniform's.
override DISPERSIVE: bool = false;
// Write the flux entering the base (tmm's T) instead of the reflectance R.
override TRANSMITTANCE: bool = false;

// Per point, formed on the host in float64: s, cos theta, the film's phase in turns reduced
// to [-1/2, 1/2], 1 / lambda (optics/thin_film.wgsl, film_point_geometry).
@group(0) @binding(0) var<storage, read> points: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> base_index: array<vec2<f32>>;  // one dummy if constant
@group(0) @binding(2) var<storage, read_write> result: array<f32>;
@group(0) @binding(3) var<uniform> film: ThinFilm;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = global_index(gid, nwg);
    if (i >= arrayLength(&result)) {
        return;
    }
    var f = film;
    if (DISPERSIVE) {
        f.n_base = base_index[i].x;
        f.k_base = base_index[i].y;
    }
    let terms = thin_film_terms_at(f, film_point_geometry(f, points[i]), POLARIZATION);
    result[i] = select(terms.x, terms.y, TRANSMITTANCE);
}
