// Entry point: D65-weighted XYZ of a Bragg mirror from its spectral landmarks, one invocation
// per angle theta[i], both polarisations averaged: the "approx", "subdivided" and "averaged"
// colour methods (wgbragg/colour/landmark_methods.py; physics in colour/landmark_methods.wgsl,
// the cmf table in colour/landmark_methods_cmf.wgsl).
//! include "gpu/harness.wgsl"
//! include "gpu/numerics.wgsl"
//! include "gpu/complex.wgsl"
//! include "optics/layer.wgsl"
//! include "optics/yeh.wgsl"
//! include "optics/landmarks.wgsl"
//! include "colour/landmark_methods.wgsl"
//! include "colour/landmark_methods_cmf.wgsl"

// host == n1: eqs 2 and 9 need no complex amplitude (Appendix D is compiled out).
override HOST_MATCHED: bool = true;
// host == n1 <= n2 with an n2 layer: only the mode-coordinate path is compiled.
override MATCHED_LAYERS: bool = false;
// 0 = approx, 1 = subdivided, 2 = averaged.
override METHOD: u32 = 2u;

// BraggMirror (optics/yeh.wgsl) with its padding word holding s of "subdivided".
struct LandmarkColourParams {
    n1: f32,
    n2: f32,
    d1_nm: f32,
    d2_nm: f32,
    host: f32,
    periods: u32,
    bulk: u32,
    subdivisions: u32,
}

@group(0) @binding(0) var<storage, read> theta: array<f32>;
@group(0) @binding(1) var<storage, read> cmf: array<vec4<u32>>;
@group(0) @binding(2) var<storage, read_write> xyz: array<vec4<f32>>;  // w = 1 where the loop budget cut the loops short
@group(0) @binding(3) var<uniform> params: LandmarkColourParams;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = global_index(gid, nwg);
    if (i >= arrayLength(&xyz)) {
        return;
    }
    let p = params;
    let m = BraggMirror(p.n1, p.n2, p.d1_nm, p.d2_nm, p.host, p.periods, p.bulk, 0u);
    let s = i32(min(p.subdivisions, 0x7fffffffu));
    let colour = landmark_colour_unpolarized(m, theta[i], METHOD, s, HOST_MATCHED, MATCHED_LAYERS);
    xyz[i] = vec4<f32>(colour, f32(loops_were_cut(p.periods)));
}
