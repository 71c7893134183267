// Scene queries of the path tracer (wgbragg/render/renderer.py): random numbers, camera rays, the BVH
// traversal and ray-triangle tests and the surface frame (the procedural environments:
// lighting/procedural_environment.wgsl).
// Needs gpu/numerics.wgsl (PI, TWO_PI).
//
// Buffers. No bindings here: the including entry point declares, under these names,
//   vertices: array<vec4<f32>>   world-space positions (xyz)
//   normals:  array<vec4<f32>>   world-space unit shading normals per vertex (xyz)
//   faces:    array<vec4<u32>>   vertex indices (xyz) and material index (w), in the BVH's
//                                triangle order, so that a leaf's faces are contiguous
//   node_texels: texture_2d<f32> bvh.BVH, depth-first with sibling pairs, as bvh_node reads it
// and a `params: Params` uniform holding a `camera: Camera` and an `environment: Environment`
// (lighting/procedural_environment.wgsl).

// Traversal stack slots: bvh.BVH.depth + 1 slots suffice; render.py refuses deeper trees. A
// binned-SAH tree of 1.3 million triangles is 21 deep; every slot costs its zeroing per trace.
const STACK_SIZE: u32 = 32u;
// A leaf stores its first face where an inner node stores its left child.
// BvhNode.count of an interior node: this bit, the axis along which its right child's centre
// lies farthest from its left child's (bits 1-2), and whether the right child lies on the
// negative side (bit 0). A leaf's count is its number of faces.
const INTERIOR: u32 = 0x40000000u;
// Texels a row of node_texels (wgbragg/render/packing.py _node_texels): node i at texels 2i and
// 2i + 1, row-major. On lavapipe textureLoad costs less than storage loads: the path tracer
// ran 1.5x faster, with identical images (docs/performance.md).
const NODE_TEXTURE_WIDTH: u32 = 4096u;

struct BvhNode {
    lo: vec3<f32>,
    left_or_first: u32,
    hi: vec3<f32>,
    count: u32,           // faces of a leaf, INTERIOR | axis and side of an inner node
}

// Node i of node_texels: (lo, left_or_first) and (hi, count), both integers stored as exact
// float32, an interior node's count code c as -(c & 7) - 1. The row width is even, so both
// texels share a row.
fn bvh_node(i: u32) -> BvhNode {
    let at = 2u * i;
    let texel = vec2<u32>(at % NODE_TEXTURE_WIDTH, at / NODE_TEXTURE_WIDTH);
    let a = textureLoad(node_texels, texel, 0);
    let b = textureLoad(node_texels, texel + vec2<u32>(1u, 0u), 0);
    let count = select(u32(b.w), INTERIOR | u32(-b.w - 1.0), b.w < 0.0);
    return BvhNode(a.xyz, u32(a.w), b.xyz, count);
}

struct Camera {
    origin: vec3<f32>,
    width: f32,
    forward: vec3<f32>,
    height: f32,
    right: vec3<f32>,     // scaled by tan(fov / 2) * aspect
    _pad0: f32,
    up: vec3<f32>,        // scaled by tan(fov / 2)
    _pad1: f32,
}

// ----------------------------------------------------------------------------- random numbers

// PCG-RXS-M-XS 32 (Jarzynski & Olano 2020, "Hash Functions for GPU Rendering"): a hash good
// enough to seed every pixel and pass independently, and a generator when iterated.
fn pcg_hash(x: u32) -> u32 {
    let state = x * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

fn random(state: ptr<function, u32>) -> f32 {
    *state = pcg_hash(*state);
    // 24 bits: every value is exact in f32 and below 1.
    return f32(*state >> 8u) * (1.0 / 16777216.0);
}

// ----------------------------------------------------------------------------- camera

fn camera_direction(c: Camera, pixel: vec2<f32>) -> vec3<f32> {
    let ndc = vec2<f32>(2.0 * pixel.x / c.width - 1.0, 1.0 - 2.0 * pixel.y / c.height);
    return normalize(c.forward + ndc.x * c.right + ndc.y * c.up);
}

// ----------------------------------------------------------------------------- intersection

struct Hit {
    t: f32,           // distance along the unit direction; t_max when nothing was hit
    face: i32,        // -1 for a miss
    u: f32,           // barycentric weights of the face's second and third vertex
    v: f32,
}

// Moller & Trumbore 1997, two-sided, as bvh._moller_trumbore.
fn triangle_hit(origin: vec3<f32>, direction: vec3<f32>, face: u32) -> vec3<f32> {
    let f = faces[face];
    let v0 = vertices[f.x].xyz;
    let edge1 = vertices[f.y].xyz - v0;
    let edge2 = vertices[f.z].xyz - v0;
    let p = cross(direction, edge2);
    let det = dot(edge1, p);
    let miss = vec3<f32>(-1.0, 0.0, 0.0);
    if (det == 0.0) {
        return miss;
    }
    let inverse = 1.0 / det;
    let s = origin - v0;
    let u = dot(s, p) * inverse;
    let q = cross(s, edge1);
    let v = dot(direction, q) * inverse;
    if (u < 0.0 || v < 0.0 || u + v > 1.0) {
        return miss;
    }
    return vec3<f32>(dot(edge2, q) * inverse, u, v);
}

// Entry and exit distances of the slab test; entry > exit for a miss.
fn box_span(origin: vec3<f32>, inverse: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>) -> vec2<f32> {
    let t0 = (lo - origin) * inverse;
    let t1 = (hi - origin) * inverse;
    let near = min(t0, t1);
    let far = max(t0, t1);
    return vec2<f32>(max(max(near.x, near.y), near.z), min(min(far.x, far.y), far.z));
}

// Closest hit with 0 < t < t_max; with `any_hit` the first hit found (shadow rays).
fn trace(origin: vec3<f32>, direction: vec3<f32>, t_max: f32, any_hit: bool) -> Hit {
    var best = Hit(t_max, -1, 0.0, 0.0);
    let inverse = 1.0 / direction;
    var stack: array<u32, STACK_SIZE>;
    var top = 1u;
    stack[0] = 0u;
    while (top > 0u) {
        top -= 1u;
        let node = bvh_node(stack[top]);
        let span = box_span(origin, inverse, node.lo, node.hi);
        if (span.x > span.y || span.y < 0.0 || span.x >= best.t) {
            continue;
        }
        if (node.count < INTERIOR) {
            for (var k = 0u; k < node.count; k++) {
                let face = node.left_or_first + k;
                let h = triangle_hit(origin, direction, face);
                if (h.x > 0.0 && h.x < best.t) {
                    best = Hit(h.x, i32(face), h.y, h.z);
                    if (any_hit) {
                        return best;
                    }
                }
            }
            continue;
        }
        let left = node.left_or_first;
        // The nearer child is popped first, so that its hits prune the other: the right one
        // when the ray runs against the axis along which the children's centres part most.
        let axis = (node.count >> 1u) & 3u;
        let right_first = (direction[axis] < 0.0) != ((node.count & 1u) == 1u);
        stack[top] = select(left, left + 1u, !right_first);
        stack[top + 1u] = select(left + 1u, left, !right_first);
        top += 2u;
    }
    return best;
}

struct Surface {
    position: vec3<f32>,
    geometric: vec3<f32>,   // unit face normal, on the side the ray came from
    shading: vec3<f32>,     // interpolated vertex normal, on the same side
    material: u32,
    uv: vec2<f32>,          // interpolated texture coordinates (vertices.w, normals.w)
}

fn surface_at(origin: vec3<f32>, direction: vec3<f32>, hit: Hit) -> Surface {
    let f = faces[u32(hit.face)];
    let v0 = vertices[f.x].xyz;
    var geometric = normalize(cross(vertices[f.y].xyz - v0, vertices[f.z].xyz - v0));
    let w = 1.0 - hit.u - hit.v;
    var shading = normalize(w * normals[f.x].xyz + hit.u * normals[f.y].xyz
                            + hit.v * normals[f.z].xyz);
    // Two-sided surfaces: seen from behind, both normals turn towards the viewer.
    if (dot(geometric, direction) > 0.0) {
        geometric = -geometric;
    }
    if (dot(shading, geometric) < 0.0) {
        shading = -shading;
    }
    let uv = w * vec2<f32>(vertices[f.x].w, normals[f.x].w)
        + hit.u * vec2<f32>(vertices[f.y].w, normals[f.y].w)
        + hit.v * vec2<f32>(vertices[f.z].w, normals[f.z].w);
    return Surface(origin + hit.t * direction, geometric, shading, f.w, uv);
}

// ----------------------------------------------------------------------------- frames

// An orthonormal basis with `n` as +z (Duff et al. 2017, "Building an Orthonormal Basis,
// Revisited"), continuous except on the plane z = 0 crossing.
struct Frame {
    x: vec3<f32>,
    y: vec3<f32>,
    z: vec3<f32>,
}

fn frame_about(n: vec3<f32>) -> Frame {
    let sign = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    return Frame(vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
                 vec3<f32>(b, sign + n.y * n.y * a, -n.y), n);
}

fn to_local(f: Frame, w: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(w, f.x), dot(w, f.y), dot(w, f.z));
}

fn to_world(f: Frame, w: vec3<f32>) -> vec3<f32> {
    return w.x * f.x + w.y * f.y + w.z * f.z;
}

fn cosine_direction(u: vec2<f32>) -> vec3<f32> {
    let radius = sqrt(u.x);
    let phi = TWO_PI * u.y;
    return vec3<f32>(radius * cos(phi), radius * sin(phi), sqrt(max(0.0, 1.0 - u.x)));
}
