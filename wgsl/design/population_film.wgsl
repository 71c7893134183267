// Entry point: the reflectance of a population of thin films at shared (wavelength, angle)
// points, one invocation per (film, point), in one dispatch (wgbragg/design/population_gpu.py).
// The physics is optics/thin_film.wgsl's thin_film_reflectance, unchanged; only the film
// varies per invocation, read from storage instead of a uniform.
//! include "gpu/harness.wgsl"
//! include "design/population.wgsl"
//! include "gpu/numerics.wgsl"
//! include "gpu/complex.wgsl"
//! include "optics/layer.wgsl"
//! include "optics/thin_film.wgsl"

// 0 = s, 1 = p, 2 = unpolarized.
override POLARIZATION: u32 = 2u;
// A dispersive base: the point's (n, k) replaces the member's n_base and k_base.
override DISPERSIVE: bool = false;

@group(0) @binding(0) var<storage, read> films: array<ThinFilm>;
// (wavelength nm, angle in the host in radians, base n, base k) of each point.
@group(0) @binding(1) var<storage, read> light: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> result: array<f32>;
@group(0) @binding(3) var<uniform> population: Population;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = global_index(gid, nwg);
    if (i >= arrayLength(&result)) {
        return;
    }
    let at = member_and_point(population, i);
    var f = films[at.x];
    let point = light[at.y];
    if (DISPERSIVE) {
        f.n_base = point.z;
        f.k_base = point.w;
    }
    result[i] = thin_film_reflectance(f, point.x, point.y, POLARIZATION);
}
