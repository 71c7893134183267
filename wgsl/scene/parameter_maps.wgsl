// Spatially varying parameters over texture coordinates (period and delta of Bragg layers,
// Bragg paper supplemental Fig. 7): the float32 twin of map_values (wgbragg/scene/parameter_maps.py,
// which states the definitions; the ParameterMap docstring of wgbragg/scene/model.py says what they
// mean). Self-contained: needs no other file.
//
//   parameter_map_value(index, uv)   lo + (hi - lo) m(uv) of map `index`, in its unit
//
// Buffers. No bindings here: the including entry point declares, under these names,
//   map_records: array<ParameterMapRecord>   pack_maps's records, one per map
//   map_texels:  array<f32>                   pack_maps's texels; a texture is `height` rows of
//                                             `width` values from map_texels[offset], its top
//                                             row first.
//
// Any finite uv gives a finite value between lo and hi: uv is wrapped into the unit tile
// first, so large or negative coordinates cost no precision beyond that of uv itself.

const MAP_CONSTANT: u32 = 0u;
const MAP_STRIPES: u32 = 1u;
const MAP_RADIAL: u32 = 2u;
const MAP_NOISE: u32 = 3u;
const MAP_TEXTURE: u32 = 4u;

// MAP_RECORD_DTYPE of wgbragg/scene/parameter_maps.py: 32 bytes.
struct ParameterMapRecord {
    kind: u32,
    lo: f32,
    hi: f32,
    scale: f32,
    width: u32,     // texels per row (textures)
    height: u32,    // rows (textures)
    offset: u32,    // index of the first texel in map_texels (textures)
    lattice: u32,   // lattice points per period N (noise)
}

// PCG hash (Jarzynski & Olano 2020), in wrapping u32 arithmetic as the numpy twin.
fn map_pcg(x: u32) -> u32 {
    let state = x * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Lattice value in [0, 1): 24 bits, which f32 holds exactly.
fn map_lattice_value(i: u32, j: u32) -> f32 {
    return f32(map_pcg(i + map_pcg(j)) >> 8u) * (1.0 / 16777216.0);
}

fn map_stripes(u: f32, scale: f32) -> f32 {
    // sin is accurate only on [-pi, pi] in WGSL: reduce the phase to a fraction first.
    let phase = fract(scale * u) - 0.5;
    return 0.5 - 0.5 * sin(6.28318531 * phase);
}

fn map_radial(uv: vec2<f32>, scale: f32) -> f32 {
    return fract(scale * length(uv - vec2<f32>(0.5)));
}

fn map_noise(uv: vec2<f32>, scale: f32, lattice: u32) -> f32 {
    let x = scale * uv;
    let cell = floor(x);
    let t = x - cell;
    let w = t * t * (3.0 - 2.0 * t);
    // cell >= 0 since uv is wrapped, so the u32 conversion keeps its value.
    let i0 = u32(cell.x) % lattice;
    let j0 = u32(cell.y) % lattice;
    let i1 = (i0 + 1u) % lattice;
    let j1 = (j0 + 1u) % lattice;
    let bottom = mix(map_lattice_value(i0, j0), map_lattice_value(i1, j0), w.x);
    let top = mix(map_lattice_value(i0, j1), map_lattice_value(i1, j1), w.x);
    return mix(bottom, top, w.y);
}

fn map_texel(r: ParameterMapRecord, row: u32, column: u32) -> f32 {
    return map_texels[r.offset + row * r.width + column];
}

fn map_texture(r: ParameterMapRecord, uv: vec2<f32>) -> f32 {
    let width = r.width;
    let height = r.height;
    let x = uv.x * f32(width) - 0.5;
    let y = (1.0 - uv.y) * f32(height) - 0.5;
    let column = floor(x);
    let row = floor(y);
    let fx = x - column;
    let fy = y - row;
    // column and row lie in [-1, size - 1]: one size added keeps them non-negative.
    let c0 = u32(i32(column) + i32(width)) % width;
    let r0 = u32(i32(row) + i32(height)) % height;
    let c1 = (c0 + 1u) % width;
    let r1 = (r0 + 1u) % height;
    let upper = mix(map_texel(r, r0, c0), map_texel(r, r0, c1), fx);
    let lower = mix(map_texel(r, r1, c0), map_texel(r, r1, c1), fx);
    return mix(upper, lower, fy);
}

fn parameter_map_value(index: u32, uv: vec2<f32>) -> f32 {
    let r = map_records[index];
    let wrapped = fract(uv);
    var m = 0.0;
    switch r.kind {
        case MAP_STRIPES: {
            m = map_stripes(wrapped.x, r.scale);
        }
        case MAP_RADIAL: {
            m = map_radial(wrapped, r.scale);
        }
        case MAP_NOISE: {
            m = map_noise(wrapped, r.scale, r.lattice);
        }
        case MAP_TEXTURE: {
            m = map_texture(r, wrapped);
        }
        case MAP_CONSTANT, default: {}
    }
    return r.lo + (r.hi - r.lo) * m;
}
