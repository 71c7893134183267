// Entry points of the real-time rasterizer, run by wgbragg/render/rasterizer.py as a wgpu render
// pipeline. It draws the primitives the path tracer traces (render/renderer_scene.wgsl), pulling
// their vertices from the same buffers, and shades each pixel's visible point with the path
// tracer's own functions (render/renderer_shading.wgsl): bsdf_eval for point and area lights,
// ibl_radiance for the prefiltered environment, sky_radiance behind everything.
//   surface_vertex:       3 vertices per triangle (BVH order), barycentrics interpolated, then
//                         6 per plane and per area light, (u, v) interpolated
//   sphere_vertex:        36 vertices per sphere: the cube around it, whose fragments intersect
//                         the exact sphere (sphere_fragment writes their depth)
//   background_vertex:    one triangle over the screen at the cleared depth (the sky)
// Fragments shade the hit of the ray through the pixel's centre: the same Hit (t, primitive,
// barycentrics) the path tracer's camera ray finds, read from the rasterized surface. With
// VISIBILITY they write (t, primitive, 0, 0) instead of a colour: the visibility buffer.
// Depth is reversed (near / z, greater is nearer) with an infinite far plane.
// Shadows: point lights and area lights (from their centre) cast shadows through shadow maps,
// six faces per light in one depth texture array, rendered by the same vertex entry points with
// a face's View (shadow_depth_fragment for spheres).
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

// Fragments write the visibility buffer (t, primitive) instead of radiance.
override VISIBILITY: bool = false;

// The camera of a pass (the scene's, or a shadow map face's: forward a unit axis, right and up
// unit, a 90 degree square view) and what the shading reads of the shadow maps.
struct View {
    camera: Camera,
    near: f32,            // the near plane's distance along camera.forward
    shadow_lights: u32,   // lights with shadow maps: point lights, then area lights
    shadow_size: f32,     // texels a shadow map side
    shadow_near: f32,     // the shadow faces' near plane
    jitter: vec2<f32>,    // pixel offset of this frame's samples from the pixel centres
}

@group(0) @binding(23) var<uniform> params: Params;
@group(1) @binding(0) var<uniform> view: View;
// Six layers a light (face f of light k at 6 k + f: +x, -x, +y, -y, +z, -z), reversed depth.
@group(1) @binding(1) var shadow_maps: texture_depth_2d_array;
@group(1) @binding(2) var shadow_sampler: sampler_comparison;

struct Varyings {
    // Invariant: the depth prepass and the shading pass compare equal depths.
    @invariant @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(flat) primitive: u32,
    // A triangle's barycentric weights of its second and third corners; a parallelogram's
    // (u, v) along its edges.
    @location(1) weights: vec2<f32>,
}

// ----------------------------------------------------------------------------- vertices

// The view's projection, shifted by -jitter pixels: the pixel centre c then samples the
// camera's pixel c + jitter.
fn clip_position(p: vec3<f32>) -> vec4<f32> {
    let c = view.camera;
    let relative = p - c.origin;
    let w = dot(relative, c.forward);
    let shift = vec2<f32>(-2.0 * view.jitter.x / c.width, 2.0 * view.jitter.y / c.height);
    return vec4<f32>(dot(relative, c.right) / dot(c.right, c.right) + shift.x * w,
                     dot(relative, c.up) / dot(c.up, c.up) + shift.y * w, view.near, w);
}

// Corner k of parallelogram j: the planes, then the area lights.
fn parallelogram_rows(j: u32) -> mat3x3<f32> {
    if (j < params.planes) {
        let row = 4u * (params.spheres + j);
        return mat3x3<f32>(shape_row(row).xyz, shape_row(row + 1u).xyz, shape_row(row + 2u).xyz);
    }
    let base = 2u * params.point_lights + 4u * (j - params.planes);
    return mat3x3<f32>(lights[base].xyz, lights[base + 1u].xyz, lights[base + 2u].xyz);
}

// The triangles (3 vertices each, BVH order), then the parallelograms (6 each: the planes,
// then the area lights, as two triangles (0, 0) (1, 0) (1, 1) and (0, 0) (1, 1) (0, 1)).
@vertex
fn surface_vertex(@builtin(vertex_index) i: u32) -> Varyings {
    let triangle_vertices = 3u * params.triangles;
    if (i < triangle_vertices) {
        let face = i / 3u;
        let corner = i % 3u;
        let weights = vec2<f32>(select(0.0, 1.0, corner == 1u), select(0.0, 1.0, corner == 2u));
        return Varyings(clip_position(triangle_corner(face, corner)), face, weights);
    }
    let j = (i - triangle_vertices) / 6u;
    let k = (i - triangle_vertices) % 6u;
    let uv = vec2<f32>(select(0.0, 1.0, k == 1u || k == 2u || k == 4u),
                       select(0.0, 1.0, k == 2u || k == 4u || k == 5u));
    let rows = parallelogram_rows(j);
    let p = rows[0] + uv.x * rows[1] + uv.y * rows[2];
    return Varyings(clip_position(p), params.triangles + params.spheres + j, uv);
}

@vertex
fn sphere_vertex(@builtin(vertex_index) i: u32, @builtin(instance_index) k: u32) -> Varyings {
    // The cube [-1, 1]^3 around the unit sphere, 12 triangles, mapped to world space by the
    // inverse of sphere_local's affine map.
    let face = i / 6u;
    let corner = i % 6u;
    let a = select(0.0, 1.0, corner == 1u || corner == 2u || corner == 4u) * 2.0 - 1.0;
    let b = select(0.0, 1.0, corner == 2u || corner == 4u || corner == 5u) * 2.0 - 1.0;
    let side = select(-1.0, 1.0, face % 2u == 0u);
    let axis = face / 2u;
    var local = vec3<f32>(side, a, b);
    if (axis == 1u) {
        local = vec3<f32>(a, side, b);
    } else if (axis == 2u) {
        local = vec3<f32>(a, b, side);
    }
    let r0 = shape_row(4u * k);
    let r1 = shape_row(4u * k + 1u);
    let r2 = shape_row(4u * k + 2u);
    let m = transpose(mat3x3<f32>(r0.xyz, r1.xyz, r2.xyz));
    let p = inverse3(m) * (local - vec3<f32>(r0.w, r1.w, r2.w));
    return Varyings(clip_position(p), params.triangles + k, vec2<f32>(0.0));
}

fn inverse3(m: mat3x3<f32>) -> mat3x3<f32> {
    let c0 = cross(m[1], m[2]);
    let c1 = cross(m[2], m[0]);
    let c2 = cross(m[0], m[1]);
    return transpose(mat3x3<f32>(c0, c1, c2)) * (1.0 / dot(m[0], c0));
}

@vertex
fn background_vertex(@builtin(vertex_index) i: u32) -> @invariant @builtin(position) vec4<f32> {
    let corner = vec2<f32>(select(-1.0, 3.0, i == 1u), select(-1.0, 3.0, i == 2u));
    return vec4<f32>(corner, 0.0, 1.0);
}

// ----------------------------------------------------------------------------- shadows

// How much of light k's shadow map sees `point` (0 to 1, 2 x 2 comparisons filtered): its
// face by the major axis of point - light, compared at the point's depth. `normal` (the
// geometric normal) moves the point by about a texel off its surface against acne.
fn light_visibility(k: u32, light: vec3<f32>, point: vec3<f32>, normal: vec3<f32>) -> f32 {
    if (k >= view.shadow_lights) {
        return 1.0;
    }
    let texel = 2.0 / view.shadow_size;
    let d0 = point - light;
    let major0 = max(max(abs(d0.x), abs(d0.y)), abs(d0.z));
    let w = d0 + normal * (1.5 * texel * major0);
    let a = abs(w);
    var layer = 6u * k;
    var major = a.z;
    var ndc = vec2<f32>(w.x, w.y);
    if (a.x >= a.y && a.x >= a.z) {
        layer += select(1u, 0u, w.x > 0.0);
        major = a.x;
        ndc = vec2<f32>(w.z, w.y);
    } else if (a.y >= a.z) {
        layer += select(3u, 2u, w.y > 0.0);
        major = a.y;
        ndc = vec2<f32>(w.x, w.z);
    } else {
        layer += select(5u, 4u, w.z > 0.0);
    }
    ndc /= major;
    let uv = vec2<f32>(0.5 * ndc.x + 0.5, 0.5 - 0.5 * ndc.y);
    let depth = view.shadow_near / major;
    return textureSampleCompareLevel(shadow_maps, shadow_sampler, uv, layer, depth * 1.0005);
}

// ----------------------------------------------------------------------------- shading

// Radiance towards the camera from the hit of the camera ray along unit `d`: the point and area
// lights' direct light (an area light as a point at its centre, with its area times the cosine
// at it), then the prefiltered environment, as the path tracer's filtered lighting shades its
// camera hits.
fn shade(d: vec3<f32>, hit: Hit) -> vec3<f32> {
    let origin = view.camera.origin;
    let first_light = params.triangles + params.spheres + params.planes;
    if (u32(hit.primitive) >= first_light) {
        let base = 2u * params.point_lights + 4u * (u32(hit.primitive) - first_light);
        var cos_area = -dot(cross(lights[base + 1u].xyz, lights[base + 2u].xyz), d);
        if (lights[base].w > 0.5) {
            cos_area = abs(cos_area);
        }
        return select(vec3<f32>(0.0), lights[base + 3u].xyz, cos_area > 0.0);
    }
    let surface = surface_at(origin, d, hit);
    let m = materials[surface.material];
    prepare_material(m, surface.uv);
    let frame = frame_about(surface.shading);
    let wi = to_local(frame, -d);
    if (wi.z <= 0.0) {
        return vec3<f32>(0.0);
    }
    var radiance = ibl_radiance(m, surface.shading, -d).xyz;
    let lights_total = params.point_lights + params.area_lights;
    for (var k = 0u; k < lights_total; k++) {
        var position: vec3<f32>;
        var intensity: vec3<f32>;
        if (k < params.point_lights) {
            position = lights[2u * k].xyz;
            intensity = lights[2u * k + 1u].xyz;
        } else {
            let base = 2u * params.point_lights + 4u * (k - params.point_lights);
            let edge_u = lights[base + 1u].xyz;
            let edge_v = lights[base + 2u].xyz;
            position = lights[base].xyz + 0.5 * (edge_u + edge_v);
            let l = normalize(surface.position - position);
            var emitting = dot(cross(edge_u, edge_v), l);
            if (lights[base].w > 0.5) {
                emitting = abs(emitting);
            }
            intensity = lights[base + 3u].xyz * max(emitting, 0.0);
        }
        let to_light = position - surface.position;
        let distance = length(to_light);
        let l = to_light / distance;
        let local = to_local(frame, l);
        let lit = any(intensity > vec3<f32>(0.0));
        if (!(dot(l, surface.geometric) > 0.0 && local.z > 0.0 && lit)) {
            continue;
        }
        let seen = light_visibility(k, position, surface.position, surface.geometric);
        if (seen <= 0.0) {
            continue;
        }
        radiance += bsdf_eval(m, wi, local).xyz * local.z * intensity
            * (seen / (distance * distance));
    }
    return radiance;
}

fn output(d: vec3<f32>, hit: Hit) -> vec4<f32> {
    //! if VISIBILITY
    return vec4<f32>(hit.t, f32(hit.primitive), 0.0, 0.0);
    //! else
    return vec4<f32>(shade(d, hit), 1.0);
    //! endif
}

fn pixel_ray(position: vec4<f32>) -> vec3<f32> {
    return camera_direction(view.camera, position.xy + view.jitter);
}

// ----------------------------------------------------------------------------- fragments

// Triangles and parallelograms: the hit is the rasterized point, at its distance along the ray.
@fragment
fn surface_fragment(v: Varyings) -> @location(0) vec4<f32> {
    let d = pixel_ray(v.position);
    let c = view.camera;
    var p: vec3<f32>;
    if (v.primitive < params.triangles) {
        let v0 = triangle_corner(v.primitive, 0u);
        p = v0 + v.weights.x * (triangle_corner(v.primitive, 1u) - v0)
            + v.weights.y * (triangle_corner(v.primitive, 2u) - v0);
    } else {
        let rows = parallelogram_rows(v.primitive - params.triangles - params.spheres);
        p = rows[0] + v.weights.x * rows[1] + v.weights.y * rows[2];
    }
    // The distance along d of the point where the ray meets the surface's depth.
    let t = dot(p - c.origin, c.forward) / dot(d, c.forward);
    return output(d, Hit(t, i32(v.primitive), v.weights.x, v.weights.y));
}

struct SphereOut {
    @location(0) value: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}

fn sphere_depth(v: Varyings) -> vec2<f32> {
    let d = pixel_ray(v.position);
    let t = sphere_hit(view.camera.origin, d, v.primitive - params.triangles);
    if (t <= 0.0) {
        discard;
    }
    return vec2<f32>(t, view.near / (t * dot(d, view.camera.forward)));
}

@fragment
fn sphere_fragment(v: Varyings) -> SphereOut {
    let hit = sphere_depth(v);
    return SphereOut(output(pixel_ray(v.position), Hit(hit.x, i32(v.primitive), 0.0, 0.0)),
                     hit.y);
}

@fragment
fn shadow_depth_fragment(v: Varyings) -> @builtin(frag_depth) f32 {
    return sphere_depth(v).y;
}

@fragment
fn background_fragment(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    //! if VISIBILITY
    return vec4<f32>(FAR, -1.0, 0.0, 0.0);
    //! else
    return vec4<f32>(sky_radiance(params.environment, pixel_ray(position)), 1.0);
    //! endif
}
