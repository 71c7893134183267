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
// The part whose formula would subtract (m - |z.x|) is taken as |z.y| / (2 x the other):
// a metal with k = 1e4 kept Re sqrt(n^2 - k^2 + 2 i n k) = n, which sqrt((m + z.x) / 2)
// rounded to 0.
fn c_sqrt(z: vec2<f32>) -> vec2<f32> {
    let m = length(z);
    let large = sqrt(max(0.5 * (m + abs(z.x)), 0.0));
    let small = select(0.5 * abs(z.y) / large, 0.0, large == 0.0);
    let re = select(small, large, z.x >= 0.0);
    let im = select(large, small, z.x >= 0.0);
    return vec2<f32>(re, select(im, -im, z.y < 0.0));
}
