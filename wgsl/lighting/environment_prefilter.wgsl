// Entry point: bake one level of a prefiltered environment (wgbragg/lighting/environment_prefilter.py,
// whose docstring defines the sums), one invocation per output texel, in float32.
//
// A dispatch sums the input rows [row_begin, row_end) that lie in the texel's window into
// `sums`, adding to what earlier dispatches of the level left there: a device with a loop budget
// (wgbragg/gpu/loops.py; Mesa 22's lavapipe) silently ends the loops of a SIMD group after so many
// iterations in total, counted as its slowest lane sees them, so the host splits the rows into
// blocks of at most block_iterations() (environment_prefilter.py) loop turns per output row. Invocations run row by row with a stride of out_stride, a multiple
// of the SIMD width, so that no group mixes the loop counts of two output rows; the columns
// past out_width idle. The last dispatch (finish = 1) also writes the normalised texel to
// `prefiltered`, in the layout of lighting/environment_prefilter_lookup.wgsl: (radiance, 0), (mean, 0),
// (xx, yy, zz, 0), (xy, yz, zx, 0), with the same stride.
//! include "gpu/harness.wgsl"
//! include "gpu/numerics.wgsl"

struct PrefilterParams {
    in_width: u32,
    in_height: u32,
    out_width: u32,
    out_height: u32,
    out_stride: u32,  // invocations per output row: out_width padded to the SIMD width
    row_begin: u32,
    row_end: u32,
    cosine: u32,     // 1: the cosine kernel, 0: GGX of roughness alpha
    finish: u32,     // 1: the level's last dispatch
    alpha: f32,
    q_max: f32,      // the window: 1 - r.l <= q_max
}

struct OutputRow {
    sin_theta: f32,
    cos_theta: f32,
    first: u32,      // input rows [first, end) reach the window
    end: u32,
}

struct OutputColumn {
    sin_phi: f32,
    cos_phi: f32,
    centre: u32,     // the input column holding this azimuth
    _pad: u32,
}

@group(0) @binding(0) var<storage, read> input_rows: array<vec4<f32>>;  // (sin, cos, Omega, 0)
@group(0) @binding(1) var<storage, read> input_columns: array<vec2<f32>>;  // (sin phi, cos phi)
@group(0) @binding(2) var<storage, read> input_texels: array<vec4<f32>>;  // (r, g, b, Y)
@group(0) @binding(3) var<storage, read> output_rows: array<OutputRow>;
@group(0) @binding(4) var<storage, read> output_columns: array<OutputColumn>;
// Per (output row, input row): -1 if the row misses the window, else n columns either side of
// the centre column (the whole row once 2 n + 1 >= in_width).
@group(0) @binding(5) var<storage, read> spans: array<i32>;
@group(0) @binding(6) var<storage, read_write> sums: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> prefiltered: array<vec4<f32>>;
@group(0) @binding(8) var<uniform> params: PrefilterParams;

// K(r, l) from q = 1 - r.l = |r - l|^2 / 2 in [0, q_max], which keeps its relative accuracy
// beside r where r.l itself rounds to 1. D at cos^2(r.h) = 1 - q/2 and sin^2(r.h) = q/2 needs
// no square root (ggx_D would take r.h and lose those digits forming 1 - cos^2 again), and
// D G1 = a2 / (pi d^2) 2 c / (c + sqrt(c^2 + a2 (1 - c^2))) takes a single division.
fn prefilter_kernel(q: f32) -> f32 {
    let c = 1.0 - q;
    if (params.cosine != 0u) {
        return c;
    }
    let a2 = params.alpha * params.alpha;
    let d = a2 + 0.5 * q * (1.0 - a2);
    return (2.0 * a2 * c) / (PI * d * d * (c + sqrt(c * c + a2 * q * (2.0 - q))));
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let index = global_index(gid, nwg);
    let y_out = index / params.out_stride;
    let x_out = index - y_out * params.out_stride;
    if (y_out >= params.out_height || x_out >= params.out_width) {
        return;
    }
    let row = output_rows[y_out];
    let column = output_columns[x_out];
    // The convention's direction (lighting/environment_map.wgsl), phi = 2 pi u.
    let r = vec3<f32>(row.sin_theta * column.sin_phi, row.cos_theta,
                      -row.sin_theta * column.cos_phi);
    let width = params.in_width;
    // (radiance sum, K sum), (w l sum, w sum), w l l diagonal and off-diagonal sums.
    var total0 = sums[4u * index];
    var total1 = sums[4u * index + 1u];
    var total2 = sums[4u * index + 2u];
    var total3 = sums[4u * index + 3u];
    let end = min(row.end, params.row_end);
    for (var y = max(row.first, params.row_begin); y < end; y++) {
        let n = spans[y_out * params.in_height + y];
        if (n < 0) {
            continue;
        }
        let ring = input_rows[y];
        let count = min(u32(2 * n + 1), width);
        // n <= width / 2, so the start stays non-negative before the wrap.
        var x = (column.centre + width - u32(n)) % width;
        let base = y * width;
        // Row sums first, then the row's solid angle: Omega is constant along a row, and
        // float32 sums of a row then of rows stay close to their float64 values.
        var row0 = vec4<f32>(0.0);
        var row1 = vec4<f32>(0.0);
        var row2 = vec3<f32>(0.0);
        var row3 = vec3<f32>(0.0);
        for (var k = 0u; k < count; k++) {
            let sc = input_columns[x];
            let l = vec3<f32>(ring.x * sc.x, ring.y, -ring.x * sc.y);
            let e = r - l;
            let q = 0.5 * dot(e, e);
            // Clamped so that the kernel stays finite where the window discards it.
            let kernel = select(0.0, prefilter_kernel(min(q, params.q_max)), q <= params.q_max);
            let texel = input_texels[base + x];
            row0 += kernel * vec4<f32>(texel.xyz, 1.0);
            let w = kernel * texel.w;
            row1 += w * vec4<f32>(l, 1.0);
            row2 += w * (l * l);
            row3 += w * (l * l.yzx);
            x = select(x + 1u, 0u, x + 1u == width);
        }
        total0 += ring.z * row0;
        total1 += ring.z * row1;
        total2 += vec4<f32>(ring.z * row2, 0.0);
        total3 += vec4<f32>(ring.z * row3, 0.0);
    }
    sums[4u * index] = total0;
    sums[4u * index + 1u] = total1;
    sums[4u * index + 2u] = total2;
    sums[4u * index + 3u] = total3;
    if (params.finish == 0u) {
        return;
    }
    var radiance = vec3<f32>(0.0);
    if (total0.w > 0.0) {
        radiance = total0.xyz / total0.w;
    }
    // A black window has no luminance to weight by: the lobe's own direction stands in.
    var mean = r;
    var diagonal = r * r;
    var off = r * r.yzx;
    if (total1.w > 0.0) {
        let scale = 1.0 / total1.w;
        mean = total1.xyz * scale;
        diagonal = total2.xyz * scale;
        off = total3.xyz * scale;
    }
    prefiltered[4u * index] = vec4<f32>(radiance, 0.0);
    prefiltered[4u * index + 1u] = vec4<f32>(mean, 0.0);
    prefiltered[4u * index + 2u] = vec4<f32>(diagonal, 0.0);
    prefiltered[4u * index + 3u] = vec4<f32>(off, 0.0);
}
