// float32 helpers that keep relative accuracy where WGSL built-ins lose it, and cheap
// polynomial trigonometry for arguments already reduced to [-pi/2, pi/2] (the built-ins pay
// for a general range reduction; these kernels reduce in "cycles" first, exactly). No bindings.

const PI: f32 = 3.14159265358979;
const HALF_PI: f32 = 1.57079632679490;
const TWO_PI: f32 = 6.28318530717959;

// 1 - exp(-y) for y >= 0; the direct form loses all digits for small y.
fn one_minus_exp_neg(y: f32) -> f32 {
    if (y < 0.03) {
        return y * (1.0 - y * (0.5 - y * (1.0 / 6.0 - y * (1.0 / 24.0))));
    }
    return 1.0 - exp(-y);
}

// asinh(y) for y >= 0; log(y + sqrt(y^2 + 1)) is inaccurate for small y.
fn asinh_accurate(y: f32) -> f32 {
    if (y < 0.01) {
        let y2 = y * y;
        return y * (1.0 - y2 * (1.0 / 6.0 - y2 * (3.0 / 40.0)));
    }
    return log(y + sqrt(y * y + 1.0));
}

// (sin(x) / x, cos x) for |x| <= pi/2: Taylor series to x^13 / x^14 (truncation < 1e-9), in
// Estrin form: lavapipe runs one SIMD vector per thread, so Horner's dependent chain is
// latency-bound while Estrin's independent pairs are not.
fn sinc_cos_reduced(x: f32) -> vec2<f32> {
    let u = x * x;
    let u2 = u * u;
    let u4 = u2 * u2;
    let sinc = (1.0 - u * (1.0 / 6.0)) + u2 * ((1.0 / 120.0) - u * (1.0 / 5040.0))
        + u4 * (((1.0 / 362880.0) - u * (1.0 / 39916800.0)) + u2 * (1.0 / 6227020800.0));
    let cosine = (1.0 - u * 0.5) + u2 * ((1.0 / 24.0) - u * (1.0 / 720.0))
        + u4 * (((1.0 / 40320.0) - u * (1.0 / 3628800.0))
        + u2 * ((1.0 / 479001600.0) - u * (1.0 / 87178291200.0)));
    return vec2<f32>(sinc, cosine);
}

fn sin_cos_reduced(x: f32) -> vec2<f32> {
    let sc = sinc_cos_reduced(x);
    return vec2<f32>(x * sc.x, sc.y);
}

// sinh(y) / y for 0 <= y <= 1/2 (truncation < 1e-9).
fn sinhc_small(y: f32) -> f32 {
    let u = y * y;
    return 1.0 + u * ((1.0 / 6.0) + u * ((1.0 / 120.0) + u * ((1.0 / 5040.0) + u * (1.0 / 362880.0))));
}

// Fractional part of cycles in [-1/2, 1/2]: the turn is exact, so phases of any size reduce
// without error beyond that of the input.
fn centered_fraction(cycles: f32) -> f32 {
    return cycles - floor(cycles + 0.5);
}

// (sin, cos) of pi * cycles, reduced to [-pi/2, pi/2]: a half phase. Both change sign with
// the reduction, which every caller pairs or squares away.
fn half_phase_sin_cos(cycles: f32) -> vec2<f32> {
    return sin_cos_reduced(PI * centered_fraction(cycles));
}

// sin(2 pi * cycles), folded into [-1/4, 1/4] turn in exact arithmetic (Sterbenz), so the
// result keeps its relative accuracy near every zero.
fn sin_cycles(cycles: f32) -> f32 {
    var r = centered_fraction(cycles);
    if (r > 0.25) {
        r = 0.5 - r;
    } else if (r < -0.25) {
        r = -0.5 - r;
    }
    return sin_cos_reduced(TWO_PI * r).x;
}

// (sin theta, cos theta) for theta in [0, pi/2]. Past pi/4 the complement is formed with a
// two-term pi/2, so cos keeps its relative accuracy at grazing incidence.
fn sin_cos_angle(theta: f32) -> vec2<f32> {
    let complement = (1.5707963705062866 - theta) - 4.3711388e-8;
    let upper = theta > 0.78539816;
    let sc = sin_cos_reduced(select(theta, complement, upper));
    return select(sc, sc.yx, upper);
}

// atan2(y, x) / (2 pi) for y, x >= 0 (not both 0): an angle in [0, 1/4] turn, relative error
// ~1e-7 (lavapipe's atan2 is off by 2e-5). Branch-free, one division.
fn atan2_cycles_positive(y: f32, x: f32) -> f32 {
    let swap = y > x;
    let lo = min(y, x);
    let hi = max(y, x);
    // atan(lo/hi) = pi/6 + atan((sqrt(3) lo - hi) / (sqrt(3) hi + lo)) keeps |w| <= tan(pi/12).
    let reduce = lo > 0.26794919 * hi;
    let w = select(lo, 1.7320508 * lo - hi, reduce) / select(hi, 1.7320508 * hi + lo, reduce);
    let w2 = w * w;
    let w4 = w2 * w2;
    let w8 = w4 * w4;
    let series = w * ((1.0 - w2 * (1.0 / 3.0)) + w4 * ((1.0 / 5.0) - w2 * (1.0 / 7.0))
        + w8 * (((1.0 / 9.0) - w2 * (1.0 / 11.0)) + w4 * (1.0 / 13.0)));
    let turn = (select(0.0, PI / 6.0, reduce) + series) * (1.0 / TWO_PI);
    return select(turn, 0.25 - turn, swap);
}
