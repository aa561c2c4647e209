// The path tracer's tracking (path.wgsl has the rest): free flights by delta and
// spectral tracking over the majorant grid's blocks, crossed by a 3-D DDA; spans too
// dense to track crossed by the density's integral (path/dense.rs); transmittance by
// ratio tracking. Compiled with path.wgsl, after the march's sources.

// ---- dense spans (path/dense.rs) ----

const DENSE_SPAN: f32 = 256.0;

fn too_many(tries: u32, depth: f32) -> bool {
    return (tries >= 8u && depth > DENSE_SPAN) || tries >= 1024u;
}

// Per channel e^{−σt·I} / Σ q_k w_k e^{−σt_k·I}, relative to the smallest exponent.
fn mis_weight(q: vec3<f32>, w: vec3<f32>, i: f32) -> vec3<f32> {
    let st = P.sigma_t.xyz;
    let e = select(st * i, vec3<f32>(0.0), st == vec3<f32>(0.0));
    var m = BIG;
    for (var k = 0; k < 3; k++) {
        if (q[k] > 0.0 && w[k] > 0.0) {
            m = min(m, e[k]);
        }
    }
    if (!(m < BIG)) {
        return vec3<f32>(0.0);
    }
    let rel = exp(vec3<f32>(m) - e);
    let sum = dot(q * w, rel);
    if (sum > 0.0) {
        return rel / sum;
    }
    return vec3<f32>(0.0);
}

// A free flight over the dense span [t0, t1]: the collision's t with in `w` the factor
// the throughput takes there (without σs, which the caller takes at the point, tinted),
// or −1 when it passes the span (`beta` weighted for that).
fn dense_flight(r: Ray, t0: f32, t1: f32, maj: f32, beta: ptr<function, vec3<f32>>,
                rng: ptr<function, vec2<u32>>, n: ptr<function, u32>, w: ptr<function, vec3<f32>>) -> f32 {
    let total = (*beta).x + (*beta).y + (*beta).z;
    if (!(total > 0.0)) {
        return -1.0;
    }
    let q = *beta / total;
    let st = P.sigma_t.xyz;
    var c = st.x;
    if (Q.grey == 0u) {
        let u = next_f(rng);
        if (u < q.x) {
            c = st.x;
        } else if (u < q.x + q.y) {
            c = st.y;
        } else {
            c = st.z;
        }
    }
    *n += 1u;
    let whole = max(integral_over(r, t0, t1), 0.0);
    let target_ = -log(1.0 - next_f(rng));
    if (!(c * whole > target_)) {
        *beta *= mis_weight(q, vec3<f32>(1.0), whole);
        return -1.0;
    }
    let ulp = max(max(abs(t0), abs(t1)) * 1.1920929e-7, 1e-30);
    var h = max(target_ * max3(st) / (c * maj), 4.0 * ulp);
    var a = t0;
    var fa = -target_;
    var b = t1;
    var fb = c * whole - target_;
    for (var i = 0; i < 64; i++) {
        if (!(t0 + h < b)) {
            break;
        }
        *n += 1u;
        let fh = c * max(integral_over(r, t0, t0 + h), 0.0) - target_;
        if (fh > 0.0) {
            b = t0 + h;
            fb = fh;
            break;
        }
        a = t0 + h;
        fa = fh;
        h *= 8.0;
    }
    var kept = 0;
    for (var i = 0; i < 64; i++) {
        if (!(b - a > max(1e-9 * (b - t0), 4.0 * ulp))) {
            break;
        }
        var m = (a * fb - b * fa) / (fb - fa);
        if (!(m > a && m < b)) {
            m = 0.5 * (a + b);
            if (!(m > a && m < b)) {
                break;
            }
        }
        *n += 1u;
        let fm = c * max(integral_over(r, t0, m), 0.0) - target_;
        if (fm > 0.0) {
            b = m;
            fb = fm;
            if (kept == -1) {
                fa *= 0.5;
            }
            kept = -1;
        } else {
            a = m;
            fa = fm;
            if (kept == 1) {
                fb *= 0.5;
            }
            kept = 1;
        }
    }
    let t = 0.5 * (a + b);
    *n += 1u;
    *w = mis_weight(q, st, max(integral_over(r, t0, t), 0.0));
    return t;
}

// ---- the majorant grid's blocks along a ray (MajorantSpans) ----

struct Blocks {
    cell: vec3<i32>,
    step: vec3<i32>,
    next: vec3<f32>,
    delta: vec3<f32>,
    t: f32,
    t_end: f32,
    left: u32,  // blocks it may still visit
};

fn blocks_start(r: Ray, t_min: f32, t_max: f32) -> Blocks {
    var b: Blocks;
    b.t = 0.0;
    b.t_end = 0.0;
    b.left = 1048576u;
    let dims = Q.maj_dims.xyz;
    if (any(dims <= vec3<i32>(0))) {
        return b;
    }
    let clip = clip_to_bounds(r, t_min, t_max);
    if (!(clip.y > clip.x)) {
        return b;
    }
    let s = f32(Q.maj_origin.w);
    let o = vec3<f32>(Q.maj_origin.xyz);
    let rel = (ray_at(r, clip.x) - o) / s;
    b.cell = vec3<i32>(0);
    b.step = vec3<i32>(0);
    b.next = vec3<f32>(BIG);
    b.delta = vec3<f32>(BIG);
    for (var a = 0; a < 3; a++) {
        let d = r.d[a];
        var c = floor(rel[a]);
        if (d < 0.0) {
            c = ceil(rel[a]) - 1.0;
        }
        b.cell[a] = clamp(i32(clamp(c, -1.0, f32(dims[a]))), 0, dims[a] - 1);
        if (d != 0.0) {
            b.step[a] = select(-1, 1, d > 0.0);
            let face = o[a] + s * f32(b.cell[a] + select(0, 1, d > 0.0));
            b.next[a] = (face - r.o[a]) / d;
            b.delta[a] = s / abs(d);
        }
    }
    b.t = clip.x;
    b.t_end = clip.y;
    return b;
}

// The next block with density: its span (t0, t1) and range (max, min) in `span`;
// false when the ray has left the grid.
fn blocks_next(b: ptr<function, Blocks>, span: ptr<function, vec4<f32>>) -> bool {
    let dims = Q.maj_dims.xyz;
    loop {
        if (!((*b).t < (*b).t_end) || (*b).left == 0u) {
            return false;
        }
        (*b).left -= 1u;
        let c = (*b).cell;
        let at = u32((c.z * dims.y + c.y) * dims.x + c.x);
        let hi = meta_[u32(Q.maj_dims.w) + at];
        let lo = meta_[Q.maj_min_base + at];
        let n = (*b).next;
        var a = 2;
        if (n.x <= n.y && n.x <= n.z) {
            a = 0;
        } else if (n.y <= n.z) {
            a = 1;
        }
        let t1 = max(min(n[a], (*b).t_end), (*b).t);
        let t0 = (*b).t;
        (*b).t = t1;
        (*b).cell[a] += (*b).step[a];
        (*b).next[a] += (*b).delta[a];
        if ((*b).cell[a] < 0 || (*b).cell[a] >= dims[a]) {
            (*b).t_end = (*b).t;
        }
        if (hi > 0.0 && t1 > t0) {
            *span = vec4<f32>(t0, t1, hi, lo);
            return true;
        }
    }
    return false;
}

// ---- emission along a flight ----

// ∫ε dt over [a, b] of the ray, in pieces of at most a voxel, each piece's emission
// coefficient the march's segment's (emitted(): the emission grid's exact mean, the
// temperature at the midpoint), as PathTracer::emission_over.
fn emission_over(r: Ray, a: f32, b: f32) -> vec3<f32> {
    let n = u32(clamp(ceil((b - a) * max(length(r.d), 1e-30)), 1.0, 65536.0));
    let h = (b - a) / f32(n);
    var w = walk_start(r, a);
    if (P.emit_grids.y != 0u) {
        let o = vec3<f32>(grid_shift(grid_of(P.emit_grids.x)));
        w = walk_start(Ray(r.o + o, r.d), a);
    }
    var budget = 16777216u;
    var sum = vec3<f32>(0.0);
    for (var i = 0u; i < n; i++) {
        let s0 = a + h * f32(i);
        let s1 = a + h * f32(i + 1u);
        sum += emitted(r, &w, s0, s1, ray_at(r, 0.5 * (s0 + s1)), &budget) * h;
    }
    return sum;
}

// Adds to `sum` the emission over [a, b] weighted by the throughput `beta`.
fn gather(r: Ray, a: f32, b: f32, beta: vec3<f32>, sum: ptr<function, vec3<f32>>) {
    if (Q.emit_lo.w != 0.0 && b > a) {
        *sum += beta * emission_over(r, a, b);
    }
}

// ---- free flights ----

// Flies along `r` over [t_min, t_max]: the first scattering event's t, with `beta`
// weighted for it, or −1 when the path leaves the volume. The emission along the
// flight (between its tentative collisions, times the throughput there) is added to
// `emitted`.
fn fly(r: Ray, t_min: f32, t_max: f32, beta: ptr<function, vec3<f32>>,
       rng: ptr<function, vec2<u32>>, n: ptr<function, u32>, emitted: ptr<function, vec3<f32>>) -> f32 {
    let st_max = max3(P.sigma_t.xyz);
    var piece = t_min;
    var blocks = blocks_start(r, t_min, t_max);
    var span: vec4<f32>;
    loop {
        if (!blocks_next(&blocks, &span)) {
            break;
        }
        let t1 = span.y;
        let maj = st_max * span.z;
        if (!(maj > 0.0)) {
            continue;
        }
        var tt = span.x;
        var tries = 0u;
        loop {
            if (too_many(tries, maj * (t1 - tt))) {
                var w: vec3<f32>;
                let tc = dense_flight(r, tt, t1, maj, beta, rng, n, &w);
                if (tc >= 0.0) {
                    gather(r, piece, tc, *beta, emitted);
                    *beta *= P.sigma_s.xyz * tint(ray_at(r, tc)) * w;
                    return tc;
                }
                break;
            }
            tries += 1u;
            tt -= log(1.0 - next_f(rng)) / maj;
            if (tt >= t1) {
                break;
            }
            let p = ray_at(r, tt);
            let rho = max(value_at(p), 0.0);
            *n += 1u;
            let st = P.sigma_t.xyz * rho;
            let sn = max(vec3<f32>(maj) - st, vec3<f32>(0.0));
            var p_real: f32;
            if (Q.grey != 0u) {
                p_real = st.x / maj;
            } else {
                p_real = dot(*beta, st) / max(maj * ((*beta).x + (*beta).y + (*beta).z), 1e-30);
            }
            p_real = clamp(p_real, 0.0, 1.0);
            let u = next_f(rng);
            gather(r, piece, tt, *beta, emitted);
            piece = tt;
            if (u < p_real) {
                *beta *= P.sigma_s.xyz * tint(p) * rho / (maj * p_real);
                return tt;
            }
            if (Q.grey == 0u) {
                *beta *= sn / (maj * (1.0 - p_real));
            }
        }
    }
    if (Q.emit_lo.w != 0.0) {
        // Past the density, emission on its lattice may still glow.
        let c = clip_to_box(r, Q.emit_lo.xyz, Q.emit_hi.xyz, t_min, t_max);
        var end = piece;
        if (c.y > c.x) {
            end = c.y;
        }
        gather(r, piece, end, *beta, emitted);
    }
    return -1.0;
}

// ---- transmittance by ratio tracking ----

const RATIO_ROULETTE: f32 = 0.1;

// The transmittance from world point x toward unit `toward` over `dist`.
fn ratio_tracking(x: vec3<f32>, toward: vec3<f32>, dist: f32, rng: ptr<function, vec2<u32>>,
                  n: ptr<function, u32>) -> vec3<f32> {
    let r = Ray(to_index(x), to_index_dir(toward));
    let st = P.sigma_t.xyz;
    let st_max = max3(st);
    var tr = vec3<f32>(1.0);
    var blocks = blocks_start(r, 0.0, dist);
    var span: vec4<f32>;
    loop {
        if (!blocks_next(&blocks, &span)) {
            break;
        }
        let len = span.y - span.x;
        if (span.z == span.w) {
            // A constant block: its transmittance is exact.
            tr *= exp(-st * span.z * len);
        } else if (st_max * span.z * len > DENSE_SPAN) {
            *n += 1u;
            let i = max(integral_over(r, span.x, span.y), 0.0);
            tr *= select(exp(-st * i), vec3<f32>(1.0), st == vec3<f32>(0.0));
        } else {
            let maj = st_max * span.z;
            if (!(maj > 0.0)) {
                continue;
            }
            var t = span.x;
            loop {
                t -= log(1.0 - next_f(rng)) / maj;
                if (t >= span.y) {
                    break;
                }
                let rho = max(value_at(ray_at(r, t)), 0.0);
                *n += 1u;
                tr *= max(vec3<f32>(1.0) - st * (rho / maj), vec3<f32>(0.0));
                let m = max3(tr);
                if (m < RATIO_ROULETTE) {
                    if (next_f(rng) >= m) {
                        return vec3<f32>(0.0);
                    }
                    tr /= m;
                }
            }
        }
        if (max3(tr) <= 0.0) {
            return vec3<f32>(0.0);
        }
    }
    return tr;
}

