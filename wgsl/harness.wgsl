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
