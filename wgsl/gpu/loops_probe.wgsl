// The loop-budget probe (wgbragg/gpu/loops.py): two loops of counts[i] iterations each, the
// second after the first, so that a budget shared by all of an invocation's loops shows;
// out[i] = (iterations taken, loops_were_cut). Where the device's compiler ends loops early,
// the taken count is where it did.
//! include "gpu/harness.wgsl"

@group(0) @binding(0) var<storage, read> counts: array<u32>;
@group(0) @binding(1) var<storage, read_write> out: array<vec2<u32>>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = global_index(gid, nwg);
    if (i >= arrayLength(&out)) { return; }
    var taken = 0u;
    for (var k = 0u; k < counts[i]; k++) { taken += 1u; }
    for (var k = 0u; k < counts[i]; k++) { taken += 1u; }
    out[i] = vec2<u32>(taken, u32(loops_were_cut(counts[i])));
}
