// Entry point: XYZ of a thin film by a Fourier method (wgbragg.colour.thin_film), one
// invocation per angle theta[i]. GAUSSIAN selects the paper's Gaussian fits (closed form)
// over the table; PREFILTERED compiles the table's prefiltering axis in.
//! include "gpu/harness.wgsl"
//! include "gpu/numerics.wgsl"
//! include "gpu/complex.wgsl"
//! include "optics/layer.wgsl"
//! include "optics/thin_film.wgsl"
//! include "colour/thin_film.wgsl"

override GAUSSIAN: bool = false;
override PREFILTERED: bool = false;

@group(0) @binding(0) var<storage, read> theta: array<f32>;
@group(0) @binding(1) var<storage, read> fourier_windows: array<FourierWindow>;
@group(0) @binding(2) var<storage, read> evanescent_nodes: array<EvanescentNode>;
@group(0) @binding(3) var film_table: texture_2d<f32>;
@group(0) @binding(4) var<storage, read_write> xyz: array<vec4<f32>>;  // w = 0
@group(0) @binding(5) var<uniform> params: FilmColourParams;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = global_index(gid, nwg);
    if (i >= arrayLength(&xyz)) {
        return;
    }
    xyz[i] = vec4<f32>(film_colour(theta[i], params, GAUSSIAN, PREFILTERED), 0.0);
}
