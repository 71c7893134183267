// Hero wavelengths (Wilkie et al. 2014): four wavelengths stratified in the inverse CDF of the
// summed CIE XYZ density, from one uniform offset. The float32 twin of
// wgbragg.colour.colorimetry.hero_wavelengths.
//
// No bindings here: the includer provides
//   fn hero_cdf_node(j: u32) -> f32   node j of colorimetry.hero_inverse_cdf (nm), j <= HERO_SEGMENTS.

const HERO_SEGMENTS: u32 = 512u;

struct HeroWavelengths {
    nm: vec4<f32>,
    scale: vec4<f32>,   // 1 / (4 pdf) per nm: sum_k v_k scale_k density_k estimates the integral
}

fn hero_wavelengths(offset: f32) -> HeroWavelengths {
    var hero: HeroWavelengths;
    let segments = f32(HERO_SEGMENTS);
    for (var k = 0u; k < 4u; k++) {
        let position = (offset + f32(k)) * 0.25 * segments;
        let j = min(u32(position), HERO_SEGMENTS - 1u);
        let lower = hero_cdf_node(j);
        let upper = hero_cdf_node(j + 1u);
        hero.nm[k] = mix(lower, upper, position - f32(j));
        hero.scale[k] = 0.25 * segments * (upper - lower);
    }
    return hero;
}
