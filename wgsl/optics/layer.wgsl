// One homogeneous layer's phase, shared by the Bragg and thin-film kernels. Requires
// gpu/numerics.wgsl. No bindings.

// n^2 - s^2 of a real index n under a host of index `host` (s = host sin theta, host_cos =
// host cos theta) without cancellation, as wgbragg/optics/fresnel.py, normal_square: for a
// medium at least as dense as the host (n - host)(n + host) + host_cos^2, two terms >= 0 and
// exact at grazing incidence where s rounds to host; for a rarer one (n - s)(n + s), exact at
// its critical angle, where the first form subtracts two numbers near host^2 (a 0.01 film
// under a 41.5 host lost every digit).
fn normal_square(n: f32, host: f32, s: f32, host_cos: f32) -> f32 {
    return select((n - s) * (n + s), (n - host) * (n + host) + host_cos * host_cos, n >= host);
}

// (R, T) of a stack between lossless media, R + T = 1 to float32's rounding: the smaller of
// the two as formed directly (it keeps its relative accuracy), the larger as 1 minus it.
fn balanced(reflected: f32, transmitted: f32) -> vec2<f32> {
    let r = clamp(reflected, 0.0, 1.0);
    let t = clamp(transmitted, 0.0, 1.0);
    return select(vec2<f32>(1.0 - t, t), vec2<f32>(r, 1.0 - r), r <= t);
}

// Evanescent layers decaying by more than this many e-folds transmit < e^-40, so R rounds to
// its opaque limit in float32; clamping keeps cosh/sinh products finite.
const MAX_DECAY: f32 = 20.0;

// Half the phase of a homogeneous layer, delta/2 = pi q d / lambda, for a normal component of
// magnitude q that is real, or imaginary when `evanescent` (then delta/2 = i kappa/2):
// c = cos(delta/2) or cosh(kappa/2), s = sin(delta/2) or sinh(kappa/2) (reduced: c and s
// change sign together, which callers pair away), and s / q in sinc form, finite at q = 0.
struct HalfPhase {
    c: f32,
    s: f32,
    s_over_q: f32,
}

fn layer_half_phase(q: f32, evanescent: bool, d_over_wavelength: f32) -> HalfPhase {
    let cycles = q * d_over_wavelength;
    return layer_half_phase_of(q, evanescent, d_over_wavelength, cycles, cycles);
}

// layer_half_phase given the phase q d / lambda in cycles, and `fraction`: the same up to
// whole turns, possibly more accurate (optics/yeh.wgsl, split_cycles). The sinc form of a layer under
// half a cycle and the evanescent decay use `cycles`.
fn layer_half_phase_of(q: f32, evanescent: bool, d_over_wavelength: f32, cycles: f32,
                       fraction: f32) -> HalfPhase {
    var h: HalfPhase;
    if (evanescent) {
        let y = min(PI * cycles, 0.5 * MAX_DECAY);
        let e = exp(y);
        let small = y < 0.5;
        let sinhc = sinhc_small(y);
        h.s = select(0.5 * (e - 1.0 / e), y * sinhc, small);
        h.c = 0.5 * (e + 1.0 / e);
        h.s_over_q = select(h.s / q, PI * d_over_wavelength * sinhc, small);
    } else {
        let unreduced = round(cycles) == 0.0;
        let x = PI * select(fraction - round(fraction), cycles, unreduced);
        let sc = sinc_cos_reduced(x);
        h.s = x * sc.x;
        h.c = sc.y;
        // Unreduced (cycles < 1/2): sin(pi q d / lambda) / q = (pi d / lambda) sinc.
        h.s_over_q = select(h.s / q, PI * d_over_wavelength * sc.x, unreduced);
    }
    return h;
}
