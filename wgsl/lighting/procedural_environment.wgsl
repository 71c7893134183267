// The procedural environments of the path tracer in float32 ("uniform", "sky", "studio", and
// "softbox-studio" with its softboxes): their radiance environment_radiance and the sampling pair environment_sample / environment_pdf.
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
    softbox_scale: f32,   // the softbox studio's intensity; 0: no softboxes
    disc_radiance: vec3<f32>,
    turn_cos: f32,        // cosine and sine of rotate_deg, by which the softboxes turn
    disc_direction: vec3<f32>,
    turn_sin: f32,
}

// The studio's softboxes (procedural_environment.STUDIO_SOFTBOXES): radiance, angular radius,
// elevation and azimuth (from +z towards +x), angles in degrees.
const STUDIO_SOFTBOXES = array<vec4<f32>, 3>(
    vec4<f32>(1.5, 35.0, 60.0, 150.0),
    vec4<f32>(4.0, 12.0, 15.0, 95.0),
    vec4<f32>(12.0, 4.0, 25.0, -140.0),
);
const SOFTBOX_EDGE: f32 = 0.2;  // the smooth edge's share of the radius

// The softboxes' grey radiance before softbox_scale: each box's radiance times a smoothstep
// of the cosine to its axis, in the direction turned back by rotate_deg.
fn studio_softboxes(e: Environment, d: vec3<f32>) -> f32 {
    let x = d.x * e.turn_cos - d.z * e.turn_sin;
    let z = d.x * e.turn_sin + d.z * e.turn_cos;
    var total = 0.0;
    for (var k = 0u; k < 3u; k++) {
        let box = STUDIO_SOFTBOXES[k];
        let r = radians(box.y);
        let elevation = radians(box.z);
        let azimuth = radians(box.w);
        let towards = x * cos(elevation) * sin(azimuth) + d.y * sin(elevation)
            + z * cos(elevation) * cos(azimuth);
        total += box.x * smoothstep(cos(r), cos((1.0 - SOFTBOX_EDGE) * r), towards);
    }
    return total;
}

// ----------------------------------------------------------------------------- environment

fn environment_radiance(e: Environment, d: vec3<f32>) -> vec3<f32> {
    var sky = e.ground;
    if (d.y >= 0.0) {
        // sqrt(elevation) keeps the horizon band bright but narrow.
        sky = mix(e.horizon, e.zenith, sqrt(d.y));
    }
    if (e.softbox_scale > 0.0) {
        sky += vec3<f32>(e.softbox_scale * studio_softboxes(e, d));
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
