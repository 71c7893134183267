// Entry point: "averaged" with quadrature "grid" (wgbragg/colour/grid.py), one invocation per
// angle: xyz[i] = sum_k R(omega_k, theta_i) weights[k].xyz over the GRID_NODES wavelengths of
// the grid, R unpolarized: phase-averaged in pass bands and exact in gaps where the angle
// averages, else the exact spectrum. host == n1 <= n2 (the host checks): no Appendix D, n2
// propagates. The grid has three segments, each uniform in omega (colour_grid.grid_segments):
// within one the half layer phases delta / 2 = q d omega / 2 advance by the same angle from node
// to node, so each node rotates them by that step instead of evaluating any trigonometry. The
// start comes from the split optical paths (optics/yeh.wgsl, split_cycles), as the reference's phases;
// a step's float32 rounding, repeated over the nodes, adds up to ~1e-7 of the phase's whole
// advance across the range, and the rotations' own ~1e-7 per node.
//! include "gpu/harness.wgsl"
//! include "gpu/numerics.wgsl"
//! include "gpu/complex.wgsl"
//! include "optics/layer.wgsl"
//! include "optics/yeh.wgsl"

override GRID_NODES: u32 = 96u;
// Cells before the finest segment (colour_grid.GRID_BAND_NM) and up to its end: cell k advances
// by step_tail_red, step_band or step_tail_blue.
override BAND_START: u32 = 5u;
override BAND_END: u32 = 88u;
// N when it is below averaging_from: every angle samples the exact spectrum by the unrolled
// recurrence (recurrence_reflectance). 0: each angle's mode says.
override EXACT_PERIODS: u32 = 0u;
// 1 / lambda (1/nm) at the first node, split as split_cycles reads it (reference_gpu.split_float32),
// and its advance per cell of each segment.
override INV_WAVELENGTH_HEAD: f32 = 0.0;
override INV_WAVELENGTH_REST: f32 = 0.0;
override STEP_TAIL_RED: f32 = 0.0;
override STEP_BAND: f32 = 0.0;
override STEP_TAIL_BLUE: f32 = 0.0;

// GridAngle.mode.x: wgbragg.colour.grid_gpu.MODE_* (checked by tests/test_wgsl_layouts.py).
const MODE_EXACT: f32 = 0.0;
const MODE_AVERAGED: f32 = 1.0;
const MODE_TOTAL: f32 = 2.0;

// Per angle, formed on the host in float64 (wgbragg/colour/grid_gpu.py, grid_angle_inputs).
struct GridAngle {
    geometry: vec4<f32>,  // s, cos theta, q1, q2^2
    paths: vec4<f32>,     // q1 d1 and q2 d2 (nm), split as split_cycles reads them
    mode: vec4<f32>,      // MODE_*, 0, 0, 0
}

@group(0) @binding(0) var<storage, read> weights: array<vec4<f32>>;  // xyz product weight, w 0
@group(0) @binding(1) var<storage, read> angles: array<GridAngle>;
@group(0) @binding(2) var<storage, read_write> xyz: array<vec4<f32>>;  // w = 0
@group(0) @binding(3) var<uniform> mirror: BraggMirror;

fn rotated(phases: vec4<f32>, step: vec4<f32>) -> vec4<f32> {
    return phases.xyzw * step.xxzz + vec4<f32>(-phases.y, phases.x, -phases.w, phases.z) * step.yyww;
}

// (cos, sin) of delta1 / 2 and of delta2 / 2, given delta1 and delta2 in cycles.
fn half_phases(cycles: vec2<f32>) -> vec4<f32> {
    let a = half_phase_sin_cos(cycles.x);
    let b = half_phase_sin_cos(cycles.y);
    return vec4<f32>(a.y, a.x, b.y, b.x);
}

struct Steps {
    tail_red: vec4<f32>,
    band: vec4<f32>,
    tail_blue: vec4<f32>,
}

fn cell_step(steps: Steps, k: u32) -> vec4<f32> {
    return select(select(steps.tail_red, steps.band, k >= BAND_START), steps.tail_blue,
                  k >= BAND_END);
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
    let mode = inputs.mode.x;
    let inv_q2 = 1.0 / max(sqrt(max(angle.q2sq, 0.0)), 1e-30);
    let paths = inputs.paths;
    let inv_start = vec2<f32>(INV_WAVELENGTH_HEAD, INV_WAVELENGTH_REST);
    let start = half_phases(vec2<f32>(split_cycles(paths.xy, inv_start),
                                      split_cycles(paths.zw, inv_start)));
    let path = vec2<f32>(paths.x + paths.y, paths.z + paths.w);
    let steps = Steps(half_phases(path * STEP_TAIL_RED), half_phases(path * STEP_BAND),
                      half_phases(path * STEP_TAIL_BLUE));
    var acc = vec3<f32>(0.0);
    // One loop per mode: lavapipe runs both sides of a branch, but skips a loop no lane enters.
    var phases = start;
    for (var k = 0u; k < select(0u, GRID_NODES, mode == MODE_AVERAGED); k++) {
        let g = at_node(angle, phases, inv_q2);
        acc += (0.5 * (averaged_node(g, 0u) + averaged_node(g, 1u))) * weights[k].xyz;
        phases = rotated(phases, cell_step(steps, k));
    }
    phases = start;
    for (var k = 0u; k < select(0u, GRID_NODES, mode == MODE_EXACT); k++) {
        let g = at_node(angle, phases, inv_q2);
        acc += (0.5 * (exact_node(g, 0u) + exact_node(g, 1u))) * weights[k].xyz;
        phases = rotated(phases, cell_step(steps, k));
    }
    // Grazing in n1 (theta = 90 degrees): every wavelength is reflected.
    for (var k = 0u; k < select(0u, GRID_NODES, mode == MODE_TOTAL); k++) {
        acc += weights[k].xyz;
    }
    xyz[i] = vec4<f32>(acc, 0.0);
}
