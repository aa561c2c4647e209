// The fast mode's multiple scattering, gathered in the march: MsLattice::toward of
// src/integrate/ms_lattice.rs, in f32. The lattice is solved on the CPU; its moments
// lie in `meta_` from P.lattice_base, every light's nodes in turn (x fastest), 15
// floats a node: per channel the mean in-radiance of light scattered two or more times
// (J, rgb), then per channel its flux (G, xyz for r, g, b), then per channel the
// once-scattered light's mean in-radiance (J1, rgb).

const MOMENTS: u32 = 15u;

// Henyey–Greenstein with mean cosine g at cos θ = mu, times 4π.
fn hg_4pi(g: f32, mu: f32) -> f32 {
    let c = clamp(g, -0.999, 0.999);
    return (1.0 - c * c) / pow(max(1.0 + c * c - 2.0 * c * mu, 1e-12), 1.5);
}

struct Moments {
    j: vec3<f32>,
    gr: vec3<f32>,
    gg: vec3<f32>,
    gb: vec3<f32>,
    j1: vec3<f32>,
};

fn moment3(at: u32) -> vec3<f32> {
    return vec3<f32>(meta_[at], meta_[at + 1u], meta_[at + 2u]);
}

// The radiance light l's once-or-more scattered light sends into direction omega at
// world point x, per unit σs·ρ, the light travelling along `travel` there (trilinear
// over the lattice's nodes; zero outside it): the once-scattered light scattered
// again by the phase function convolved with itself (Henyey–Greenstein of ḡ²), the
// later orders' broad radiance to the phase function's first order, J + 3ḡ·ω·G.
fn multiple_toward(l: u32, x: vec3<f32>, omega: vec3<f32>, travel: vec3<f32>) -> vec3<f32> {
    let q = (x - P.lattice_lo.xyz) * P.lattice_lo.w;
    let dims = P.lattice_dims.xyz;
    // Outside (or NaN): nothing; the last node has no cell beyond it.
    if (!all(q >= vec3<f32>(0.0)) || any(q >= vec3<f32>(dims - vec3<u32>(1u)))) {
        return vec3<f32>(0.0);
    }
    let c = vec3<u32>(q);
    let f = q - vec3<f32>(c);
    let light_base = P.lattice_base + l * P.lattice_dims.w * MOMENTS;
    var m: Moments;
    m.j = vec3<f32>(0.0);
    m.gr = vec3<f32>(0.0);
    m.gg = vec3<f32>(0.0);
    m.gb = vec3<f32>(0.0);
    m.j1 = vec3<f32>(0.0);
    for (var k = 0u; k < 8u; k++) {
        let d = vec3<u32>(k & 1u, (k >> 1u) & 1u, (k >> 2u) & 1u);
        let wv = select(vec3<f32>(1.0) - f, f, d == vec3<u32>(1u));
        let w = wv.x * wv.y * wv.z;
        let n = c + d;
        let at = light_base + (n.x + dims.x * (n.y + dims.y * n.z)) * MOMENTS;
        m.j += w * moment3(at);
        m.gr += w * moment3(at + 3u);
        m.gg += w * moment3(at + 6u);
        m.gb += w * moment3(at + 9u);
        m.j1 += w * moment3(at + 12u);
    }
    let gm = P.g_mean;
    let twice = hg_4pi(gm * gm, dot(travel, omega));
    let g_dot = vec3<f32>(dot(omega, m.gr), dot(omega, m.gg), dot(omega, m.gb));
    let broad = max(m.j + 3.0 * gm * g_dot, vec3<f32>(0.0));
    return broad + m.j1 * twice;
}
