// Cell means of the transmittance T = 1 - R of a matched mirror (host == n1): the twin of
// wgbragg.bsdf.rough_layer._cell_transmittance (see its docstring). Requires numerics, complex,
// layer and optics/yeh.wgsl. The phase window widens with the cell's span of T's features between
// these (rough_layer._RESOLVED, _UNRESOLVED; checked by tests/test_wgsl_layouts.py).
const RESOLVED: f32 = 0.1;
const UNRESOLVED: f32 = 0.5;

// K Lambda in [0, pi] (turns in [0, 1/2]) from cos and sin^2; the real part inside gaps.
fn bloch_turns(t: CellTerms) -> f32 {
    let root = sqrt(max(t.sin2, 0.0));
    let folded = atan2_cycles_positive(root, abs(t.x));
    return select(folded, 0.5 - folded, t.x < 0.0);
}

// Mean of b / (b + a sin^2 psi) over psi in psi0 +- width / 2 (width > 0), psi0 and width in
// turns of 2 pi (see rough_layer._window_transmittance).
fn window_transmittance(a: f32, b: f32, psi0_turns: f32, width_turns: f32) -> f32 {
    let whole = floor(2.0 * width_turns);           // periods of pi
    let rest = width_turns - 0.5 * whole;            // turns, in [0, 1/2)
    let u = centered_fraction(psi0_turns - 0.5 * width_turns);
    let v = u + rest;
    let ab = a + b;
    let su = sin_cycles(u);
    let cu = sin_cycles(u + 0.25);
    let sv = sin_cycles(v);
    let cv = sin_cycles(v + 0.25);
    let angle = atan2(sqrt(b * ab) * sin_cycles(rest), b * cu * cv + ab * su * sv);
    return sqrt(b / ab) * (whole * PI + angle) / (TWO_PI * width_turns);
}

fn smoothstep_unit(z: f32) -> f32 {
    let t = clamp((z - RESOLVED) / (UNRESOLVED - RESOLVED), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

// One polarisation's T at geometry g averaged over its cell, across which the Bloch phase
// K Lambda moves by `step` turns.
fn cell_transmittance_polarized(m: BraggMirror, g: CellGeometry, polarization: u32,
                                step: f32) -> f32 {
    let t = cell_terms(m, g, polarization);
    let point = 1.0 - matched_reflectance(t, g.cell_cycles, m.periods);
    if (t.sin2 <= 0.0) {
        return point;
    }
    let n = f32(m.periods);
    let span = n * step;
    let w = min(abs(t.W), MAX_AMPLITUDE);
    let a = w * w;
    let b = t.sin2;
    let features = 2.0 * span * sqrt((a + b) / b);
    // Resolved features keep the point value (matched_reflectance already averages where
    // float32 cannot place the phase), and so do nodes within psi0 < pi / 2 of a band edge,
    // where the window below is empty: most nodes of most mirrors stop here.
    let edge = sin(0.5 * PI / n);
    if (features <= RESOLVED || b <= edge * edge) {
        return point;
    }
    let root = sqrt(b);
    let psi0 = n * atan2_cycles_positive(root, abs(t.x));
    if (phase_unresolved(t, g.cell_cycles, psi0, root, n)) {
        return clamp(root / sqrt(a + b), 0.0, 1.0);  // float32 cannot place psi0
    }
    let width = min(span * smoothstep_unit(features), max(min(psi0, 2.0 * psi0 - 0.5), 0.0));
    if (width <= 0.0) {
        return point;
    }
    return clamp(window_transmittance(a, b, psi0, width), 0.0, 1.0);
}

// Unpolarized T at geometry g averaged over its cell, whose ends have the Bloch phases
// (s, p) `lower` and `upper` in turns (bsdf/rough_layer_phases.wgsl).
fn cell_transmittance(m: BraggMirror, g: CellGeometry, lower: vec2<f32>,
                      upper: vec2<f32>) -> f32 {
    if (g.q1 <= 0.0) {
        return 0.0;  // grazing in n1: r12 = -1 (yeh_polarized)
    }
    let step = abs(upper - lower);
    return 0.5 * (cell_transmittance_polarized(m, g, 0u, step.x)
        + cell_transmittance_polarized(m, g, 1u, step.y));
}
