// Filtered image-based lighting of microfacet materials in float32: the microfacet albedo
// E(cos_v) from its table, the split-sum and Kneiphof et al. (2019) reflectances of a thin
// film, our Gauss-Hermite analogue for a Bragg layer and the split sum of a layered material.
// The float32 twin of wgbragg/lighting/ibl.py (the renderer's ibl_radiance dispatches to it).
//
// Requires numerics, bsdf/layered/model.wgsl (layer_colour, filter_row, table_lerp_rgb, BASE;
// it reads the includer's `layers` buffer as model.wgsl does), bsdf/rough_thin_film.wgsl and
// lighting/environment_prefilter_lookup.wgsl (Prefiltered, prefiltered_lookup). The includer
// declares the override IBL (IBL_KNEIPHOF selects the filtered colours) and provides
//   fn ibl_albedo_node(i: u32) -> f32
// node i of the microfacet albedo table (IBL_ALBEDO_NODES cosines per prefiltered level), from
// wherever it keeps it (render/renderer.wgsl: its `ibl_albedo` buffer).
//
// No bindings here.

const IBL_ALBEDO_NODES: u32 = 64u;

// E(cos_v) of the level's roughness, linear between nodes at cos_v = (k + 1/2) / nodes.
fn microfacet_albedo(level: u32, cos_v: f32) -> f32 {
    let at = clamp(cos_v * f32(IBL_ALBEDO_NODES) - 0.5, 0.0, f32(IBL_ALBEDO_NODES - 1u));
    let lower = min(u32(at), IBL_ALBEDO_NODES - 2u);
    let first = level * IBL_ALBEDO_NODES + lower;
    return mix(ibl_albedo_node(first), ibl_albedo_node(first + 1u), at - f32(lower));
}

// Mean and standard deviation of x = l.v over the prefiltered light directions l (Kneiphof et
// al. 2019, eqs 20-21).
fn light_spread(p: Prefiltered, v: vec3<f32>) -> vec2<f32> {
    let mean = clamp(dot(v, p.mean), -1.0, 1.0);
    let second = dot(v * v, p.second_diagonal)
        + 2.0 * (v.x * v.y * p.second_off.x + v.y * v.z * p.second_off.y
                 + v.z * v.x * p.second_off.z);
    return vec2<f32>(mean, sqrt(max(0.0, second - mean * mean)));
}

// Kneiphof et al. 2019 eqs 22-29: the film's colour at the mean microfacet incidence, its
// Fourier terms filtered by the spread of the optical path difference (the prefiltered table).
fn film_kneiphof(f: FilmMaterial, spread: vec2<f32>) -> vec4<f32> {
    let c1 = sqrt(max(0.0, 0.5 * (1.0 + spread.x)));
    let k = (f.colour.host * f.colour.host) / (f.colour.n_film * f.colour.n_film);
    let c2_squared = 1.0 + 0.5 * k * (spread.x - 1.0);
    var sigma_nm = 0.0;
    if (c2_squared > 0.0) {
        let mean_c2 = sqrt(c2_squared);
        // sigma_D = 2 n2 d sigma_c2, and film_colour spreads the m-th term by m 2 n2 c2 sigma.
        sigma_nm = film_thickness * (0.25 * k / mean_c2 * spread.y) / mean_c2;
    }
    return film_reflectance(f, c1, sigma_nm);
}

// Probabilists' Gauss-Hermite rule of 5 nodes: the mean of g(x) for x ~ N(0, 1).
const HERMITE_NODES = array<f32, 5>(-2.8569700, -1.3556262, 0.0, 1.3556262, 2.8569700);
const HERMITE_WEIGHTS = array<f32, 5>(0.0112574, 0.2220759, 0.5333333, 0.2220759, 0.0112574);

// Our analogue for a Bragg layer, whose colour has no short Fourier series in the optical path:
// its colour averaged over x = l.v ~ N(mean, std^2), each node mapped exactly (no
// linearisation) to the microfacet incidence theta_d = acos(sqrt((1 + x) / 2)).
fn bragg_filtered(s: LayeredStructure, layer: RoughLayer, spread: vec2<f32>) -> vec3<f32> {
    var total = vec3<f32>(0.0);
    for (var k = 0u; k < 5u; k++) {
        let x = clamp(spread.x + HERMITE_NODES[k] * spread.y, -1.0, 1.0);
        total += HERMITE_WEIGHTS[k] * layer_colour(s, layer, acos(sqrt(0.5 * (1.0 + x))));
    }
    return total;
}

// Mean cosine of a cosine-distributed direction: where the diffuse base's light crosses the
// layers, on average.
const DIFFUSE_MEAN_COS: f32 = 0.6666667;

// The single-reflection model (eq 34) by the split sum, layer by layer: each lobe lit by the
// environment prefiltered for its roughness (its levels follow the material's first), its
// colour at the ideal reflection (or filtered, IBL_KNEIPHOF), through the layers above at
// theta_v both ways; a Lambertian base by the cosine level (the material's last), through the
// layers at theta_v and at the diffuse mean angle. With a coating, theta_v is the view's
// angle inside it and everything is dimmed by its transmittance both ways; the lobes keep
// the prefiltered width of their own roughness (refraction widens them outside: an
// approximation, docs/physics.md section 13).
fn layered_ibl(s: LayeredStructure, ibl_level: u32, ibl_layers: u32, n: vec3<f32>,
               v: vec3<f32>, cos_v: f32) -> vec3<f32> {
    let r = 2.0 * cos_v * n - v;
    // Under a smooth coating of index n1 the layers see the view refracted, and the light
    // around the mirror direction crosses the coating at the same angle both ways: eq 34's
    // T_c(l) T_c(v) / n1^2 with Snell's change of solid angle (n1^2 cos' / cos) cancelling
    // the 1 / n1^2. The coating's own mirror reflection is the includer's (ibl_radiance).
    var cos_inside = cos_v;
    var coated = 1.0;
    if (COATING) {
        let transmitted = 1.0 - coating_reflectance(cos_v, s.host);
        coated = transmitted * transmitted;
        cos_inside = sqrt(max(0.0, 1.0 - (1.0 - cos_v * cos_v) / (s.host * s.host)));
    }
    let theta_v = acos(cos_inside);
    var total = vec3<f32>(0.0);
    var through = vec3<f32>(coated);
    var through_diffuse = vec3<f32>(coated);
    for (var l = 0u; l < ibl_layers; l++) {
        let layer = layers[s.first_layer + l];
        let level = ibl_level + l;
        let p = prefiltered_lookup(level, r);
        //! if IBL == IBL_KNEIPHOF
        let colour = bragg_filtered(s, layer, light_spread(p, v));
        //! else
        let colour = layer_colour(s, layer, theta_v);
        //! endif
        total += p.radiance * microfacet_albedo(level, cos_inside) * colour * through;
        let t = table_lerp_rgb(layer.transmissivity_rgb, filter_row(layer, theta_v));
        through *= t * t;
        through_diffuse *= t * table_lerp_rgb(layer.transmissivity_rgb,
                                              filter_row(layer, acos(DIFFUSE_MEAN_COS)));
    }
    if (BASE == BASE_LAMBERTIAN && any(s.base_rgb > vec3<f32>(0.0))) {
        let diffuse = prefiltered_lookup(ibl_level + ibl_layers, n).radiance;
        total += s.base_rgb * diffuse * through_diffuse;
    }
    return total;
}

