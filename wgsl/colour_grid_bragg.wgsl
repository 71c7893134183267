// Entry point: "averaged" with quadrature "grid" (wgbragg/colour_grid.py), one invocation per
// angle: xyz[i] = sum_k R(omega_k, theta_i) weights[k].xyz over the GRID_NODES wavelengths of
// the grid, R unpolarized: phase-averaged in pass bands and exact in gaps where the angle
// averages, else the exact spectrum. host == n1 <= n2 (the host checks): no Appendix D, n2
// propagates. The grid has three segments, each uniform in omega (colour_grid.grid_segments):
// within one the half layer phases delta / 2 = q d omega / 2 advance by the same angle from node
// to node, so each node rotates them by the step the host formed in float64 (with the start)
// instead of evaluating any trigonometry: 4096 steps drift by ~1e-4 rad at most.
//! include "harness.wgsl"
//! include "numerics.wgsl"
//! include "complex.wgsl"
//! include "layer.wgsl"
//! include "yeh.wgsl"

override GRID_NODES: u32 = 96u;
// Cells before the finest segment (colour_grid.GRID_BAND_NM) and up to its end: cell k advances
// by step_tail_red, step_band or step_tail_blue.
override BAND_START: u32 = 5u;
override BAND_END: u32 = 88u;
// N when it is below averaging_from: every angle samples the exact spectrum by the unrolled
// recurrence (recurrence_reflectance). 0: each angle's mode says.
override EXACT_PERIODS: u32 = 0u;

const MODE_EXACT: f32 = 0.0;
const MODE_AVERAGED: f32 = 1.0;
const MODE_TOTAL: f32 = 2.0;

// Per angle, formed on the host in float64 (wgbragg/colour_grid_gpu.py, grid_angle_inputs).
struct GridAngle {
    geometry: vec4<f32>,  // s, cos theta, q1, q2^2
    start: vec4<f32>,     // cos, sin of delta1 / 2 and of delta2 / 2 at the first node
    step_tail_red: vec4<f32>,   // cos, sin of their advance per cell, by segment
    step_band: vec4<f32>,
    step_tail_blue: vec4<f32>,
    extra: vec4<f32>,     // mode (MODE_*), 1 / q2, 0, 0
}

@group(0) @binding(0) var<storage, read> weights: array<vec4<f32>>;  // xyz product weight, w 0
@group(0) @binding(1) var<storage, read> angles: array<GridAngle>;
@group(0) @binding(2) var<storage, read_write> xyz: array<vec4<f32>>;  // w = 0
@group(0) @binding(3) var<uniform> mirror: BraggMirror;

fn rotated(phases: vec4<f32>, step: vec4<f32>) -> vec4<f32> {
    return phases.xyzw * step.xxzz + vec4<f32>(-phases.y, phases.x, -phases.w, phases.z) * step.yyww;
}

fn cell_step(inputs: GridAngle, k: u32) -> vec4<f32> {
    return select(select(inputs.step_tail_red, inputs.step_band, k >= BAND_START),
                  inputs.step_tail_blue, k >= BAND_END);
}

fn at_node(angle: CellGeometry, phases: vec4<f32>, inv_q2: f32) -> CellGeometry {
    var g = angle;
    g.ca = phases.x;
    g.sa = phases.y;
    g.half2 = HalfPhase(phases.z, phases.w, phases.w * inv_q2);
    return g;
}

fn exact_node(g: CellGeometry, polarization: u32) -> f32 {
    let t = cell_terms(mirror, g, polarization);
    if (EXACT_PERIODS != 0u) {
        return recurrence_reflectance(t, EXACT_PERIODS);
    }
    return matched_reflectance(t, g.cell_cycles, mirror.periods);
}

fn averaged_node(g: CellGeometry, polarization: u32) -> f32 {
    return averaged_matched_reflectance(cell_terms(mirror, g, polarization), mirror.periods);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = global_index(gid, nwg);
    if (i >= arrayLength(&xyz)) {
        return;
    }
    let inputs = angles[i];
    var angle = angle_geometry_given(inputs.geometry);
    // The rotations' rounding: a phase of a few turns (matched_reflectance's resolution test).
    angle.cell_cycles = 2.0;
    let mode = inputs.extra.x;
    let inv_q2 = inputs.extra.y;
    var acc = vec3<f32>(0.0);
    // One loop per mode: lavapipe runs both sides of a branch, but skips a loop no lane enters.
    var phases = inputs.start;
    for (var k = 0u; k < select(0u, GRID_NODES, mode == MODE_AVERAGED); k++) {
        let g = at_node(angle, phases, inv_q2);
        acc += (0.5 * (averaged_node(g, 0u) + averaged_node(g, 1u))) * weights[k].xyz;
        phases = rotated(phases, cell_step(inputs, k));
    }
    phases = inputs.start;
    for (var k = 0u; k < select(0u, GRID_NODES, mode == MODE_EXACT); k++) {
        let g = at_node(angle, phases, inv_q2);
        acc += (0.5 * (exact_node(g, 0u) + exact_node(g, 1u))) * weights[k].xyz;
        phases = rotated(phases, cell_step(inputs, k));
    }
    // Grazing in n1 (theta = 90 degrees): every wavelength is reflected.
    for (var k = 0u; k < select(0u, GRID_NODES, mode == MODE_TOTAL); k++) {
        acc += weights[k].xyz;
    }
    xyz[i] = vec4<f32>(acc, 0.0);
}
