// The scene's bindings shared by the path tracer (render/renderer.wgsl) and the rasterizer
// (render/rasterizer.wgsl): geometry, materials and their tables, lights, spectra, environment,
// parameter maps, thin films and the prefiltered environment, at @group(0) @binding(0..22), as
// wgbragg/render/scene_resources.py uploads them; and the Params uniform each entry point binds
// after its own buffers. Included only by entry points: library files declare no bindings.


struct Material {
    albedo: vec3<f32>,    // Lambertian albedo, linear sRGB
    kind: u32,
    structure: u32,       // index in structures (layered materials) or films (thin films)
    period_map: u32,      // index in map_records (VARYING_LAYERS): period (nm) over uv
    delta_map: u32,       // d1 / period over uv
    ibl_level: u32,       // its first level of the prefiltered environment (filtered IBL)
    ibl_layers: u32,      // layered: its layers, whose levels follow ibl_level (then the
                          // base's cosine level)
}

struct Params {
    camera: Camera,
    environment: Environment,
    _pad0: u32,
    count: u32,           // pixels: the image's, or those of a render / accumulate range
    width: u32,
    point_lights: u32,
    area_lights: u32,
    epsilon: f32,         // ray offset from a surface, in scene units, besides 1e-5 of
                          // the hit point's largest coordinate (its float32 rounding)
    seed: u32,
    samples: u32,         // paths per pixel in this render dispatch
    triangles: u32,       // primitives: triangles, spheres, planes, then area lights
    spheres: u32,
    planes: u32,
    first: u32,           // first pixel of a render / accumulate range (0: the whole image)
}

@group(0) @binding(0) var<storage, read> vertices: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> normals: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> faces: array<vec4<u32>>;
@group(0) @binding(3) var node_texels: texture_2d<f32>;
// The exact spheres and planes (render/renderer_scene.wgsl).
@group(0) @binding(4) var shape_texels: texture_2d<f32>;
// The triangles' corners in BVH order (render/renderer_scene.wgsl's triangle_hit).
@group(0) @binding(5) var triangle_texels: texture_2d<f32>;
@group(0) @binding(6) var<storage, read> materials: array<Material>;
@group(0) @binding(7) var<storage, read> structures: array<LayeredStructure>;
@group(0) @binding(8) var<storage, read> layers: array<RoughLayer>;
@group(0) @binding(9) var<storage, read> tables: array<f32>;
// Point lights (position, intensity), then area lights (corner with w = 1 when two-sided,
// edge_u, edge_v, radiance), then a row per light of next-event estimation, the environment
// first under Monte Carlo lighting (wgbragg/render/packing.py light_buffer): (the cumulative
// probability of choosing it, that probability, 0, 0); the probability is 1 for every light
// when all are sampled at each vertex.
@group(0) @binding(10) var<storage, read> lights: array<vec4<f32>>;
// Spectral mode (wgbragg/render/renderer.py _spectra): 471 rows of basis spectra, 471 rows of the
// linear sRGB response per nm (360..830 nm), then the hero wavelengths' inverse CDF in x.
@group(0) @binding(11) var<storage, read> spectra: array<vec4<f32>>;
// EnvironmentMap.packed() (wgsl/lighting/environment_map.wgsl) when ENVIRONMENT_MAP.
@group(0) @binding(12) var<storage, read> environment_texels: array<vec4<f32>>;
// pack_maps (wgbragg/scene/parameter_maps.py) when VARYING_LAYERS: record 0 is unused.
@group(0) @binding(13) var<storage, read> map_records: array<ParameterMapRecord>;
@group(0) @binding(14) var<storage, read> map_texels: array<f32>;
// Thin films (THIN_FILMS, wgbragg/render/renderer.py _film_buffers): their records, the Fourier
// colour's windows and evanescent nodes (film_colour, colour/thin_film.wgsl) and table, and
// each film's base index (n, k) every FILM_BASE_STEP_NM from 360 nm (spectral mode).
@group(0) @binding(15) var<storage, read> films: array<FilmMaterial>;
@group(0) @binding(16) var<storage, read> fourier_windows: array<FourierWindow>;
@group(0) @binding(17) var<storage, read> evanescent_nodes: array<EvanescentNode>;
@group(0) @binding(18) var film_table: texture_2d<f32>;
@group(0) @binding(19) var<storage, read> film_base: array<vec4<f32>>;
// Filtered image-based lighting (IBL != IBL_MONTE_CARLO): the prefiltered environment
// (wgbragg.lighting.environment_prefilter, read by lighting/environment_prefilter_lookup.wgsl)
// and, per level, the microfacet albedo E(cos_v) at IBL_ALBEDO_NODES cosines
// (wgbragg.lighting.ibl.microfacet_albedo_table).
@group(0) @binding(20) var<storage, read> prefiltered_levels: array<PrefilteredLevel>;
@group(0) @binding(21) var<storage, read> prefiltered_texels: array<vec4<f32>>;
@group(0) @binding(22) var<storage, read> ibl_albedo: array<f32>;
