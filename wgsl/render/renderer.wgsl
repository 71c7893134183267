// Entry points of the progressive path tracer, run by wgbragg/render/renderer.py:
//   render:        `samples` paths per pixel, their linear sRGB radiance written to paths
//   accumulate:    each pixel's paths added to accum (rgb, and their number in w), their
//                  denoising features to albedo_sum and normal_sum
//   primary_hits:  the closest hit of each pixel-centre camera ray, accum = (t, primitive, 0,
//                  0), primitive -1 and t = 3.4e38 for a miss (to check the traversal against numpy)
// Each sets loops_cut[0] = 1 where the device ended an invocation's loops early (wgbragg.gpu.loops,
// "Loop budget"): a path's loops (bounces, lights, BVH traversals, in-kernel colours) add up
// to what the host cannot foresee, so it checks the flag after every submission.
// Light transport: next-event estimation towards the environment, point lights and area
// lights (every light at each vertex, or one chosen by power: ONE_LIGHT), combined with BSDF
// sampling by the power heuristic where BSDF rays can reach the light too (the environment;
// area lights are geometry: they are seen, occlude and emit, and reflect nothing), Russian
// roulette after a few bounces. Materials are seen only through bsdf_eval / bsdf_pdf / bsdf_sample.
// A path carries a vec4 "spectrum": linear sRGB in xyz (RGB mode, w unused), or its values at
// four hero wavelengths (SPECTRAL), to which every RGB quantity of the scene (albedos,
// lights, environment) is upsampled by Mallett and Yuksel's basis spectra.
//! include "gpu/harness.wgsl"
//! include "gpu/numerics.wgsl"
//! include "gpu/complex.wgsl"
//! include "optics/layer.wgsl"
//! include "optics/yeh.wgsl"
//! include "optics/landmarks.wgsl"
//! include "colour/landmark_methods.wgsl"
//! include "bsdf/microfacet.wgsl"
//! include "bsdf/layered/coating.wgsl"
//! include "bsdf/layered/model.wgsl"
//! include "optics/thin_film.wgsl"
//! include "colour/thin_film.wgsl"
//! include "bsdf/rough_thin_film.wgsl"
//! include "render/renderer_bindings.wgsl"
//! include "render/renderer_shading.wgsl"
//! include "render/renderer_scene.wgsl"
//! include "lighting/procedural_environment.wgsl"
//! include "lighting/environment_map.wgsl"
//! include "scene/parameter_maps.wgsl"
//! include "lighting/environment_prefilter_lookup.wgsl"
//! include "lighting/ibl.wgsl"
//! include "colour/colorimetry_hero.wgsl"

// Bounces after the camera ray; the path ends at a hit beyond them.
override MAX_BOUNCES: u32 = 8u;
// Russian roulette from this bounce on: the first bounces carry most of the image.
override ROULETTE_FROM: u32 = 3u;
// Next-event estimation samples one light per vertex, chosen by its power, instead of every
// light: fewer shadow rays, more noise per sample (docs/performance.md compares them).
override ONE_LIGHT: bool = false;
// The scene is one convex object: a ray leaving its surface (above the face it leaves) meets
// nothing but the environment, so only camera rays are traced.
override CONVEX_ALONE: bool = false;

@group(0) @binding(23) var<storage, read_write> accum: array<vec4<f32>>;
// The radiance of each path of a render dispatch, for accumulate.
@group(0) @binding(24) var<storage, read_write> paths: array<vec3<f32>>;
@group(0) @binding(25) var<storage, read_write> loops_cut: array<u32>;
// The denoiser's feature images (wgbragg/render/denoise.py): each pixel's sums over its samples
// of its camera ray's first-hit albedo (rgb) and shading normal (xyz, world space), w unused;
// the samples' count is accum.w.
@group(0) @binding(26) var<storage, read_write> albedo_sum: array<vec4<f32>>;
@group(0) @binding(27) var<storage, read_write> normal_sum: array<vec4<f32>>;
// The features of each path of a render dispatch, for accumulate, packed in 16 bytes: the
// albedo as half floats (r, g), (b, 0), the normal as 16-bit snorms (x, y), (z, 0).
@group(0) @binding(28) var<storage, read_write> path_features: array<vec4<u32>>;
@group(0) @binding(29) var<uniform> params: Params;


// ----------------------------------------------------------------------------- transport

fn power_heuristic(a: f32, b: f32) -> f32 {
    let a2 = a * a;
    return a2 / (a2 + b * b);
}

fn unoccluded(origin: vec3<f32>, direction: vec3<f32>, distance: f32) -> bool {
    // Rays leave surfaces only above their face: a convex object cannot stand in the way.
    if (CONVEX_ALONE) {
        return true;
    }
    return trace(origin, direction, distance, true).primitive < 0;
}

// Lights of next-event estimation: the environment (Monte Carlo lighting only), then the
// point lights, then the area lights.
fn environment_lights() -> u32 {
    return select(0u, 1u, IBL == IBL_MONTE_CARLO);
}

fn light_total() -> u32 {
    return environment_lights() + params.point_lights + params.area_lights;
}

// The probability that next-event estimation samples light k at a vertex (1 when every light
// is sampled).
fn light_probability(k: u32) -> f32 {
    if (!ONE_LIGHT) {
        return 1.0;
    }
    return lights[2u * params.point_lights + 4u * params.area_lights + k].y;
}

// One light by the cumulative probabilities of the selection rows.
fn choose_light(u: f32) -> u32 {
    let rows = 2u * params.point_lights + 4u * params.area_lights;
    let last = light_total() - 1u;
    for (var k = 0u; k < last; k++) {
        if (u < lights[rows + k].x) {
            return k;
        }
    }
    return last;
}

// Area light k's solid-angle density of next-event estimation towards a point at `distance`
// along `direction`, seen at `cos_area` = -dot(edge_u x edge_v, direction) (its area times
// the cosine).
fn area_light_pdf(k: u32, distance: f32, cos_area: f32) -> f32 {
    return light_probability(environment_lights() + params.point_lights + k) * distance
        * distance / abs(cos_area);
}

// Radiance reflected at one vertex towards wi from the lights reached by shadow rays: one
// environment sample (Monte Carlo lighting only), every point light, one point on every area
// light; or, with ONE_LIGHT, one of them chosen by power. One loop over them all, so that the
// BSDF (for some scenes a whole in-kernel colour integral) is inlined once here: once per
// light kind, the render kernel of period-mapped layers in RGB mode took 3.6 s to compile
// instead of 1.4 s.
fn direct_light(m: Material, frame: Frame, wi: vec3<f32>, origin: vec3<f32>,
                geometric: vec3<f32>, state: ptr<function, u32>) -> vec4<f32> {
    let e = params.environment;
    let environment = environment_lights();
    let first_area = environment + params.point_lights;
    var first = 0u;
    var end = light_total();
    if (ONE_LIGHT && end > 0u) {
        first = choose_light(random(state));
        end = first + 1u;
    }
    var total = vec4<f32>(0.0);
    for (var k = first; k < end; k++) {
        var l: vec3<f32>;
        var shadow_distance = FAR;
        var distance = 0.0;
        var emitting = 1.0;
        var base = 0u;
        if (k < environment) {
            l = sky_sample(e, vec3<f32>(random(state), random(state), random(state)));
        } else if (k < first_area) {
            base = 2u * (k - environment);
            let to_light = lights[base].xyz - origin;
            distance = length(to_light);
            l = to_light / distance;
            shadow_distance = distance;
        } else {
            base = 2u * params.point_lights + 4u * (k - first_area);
            let edge_u = lights[base + 1u].xyz;
            let edge_v = lights[base + 2u].xyz;
            let normal_area = cross(edge_u, edge_v);
            let point = lights[base].xyz + random(state) * edge_u + random(state) * edge_v;
            let to_light = point - origin;
            distance = length(to_light);
            l = to_light / distance;
            // A one-sided emitter shines towards edge_u x edge_v, a two-sided one both ways.
            emitting = -dot(normal_area, l);
            if (lights[base].w > 0.5) {
                emitting = abs(emitting);
            }
            // Short of the light, which is geometry too.
            shadow_distance = distance * (1.0 - 1e-4);
        }
        let local = to_local(frame, l);
        if (!(emitting > 0.0 && dot(l, geometric) > 0.0 && local.z > 0.0)) {
            continue;
        }
        let f = bsdf_eval(m, wi, local);
        if (!any(f > vec4<f32>(0.0)) || !unoccluded(origin, l, shadow_distance)) {
            continue;
        }
        let chosen = light_probability(k);
        if (k < environment) {
            let light_pdf = chosen * sky_pdf(e, l);
            let weight = power_heuristic(light_pdf, bsdf_pdf(m, wi, local));
            total += f * local.z * upsample(sky_radiance(e, l)) * (weight / light_pdf);
        } else if (k < first_area) {
            total += f * local.z * upsample(lights[base + 1u].xyz)
                / (chosen * distance * distance);
        } else {
            // Uniform on the area A: the density distance^2 / (A cos_light) per solid angle,
            // and emitting is A cos_light.
            let light_pdf = area_light_pdf(k - first_area, distance, emitting);
            let weight = power_heuristic(light_pdf, bsdf_pdf(m, wi, local));
            total += f * local.z * upsample(lights[base + 3u].xyz) * (weight / light_pdf);
        }
    }
    return total;
}

// Radiance of area light k seen along `direction` at `distance`, weighted against its
// next-event estimation unless the ray was a camera ray or a Dirac bounce (`specular`); its
// back is black unless it is two-sided.
fn area_light_radiance(k: u32, direction: vec3<f32>, distance: f32, specular: bool,
                       last_pdf: f32) -> vec4<f32> {
    let base = 2u * params.point_lights + 4u * k;
    var cos_area = -dot(cross(lights[base + 1u].xyz, lights[base + 2u].xyz), direction);
    if (lights[base].w > 0.5) {
        cos_area = abs(cos_area);
    }
    if (!(cos_area > 0.0)) {
        return vec4<f32>(0.0);
    }
    var weight = 1.0;
    if (!specular) {
        weight = power_heuristic(last_pdf, area_light_pdf(k, distance, cos_area));
    }
    return upsample(lights[base + 3u].xyz) * weight;
}

// ----------------------------------------------------------------------------- denoising features

// What the camera ray's first hit shows the denoiser (OIDN's albedo and normal images), set by
// path_radiance: a miss, the environment's radiance clipped to [0, 1] and a zero normal; an
// area light, its radiance clipped and its normal; a surface, its shading normal (world space,
// towards the viewer) and the albedo: a Lambertian material's own, else the first bounce's
// BSDF sample weight f cos / pdf in linear sRGB clipped to [0, 1], a one-sample estimate of the
// directional albedo at the viewing angle (the reflectance colour a viewer sees there).
var<private> first_albedo: vec3<f32>;
var<private> first_normal: vec3<f32>;

fn sample_weight_albedo(weight: vec4<f32>) -> vec3<f32> {
    return clamp(to_rgb(weight), vec3<f32>(0.0), vec3<f32>(1.0));
}

fn path_radiance(start: vec3<f32>, direction: vec3<f32>, state: ptr<function, u32>)
    -> vec4<f32> {
    let e = params.environment;
    first_albedo = vec3<f32>(0.0);
    first_normal = vec3<f32>(0.0);
    var origin = start;
    var d = direction;
    var throughput = vec4<f32>(1.0);
    var radiance = vec4<f32>(0.0);
    // The camera ray and Dirac bounces see the environment directly: no other strategy
    // could have found it.
    var specular = true;
    var last_pdf = 0.0;
    for (var depth = 0u; depth <= MAX_BOUNCES; depth++) {
        var hit = Hit(FAR, -1, 0.0, 0.0);
        if (!CONVEX_ALONE || depth == 0u) {
            hit = trace(origin, d, FAR, false);
        }
        if (hit.primitive < 0) {
            var weight = 1.0;
            if (!specular) {
                weight = power_heuristic(last_pdf, light_probability(0u) * sky_pdf(e, d));
            }
            let sky = sky_radiance(e, d);
            if (depth == 0u) {
                first_albedo = clamp(sky, vec3<f32>(0.0), vec3<f32>(1.0));
            }
            radiance += throughput * upsample(sky) * weight;
            break;
        }
        let first_light = i32(params.triangles + params.spheres + params.planes);
        if (hit.primitive >= first_light) {
            let k = u32(hit.primitive - first_light);
            if (depth == 0u) {
                let base = 2u * params.point_lights + 4u * k;
                let normal = normalize(cross(lights[base + 1u].xyz, lights[base + 2u].xyz));
                first_albedo = clamp(lights[base + 3u].xyz, vec3<f32>(0.0), vec3<f32>(1.0));
                first_normal = select(normal, -normal, dot(normal, d) > 0.0);
            }
            radiance += throughput * area_light_radiance(k, d, hit.t, specular, last_pdf);
            break;
        }
        if (depth == MAX_BOUNCES) {
            break;
        }
        let surface = surface_at(origin, d, hit);
        let m = materials[surface.material];
        prepare_material(m, surface.uv);
        let frame = frame_about(surface.shading);
        let wi = to_local(frame, -d);
        if (depth == 0u) {
            first_normal = surface.shading;
            first_albedo = select(vec3<f32>(0.0), m.albedo, m.kind == MATERIAL_LAMBERTIAN);
        }
        // Interpolated normals can face away from a viewer that the face itself sees.
        if (wi.z <= 0.0) {
            break;
        }
        let scale = max(max(abs(surface.position.x), abs(surface.position.y)),
                        abs(surface.position.z));
        let next = surface.position + surface.geometric * (params.epsilon + 1e-5 * scale);
        radiance += throughput * direct_light(m, frame, wi, next, surface.geometric, state);
        //! if IBL != IBL_MONTE_CARLO
        radiance += throughput * ibl_radiance(m, surface.shading, -d);
        if (m.kind != MATERIAL_LAMBERTIAN) {
            // Drawn after the path's last random number: the image does not change.
            let drawn = bsdf_sample(m, wi, vec3<f32>(random(state), random(state),
                                                     random(state)));
            first_albedo = sample_weight_albedo(drawn.weight);
        }
        break;
        //! else
        let drawn = bsdf_sample(m, wi, vec3<f32>(random(state), random(state), random(state)));
        if (depth == 0u && m.kind != MATERIAL_LAMBERTIAN) {
            first_albedo = sample_weight_albedo(drawn.weight);
        }
        d = to_world(frame, drawn.wo);
        if (lanes_max(drawn.weight) <= 0.0 || dot(d, surface.geometric) <= 0.0) {
            break;
        }
        throughput *= drawn.weight;
        specular = drawn.dirac;
        last_pdf = drawn.pdf;
        origin = next;
        if (depth + 1u >= ROULETTE_FROM) {
            let survive = min(lanes_max(throughput), 0.95);
            if (random(state) >= survive) {
                break;
            }
            throughput /= survive;
        }
        //! endif
    }
    return radiance;
}

// Flags the dispatch when the device ended this invocation's loops early. Every writer stores
// the same value, so the race is harmless.
fn report_cut_loops() {
    if (loops_were_cut(params.count)) {
        loops_cut[0] = 1u;
    }
}

// One path per invocation: pixel first + index % count (a range of count pixels from first,
// the whole image by default), the pixel's sample (its count so far in accum.w) plus
// index / count. The random numbers depend on the pixel and the sample only, so an image of n
// samples a pixel is the same however its dispatches split the pixels and the samples. Looping
// over samples in one invocation would be cheaper, but a loop budget (Mesa 22's lavapipe: 65536
// iterations counted over the whole invocation) would end it, and BVH traversals add up to
// thousands a path.
@compute @workgroup_size(WORKGROUP_SIZE)
fn render(@builtin(global_invocation_id) gid: vec3<u32>,
          @builtin(num_workgroups) nwg: vec3<u32>) {
    let index = global_index(gid, nwg);
    if (index >= params.count * params.samples) {
        return;
    }
    let pixel_index = params.first + index % params.count;
    let sample = u32(accum[pixel_index].w) + index / params.count;
    var state = pcg_hash(pixel_index ^ pcg_hash(sample ^ pcg_hash(params.seed)));
    let pixel = vec2<f32>(f32(pixel_index % params.width) + random(&state),
                          f32(pixel_index / params.width) + random(&state));
    if (SPECTRAL) {
        start_wavelengths(random(&state));
    }
    let c = params.camera;
    paths[index] = to_rgb(path_radiance(c.origin, camera_direction(c, pixel), &state));
    path_features[index] = vec4<u32>(pack2x16float(first_albedo.xy),
                                     pack2x16float(vec2<f32>(first_albedo.z, 0.0)),
                                     pack2x16snorm(first_normal.xy),
                                     pack2x16snorm(vec2<f32>(first_normal.z, 0.0)));
    report_cut_loops();
}

// Each pixel's paths of a render dispatch (of the same range) added to its running sum.
@compute @workgroup_size(WORKGROUP_SIZE)
fn accumulate(@builtin(global_invocation_id) gid: vec3<u32>,
              @builtin(num_workgroups) nwg: vec3<u32>) {
    let index = global_index(gid, nwg);
    if (index >= params.count) {
        return;
    }
    var total = vec3<f32>(0.0);
    var albedo = vec3<f32>(0.0);
    var normal = vec3<f32>(0.0);
    for (var k = 0u; k < params.samples; k++) {
        let path = index + k * params.count;
        total += paths[path];
        let f = path_features[path];
        albedo += vec3<f32>(unpack2x16float(f.x), unpack2x16float(f.y).x);
        normal += vec3<f32>(unpack2x16snorm(f.z), unpack2x16snorm(f.w).x);
    }
    let pixel = params.first + index;
    accum[pixel] += vec4<f32>(total, f32(params.samples));
    albedo_sum[pixel] += vec4<f32>(albedo, 0.0);
    normal_sum[pixel] += vec4<f32>(normal, 0.0);
    report_cut_loops();
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn primary_hits(@builtin(global_invocation_id) gid: vec3<u32>,
                @builtin(num_workgroups) nwg: vec3<u32>) {
    let index = global_index(gid, nwg);
    if (index >= params.count) {
        return;
    }
    let pixel = vec2<f32>(f32(index % params.width) + 0.5, f32(index / params.width) + 0.5);
    let c = params.camera;
    let hit = trace(c.origin, camera_direction(c, pixel), FAR, false);
    accum[index] = vec4<f32>(hit.t, f32(hit.primitive), 0.0, 0.0);
    report_cut_loops();
}
