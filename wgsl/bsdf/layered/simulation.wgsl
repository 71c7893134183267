// Entry point: position-free Monte Carlo simulation of a layered Bragg structure (Fourneau,
// Pacanowski & Barla 2024, sec. 4.2; Guo, Hasan & Zhao 2018). wgbragg/bsdf/layered/simulation.py
// states the estimator; this file holds the walk. One invocation runs params.per_invocation
// paths of one query (wi, wo) and one group of four wavelengths and, with NEXT_EVENT, writes
// the paths' mean and sum of squared deviations (Welford) per wavelength or channel; without
// it, each path's exit direction and weight. The host sizes per_invocation and max_reflections
// so that an invocation's walks fit in the device's loop budget (wgbragg.gpu.loops);
// should they not, the flag at the end of `directions` tells it.
//
// A path carries four wavelengths, one vec4: a group of the given ones, or in RGB mode hero
// wavelengths stratified in the inverse CDF of the summed XYZ density, one offset per path.
// Groups of a query draw the same random numbers. (Four, not more in private arrays of vec4:
// docs/performance.md, "Layered structures".)
//! include "gpu/harness.wgsl"
//! include "gpu/numerics.wgsl"
//! include "gpu/complex.wgsl"
//! include "optics/layer.wgsl"
//! include "optics/yeh.wgsl"
//! include "bsdf/microfacet.wgsl"
//! include "bsdf/layered/coating.wgsl"
//! include "bsdf/layered/simulation_walk.wgsl"
//! include "colour/colorimetry_hero.wgsl"

override LAYERS: u32 = 1u;
override COATING: bool = false;
override LAMBERTIAN: bool = false;
override BALLISTIC: bool = true;
override SINGLE: bool = false;
// true: the BRDF at wo by next-event estimation; false: exit particles.
override NEXT_EVENT: bool = true;
override RGB: bool = true;
// RGB tables as the corners of their cells (one load per lookup); else plain, four floats per
// vec4, where the corners would not fit (gpu.bilinear_quads_fit).
override QUADS: bool = true;
// Every layer's mirror sits in its own n1 (else Appendix D: seen from the walk's medium).
override HOST_MATCHED: bool = true;

// The first node of the 1 nm tables (colorimetry.WAVELENGTH_RANGE_NM; checked by
// tests/test_wgsl_layouts.py).
const FIRST_NM: f32 = 360.0;
// Russian roulette from this many reflections on: earlier vertices carry most of the estimate.
const ROULETTE_AFTER: u32 = 3u;
// scatter's result for a transmission, walk's for a path that does not leave: w = 0.
const TRANSMITTED: vec4<f32> = vec4<f32>(0.0);
const ABSORBED: vec4<f32> = vec4<f32>(0.0);

struct Layer {
    mirror: BraggMirror,
    alpha: f32,
    table: u32,       // offset of its transmissivity table in `transmissivity` (vec4s)
    rows: u32,        // theta_i entries of the table (the filter's grid from 0 to pi/2)
    row_step: f32,    // their spacing, radians
}

struct SimulationParams {
    queries: u32,          // in this dispatch
    first_query: u32,      // index of its first: keys the random numbers
    groups: u32,           // of four wavelengths
    batches: u32,          // invocations per query and group in this dispatch
    paths: u32,            // per query
    seed: u32,
    host: f32,             // n1, the coating's index
    max_reflections: u32,  // reflections a walk may make before it stops
    columns: u32,          // wavelengths per table row: 471 (RGB, 1 nm) or 4 groups
    per_invocation: u32,   // paths an invocation runs (fewer in a query's last batch)
    first_batch: u32,      // index of this dispatch's first batch in its queries
    _pad: u32,
}

// [query] wi in air, wi and wo refracted into n1.
@group(0) @binding(0) var<storage, read> queries: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> layers: array<Layer>;
// [layer] its table, in one load per lookup: RGB, the corners of each cell of the 1 nm grid,
// (t[r][c], t[r][c + 1], t[r + 1][c], t[r + 1][c + 1]) at [r][c] (QUADS; else [row][column],
// four per vec4); spectral, [row][group].
@group(0) @binding(2) var<storage, read> transmissivity: array<vec4<f32>>;
// RGB: [471] linear sRGB density per nm (xyz), base albedo (w) at 360, 361, ... nm.
// Spectral: [4 groups] wavelength in nm (x), base albedo (w).
@group(0) @binding(3) var<storage, read> spectrum: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> inverse_cdf: array<f32>;  // [HERO_SEGMENTS + 1] nm (RGB)
// NEXT_EVENT: [query][group][batch][mean, m2][4]; else [query][path][4] (one group).
@group(0) @binding(5) var<storage, read_write> values: array<vec4<f32>>;
// Without NEXT_EVENT [query][path] (w = 0); then one more element, whose w is 1 if the device
// ended some invocation's loops early (the only element with NEXT_EVENT).
@group(0) @binding(6) var<storage, read_write> directions: array<vec4<f32>>;
@group(0) @binding(7) var<uniform> params: SimulationParams;

// The state of the path being walked.
var<private> rng: u32;
var<private> group: u32;
var<private> wavelength: vec4<f32>;
var<private> lane_scale: vec4<f32>;  // RGB: 1 / (4 pdf(wavelength))
var<private> beta: vec4<f32>;        // throughput
var<private> estimate: vec4<f32>;    // next-event sum

fn uniform2() -> vec2<f32> {
    let u = pcg_uniform(&rng);
    return vec2<f32>(u, pcg_uniform(&rng));
}

fn spectrum_at(wavelength_nm: f32) -> vec4<f32> {
    let c = clamp(wavelength_nm - FIRST_NM, 0.0, f32(params.columns - 1u));
    let c0 = min(u32(c), params.columns - 2u);
    return mix(spectrum[c0], spectrum[c0 + 1u], c - f32(c0));
}

fn base_albedo() -> vec4<f32> {
    if (!RGB) {
        let c = 4u * group;
        return vec4<f32>(spectrum[c].w, spectrum[c + 1u].w, spectrum[c + 2u].w,
                         spectrum[c + 3u].w);
    }
    return vec4<f32>(spectrum_at(wavelength.x).w, spectrum_at(wavelength.y).w,
                     spectrum_at(wavelength.z).w, spectrum_at(wavelength.w).w);
}

fn table_float(index: u32) -> f32 {
    return transmissivity[index / 4u][index % 4u];
}

// t = f_t cos (eq 28) at theta for the path's wavelengths, interpolated linearly in theta (and
// in wavelength on the 1 nm grid in RGB mode), as RoughBraggLayer._interpolate_rows does.
fn transmissivity_at(layer: Layer, theta: f32) -> vec4<f32> {
    let position = min(theta / layer.row_step, f32(layer.rows - 1u));
    let r0 = min(u32(position), layer.rows - 2u);
    let fr = position - f32(r0);
    if (!RGB) {
        let row0 = layer.table + r0 * params.groups + group;
        return mix(transmissivity[row0], transmissivity[row0 + params.groups], fr);
    }
    var t: vec4<f32>;
    for (var k = 0u; k < 4u; k++) {
        let c = clamp(wavelength[k] - FIRST_NM, 0.0, f32(params.columns - 1u));
        let c0 = min(u32(c), params.columns - 2u);
        let fc = c - f32(c0);
        if (QUADS) {
            let q = transmissivity[layer.table + r0 * (params.columns - 1u) + c0];
            t[k] = mix(mix(q.x, q.y, fc), mix(q.z, q.w, fc), fr);
        } else {
            let row0 = layer.table + r0 * params.columns + c0;
            let row1 = row0 + params.columns;
            t[k] = mix(mix(table_float(row0), table_float(row0 + 1u), fc),
                       mix(table_float(row1), table_float(row1 + 1u), fc), fr);
        }
    }
    return t;
}

fn start_path(query: u32, path: u32) {
    rng = pcg_start(params.seed, params.first_query + query, path);
    beta = vec4<f32>(1.0);
    estimate = vec4<f32>(0.0);
    if (!RGB) {
        let c = 4u * group;
        wavelength = vec4<f32>(spectrum[c].x, spectrum[c + 1u].x, spectrum[c + 2u].x,
                               spectrum[c + 3u].x);
        return;
    }
    let hero = hero_wavelengths(pcg_uniform(&rng));
    wavelength = hero.nm;
    lane_scale = hero.scale;
}

fn hero_cdf_node(j: u32) -> f32 {
    return inverse_cdf[j];
}

// The path's result from per-wavelength values: as they are, or in RGB mode the hero
// wavelengths' estimate of the sRGB integral (xyz).
fn to_channels(lanes: vec4<f32>) -> vec4<f32> {
    if (!RGB) {
        return lanes;
    }
    let w = lanes * lane_scale;
    let rgb = w.x * spectrum_at(wavelength.x).xyz + w.y * spectrum_at(wavelength.y).xyz
        + w.z * spectrum_at(wavelength.z).xyz + w.w * spectrum_at(wavelength.w).xyz;
    return vec4<f32>(rgb, 0.0);
}

fn largest_throughput() -> f32 {
    return max(max(beta.x, beta.y), max(beta.z, beta.w));
}

// The transmission of the layers above `above` along o (z > 0): the ballistic t, or one
// unbiased sample G1(o) T(theta_d), m ~ VNDF(o), of it per layer.
fn connect(above: u32, o: vec3<f32>) -> vec4<f32> {
    var through = vec4<f32>(1.0);
    let theta = polar_angle(o);
    for (var l = 0u; l < above; l++) {
        let layer = layers[l];
        if (BALLISTIC) {
            through *= transmissivity_at(layer, theta);
        } else {
            let m = ggx_sample_visible_normal(o, uniform2(), layer.alpha);
            let theta_d = angle_between(o, m);
            through *= ggx_G1(o.z, layer.alpha)
                * (1.0 - quad_reflectance(layer.mirror, wavelength, theta_d));
        }
    }
    return through;
}

// Next-event estimation at layer l hit from above along -i: its lobe (eq 17) towards o, seen
// through the layers above.
fn connect_layer(layer: Layer, l: u32, i: vec3<f32>, o: vec3<f32>) {
    let h = half_vector(i, o);
    let lobe = layer_lobe(i.z, o.z, h, layer.alpha);
    let r = quad_reflectance(layer.mirror, wavelength, angle_between(i, h));
    estimate += beta * lobe * r * connect(l, o);
}

// A layer met along -i (its frame): reflection returns (o, 1) with o in that frame, transmission
// (undeviated) returns TRANSMITTED. `forced`: transmission with probability 1 (mode "single",
// where a reflection would end the path).
fn scatter(layer: Layer, i: vec3<f32>, forced: bool) -> vec4<f32> {
    let alpha = layer.alpha;
    let g1 = ggx_G1(i.z, alpha);
    if (BALLISTIC) {
        let t = transmissivity_at(layer, polar_angle(i));
        if (forced) {
            beta *= t;
            return TRANSMITTED;
        }
        let p = transmission_probability(0.25 * dot(t, vec4<f32>(1.0)), g1);
        if (pcg_uniform(&rng) < p) {
            beta *= t / p;
            return TRANSMITTED;
        }
        let m = ggx_sample_visible_normal(i, uniform2(), alpha);
        let o = normalize(reflect_about(i, m));
        let r = quad_reflectance(layer.mirror, wavelength, angle_between(i, m));
        beta *= r * (ggx_G1(o.z, alpha) / (1.0 - p));
        return vec4<f32>(o, 1.0);
    }
    let m = ggx_sample_visible_normal(i, uniform2(), alpha);
    let r = quad_reflectance(layer.mirror, wavelength, angle_between(i, m));
    let p = select(0.25 * dot(r, vec4<f32>(1.0)), 0.0, forced);
    if (pcg_uniform(&rng) < p) {
        let o = normalize(reflect_about(i, m));
        beta *= r * (ggx_G1(o.z, alpha) / p);
        return vec4<f32>(o, 1.0);
    }
    beta *= (1.0 - r) * (g1 / (1.0 - p));
    return TRANSMITTED;
}

// One path from air along -wi, inside n1 along -i. Next-event contributions towards o (wo
// refracted into n1) go to `estimate`; the result is the exit direction in air with w = 1, or
// ABSORBED.
fn walk(wi: vec3<f32>, i: vec3<f32>, o: vec3<f32>) -> vec4<f32> {
    let n = params.host;
    // The coating's Dirac reflection, sampled with its Fresnel probability (weight 1).
    if (!NEXT_EVENT && COATING && pcg_uniform(&rng) < coating_reflectance(wi.z, n)) {
        return vec4<f32>(-wi.xy, wi.z, 1.0);
    }
    var d = -i;
    var gap = 0u;  // between layers gap - 1 and gap; LAYERS: above the base
    var reflections = 0u;
    while (reflections <= params.max_reflections) {
        let down = d.z < 0.0;
        if (down && gap == LAYERS) {
            if (!LAMBERTIAN) {
                return ABSORBED;
            }
            let albedo = base_albedo();
            if (NEXT_EVENT) {
                estimate += beta * albedo * connect(LAYERS, o) * (1.0 / PI);
                if (SINGLE) {
                    return ABSORBED;
                }
            }
            beta *= albedo;
            d = cosine_direction(uniform2());
        } else if (!down && gap == 0u) {
            if (!COATING) {
                return vec4<f32>(d, 1.0);
            }
            let f = coating_reflectance_inside(d.z, n);
            let leaves = vec4<f32>(refract_out(d, n).xyz, 1.0);
            // Mode "single" has reflected once already: it keeps the transmitted part only.
            if (SINGLE) {
                if (f >= 1.0) {
                    return ABSORBED;
                }
                beta *= 1.0 - f;
                return leaves;
            }
            if (pcg_uniform(&rng) >= f) {
                return leaves;
            }
            d.z = -d.z;
        } else {
            let l = select(gap - 1u, gap, down);
            let layer = layers[l];
            let incident = layer_incident(d);
            if (NEXT_EVENT && down) {
                connect_layer(layer, l, incident, o);
            }
            let forced = SINGLE && (NEXT_EVENT || reflections > 0u);
            let scattered = scatter(layer, incident, forced);
            if (scattered.w == 0.0) {
                gap = select(gap - 1u, gap + 1u, down);
                if (largest_throughput() <= 0.0) {
                    return ABSORBED;
                }
                continue;
            }
            d = layer_reflected(scattered.xyz, d);
        }
        reflections++;
        if (reflections >= ROULETTE_AFTER) {
            let survival = min(1.0, largest_throughput());
            if (pcg_uniform(&rng) >= survival) {
                return ABSORBED;
            }
            beta /= survival;
        } else if (largest_throughput() <= 0.0) {
            return ABSORBED;
        }
    }
    // Cut off at max_bounces.
    return ABSORBED;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let g = global_index(gid, nwg);
    if (g >= params.queries * params.groups * params.batches) {
        return;
    }
    let query = g / (params.groups * params.batches);
    group = (g / params.batches) % params.groups;
    let first = (params.first_batch + g % params.batches) * params.per_invocation;
    let count = min(params.per_invocation, params.paths - first);
    let wi = queries[3u * query].xyz;
    let i = queries[3u * query + 1u].xyz;
    let o = queries[3u * query + 2u].xyz;
    var mean = vec4<f32>(0.0);
    var m2 = vec4<f32>(0.0);
    for (var p = 0u; p < count; p++) {
        start_path(query, first + p);
        let exit = walk(wi, i, o);
        if (NEXT_EVENT) {
            let x = to_channels(estimate);
            let delta = x - mean;
            mean += delta / f32(p + 1u);
            m2 += delta * (x - mean);
        } else {
            let index = query * params.paths + first + p;
            let left = exit.w > 0.0;
            directions[index] = vec4<f32>(select(vec3<f32>(0.0), exit.xyz, left), 0.0);
            values[index] = select(vec4<f32>(0.0), to_channels(beta), left);
        }
    }
    if (NEXT_EVENT) {
        values[2u * g] = mean;
        values[2u * g + 1u] = m2;
    }
    // Every writer stores the same value, so the race is harmless.
    if (loops_were_cut(count)) {
        directions[arrayLength(&directions) - 1u].w = 1.0;
    }
}
