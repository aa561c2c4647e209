// The single-scattering march of src/integrate/march.rs, one camera sample per
// invocation, in f32: hierarchical DDA over the grid's nodes (empty cells skipped at
// every level), segments of at most `step` voxels restarted in every cell (the first
// shortened by the sample's jitter, longer where the cell is optically thin), each
// segment's density from its exact integral (voxel by voxel, two-point Gauss–Legendre),
// τ toward each light from its deep shadow map or a marched shadow ray at the segment ends, early termination;
// under `--scattering fast` each segment also gathers the lattice's multiple scattering
// (lattice.wgsl). Compiled after grid.wgsl (the parameters, tree lookups and cell walk).

struct Sample {
    world_origin: vec4<f32>, // xyz, w: jitter
    world_dir: vec4<f32>,
    index_origin: vec4<f32>, // xyz, w: t_min (the near clipping plane)
    index_dir: vec4<f32>,    // xyz, w: where the ray meets the ground plane (0: not
                             // seen; its sign: the side the camera is on)
};

@group(0) @binding(3) var<storage, read> dsm0: array<u32>;
@group(0) @binding(4) var<storage, read> meta_: array<f32>;
// The samples' inputs: each one's pick (its pixel, the holdout's depth there and its
// index, from which rays.wgsl makes its ray), then for the path tracer a vec4 of flags.
@group(0) @binding(5) var<storage, read> samples: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> results: array<f32>;
@group(0) @binding(7) var<storage, read> dsm1: array<u32>;
@group(0) @binding(8) var<storage, read> dsm2: array<u32>;

const MAX_LIGHTS: u32 = 8u;

// The march's optional parts, each false where the scene does not use it (the host sets
// them: upload.rs, MarchFeatures), so that its code, and the registers it holds, are
// left out of the pipeline; the defaults keep every part (the path tracer's pipeline,
// compiled from these sources too, sets none).
override EMITS: bool = true;    // something emits
override TINTED: bool = true;   // a colour grid tints σs
override MULTIPLE: bool = true; // the fast mode's lattice is gathered
override MARCHED: bool = true;  // some light's shadow rays are marched
override GROUND: bool = true;   // camera rays may meet a ground plane
const MAX_CELLS: u32 = 1048576u;

// ---- rays against the grid's bounds and cells ----

fn clip_to_bounds(r: Ray, t_min: f32, t_max: f32) -> vec2<f32> {
    return clip_to_box(r, P.bounds_lo.xyz, P.bounds_hi.xyz, t_min, t_max);
}

// [t0, t1] of the ray over [t_min, t_max] inside the box [lo, hi] ((0, 0): none).
fn clip_to_box(r: Ray, lo: vec3<f32>, hi: vec3<f32>, t_min: f32, t_max: f32) -> vec2<f32> {
    var t0 = t_min;
    var t1 = t_max;
    if (any(lo > hi)) {
        return vec2<f32>(0.0, 0.0);
    }
    for (var a = 0; a < 3; a++) {
        let o = r.o[a];
        let d = r.d[a];
        if (d == 0.0) {
            if (o < lo[a] || o > hi[a]) {
                return vec2<f32>(0.0, 0.0);
            }
            continue;
        }
        let inv = 1.0 / d;
        var ta = (lo[a] - o) * inv;
        var tb = (hi[a] - o) * inv;
        if (ta > tb) {
            let s = ta;
            ta = tb;
            tb = s;
        }
        t0 = max(t0, ta);
        t1 = min(t1, tb);
        if (t0 > t1) {
            return vec2<f32>(0.0, 0.0);
        }
    }
    if (t0 < t1) {
        return vec2<f32>(t0, t1);
    }
    return vec2<f32>(0.0, 0.0);
}

// The voxel the ray is in just after t (on a face: the one it enters).
fn voxel_ahead(r: Ray, t: f32) -> vec3<i32> {
    let p = ray_at(r, t);
    var c = floor(p);
    for (var a = 0; a < 3; a++) {
        if (r.d[a] < 0.0) {
            c[a] = ceil(p[a]) - 1.0;
        }
    }
    return vec3<i32>(clamp(c, vec3<f32>(-1073741824.0), vec3<f32>(1073741824.0)));
}

fn cell_exit(r: Ray, origin: vec3<i32>, size: i32) -> f32 {
    var t_exit = BIG;
    for (var a = 0; a < 3; a++) {
        let d = r.d[a];
        if (d == 0.0) {
            continue;
        }
        var face = f32(origin[a]);
        if (d > 0.0) {
            face += f32(size);
        }
        t_exit = min(t_exit, (face - r.o[a]) / d);
    }
    return t_exit;
}

// The cells a ray crosses over [t_min, t_max] inside the bounds, front to back: at most
// MAX_CELLS of them, each at least a rounding step long (cells_next).
struct Cells {
    t: f32,
    t_end: f32,
    min_step: f32,
    left: u32,
};

fn cells_start(r: Ray, t_min: f32, t_max: f32) -> Cells {
    let clip = clip_to_bounds(r, t_min, t_max);
    // The least progress must move t and the ray's point past f32's rounding wherever
    // the walk is: scaled by the largest coordinate at the origin and at either end of
    // the stretch, and by t's own size. (From the origin alone, a ray starting near index
    // 0 rounds t + min_step back to t far from it, where a cell's exit computes a hair
    // short of the point it reaches: the walk spins there until MAX_CELLS.)
    let p0 = abs(ray_at(r, clip.x));
    let p1 = abs(ray_at(r, clip.y));
    let far = max(max(abs(r.o), p0), p1);
    let scale = max(max(far.x, far.y), max(far.z, 1.0));
    let min_step = max(1e-6 * scale / length(r.d), 1e-6 * max(abs(clip.x), abs(clip.y)));
    return Cells(clip.x, clip.y, min_step, MAX_CELLS);
}

// The next cell whose range is not all 0, in `cell`, and the ray's stretch [t0, t1] in
// it, in `span`: the density's cells (cell_at), or with `beside` theirs with the grids
// visited beside it (visited_cell); false past the end.
fn cells_next(c: ptr<function, Cells>, r: Ray, beside: bool, cell: ptr<function, Cell>,
              span: ptr<function, vec2<f32>>) -> bool {
    loop {
        if (!((*c).t < (*c).t_end) || (*c).left == 0u) {
            break;
        }
        (*c).left -= 1u;
        var here: Cell;
        if (beside) {
            here = visited_cell(voxel_ahead(r, (*c).t));
        } else {
            here = cell_at(voxel_ahead(r, (*c).t));
        }
        let exit = cell_exit(r, here.origin, here.size);
        let t0 = (*c).t;
        (*c).t = min(max(exit, t0 + (*c).min_step), (*c).t_end);
        if (here.hi <= 0.0 && here.lo >= 0.0) {
            continue;
        }
        *cell = here;
        *span = vec2<f32>(t0, (*c).t);
        return true;
    }
    return false;
}

// ---- exact density integrals: a walk over the voxel cells ----

fn load_corners(w: ptr<function, Walk>) {
    load_corners_in(0u, w);
}

// The corners of the walk's cell in grid k (0: the density).
fn load_corners_in(k: u32, w: ptr<function, Walk>) {
    if ((*w).has && all((*w).loaded == (*w).cell)) {
        return;
    }
    var v: array<f32, 8>;
    if (k == 0u) {
        v = walk_corners(w);
    } else {
        v = cell_corners_in(grid_of(k), (*w).cell, 0u);
    }
    (*w).corners0 = vec4<f32>(v[0], v[1], v[2], v[3]);
    (*w).corners1 = vec4<f32>(v[4], v[5], v[6], v[7]);
    (*w).loaded = (*w).cell;
    (*w).has = true;
}

// ∫ρ dt over [a, b], continuing the walk (which is at or before a).
fn integral(r: Ray, w: ptr<function, Walk>, a: f32, b: f32, budget: ptr<function, u32>) -> f32 {
    return integral_in(0u, r, w, a, b, budget);
}

// integral() of grid k (0: the density; r in its local index space).
fn integral_in(k: u32, r: Ray, w: ptr<function, Walk>, a: f32, b: f32, budget: ptr<function, u32>) -> f32 {
    var sum = 0.0;
    var lo = a;
    loop {
        if (*budget == 0u) {
            break;
        }
        *budget -= 1u;
        let tn = min(min((*w).next.x, (*w).next.y), (*w).next.z);
        let hi = min(tn, b);
        if (hi > lo) {
            load_corners_in(k, w);
            let t = ray_at(r, 0.5 * (lo + hi)) - vec3<f32>((*w).cell);
            let off = r.d * (GL2_HALF_OFFSET * (hi - lo));
            sum += 0.5 * (hi - lo) * (trilinear((*w).corners0, (*w).corners1, t - off)
                + trilinear((*w).corners0, (*w).corners1, t + off));
            lo = hi;
        }
        if (tn >= b) {
            break;
        }
        for (var k = 0; k < 3; k++) {
            if ((*w).next[k] <= tn) {
                (*w).cell[k] += (*w).step[k];
                (*w).next[k] = face_t(r, *w, k);
            }
        }
    }
    return sum;
}

// ---- optics ----

fn one_minus_exp(x: f32) -> f32 {
    if (abs(x) < 1e-3) {
        return x * (1.0 - 0.5 * x * (1.0 - x / 3.0));
    }
    return 1.0 - exp(-x);
}

fn phi(x: f32) -> f32 {
    if (abs(x) < 1e-2) {
        return 1.0 - x / 2.0 * (1.0 - x / 3.0 * (1.0 - x / 4.0 * (1.0 - x / 5.0)));
    }
    return one_minus_exp(x) / x;
}

fn exp_source_weight(st: f32, tau0: f32, tau1: f32, ds: f32) -> f32 {
    let a_ds = st * ds + (tau1 - tau0);
    if (a_ds >= 0.0) {
        return exp(-tau0) * ds * phi(a_ds);
    }
    return exp(-(tau1 + st * ds)) * ds * phi(-a_ds);
}

fn phase(cos_theta: f32) -> vec3<f32> {
    return phase_at(acos(clamp(cos_theta, -1.0, 1.0)));
}

// The phase function between the direction light travels and the one toward the
// camera (unit vectors), its angle from both (acos of the cosine alone, in f32, cannot
// tell angles under a milliradian apart: water drops' forward peak is narrower).
fn phase_between(travel: vec3<f32>, toward_camera: vec3<f32>) -> vec3<f32> {
    return phase_at(atan2(length(cross(travel, toward_camera)), dot(travel, toward_camera)));
}

// Tabulated over the scattering angle θ, linear between nodes (4 floats each: rgb and
// θ) placed as P.phase_grid says: log-spaced to θ = phase_grid.z, then evenly.
fn phase_at(theta: f32) -> vec3<f32> {
    let n = P.phase_n;
    let g = P.phase_grid;
    var x: f32;
    if (theta < g.z) {
        x = log(1.0 + theta / g.x) / g.y;
    } else {
        x = f32(P.flags.z) + (theta - g.z) / g.w;
    }
    var i = min(u32(max(x, 0.0)), n - 2u);
    // The nodes' own angles settle a bin that rounding put one off.
    if (i > 0u && theta < meta_[P.phase_base + 4u * i + 3u]) {
        i -= 1u;
    } else if (i + 2u < n && theta > meta_[P.phase_base + 4u * i + 7u]) {
        i += 1u;
    }
    let at = P.phase_base + 4u * i;
    let p0 = vec3<f32>(meta_[at], meta_[at + 1u], meta_[at + 2u]);
    let p1 = vec3<f32>(meta_[at + 4u], meta_[at + 5u], meta_[at + 6u]);
    let span = meta_[at + 7u] - meta_[at + 3u];
    var f = 0.0;
    if (span > 0.0) {
        f = clamp((theta - meta_[at + 3u]) / span, 0.0, 1.0);
    }
    return mix(p0, p1, f);
}

// ---- lights: 16 floats each in `meta_` ----
// [kind (0 sun, 1 point), shadow (0 none, 1 map, 2 cube map), first chart, 0,
//  position or direction toward the sun (xyz), 0, irradiance or intensity (rgb), 0, 0 0 0 0]

fn light_f(l: u32, k: u32) -> f32 {
    return meta_[l * 16u + k];
}

// Unshadowed irradiance at x and the direction the light travels there.
fn incident(l: u32, x: vec3<f32>, irr: ptr<function, vec3<f32>>) -> vec3<f32> {
    let v = vec3<f32>(light_f(l, 4u), light_f(l, 5u), light_f(l, 6u));
    let e = vec3<f32>(light_f(l, 8u), light_f(l, 9u), light_f(l, 10u));
    if (light_f(l, 0u) == 0.0) {
        *irr = e;
        return -v;
    }
    let d = x - v;
    let r2 = max(dot(d, d), 1e-12);
    *irr = e / r2;
    return d / sqrt(r2);
}

// ---- the march ----

// light_depth() (toward_light.wgsl), its marched shadow rays left out without MARCHED.
fn depth_to_light(l: u32, pw: vec3<f32>, pi: vec3<f32>) -> f32 {
    if (MARCHED) {
        return light_depth(l, pw, pi);
    }
    return density_to_light(l, pw);
}

// Results of one sample at results[i * stride]: optical depth (rgb) and 1 where the
// march terminated, transmittance (rgb) and the half-opacity t (−1: none), the density
// samples taken and the multiply scattered radiance of all lights (rgb), the emitted
// radiance (rgb) and the ray's depth rate (camera depth per unit of t), then per light its
// scattered radiance (rgb, every order) and 0; then, where a ground plane is lit, the
// light it receives (ground_light).
@compute @workgroup_size(64)
fn march_samples(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * 65535u * 64u;
    if (i >= P.n_samples) {
        return;
    }
    let smp = camera_sample(samples[i]);
    let wo = smp.world_origin.xyz;
    let wd = smp.world_dir.xyz;
    let u = clamp(smp.world_origin.w, 0.0, 1.0);
    let t_max = smp.world_dir.w;
    let r = Ray(smp.index_origin.xyz, smp.index_dir.xyz);
    let out = i * P.stride;
    let speed = length(r.d);
    var tau = vec3<f32>(0.0);
    var t_now = vec3<f32>(1.0);
    var half_t = -1.0;
    var terminated = false;
    var n = 0u;
    var per_light: array<vec3<f32>, 8>;
    var indirect = vec3<f32>(0.0);
    var emission = vec3<f32>(0.0);
    var light_tau: array<vec3<f32>, 8>;
    var light_tau_ok: array<bool, 8>;
    for (var l = 0u; l < MAX_LIGHTS; l++) {
        per_light[l] = vec3<f32>(0.0);
        light_tau_ok[l] = false;
    }
    let n_lights = min(P.n_lights, MAX_LIGHTS);
    // A sun's phase toward the camera is the same all along the ray: found once.
    var sun_phase: array<vec3<f32>, 8>;
    for (var l = 0u; l < n_lights; l++) {
        if (P.scatters != 0u && light_f(l, 0u) == 0.0) {
            var irr: vec3<f32>;
            sun_phase[l] = phase_between(incident(l, wo, &irr), -wd);
        }
    }
    var last_end = -BIG;
    if (speed > 0.0 && speed < BIG) {
        let h = max(P.step_voxels, 1e-6) / speed;
        let st_max = max(max(P.sigma_t.x, P.sigma_t.y), P.sigma_t.z);
        var cells = cells_start(r, smp.index_origin.w, t_max);
        var cell: Cell;
        var span: vec2<f32>;
        var budget = 16777216u;
        loop {
            if (terminated || !cells_next(&cells, r, true, &cell, &span)) {
                break;
            }
            let t0 = span.x;
            let t1 = span.y;
            // One span [t0, t1]: segments of h_span, the first shortened by the jitter
            // (not longer in thin cells where something emits: flame does not follow
            // density). A cell of several grids' is never taken as constant.
            let constant = cell.lo == cell.hi && P.traverse.x == 0u;
            var h_span = h;
            let per_step = st_max * cell.hi * h;
            if (per_step > 0.0 && per_step < P.thin_depth && P.flags.x == 0u) {
                h_span = h * (P.thin_depth / per_step);
            }
            var walk = walk_start(r, t0);
            var emission_walk = walk;
            if (EMITS && P.emit_grids.y != 0u) {
                let o = vec3<f32>(grid_shift(grid_of(P.emit_grids.x)));
                emission_walk = walk_start(Ray(r.o + o, r.d), t0);
            }
            var a = t0;
            var first = true;
            loop {
                if (!(a < t1) || budget == 0u) {
                    break;
                }
                var step = h_span;
                if (first) {
                    step = u * h_span;
                    first = false;
                    if (step <= 0.0) {
                        continue;
                    }
                }
                var b = min(a + step, t1);
                if (!(b > a)) {
                    b = t1;
                }
                let ds = b - a;
                let mid = 0.5 * (a + b);
                var rho: f32;
                if (constant) {
                    rho = cell.hi;
                } else {
                    rho = integral(r, &walk, a, b, &budget) / ds;
                }
                n += 1u;
                let st = P.sigma_t.xyz * rho;
                let p_mid = ray_at(r, mid);
                if (EMITS && P.flags.x != 0u) {
                    let eps = emitted(r, &emission_walk, a, b, p_mid, &budget);
                    if (max(max(eps.x, eps.y), eps.z) > 0.0) {
                        let w = ds * vec3<f32>(phi(st.x * ds), phi(st.y * ds), phi(st.z * ds));
                        emission += t_now * eps * w;
                    }
                }
                if (P.scatters != 0u && rho > 0.0) {
                    let xw = wo + wd * mid;
                    var sigma_s_here = P.sigma_s.xyz;
                    if (TINTED) {
                        sigma_s_here *= tint(p_mid);
                    }
                    for (var l = 0u; l < n_lights; l++) {
                        var tau0: vec3<f32>;
                        if (light_tau_ok[l] && last_end == a) {
                            tau0 = light_tau[l];
                        } else {
                            tau0 = P.sigma_t.xyz * depth_to_light(l, wo + wd * a, ray_at(r, a));
                        }
                        let tau1 = P.sigma_t.xyz * depth_to_light(l, wo + wd * b, ray_at(r, b));
                        light_tau[l] = tau1;
                        light_tau_ok[l] = true;
                        var irr: vec3<f32>;
                        let travel = incident(l, xw, &irr);
                        var ph: vec3<f32>;
                        if (light_f(l, 0u) == 0.0) {
                            ph = sun_phase[l];
                        } else {
                            ph = phase_between(travel, -wd);
                        }
                        let weight = vec3<f32>(
                            exp_source_weight(st.x, tau0.x, tau1.x, ds),
                            exp_source_weight(st.y, tau0.y, tau1.y, ds),
                            exp_source_weight(st.z, tau0.z, tau1.z, ds));
                        per_light[l] += t_now * sigma_s_here * rho * ph * irr * weight;
                        if (MULTIPLE && P.multiple != 0u) {
                            // Multiply scattered light toward the camera, constant over
                            // the segment: the segment's own weight.
                            let w = ds * vec3<f32>(phi(st.x * ds), phi(st.y * ds), phi(st.z * ds));
                            let ms = t_now * sigma_s_here * rho * multiple_toward(l, xw, -wd, travel) * w;
                            per_light[l] += ms;
                            indirect += ms;
                        }
                    }
                    last_end = b;
                }
                let t_before = t_now;
                tau += st * ds;
                t_now = exp(-tau);
                let m0 = (t_before.x + t_before.y + t_before.z) / 3.0;
                let m1 = (t_now.x + t_now.y + t_now.z) / 3.0;
                if (half_t < 0.0 && m0 > 0.5 && m1 <= 0.5) {
                    let rate = log(m0 / m1) / ds;
                    var s = ds;
                    if (rate > 0.0 && rate < BIG) {
                        s = log(m0 / 0.5) / rate;
                    }
                    half_t = a + clamp(s, 0.0, ds);
                }
                if (max(max(t_now.x, t_now.y), t_now.z) < P.termination) {
                    t_now = vec3<f32>(0.0);
                    terminated = true;
                    break;
                }
                a = b;
            }
        }
    }
    results[out] = tau.x;
    results[out + 1u] = tau.y;
    results[out + 2u] = tau.z;
    results[out + 3u] = select(0.0, 1.0, terminated);
    results[out + 4u] = t_now.x;
    results[out + 5u] = t_now.y;
    results[out + 6u] = t_now.z;
    results[out + 7u] = half_t;
    results[out + 8u] = f32(n);
    results[out + 9u] = indirect.x;
    results[out + 10u] = indirect.y;
    results[out + 11u] = indirect.z;
    results[out + 12u] = emission.x;
    results[out + 13u] = emission.y;
    results[out + 14u] = emission.z;
    results[out + 15u] = dot(wd, C.forward.xyz);
    for (var l = 0u; l < n_lights; l++) {
        let o = out + 16u + 4u * l;
        results[o] = per_light[l].x;
        results[o + 1u] = per_light[l].y;
        results[o + 2u] = per_light[l].z;
    }
    // A ground plane: its light after the lights' (toward_light.wgsl).
    let ground_at = 16u + 4u * n_lights;
    if (GROUND && P.stride >= ground_at + 8u) {
        ground_light(wo, wd, r, smp.index_dir.w, out + ground_at);
    }
}
