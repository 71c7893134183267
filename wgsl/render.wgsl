// Entry points of the progressive RGB path tracer, run by wgbragg/render.py:
//   render:        one path per pixel, its radiance added to accum (rgb, and 1 in w)
//   primary_hits:  the closest hit of each pixel-centre camera ray, accum = (t, face, 0, 0),
//                  face -1 and t = 3.4e38 for a miss (to check the traversal against numpy)
// Light transport: next-event estimation towards the environment (combined with BRDF
// sampling by the power heuristic), point lights and area lights (shadow rays, which only
// next-event estimation reaches: neither kind is part of the geometry), Russian roulette
// after a few bounces. Materials are seen only through bsdf_eval / bsdf_pdf / bsdf_sample.
//! include "harness.wgsl"
//! include "numerics.wgsl"
//! include "complex.wgsl"
//! include "layer.wgsl"
//! include "yeh.wgsl"
//! include "landmarks.wgsl"
//! include "colour_landmark.wgsl"
//! include "ggx.wgsl"
//! include "layered.wgsl"
//! include "layered_brdf.wgsl"
//! include "render_scene.wgsl"

// Bounces after the camera ray; the path ends at a hit beyond them.
override MAX_BOUNCES: u32 = 8u;
// Russian roulette from this bounce on: the first bounces carry most of the image.
override ROULETTE_FROM: u32 = 3u;
// The scene holds layered Bragg materials: otherwise their code is never reached.
override LAYERED: bool = false;

const MATERIAL_LAMBERTIAN: u32 = 0u;
const MATERIAL_LAYERED: u32 = 1u;
const FAR: f32 = 3.4e38;

struct Material {
    albedo: vec3<f32>,    // Lambertian albedo, linear sRGB
    kind: u32,
    structure: u32,       // index in structures, layered materials
}

struct Params {
    camera: Camera,
    environment: Environment,
    pass_index: u32,
    count: u32,           // pixels
    width: u32,
    point_lights: u32,
    area_lights: u32,
    epsilon: f32,         // ray offset from a surface, in scene units, besides 1e-5 of
                          // the hit point's largest coordinate (its float32 rounding)
    seed: u32,
    _pad0: u32,
}

@group(0) @binding(0) var<storage, read> vertices: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> normals: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> faces: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read> nodes: array<BvhNode>;
@group(0) @binding(4) var<storage, read> materials: array<Material>;
@group(0) @binding(5) var<storage, read> structures: array<LayeredStructure>;
@group(0) @binding(6) var<storage, read> layers: array<RoughLayer>;
@group(0) @binding(7) var<storage, read> tables: array<f32>;
// Point lights (position, intensity), then area lights (corner, edge_u, edge_v, radiance).
@group(0) @binding(8) var<storage, read> lights: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read_write> accum: array<vec4<f32>>;
@group(0) @binding(10) var<uniform> params: Params;

// ----------------------------------------------------------------------------- materials

struct BsdfSample {
    wo: vec3<f32>,
    weight: vec3<f32>,    // f cos / pdf, or the Dirac lobe's weight
    pdf: f32,             // 0 for a Dirac lobe
    dirac: bool,
}

// f (1/sr) for local directions, +z the shading normal.
fn bsdf_eval(m: Material, wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    if (LAYERED && m.kind == MATERIAL_LAYERED) {
        let s = structures[m.structure];
        return layered_eval_rgb(s, layered_pair(s, wi, wo));
    }
    return select(vec3<f32>(0.0), m.albedo / PI, wi.z > 0.0 && wo.z > 0.0);
}

fn bsdf_pdf(m: Material, wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    if (LAYERED && m.kind == MATERIAL_LAYERED) {
        return layered_pdf(structures[m.structure], wi, wo);
    }
    return select(0.0, wo.z / PI, wi.z > 0.0 && wo.z > 0.0);
}

fn bsdf_sample(m: Material, wi: vec3<f32>, u: vec3<f32>) -> BsdfSample {
    if (LAYERED && m.kind == MATERIAL_LAYERED) {
        let s = structures[m.structure];
        let drawn = layered_sample(s, wi, u);
        var weight = vec3<f32>(drawn.dirac);
        if (drawn.cos_over_pdf > 0.0) {
            weight += layered_eval_rgb(s, layered_pair(s, wi, drawn.wo)) * drawn.cos_over_pdf;
        }
        return BsdfSample(drawn.wo, weight, drawn.pdf, drawn.dirac > 0.0);
    }
    let wo = cosine_direction(u.yz);
    return BsdfSample(wo, m.albedo, wo.z / PI, false);
}

// ----------------------------------------------------------------------------- transport

fn power_heuristic(a: f32, b: f32) -> f32 {
    let a2 = a * a;
    return a2 / (a2 + b * b);
}

fn unoccluded(origin: vec3<f32>, direction: vec3<f32>, distance: f32) -> bool {
    return trace(origin, direction, distance, true).face < 0;
}

// Radiance reflected at one vertex towards wi from the lights reached by shadow rays.
fn direct_light(m: Material, frame: Frame, wi: vec3<f32>, origin: vec3<f32>,
                geometric: vec3<f32>, state: ptr<function, u32>) -> vec3<f32> {
    let e = params.environment;
    var total = vec3<f32>(0.0);
    let d = environment_sample(e, vec3<f32>(random(state), random(state), random(state)));
    let local = to_local(frame, d);
    if (dot(d, geometric) > 0.0 && local.z > 0.0) {
        let f = bsdf_eval(m, wi, local);
        if (any(f > vec3<f32>(0.0)) && unoccluded(origin, d, FAR)) {
            let light_pdf = environment_pdf(e, d);
            let weight = power_heuristic(light_pdf, bsdf_pdf(m, wi, local));
            total += f * local.z * environment_radiance(e, d) * (weight / light_pdf);
        }
    }
    for (var k = 0u; k < params.point_lights; k++) {
        let to_light = lights[2u * k].xyz - origin;
        let distance = length(to_light);
        let l = to_light / distance;
        let local_l = to_local(frame, l);
        if (dot(l, geometric) > 0.0 && local_l.z > 0.0 && unoccluded(origin, l, distance)) {
            total += bsdf_eval(m, wi, local_l) * local_l.z * lights[2u * k + 1u].xyz
                / (distance * distance);
        }
    }
    let first_area = 2u * params.point_lights;
    for (var k = 0u; k < params.area_lights; k++) {
        let base = first_area + 4u * k;
        let edge_u = lights[base + 1u].xyz;
        let edge_v = lights[base + 2u].xyz;
        let normal_area = cross(edge_u, edge_v);
        let point = lights[base].xyz + random(state) * edge_u + random(state) * edge_v;
        let to_light = point - origin;
        let distance = length(to_light);
        let l = to_light / distance;
        // One-sided emitter: it shines towards edge_u x edge_v.
        let emitting = -dot(normal_area, l);
        let local_l = to_local(frame, l);
        if (emitting > 0.0 && dot(l, geometric) > 0.0 && local_l.z > 0.0
            && unoccluded(origin, l, distance * (1.0 - 1e-4))) {
            // Uniform on the area (pdf 1 / A): A cos_light / distance^2, and emitting is A cos_light.
            total += bsdf_eval(m, wi, local_l) * local_l.z * lights[base + 3u].xyz * emitting
                / (distance * distance);
        }
    }
    return total;
}

fn path_radiance(start: vec3<f32>, direction: vec3<f32>, state: ptr<function, u32>)
    -> vec3<f32> {
    let e = params.environment;
    var origin = start;
    var d = direction;
    var throughput = vec3<f32>(1.0);
    var radiance = vec3<f32>(0.0);
    // The camera ray and Dirac bounces see the environment directly: no other strategy
    // could have found it.
    var specular = true;
    var last_pdf = 0.0;
    for (var depth = 0u; depth <= MAX_BOUNCES; depth++) {
        let hit = trace(origin, d, FAR, false);
        if (hit.face < 0) {
            var weight = 1.0;
            if (!specular) {
                weight = power_heuristic(last_pdf, environment_pdf(e, d));
            }
            radiance += throughput * environment_radiance(e, d) * weight;
            break;
        }
        if (depth == MAX_BOUNCES) {
            break;
        }
        let surface = surface_at(origin, d, hit);
        let m = materials[surface.material];
        let frame = frame_about(surface.shading);
        let wi = to_local(frame, -d);
        // Interpolated normals can face away from a viewer that the face itself sees.
        if (wi.z <= 0.0) {
            break;
        }
        let scale = max(max(abs(surface.position.x), abs(surface.position.y)),
                        abs(surface.position.z));
        let next = surface.position + surface.geometric * (params.epsilon + 1e-5 * scale);
        radiance += throughput * direct_light(m, frame, wi, next, surface.geometric, state);

        let drawn = bsdf_sample(m, wi, vec3<f32>(random(state), random(state), random(state)));
        d = to_world(frame, drawn.wo);
        if (!any(drawn.weight > vec3<f32>(0.0)) || dot(d, surface.geometric) <= 0.0) {
            break;
        }
        throughput *= drawn.weight;
        specular = drawn.dirac;
        last_pdf = drawn.pdf;
        origin = next;
        if (depth + 1u >= ROULETTE_FROM) {
            let survive = min(max(max(throughput.x, throughput.y), throughput.z), 0.95);
            if (random(state) >= survive) {
                break;
            }
            throughput /= survive;
        }
    }
    return radiance;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn render(@builtin(global_invocation_id) gid: vec3<u32>,
          @builtin(num_workgroups) nwg: vec3<u32>) {
    let index = global_index(gid, nwg);
    if (index >= params.count) {
        return;
    }
    var state = pcg_hash(index ^ pcg_hash(params.pass_index ^ pcg_hash(params.seed)));
    let pixel = vec2<f32>(f32(index % params.width) + random(&state),
                          f32(index / params.width) + random(&state));
    let c = params.camera;
    let radiance = path_radiance(c.origin, camera_direction(c, pixel), &state);
    accum[index] += vec4<f32>(radiance, 1.0);
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
    accum[index] = vec4<f32>(hit.t, f32(hit.face), 0.0, 0.0);
}
