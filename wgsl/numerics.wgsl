// float32 helpers that keep relative accuracy where WGSL built-ins lose it. No bindings.

const PI: f32 = 3.14159265358979;

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

// pi * cycles reduced to [-pi/2, pi/2]: a half phase, exact in its sine/cosine products
// up to a common sign that every caller squares or pairs away.
fn half_phase(cycles: f32) -> f32 {
    return PI * (cycles - round(cycles));
}

// sin(2 pi * cycles) with the argument reduced first, so huge phases stay in range.
fn sin_cycles(cycles: f32) -> f32 {
    return sin(2.0 * PI * (cycles - round(cycles)));
}

// atan2(y, x) for y, x >= 0 to float32 accuracy. lavapipe's atan2 is off by up to 2e-5
// (relative), which U_{N-1} = sin(N phi)/sin(phi) multiplies by N; one Newton step on
// tan(phi) = y/x with the accurate sin/cos restores it.
fn atan2_accurate(y: f32, x: f32) -> f32 {
    let guess = atan2(y, x);
    let s = sin(guess);
    let c = cos(guess);
    return guess + (y * c - x * s) / (x * c + y * s);
}
