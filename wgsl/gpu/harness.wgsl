// Harness helpers shared by every entry-point kernel run through wgbragg.gpu.
// Declares no bindings. The harness sets WORKGROUP_SIZE through the pipeline's
// override constants, so entry points declare `@compute @workgroup_size(WORKGROUP_SIZE)`.

override WORKGROUP_SIZE: u32 = 64u;

// Flat element index for the 2D grid the harness dispatches: one dispatch
// dimension holds at most 65535 workgroups, so large counts wrap into y.
// Kernels must still bounds-check, because the last row is over-dispatched.
fn global_index(gid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return gid.x + gid.y * nwg.x * WORKGROUP_SIZE;
}

// Whether the device ended this invocation's loops early (wgbragg/gpu/loops.py: a loop budget, as
// Mesa 22's lavapipe has; never where the device has none). Call it
// after the kernel's last loop and report the answer to the host, which refuses the result.
// Its loop runs 2 or 3 times, a count the compiler cannot know from `unknown` (any runtime
// value), so it is not unrolled away: once the SIMD group's budget is spent, the loop stops
// after one pass. The answer is shared by the group, so it errs towards "cut".
fn loops_were_cut(unknown: u32) -> bool {
    let trips = 2u + min(unknown, 1u);
    var taken = 0u;
    loop {
        taken += 1u;
        if (taken >= trips) {
            break;
        }
    }
    return taken < 2u;
}
