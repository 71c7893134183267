// Indexing shared by the population kernels (population_bragg.wgsl, population_film.wgsl,
// stack_population.wgsl):
// invocation i evaluates member i / points at shared point i % points. No bindings.

struct Population {
    points: u32,  // (wavelength, angle) points per member
    layers: u32,  // layers per member (stack_population.wgsl; 0 for the others)
    _pad1: u32,
    _pad2: u32,
}

// (member, point) of invocation i.
fn member_and_point(p: Population, i: u32) -> vec2<u32> {
    return vec2<u32>(i / p.points, i % p.points);
}
