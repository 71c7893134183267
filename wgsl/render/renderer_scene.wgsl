// Scene queries of the path tracer (wgbragg/render/renderer.py): random numbers, camera rays, the
// ray casts against the scene's primitives (triangles through a BVH, exact spheres, area
// lights) and the surface frame (the procedural environments:
// lighting/procedural_environment.wgsl).
// Needs gpu/numerics.wgsl (PI, TWO_PI).
//
// Buffers. No bindings here: the including entry point declares, under these names,
//   vertices: array<vec4<f32>>   world-space positions (xyz)
//   normals:  array<vec4<f32>>   world-space unit shading normals per vertex (xyz)
//   faces:    array<vec4<u32>>   vertex indices (xyz) and material index (w), in the BVH's
//                                triangle order, so that a leaf's faces are contiguous
//   node_texels: texture_2d<f32> bvh.BVH's nodes, a texel each holding 32-bit words (float16
//                                boxes, references), as bvh_node and bvh_root read them
//   triangle_texels: texture_2d<f32> the corners of face i (in BVH order) at texels 3 i .. 3 i + 2,
//                                rows of SHAPE_TEXTURE_WIDTH texels, read by triangle_corner
//   shape_texels: texture_2d<f32> rows of SHAPE_TEXTURE_WIDTH texels, read by shape_row: 4 a
//                                sphere: the affine map from world space to the unit
//                                sphere (3 rows, translation in w), then (material, 0, 0, 0);
//                                then 4 rows a plane: its corner (material in w), edge_u,
//                                edge_v, unit normal
//   lights:   array<vec4<f32>>   point lights (2 rows each), then area lights (corner, edge_u,
//                                edge_v, radiance), then the light selection table
// and a `params: Params` uniform holding a `camera: Camera`, an `environment: Environment`
// (lighting/procedural_environment.wgsl) and the counts `triangles`, `spheres`, `planes`,
// `point_lights` and `area_lights`.
//
// Primitives are numbered as Renderer.primary_hits reports them: the triangles (in BVH order
// here), then the spheres, then the planes (parallelograms), then the area lights.

// Slots of bvh_trace_deep's stack: bvh.BVH.depth + 1 suffice; packing_geometry.py refuses
// deeper trees.
// A binned-SAH tree of 1.3 million triangles is 21 deep.
const STACK_SIZE: u32 = 48u;
// Entries of bvh_trace_registers' stack (at most its eight registers); a pipeline constant so
// that tests can make the deep traversal run.
override REGISTER_STACK: u32 = 8u;
// A node's reference word (wgbragg/render/packing_geometry.py _node_texels): for an interior
// node this bit and its number as a wide node (of four children, bvh.collapse_wide); for a
// leaf its first face << 7 | its number of faces.
const NODE_INTERIOR: u32 = 0x80000000u;
// Texels a row of node_texels (packing_geometry._node_texels), row-major: texel 0 the root
// box's centre and the root's reference, texels 4 k + 4 .. 4 k + 7 wide node k's four
// children, each its box relative to that centre as six float16 (rounded outward) and its
// reference, 32-bit words read with bitcast: a box in one texel (docs/performance.md,
// "Traversal").
const NODE_TEXTURE_WIDTH: u32 = 4096u;

// Texels a row of shape_texels (wgbragg/render/packing_geometry.py SHAPE_TEXTURE_WIDTH),
// row-major.
const SHAPE_TEXTURE_WIDTH: u32 = 4096u;

// Row i of the shapes (textureLoad costs llvmpipe less than a storage load, as for nodes).
fn shape_row(i: u32) -> vec4<f32> {
    return textureLoad(shape_texels, vec2<u32>(i % SHAPE_TEXTURE_WIDTH, i / SHAPE_TEXTURE_WIDTH),
                       0);
}

struct BvhNode {
    lo: vec3<f32>,        // relative to bvh_centre()
    hi: vec3<f32>,
    reference: u32,       // NODE_INTERIOR | its wide node, or first face << 7 | faces
}

fn node_word(i: u32) -> vec4<u32> {
    return bitcast<vec4<u32>>(textureLoad(node_texels, vec2<u32>(i % NODE_TEXTURE_WIDTH,
                                                                   i / NODE_TEXTURE_WIDTH), 0));
}

// Texel i >= 4: child i % 4 of wide node i / 4 - 1. The root is known by its reference
// alone (bvh_root).
fn bvh_node(i: u32) -> BvhNode {
    let w = node_word(i);
    let xy = unpack2x16float(w.x);
    let zx = unpack2x16float(w.y);
    let yz = unpack2x16float(w.z);
    return BvhNode(vec3<f32>(xy, zx.x), vec3<f32>(zx.y, yz), w.w);
}

// The root box's centre (boxes are stored relative to it) in xyz, the root's reference in w.
fn bvh_root() -> vec4<u32> {
    return node_word(0u);
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

// The scene holds triangles: otherwise the BVH is an empty placeholder, never traversed.
override MESHES: bool = true;

struct Hit {
    t: f32,           // distance along the unit direction; t_max when nothing was hit
    primitive: i32,   // -1 for a miss
    u: f32,           // a triangle's barycentric weights of its second and third vertex
    v: f32,
}

// Corner j of face i (BVH order), from triangle_texels: the traversal's triangle tests read
// textures, which llvmpipe loads faster than storage buffers (docs/performance.md).
fn triangle_corner(i: u32, j: u32) -> vec3<f32> {
    let at = 3u * i + j;
    return textureLoad(triangle_texels,
                       vec2<u32>(at % SHAPE_TEXTURE_WIDTH, at / SHAPE_TEXTURE_WIDTH), 0).xyz;
}

// Moller & Trumbore 1997, two-sided, as bvh._moller_trumbore.
fn triangle_hit(origin: vec3<f32>, direction: vec3<f32>, face: u32) -> vec3<f32> {
    let v0 = triangle_corner(face, 0u);
    let edge1 = triangle_corner(face, 1u) - v0;
    let edge2 = triangle_corner(face, 2u) - v0;
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

// Moller & Trumbore's algebra for the parallelogram corner + u edge_u + v edge_v, u and v in
// [0, 1], two-sided: (distance, u, v), the distance -1 for a miss.
fn parallelogram_hit(origin: vec3<f32>, direction: vec3<f32>, corner: vec3<f32>,
                     edge_u: vec3<f32>, edge_v: vec3<f32>) -> vec3<f32> {
    let miss = vec3<f32>(-1.0, 0.0, 0.0);
    let p = cross(direction, edge_v);
    let det = dot(edge_u, p);
    if (det == 0.0) {
        return miss;
    }
    let inverse = 1.0 / det;
    let s = origin - corner;
    let u = dot(s, p) * inverse;
    let q = cross(s, edge_u);
    let v = dot(direction, q) * inverse;
    if (u < 0.0 || u > 1.0 || v < 0.0 || v > 1.0) {
        return miss;
    }
    return vec3<f32>(dot(edge_v, q) * inverse, u, v);
}

// The point of world space `p` in sphere k's own space, where it is the unit sphere.
fn sphere_local(k: u32, p: vec3<f32>) -> vec3<f32> {
    let r0 = shape_row(4u * k);
    let r1 = shape_row(4u * k + 1u);
    let r2 = shape_row(4u * k + 2u);
    return vec3<f32>(dot(r0.xyz, p) + r0.w, dot(r1.xyz, p) + r1.w, dot(r2.xyz, p) + r2.w);
}

// The nearest distance > 0 to sphere k (any affine image of the unit sphere), or a value
// <= 0 for a miss. In its own space the ray's closest approach to the centre gives the
// discriminant without cancellation, and the roots' product (|o|^2 - 1) the far one.
fn sphere_hit(origin: vec3<f32>, direction: vec3<f32>, k: u32) -> f32 {
    let r0 = shape_row(4u * k);
    let r1 = shape_row(4u * k + 1u);
    let r2 = shape_row(4u * k + 2u);
    let o = vec3<f32>(dot(r0.xyz, origin) + r0.w, dot(r1.xyz, origin) + r1.w,
                      dot(r2.xyz, origin) + r2.w);
    let d = vec3<f32>(dot(r0.xyz, direction), dot(r1.xyz, direction), dot(r2.xyz, direction));
    let scale = length(d);
    let unit = d / scale;
    let b = dot(o, unit);
    let closest = o - b * unit;
    let h = 1.0 - dot(closest, closest);
    if (h < 0.0) {
        return -1.0;
    }
    let q = -b - select(-sqrt(h), sqrt(h), b >= 0.0);
    if (q == 0.0) {
        return -1.0;
    }
    let other = (dot(o, o) - 1.0) / q;
    let near = min(q, other);
    return select(max(q, other), near, near > 0.0) / scale;
}

// Entry and exit distances of the slab test; entry > exit for a miss.
fn box_span(origin: vec3<f32>, inverse: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>) -> vec2<f32> {
    let t0 = (lo - origin) * inverse;
    let t1 = (hi - origin) * inverse;
    let near = min(t0, t1);
    let far = max(t0, t1);
    return vec2<f32>(max(max(near.x, near.y), near.z), min(min(far.x, far.y), far.z));
}

// Faces first .. first + count - 1 against `best`; true when `any_hit` and one was hit.
fn leaf_hits(origin: vec3<f32>, direction: vec3<f32>, first: u32, count: u32,
             best: ptr<function, Hit>, any_hit: bool) -> bool {
    for (var k = 0u; k < count; k++) {
        let face = first + k;
        let h = triangle_hit(origin, direction, face);
        if (h.x > 0.0 && h.x < (*best).t) {
            *best = Hit(h.x, i32(face), h.y, h.z);
            if (any_hit) {
                return true;
            }
        }
    }
    return false;
}

// What opening a wide node did (bvh_open).
struct Opened {
    count: u32,    // interior children to visit (0 to 4); OPEN_DONE: the any-hit query is done
    c0: u32,       // their wide nodes, nearest first
    c1: u32,
    c2: u32,
    c3: u32,
}
const OPEN_DONE: u32 = 5u;

// Entry distance of a slot's box (0 from inside it), or -1 for a miss.
fn slot_entry(local: vec3<f32>, inverse: vec3<f32>, node: BvhNode, t_best: f32) -> f32 {
    let span = box_span(local, inverse, node.lo, node.hi);
    return select(-1.0, max(span.x, 0.0), span.x <= span.y && span.y >= 0.0 && span.x < t_best);
}

// Opens wide node k: its four children's boxes are tested here, a hit leaf's faces at once,
// and the hit interior children sorted by entry distance. `local` is the ray's origin
// relative to bvh_centre (boxes), `origin` its own (faces).
fn bvh_open(origin: vec3<f32>, direction: vec3<f32>, local: vec3<f32>, inverse: vec3<f32>,
            k: u32, best: ptr<function, Hit>, any_hit: bool) -> Opened {
    let n0 = bvh_node(4u * k + 4u);
    let n1 = bvh_node(4u * k + 5u);
    let n2 = bvh_node(4u * k + 6u);
    let n3 = bvh_node(4u * k + 7u);
    var e = vec4<f32>(slot_entry(local, inverse, n0, (*best).t),
                      slot_entry(local, inverse, n1, (*best).t),
                      slot_entry(local, inverse, n2, (*best).t),
                      slot_entry(local, inverse, n3, (*best).t));
    var r = vec4<u32>(n0.reference, n1.reference, n2.reference, n3.reference);
    let leaf = (e >= vec4<f32>(0.0)) & (r < vec4<u32>(NODE_INTERIOR));
    if (any(leaf)) {
        // The hit leaves' faces in one loop: face k of the leaf whose range holds it.
        let counts = select(vec4<u32>(0u), r & vec4<u32>(127u), leaf);
        let end0 = counts.x;
        let end1 = end0 + counts.y;
        let end2 = end1 + counts.z;
        let total = end2 + counts.w;
        let first = r >> vec4<u32>(7u);
        for (var k = 0u; k < total; k++) {
            let face = select(select(select(first.w + k - end2, first.z + k - end1, k < end2),
                                     first.y + k - end0, k < end1), first.x + k, k < end0);
            let h = triangle_hit(origin, direction, face);
            if (h.x > 0.0 && h.x < (*best).t) {
                *best = Hit(h.x, i32(face), h.y, h.z);
                if (any_hit) {
                    return Opened(OPEN_DONE, 0u, 0u, 0u, 0u);
                }
            }
        }
    }
    // Misses, leaves and boxes beyond the nearest hit found sort last (as +inf).
    let keep = (e >= vec4<f32>(0.0)) & !leaf & (e < vec4<f32>((*best).t));
    e = select(vec4<f32>(3.0e38), e, keep);
    // A sorting network of five compare-exchanges.
    var lo = select(e.yx, e.xy, e.x <= e.y);
    var rlo = select(r.yx, r.xy, e.x <= e.y);
    var hi = select(e.wz, e.zw, e.z <= e.w);
    var rhi = select(r.wz, r.zw, e.z <= e.w);
    let a0 = select(hi.x, lo.x, lo.x <= hi.x);
    let ra0 = select(rhi.x, rlo.x, lo.x <= hi.x);
    let b0 = select(lo.x, hi.x, lo.x <= hi.x);
    let rb0 = select(rlo.x, rhi.x, lo.x <= hi.x);
    let a1 = select(hi.y, lo.y, lo.y <= hi.y);
    let ra1 = select(rhi.y, rlo.y, lo.y <= hi.y);
    let b1 = select(lo.y, hi.y, lo.y <= hi.y);
    let rb1 = select(rlo.y, rhi.y, lo.y <= hi.y);
    // a0 is the least, b1 the greatest; b0 and a1 in between.
    let m0 = select(a1, b0, b0 <= a1);
    let rm0 = select(ra1, rb0, b0 <= a1);
    let m1 = select(b0, a1, b0 <= a1);
    let rm1 = select(rb0, ra1, b0 <= a1);
    let count = u32(keep.x) + u32(keep.y) + u32(keep.z) + u32(keep.w);
    let mask = ~NODE_INTERIOR;
    return Opened(count, ra0 & mask, rm0 & mask, rm1 & mask, rb1 & mask);
}

// The traversal with its stack in eight registers (s0 the top): llvmpipe keeps a dynamically
// indexed array per lane in memory, and such an array alone cost several % of a frame
// (docs/performance.md, "Traversal"). False if the stack would overflow: `best` then holds
// what was found so far, and bvh_trace_deep finishes the query.
fn bvh_trace_registers(origin: vec3<f32>, direction: vec3<f32>, local: vec3<f32>,
                       inverse: vec3<f32>, root: u32, best: ptr<function, Hit>,
                       any_hit: bool) -> bool {
    var s0 = 0u; var s1 = 0u; var s2 = 0u; var s3 = 0u;
    var s4 = 0u; var s5 = 0u; var s6 = 0u; var s7 = 0u;
    var top = 0u;
    var node = root;
    loop {
        let o = bvh_open(origin, direction, local, inverse, node, best, any_hit);
        if (o.count == OPEN_DONE) {
            return true;
        }
        if (o.count > 0u) {
            if (top + o.count - 1u > REGISTER_STACK) {
                return false;
            }
            // The farther ones pushed, the farthest first.
            if (o.count == 4u) {
                s7 = s6; s6 = s5; s5 = s4; s4 = s3; s3 = s2; s2 = s1; s1 = s0; s0 = o.c3;
            }
            if (o.count >= 3u) {
                s7 = s6; s6 = s5; s5 = s4; s4 = s3; s3 = s2; s2 = s1; s1 = s0; s0 = o.c2;
            }
            if (o.count >= 2u) {
                s7 = s6; s6 = s5; s5 = s4; s4 = s3; s3 = s2; s2 = s1; s1 = s0; s0 = o.c1;
            }
            top += o.count - 1u;
            node = o.c0;
            continue;
        }
        if (top == 0u) {
            return true;
        }
        node = s0;
        s0 = s1; s1 = s2; s2 = s3; s3 = s4; s4 = s5; s5 = s6; s6 = s7;
        top -= 1u;
    }
    return true;
}

// The same traversal with a stack in memory, as deep as any tree packing_geometry.py accepts:
// for the rare query that overflows bvh_trace_registers' eight entries, from the root again
// with the hits found so far pruning it.
fn bvh_trace_deep(origin: vec3<f32>, direction: vec3<f32>, local: vec3<f32>,
                  inverse: vec3<f32>, root: u32, best: ptr<function, Hit>, any_hit: bool) {
    var stack: array<u32, STACK_SIZE>;
    var top = 0u;
    var node = root;
    loop {
        let o = bvh_open(origin, direction, local, inverse, node, best, any_hit);
        if (o.count == OPEN_DONE) {
            return;
        }
        if (o.count > 0u) {
            if (o.count == 4u) {
                stack[top] = o.c3;
                top += 1u;
            }
            if (o.count >= 3u) {
                stack[top] = o.c2;
                top += 1u;
            }
            if (o.count >= 2u) {
                stack[top] = o.c1;
                top += 1u;
            }
            node = o.c0;
            continue;
        }
        if (top == 0u) {
            return;
        }
        top -= 1u;
        node = stack[top];
    }
}

// Closest hit with 0 < t < t_max; with `any_hit` the first hit found (shadow rays). Spheres,
// planes and area lights first, each a few loads, so that their hits prune the BVH.
fn trace(origin: vec3<f32>, direction: vec3<f32>, t_max: f32, any_hit: bool) -> Hit {
    var best = Hit(t_max, -1, 0.0, 0.0);
    for (var k = 0u; k < params.spheres; k++) {
        let t = sphere_hit(origin, direction, k);
        if (t > 0.0 && t < best.t) {
            best = Hit(t, i32(params.triangles + k), 0.0, 0.0);
            if (any_hit) {
                return best;
            }
        }
    }
    let first_plane = params.triangles + params.spheres;
    for (var k = 0u; k < params.planes; k++) {
        let row = 4u * (params.spheres + k);
        let h = parallelogram_hit(origin, direction, shape_row(row).xyz, shape_row(row + 1u).xyz,
                                  shape_row(row + 2u).xyz);
        if (h.x > 0.0 && h.x < best.t) {
            best = Hit(h.x, i32(first_plane + k), h.y, h.z);
            if (any_hit) {
                return best;
            }
        }
    }
    for (var k = 0u; k < params.area_lights; k++) {
        let base = 2u * params.point_lights + 4u * k;
        let t = parallelogram_hit(origin, direction, lights[base].xyz, lights[base + 1u].xyz,
                                  lights[base + 2u].xyz).x;
        if (t > 0.0 && t < best.t) {
            best = Hit(t, i32(first_plane + params.planes + k), 0.0, 0.0);
            if (any_hit) {
                return best;
            }
        }
    }
    if (!MESHES) {
        return best;
    }
    let inverse = 1.0 / direction;
    let root = bvh_root();
    let local = origin - bitcast<vec3<f32>>(root.xyz);
    if (root.w < NODE_INTERIOR) {
        // A tree of one leaf.
        leaf_hits(origin, direction, root.w >> 7u, root.w & 127u, &best, any_hit);
        return best;
    }
    let wide = root.w & ~NODE_INTERIOR;
    if (!bvh_trace_registers(origin, direction, local, inverse, wide, &best, any_hit)) {
        bvh_trace_deep(origin, direction, local, inverse, wide, &best, any_hit);
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

// A sphere's surface: the normal is the gradient of |local|^2, M^T local for the affine map
// M of sphere_local; uv as the tessellated sphere's (wgbragg.scene.meshes.sphere_mesh, +z up
// there): u the azimuth from +x towards -z over 2 pi, v = 1/2 + latitude / pi.
fn sphere_surface(position: vec3<f32>, direction: vec3<f32>, k: u32) -> Surface {
    let local = sphere_local(k, position);
    var normal = normalize(local.x * shape_row(4u * k).xyz + local.y * shape_row(4u * k + 1u).xyz
                           + local.z * shape_row(4u * k + 2u).xyz);
    if (dot(normal, direction) > 0.0) {
        normal = -normal;
    }
    let uv = vec2<f32>(fract(atan2(-local.z, local.x) / TWO_PI),
                       0.5 + asin(clamp(local.y / length(local), -1.0, 1.0)) / PI);
    return Surface(position, normal, normal, u32(shape_row(4u * k + 3u).x), uv);
}

// The surface of a triangle, sphere or plane hit (area lights are not surfaces: they only
// emit).
fn surface_at(origin: vec3<f32>, direction: vec3<f32>, hit: Hit) -> Surface {
    let primitive = u32(hit.primitive);
    let position = origin + hit.t * direction;
    if (primitive >= params.triangles + params.spheres) {
        // A plane: its normal and (u, v) along its edges, as the two triangles of
        // wgbragg.scene.meshes.plane_mesh would interpolate them.
        let row = 4u * (primitive - params.triangles);
        var normal = shape_row(row + 3u).xyz;
        if (dot(normal, direction) > 0.0) {
            normal = -normal;
        }
        return Surface(position, normal, normal, u32(shape_row(row).w), vec2<f32>(hit.u, hit.v));
    }
    if (primitive >= params.triangles) {
        return sphere_surface(position, direction, primitive - params.triangles);
    }
    let f = faces[primitive];
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
