// The procedural environments of the path tracer in float32 ("uniform", "sky", "studio"): their
// radiance environment_radiance and the sampling pair environment_sample / environment_pdf.
// The float32 twin of wgbragg/lighting/procedural_environment.py (ProceduralEnvironment packs
// the Environment record below).
//
// Requires gpu/numerics.wgsl (PI, TWO_PI) and render/renderer_scene.wgsl (frame_about,
// to_world).
//
// No bindings here.

// A gradient over the upper hemisphere, a ground colour below and a disc source (the sun, or
// a studio's key light): a uniform environment has three equal colours and no disc.
struct Environment {
    zenith: vec3<f32>,
    disc_cos: f32,        // cosine of the disc's angular radius
    horizon: vec3<f32>,
    disc_probability: f32,  // share of environment samples aimed at the disc
    ground: vec3<f32>,
    _pad0: f32,
    disc_radiance: vec3<f32>,
    _pad1: f32,
    disc_direction: vec3<f32>,
    _pad2: f32,
}

// ----------------------------------------------------------------------------- environment

fn environment_radiance(e: Environment, d: vec3<f32>) -> vec3<f32> {
    var sky = e.ground;
    if (d.y >= 0.0) {
        // sqrt(elevation) keeps the horizon band bright but narrow.
        sky = mix(e.horizon, e.zenith, sqrt(d.y));
    }
    if (dot(d, e.disc_direction) >= e.disc_cos) {
        sky += e.disc_radiance;
    }
    return sky;
}

fn disc_solid_angle(e: Environment) -> f32 {
    return TWO_PI * (1.0 - e.disc_cos);
}

// Density (1/sr) of environment_sample: uniform over the sphere, mixed with uniform over the
// disc's cone.
fn environment_pdf(e: Environment, d: vec3<f32>) -> f32 {
    var density = (1.0 - e.disc_probability) / (4.0 * PI);
    if (e.disc_probability > 0.0 && dot(d, e.disc_direction) >= e.disc_cos) {
        density += e.disc_probability / disc_solid_angle(e);
    }
    return density;
}

fn environment_sample(e: Environment, u: vec3<f32>) -> vec3<f32> {
    if (u.x < e.disc_probability) {
        let c = mix(1.0, e.disc_cos, u.y);
        let s = sqrt(max(0.0, 1.0 - c * c));
        let phi = TWO_PI * u.z;
        return to_world(frame_about(e.disc_direction), vec3<f32>(s * cos(phi), s * sin(phi), c));
    }
    let z = 1.0 - 2.0 * u.y;
    let s = sqrt(max(0.0, 1.0 - z * z));
    let phi = TWO_PI * u.z;
    return vec3<f32>(s * cos(phi), s * sin(phi), z);
}
