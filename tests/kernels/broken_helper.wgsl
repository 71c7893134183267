// Deliberately broken helper: line 5 assigns a u32 to an f32 (the test expects line 5).
fn helper(v: f32) -> f32 {
    // Keep the error on line 5.
    var acc: f32 = v;
    let bad: f32 = 1u;
    return acc + bad;
}
