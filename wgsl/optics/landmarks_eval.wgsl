// Test kernel: the spectral landmarks found by optics/landmarks.wgsl, one invocation per angle, for
// comparison with wgbragg.optics.landmarks.find_landmarks. Row i holds up to CAPACITY landmarks
// (omega in rad/nm, kind as landmarks.KINDS index, mode number, 0) in increasing omega.
//! include "gpu/harness.wgsl"
//! include "gpu/numerics.wgsl"
//! include "gpu/complex.wgsl"
//! include "optics/layer.wgsl"
//! include "optics/yeh.wgsl"
//! include "optics/landmarks.wgsl"

// 0 = s, 1 = p.
override POLARIZATION: u32 = 0u;
override CAPACITY: u32 = 64u;

@group(0) @binding(0) var<storage, read> theta: array<f32>;
@group(0) @binding(1) var<storage, read_write> found: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> count: array<u32>;
@group(0) @binding(3) var<uniform> mirror: BraggMirror;

fn emit(i: u32, n: ptr<function, u32>, omega: f32, kind: u32, mode: i32) {
    if (omega <= OMEGA_LO || omega >= OMEGA_HI || *n >= CAPACITY) {
        return;
    }
    found[i * CAPACITY + *n] = vec4<f32>(omega, f32(kind), f32(mode), 0.0);
    *n += 1u;
}

fn emit_t(i: u32, n: ptr<function, u32>, f: ModeFrame, t: f32, kind: u32, mode: i32) {
    if (t > f.t_lo && t < f.t_hi) {
        emit(i, n, PI * t / f.n_plus, kind, mode);
    }
}

fn emit_tau(i: u32, n: ptr<function, u32>, f: EvanescentFrame, tau: f32, kind: u32, mode: i32) {
    if (tau > f.tau_lo && tau < f.tau_hi) {
        emit(i, n, tau / f.scale, kind, mode);
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = global_index(gid, nwg);
    if (i >= arrayLength(&count)) {
        return;
    }
    var n = 0u;
    let angle = cell_geometry(mirror, 1.0, theta[i]);
    let host_matched = mirror.host == mirror.n1;
    if (angle.q1 > 0.0 && (host_matched || angle.s < mirror.n1) && mirror.bulk == 0u) {
        if (angle.q2sq > 0.0) {
            let f = mode_frame(mirror, angle, POLARIZATION);
            for (var k = i32(floor(f.t_lo)); k < i32(ceil(f.t_hi)); k++) {
                let iv = mode_interval(f, k);
                emit_t(i, &n, f, f32(k), KIND_MODE, k);
                emit_t(i, &n, f, iv.rising, KIND_EDGE, k);
                if (iv.zero > 0.0 && iv.zero < iv.airy) {
                    emit_t(i, &n, f, iv.zero, KIND_ZERO, k);
                }
                emit_t(i, &n, f, iv.airy, KIND_AIRY, k);
                if (iv.zero > 0.0 && iv.zero >= iv.airy) {
                    emit_t(i, &n, f, iv.zero, KIND_ZERO, k);
                }
                emit_t(i, &n, f, iv.falling, KIND_EDGE, k);
            }
        } else {
            let f = evanescent_frame(mirror, angle, POLARIZATION);
            for (var k = i32(floor(f.tau_lo)); k < i32(ceil(f.tau_hi)); k++) {
                let band = evanescent_band(f, k);
                emit_tau(i, &n, f, f32(k), KIND_MODE, k);
                emit_tau(i, &n, f, band.x, KIND_EDGE, k);
                emit_tau(i, &n, f, band.y, KIND_AIRY, k);
                emit_tau(i, &n, f, band.z, KIND_EDGE, k);
            }
        }
    }
    count[i] = n;
}
