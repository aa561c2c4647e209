// The path tracer of src/integrate/path.rs, one camera sample per invocation, in f32:
// free flights by delta (spectral) tracking over the majorant grid's blocks (a 3-D DDA;
// a span too dense to track by its integral, as path/dense.rs), next-event estimation
// of every sun and point light at each scattering event (the transmittance from the
// light's deep shadow map, dsm.wgsl, or by ratio tracking), a uniform dome found by the
// paths themselves, Henyey–Greenstein sampled exactly, Russian roulette from the third
// event; the camera ray's exact opacity and depth on the samples the CPU computes them
// on. Random numbers: SplitMix64 on pairs of u32 (WGSL has no u64; rays.wgsl), each
// flight's and shadow ray's stream derived from the sample's key as the CPU's
// `SampleRng::stream` derives it, so both draw the same numbers (the GPU keeps the top
// 24 bits of each).
// The tracking is in path_tracking.wgsl. Compiled after grid.wgsl, march.wgsl (its
// bindings, the integral walk, clipping, the lights), rays.wgsl (the camera rays),
// dsm.wgsl and lattice.wgsl.

struct PathParams {
    to_index_x: vec4<f32>,   // world → local index: the inverse linear map's columns,
    to_index_y: vec4<f32>,
    to_index_z: vec4<f32>,
    translation: vec4<f32>,  // and the world position of local index (0, 0, 0)
    maj_origin: vec4<i32>,   // the majorant grid's block (0,0,0) corner, w: block edge
    maj_dims: vec4<i32>,     // blocks per axis, w: where their maxima start in meta_
    g: f32,                  // the phase function's asymmetry
    bounces: u32,
    n_lights: u32,
    stride: u32,             // result floats per sample
    grey: u32,               // every channel's extinction is the same
    maj_min_base: u32,       // where the blocks' minima start in meta_
    ratio: u32,              // 1: shadow rays by ratio tracking, else the lights' maps
    _pad: u32,
    environment: vec4<f32>,  // a uniform dome's radiance, w: 1 where there is one
    emit_lo: vec4<f32>,      // where emission is gathered to past the density: the
    emit_hi: vec4<f32>,      // traversed grids' bounds (local index); emit_lo.w: 1 where
                             // something emits
    phase: vec4<u32>,        // 1 where the phase function is a table (water drops), its
                             // sampling bins' start in meta_ and their number, 0
};

@group(0) @binding(9) var<uniform> Q: PathParams;

// Stream `id` of the sample whose key is `key` (SampleRng::stream).
fn stream(key: vec2<u32>, id: vec2<u32>) -> vec2<u32> {
    return mix64(key ^ mul64(id, vec2<u32>(0x6659FD93u, 0xD6E8FEB8u)));
}

// The next number in [0, 1): the top 24 of the 53 bits the CPU takes.
fn next_f(s: ptr<function, vec2<u32>>) -> f32 {
    *s = add64(*s, vec2<u32>(0x7F4A7C15u, 0x9E3779B9u));
    return f32(mix64(*s).y >> 8u) * (1.0 / 16777216.0);
}

// The next number to 48 of the CPU's 53 bits, as hi + lo (hi: next_f's): where a
// weight depends on where in a bin the number falls (the water drops' θ), 24 bits
// would move it by up to 2^-24 of the bin's probability away from the CPU's.
fn next_f_fine(s: ptr<function, vec2<u32>>) -> vec2<f32> {
    *s = add64(*s, vec2<u32>(0x7F4A7C15u, 0x9E3779B9u));
    let z = mix64(*s);
    let hi = f32(z.y >> 8u) * (1.0 / 16777216.0);
    let lo = f32(((z.y & 0xffu) << 16u) | (z.x >> 16u)) * (1.0 / 281474976710656.0);
    return vec2<f32>(hi, lo);
}

// ---- helpers ----

fn max3(v: vec3<f32>) -> f32 {
    return max(max(v.x, v.y), v.z);
}

fn finite3(v: vec3<f32>) -> bool {
    let e = bitcast<vec3<u32>>(v) & vec3<u32>(0x7f800000u);
    return all(e != vec3<u32>(0x7f800000u));
}

fn to_index(x: vec3<f32>) -> vec3<f32> {
    let d = x - Q.translation.xyz;
    return Q.to_index_x.xyz * d.x + Q.to_index_y.xyz * d.y + Q.to_index_z.xyz * d.z;
}

fn to_index_dir(d: vec3<f32>) -> vec3<f32> {
    return Q.to_index_x.xyz * d.x + Q.to_index_y.xyz * d.y + Q.to_index_z.xyz * d.z;
}

// ∫ρ dt over [a, b] of the ray, by a fresh walk.
fn integral_over(r: Ray, a: f32, b: f32) -> f32 {
    if (!(b > a)) {
        return 0.0;
    }
    var w = walk_start(r, a);
    var budget = 16777216u;
    return integral(r, &w, a, b, &budget);
}

// ---- Henyey–Greenstein ----

fn hg(c: f32, g: f32) -> f32 {
    let g2 = g * g;
    let d = max(1.0 + g2 - 2.0 * g * clamp(c, -1.0, 1.0), 1e-12);
    return 0.07957747154594767 * (1.0 - g2) / (d * sqrt(d));
}

fn hg_inverse_cdf(xi: f32, g: f32) -> f32 {
    if (abs(g) < 1e-8) {
        return clamp(2.0 * xi - 1.0, -1.0, 1.0);
    }
    let q = (1.0 - g * g) / (1.0 - g + 2.0 * g * xi);
    return clamp((1.0 + g * g - q * q) / (2.0 * g), -1.0, 1.0);
}

// A unit direction at angle acos(c) from the unit `axis`, azimuth `phi` (frame_around).
fn frame_around(axis: vec3<f32>, c0: f32, phi: f32) -> vec3<f32> {
    let c = clamp(c0, -1.0, 1.0);
    return frame_around_cs(axis, c, sqrt(max(1.0 - c * c, 0.0)), phi);
}

// frame_around() at the angle whose cosine is c and sine s.
fn frame_around_cs(axis: vec3<f32>, c: f32, s: f32, phi: f32) -> vec3<f32> {
    let sgn = select(1.0, -1.0, axis.z < 0.0);
    let a = -1.0 / (sgn + axis.z);
    let b = axis.x * axis.y * a;
    let t1 = vec3<f32>(1.0 + sgn * axis.x * axis.x * a, sgn * b, -sgn * axis.x);
    let t2 = vec3<f32>(b, sgn + axis.y * axis.y * a, -axis.y);
    return normalize(axis * c + (t1 * cos(phi) + t2 * sin(phi)) * s);
}

// ---- the phase function: Henyey–Greenstein, or the water drops' table ----

// The phase function between the direction light travels and the one toward the
// camera (unit vectors), per channel.
fn path_phase(travel: vec3<f32>, toward: vec3<f32>) -> vec3<f32> {
    if (Q.phase.x != 0u) {
        return phase_between(travel, toward);
    }
    return vec3<f32>(hg(dot(travel, toward), Q.g));
}

// A direction light travelling along `incoming` scatters into, drawn from (u0, u1) as
// PhaseFunction::sample draws it (u0 to 48 bits: next_f_fine), with its weight p/pdf per
// channel in `weight`. A table's θ: the last bin whose cumulative probability starts at
// or below u0, 1 − cos θ linear in the probability within it (taken from 1 − cos θ
// itself: f32's cosine cannot tell the drops' forward peak apart). Its nodes: the
// cumulative probability as hi + lo, 1 − cos θ, the bin's density.
fn sample_phase(incoming: vec3<f32>, u0: vec2<f32>, u1: f32, weight: ptr<function, vec3<f32>>) -> vec3<f32> {
    let phi = 6.283185307179586 * u1;
    if (Q.phase.x == 0u) {
        *weight = vec3<f32>(1.0);
        return frame_around(incoming, hg_inverse_cdf(u0.x, Q.g), phi);
    }
    let base = Q.phase.y;
    let bins = Q.phase.z;
    var lo = 0u;
    var hi = bins + 1u;
    while (lo < hi) {
        let m = (lo + hi) / 2u;
        if (past_cdf(u0, base + 4u * m) >= 0.0) {
            lo = m + 1u;
        } else {
            hi = m;
        }
    }
    let at = base + 4u * min(max(lo, 1u) - 1u, bins - 1u);
    let width = (meta_[at + 4u] - meta_[at]) + (meta_[at + 5u] - meta_[at + 1u]);
    var v = 0.5;
    if (width > 0.0) {
        v = clamp(past_cdf(u0, at) / width, 0.0, 1.0);
    }
    let omc = clamp(meta_[at + 2u] + v * (meta_[at + 6u] - meta_[at + 2u]), 0.0, 2.0);
    let pdf = meta_[at + 3u];
    *weight = vec3<f32>(0.0);
    if (pdf > 0.0) {
        *weight = phase_at(2.0 * asin(sqrt(0.5 * omc))) / pdf;
    }
    return frame_around_cs(incoming, 1.0 - omc, sqrt(omc * (2.0 - omc)), phi);
}

// u − the cumulative probability stored (hi, lo) at meta_[at].
fn past_cdf(u: vec2<f32>, at: u32) -> f32 {
    return (u.x - meta_[at]) + (u.y - meta_[at + 1u]);
}

// ---- the camera ray's opacity (path/camera.rs) ----

fn mean_transmittance(d: f32) -> f32 {
    let t = exp(-P.sigma_t.xyz * d);
    return (t.x + t.y + t.z) / 3.0;
}

// Where in [t0, t1] the mean transmittance falls to ½, given ∫ρ = `before` up to t0:
// pieces of a voxel, the crossing one interpolated as an exponential.
fn half_crossing(r: Ray, t0: f32, t1: f32, before: f32) -> f32 {
    let n = u32(clamp(ceil((t1 - t0) * length(r.d)), 1.0, 4096.0));
    let h = (t1 - t0) / f32(n);
    var w = walk_start(r, t0);
    var budget = 16777216u;
    var a = t0;
    var d = before;
    for (var i = 1u; i <= n; i++) {
        var b = t0 + h * f32(i);
        if (i == n) {
            b = t1;
        }
        let part = integral(r, &w, a, b, &budget);
        let m0 = mean_transmittance(d);
        let m1 = mean_transmittance(d + part);
        if (m1 <= 0.5) {
            let rate = log(m0 / m1) / (b - a);
            var s = b - a;
            if (rate > 0.0 && rate < BIG) {
                s = log(m0 / 0.5) / rate;
            }
            return a + clamp(s, 0.0, b - a);
        }
        d += part;
        a = b;
    }
    return t1;
}

// The camera ray's ∫ρ over [t_min, t_max], exact per cell, and in `half` where the
// mean transmittance first falls to ½ (−1: nowhere). Its cells' integrals are not
// counted among the density samples, as the CPU's are not.
fn camera_ray(r: Ray, t_min: f32, t_max: f32, half: ptr<function, f32>) -> f32 {
    *half = -1.0;
    let speed = length(r.d);
    if (!(speed > 0.0 && speed < BIG)) {
        return 0.0;
    }
    var total = 0.0;
    var cells = cells_start(r, t_min, t_max);
    var cell: Cell;
    var span: vec2<f32>;
    loop {
        if (!cells_next(&cells, r, false, &cell, &span)) {
            break;
        }
        let t0 = span.x;
        let t1 = span.y;
        var part: f32;
        if (cell.lo == cell.hi) {
            part = cell.hi * (t1 - t0);
        } else {
            part = integral_over(r, t0, t1);
        }
        if (*half < 0.0 && mean_transmittance(total + part) <= 0.5) {
            *half = half_crossing(r, t0, t1, total);
        }
        total += part;
    }
    return total;
}

// ---- the paths ----

// Stream `lo` of event `events` (flights: lo 0; shadow rays: 1 + their light).
fn event_stream(key: vec2<u32>, events: u32, lo: u32) -> vec2<u32> {
    return stream(key, vec2<u32>((events << 16u) | lo, events >> 16u));
}

// Results of sample i at results[i * Q.stride]: the camera ray's ∫ρ (0 where its
// opacity is not computed), the half-opacity t (−1: none), the density samples taken,
// the ray's depth rate; the emission seen directly, after one scattering event and after
// more (rgb, 0 each); then per light (the environment last) its light scattered once
// (rgb, 0) and more than once (rgb, 0). The samples: two vec4s each, its pick (the ray
// and the key of its random streams made from it, rays.wgsl), then 1 where its opacity
// is computed (x).
@compute @workgroup_size(64)
fn path_samples(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * 65535u * 64u;
    if (i >= P.n_samples) {
        return;
    }
    let pick = samples[2u * i];
    let smp = camera_sample(pick);
    let key = stream_key(pick);
    let opacity = samples[2u * i + 1u].x != 0.0;
    let out = i * Q.stride;
    var n = 0u;
    var half = -1.0;
    var depth = 0.0;
    var r = Ray(smp.index_origin.xyz, smp.index_dir.xyz);
    var t_min = smp.index_origin.w;
    var t_max = smp.world_dir.w;
    if (opacity) {
        depth = camera_ray(r, t_min, t_max, &half);
    }
    var once: array<vec3<f32>, 9>;
    var more: array<vec3<f32>, 9>;
    for (var l = 0u; l <= MAX_LIGHTS; l++) {
        once[l] = vec3<f32>(0.0);
        more[l] = vec3<f32>(0.0);
    }
    let n_lights = min(Q.n_lights, MAX_LIGHTS);
    let env = Q.environment.w != 0.0;
    let n_layers = n_lights + select(0u, 1u, env);
    let emits = Q.emit_lo.w != 0.0;
    var glow: array<vec3<f32>, 3>;
    for (var k = 0; k < 3; k++) {
        glow[k] = vec3<f32>(0.0);
    }
    var wo = smp.world_origin.xyz;
    var wd = smp.world_dir.xyz;
    var beta = vec3<f32>(1.0);
    var events = 0u;
    loop {
        if (n_layers == 0u && !emits) {
            break;
        }
        var rng = event_stream(key, events, 0u);
        var emitted = vec3<f32>(0.0);
        let t = fly(r, t_min, t_max, &beta, &rng, &n, &emitted);
        glow[min(events, 2u)] += emitted;
        if (t < 0.0) {
            // Escaped: the dome's light, after at least one event.
            if (env && events > 0u) {
                let v = beta * Q.environment.xyz;
                if (events == 1u) {
                    once[n_lights] += v;
                } else {
                    more[n_lights] += v;
                }
            }
            break;
        }
        let x = wo + wd * t;
        events += 1u;
        for (var l = 0u; l < n_lights; l++) {
            var irr: vec3<f32>;
            let travel = incident(l, x, &irr);
            if (all(irr == vec3<f32>(0.0))) {
                continue;
            }
            var tr: vec3<f32>;
            if (Q.ratio != 0u) {
                var sh = event_stream(key, events, 1u + l);
                var dist = BIG;
                if (light_f(l, 0u) != 0.0) {
                    dist = length(vec3<f32>(light_f(l, 4u), light_f(l, 5u), light_f(l, 6u)) - x);
                }
                tr = ratio_tracking(x, -travel, dist, &sh, &n);
            } else {
                tr = exp(-P.sigma_t.xyz * max(density_to_light(l, x), 0.0));
            }
            let v = beta * path_phase(travel, -wd) * irr * tr;
            if (finite3(v)) {
                if (events == 1u) {
                    once[l] += v;
                } else {
                    more[l] += v;
                }
            }
        }
        if (events >= Q.bounces) {
            // The last event: the dome's light through it, by ratio tracking along a
            // phase-sampled direction.
            if (env) {
                let u0 = next_f_fine(&rng);
                let u1 = next_f(&rng);
                var w: vec3<f32>;
                let d = sample_phase(wd, u0, u1, &w);
                var sh = event_stream(key, events, 1u + n_lights);
                let v = beta * w * ratio_tracking(x, d, BIG, &sh, &n) * Q.environment.xyz;
                if (events == 1u) {
                    once[n_lights] += v;
                } else {
                    more[n_lights] += v;
                }
            }
            break;
        }
        if (events >= 3u) {
            let q = max3(beta);
            if (q < 1.0) {
                if (!(next_f(&rng) < q)) {
                    break;
                }
                beta /= q;
            }
        }
        let u0 = next_f_fine(&rng);
        let u1 = next_f(&rng);
        var w: vec3<f32>;
        wd = sample_phase(wd, u0, u1, &w);
        beta *= w;
        if (!(max3(beta) > 0.0) || !finite3(beta)) {
            break;
        }
        wo = x;
        r = Ray(to_index(x), to_index_dir(wd));
        t_min = 0.0;
        t_max = BIG;
    }
    results[out] = depth;
    results[out + 1u] = half;
    results[out + 2u] = f32(n);
    results[out + 3u] = dot(smp.world_dir.xyz, C.forward.xyz);
    for (var k = 0u; k < 3u; k++) {
        let o = out + 4u + 4u * k;
        results[o] = glow[k].x;
        results[o + 1u] = glow[k].y;
        results[o + 2u] = glow[k].z;
        results[o + 3u] = 0.0;
    }
    for (var l = 0u; l < n_layers; l++) {
        let o = out + 16u + 8u * l;
        results[o] = once[l].x;
        results[o + 1u] = once[l].y;
        results[o + 2u] = once[l].z;
        results[o + 3u] = 0.0;
        results[o + 4u] = more[l].x;
        results[o + 5u] = more[l].y;
        results[o + 6u] = more[l].z;
        results[o + 7u] = 0.0;
    }
}
