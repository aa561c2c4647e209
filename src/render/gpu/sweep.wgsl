// The multiple-scattering lattice's upwind sweeps (integrate/ms_sweep.rs) on the GPU:
// one dispatch of `sweep_plane` per plane step, every direction of the order at once
// (invocation = direction × node of the plane), then `gather_moments` averages the
// directions' radiances per node in the CPU's order. Each node's arithmetic is the
// CPU's, in f32, in the same order.

struct SweepParams {
    nx: u32,
    ny: u32,
    nz: u32,
    nodes: u32,
    channels: u32,
    ndirs: u32,
    // The most nodes of a plane over the order's directions.
    plane_max: u32,
    // Direction k's weight at node n is weights[k + n * weight_stride].
    weight_stride: u32,
    // The plane step this dispatch sweeps (written before each dispatch).
    step: u32,
    flux: u32,
    albedo0: u32,
    albedo1: u32,
    albedo2: u32,
    // 1 / directions, f32 bits.
    inv: u32,
    // Invocations per row of the dispatch (workgroups per row × 64).
    row: u32,
    group: u32,
}

@group(0) @binding(0) var<uniform> sp: SweepParams;
@group(0) @binding(1) var<storage, read> rho: array<f32>;
@group(0) @binding(2) var<storage, read> source: array<f32>;
@group(0) @binding(3) var<storage, read> weights: array<f32>;
// Per direction DIR_WORDS words: a, b, c, forward, fb, fc, -, -, w[4], σt·step[3], -,
// d (f32) x y z, -.
@group(0) @binding(4) var<storage, read> dirs: array<u32>;
// Per direction, node and channel.
@group(0) @binding(5) var<storage, read_write> radiance: array<f32>;
@group(0) @binding(6) var<storage, read_write> out_j: array<f32>;
@group(0) @binding(7) var<storage, read_write> out_g: array<f32>;

const DIR_WORDS: u32 = 20u;

fn lattice_dim(axis: u32) -> u32 {
    return select(select(sp.nz, sp.ny, axis == 1u), sp.nx, axis == 0u);
}

fn lattice_stride(axis: u32) -> u32 {
    return select(select(sp.nx * sp.ny, sp.nx, axis == 1u), 1u, axis == 0u);
}

fn albedo_of(ch: u32) -> f32 {
    return bitcast<f32>(select(select(sp.albedo2, sp.albedo1, ch == 1u), sp.albedo0, ch == 0u));
}

// Direction k's source ρ·J·p at node n.
fn source_at(n: u32, k: u32, ch: u32) -> f32 {
    return source[n * sp.channels + ch] * weights[k + n * sp.weight_stride];
}

// ms_sweep.rs `Node::radiance`, one channel.
fn node_radiance(l_up: f32, r_up: f32, rj_up: f32, r_here: f32, rj_here: f32, sigma_step: f32,
                 albedo: f32) -> f32 {
    let rho_mean = 0.5 * (r_here + r_up);
    if (rho_mean <= 0.0) {
        return l_up;
    }
    let tau = sigma_step * rho_mean;
    var j_up = 0.0;
    if (r_up > 0.0) {
        j_up = rj_up / r_up;
    }
    var j_here = j_up;
    if (r_here > 0.0) {
        j_here = rj_here / r_here;
        if (!(r_up > 0.0)) {
            j_up = j_here;
        }
    }
    let e = exp(-tau);
    var one_minus: f32;
    var p: f32;
    if (tau < 1e-2) {
        one_minus = tau * (1.0 - 0.5 * tau * (1.0 - tau / 3.0));
        p = tau * (0.5 - tau * (1.0 / 3.0 - tau / 8.0));
    } else {
        one_minus = 1.0 - e;
        p = (one_minus - tau * e) / tau;
    }
    let l = l_up * e + albedo * (j_here * (one_minus - p) + j_up * p);
    return max(l, 0.0);
}

@compute @workgroup_size(64)
fn sweep_plane(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * sp.row;
    let k = i / sp.plane_max;
    let p = i % sp.plane_max;
    if (k >= sp.ndirs) {
        return;
    }
    let o = k * DIR_WORDS;
    let a = dirs[o];
    let b = dirs[o + 1u];
    let c = dirs[o + 2u];
    let forward = dirs[o + 3u] != 0u;
    let fb = bitcast<i32>(dirs[o + 4u]);
    let fc = bitcast<i32>(dirs[o + 5u]);
    let na = lattice_dim(a);
    let nb = lattice_dim(b);
    let nc = lattice_dim(c);
    if (sp.step >= na || p >= nb * nc) {
        return;
    }
    let ib = p % nb;
    let ic = p / nb;
    let ia = select(na - 1u - sp.step, sp.step, forward);
    let sa = lattice_stride(a);
    let sb = lattice_stride(b);
    let sc = lattice_stride(c);
    let n = ia * sa + ib * sb + ic * sc;
    let base = k * sp.nodes;
    let up_a = select(ia + 1u, ia - 1u, forward);
    for (var ch = 0u; ch < sp.channels; ch++) {
        var l = 0.0;
        var r = 0.0;
        var rj = 0.0;
        if (sp.step > 0u) {
            for (var t = 0u; t < 4u; t++) {
                let wk = bitcast<f32>(dirs[o + 8u + t]);
                let jb = i32(ib) + fb + i32(t & 1u);
                let jc = i32(ic) + fc + i32(t >> 1u);
                if (wk == 0.0 || jb < 0 || jc < 0 || jb >= i32(nb) || jc >= i32(nc)) {
                    continue;
                }
                let m = up_a * sa + u32(jb) * sb + u32(jc) * sc;
                r += wk * rho[m];
                l += wk * radiance[(base + m) * sp.channels + ch];
                rj += wk * source_at(m, k, ch);
            }
        }
        let sigma_step = bitcast<f32>(dirs[o + 12u + ch]);
        radiance[(base + n) * sp.channels + ch] =
            node_radiance(l, r, rj, rho[n], source_at(n, k, ch), sigma_step, albedo_of(ch));
    }
}

@compute @workgroup_size(64)
fn gather_moments(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = id.x + id.y * sp.row;
    if (n >= sp.nodes) {
        return;
    }
    let inv = bitcast<f32>(sp.inv);
    for (var ch = 0u; ch < sp.channels; ch++) {
        var j = 0.0;
        var g = vec3<f32>(0.0);
        for (var k0 = 0u; k0 < sp.ndirs; k0 += sp.group) {
            var acc = 0.0;
            var acc_g = vec3<f32>(0.0);
            for (var k = k0; k < min(k0 + sp.group, sp.ndirs); k++) {
                let v = radiance[(k * sp.nodes + n) * sp.channels + ch];
                let o = k * DIR_WORDS + 16u;
                let d = vec3<f32>(bitcast<f32>(dirs[o]), bitcast<f32>(dirs[o + 1u]),
                                  bitcast<f32>(dirs[o + 2u]));
                acc += v;
                acc_g += v * d;
            }
            j += acc;
            g += acc_g;
        }
        out_j[n * sp.channels + ch] = j * inv;
        if (sp.flux != 0u) {
            let at = (n * sp.channels + ch) * 3u;
            out_g[at] = g.x * inv;
            out_g[at + 1u] = g.y * inv;
            out_g[at + 2u] = g.z * inv;
        }
    }
}
