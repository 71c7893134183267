// Complex arithmetic on vec2<f32> = (re, im). No bindings.

fn c_mul(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x);
}

fn c_conj(a: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(a.x, -a.y);
}

fn c_abs2(a: vec2<f32>) -> f32 {
    return dot(a, a);
}

// Scaled by the larger component first so |b|^2 cannot overflow or underflow.
fn c_div(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    let scale = max(abs(b.x), abs(b.y));
    let bs = b / scale;
    return c_mul(a / scale, c_conj(bs)) / dot(bs, bs);
}

fn c_exp_i(phase: f32) -> vec2<f32> {
    return vec2<f32>(cos(phase), sin(phase));
}

// Principal square root with Im >= 0 for Im(z) >= 0 (the decaying branch of n cos(theta)).
fn c_sqrt(z: vec2<f32>) -> vec2<f32> {
    let m = length(z);
    let re = sqrt(max(0.5 * (m + z.x), 0.0));
    let im = sqrt(max(0.5 * (m - z.x), 0.0));
    return vec2<f32>(re, select(im, -im, z.y < 0.0));
}
