// One homogeneous layer's phase, shared by the Bragg and thin-film kernels. Requires
// gpu/numerics.wgsl. No bindings.

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
