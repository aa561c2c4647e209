// The shadow bake's light columns (src/shadow/columns.rs with a voxel grid's closed
// forms, VoxelGrid::slopes_along in src/field/grid_integrals.rs), one column per
// invocation, in f32: the ray is walked voxel by voxel (Amanatides–Woo) from where its
// march starts; inside a voxel the trilinear reconstruction along the ray is a cubic,
// and ∫ρ, ∫∇ρ·a, ∫∇ρ·b and ∫(aᵀ(∇∇ρ)b + ∇ρ·c) dt are integrated exactly with two
// Gauss–Legendre nodes per piece, adding the gradient's jump at each face crossed; at
// every sample depth the sums and the density there are written out. Compiled after
// grid.wgsl (the tree lookups and the cell walk the march uses too).

struct Job {
    origin: vec4<f32>,  // xyz: the index point where the march starts (t = 0); w: first depth (bits)
    dir: vec4<f32>,     // xyz: index units per world unit; w: depth count (bits)
    a0: vec4<f32>,      // a(t) = a0 + a1 t; w: first sample out (bits)
    a1: vec4<f32>,
    b0: vec4<f32>,
    b1: vec4<f32>,
    c0: vec4<f32>,
    c1: vec4<f32>,
};

@group(0) @binding(9) var<storage, read> jobs: array<Job>;
@group(0) @binding(10) var<storage, read> depths: array<f32>;
@group(0) @binding(11) var<storage, read_write> column_out: array<f32>;
@group(0) @binding(12) var<storage, read_write> column_done: array<u32>;

// The trilinear density at local index point p.
fn density_at(p: vec3<f32>) -> f32 {
    let c = floor(p);
    let v = cell_corners(vec3<i32>(c));
    return trilinear(vec4<f32>(v[0], v[1], v[2], v[3]), vec4<f32>(v[4], v[5], v[6], v[7]), p - c);
}

struct Jet {
    value: f32,
    gradient: vec3<f32>,
    mixed: vec3<f32>,   // ∂xy, ∂xz, ∂yz
};

// The trilinear blend of corners v at t ∈ [0, 1]³: value, gradient and the Hessian's
// off-diagonal terms (trilinear_jet in grid_integrals.rs).
fn jet(v: array<f32, 8>, t: vec3<f32>) -> Jet {
    let z = vec4<f32>(mix(v[0], v[1], t.z), mix(v[2], v[3], t.z), mix(v[4], v[5], t.z), mix(v[6], v[7], t.z));
    let dz = vec4<f32>(v[1] - v[0], v[3] - v[2], v[5] - v[4], v[7] - v[6]);
    let y0 = mix(z[0], z[1], t.y);
    let y1 = mix(z[2], z[3], t.y);
    let dz0 = mix(dz[0], dz[1], t.y);
    let dz1 = mix(dz[2], dz[3], t.y);
    var j: Jet;
    j.value = mix(y0, y1, t.x);
    j.gradient = vec3<f32>(y1 - y0, mix(z[1] - z[0], z[3] - z[2], t.x), mix(dz0, dz1, t.x));
    j.mixed = vec3<f32>((z[3] - z[2]) - (z[1] - z[0]), dz1 - dz0, mix(dz[1] - dz[0], dz[3] - dz[2], t.x));
    return j;
}

// acc += x, with what rounding lost kept in `lost` and added back (Kahan).
fn add(acc: ptr<function, vec4<f32>>, lost: ptr<function, vec4<f32>>, x: vec4<f32>) {
    let y = x - *lost;
    let t = *acc + y;
    *lost = (t - *acc) - y;
    *acc = t;
}

fn put_sample(r: Ray, at: u32, acc: vec4<f32>, t: f32) {
    let o = at * 5u;
    column_out[o] = acc.x;
    column_out[o + 1u] = density_at(ray_at(r, t));
    column_out[o + 2u] = acc.y;
    column_out[o + 3u] = acc.z;
    column_out[o + 4u] = acc.w;
}

@compute @workgroup_size(64)
fn march_columns(@builtin(global_invocation_id) id: vec3<u32>) {
    let j = id.x + id.y * 65535u * 64u;
    if (j >= P.n_samples) {
        return;
    }
    let job = jobs[j];
    let first = bitcast<u32>(job.origin.w);
    let n = bitcast<u32>(job.dir.w);
    let out = bitcast<u32>(job.a0.w);
    let r = Ray(job.origin.xyz, job.dir.xyz);
    let d = r.d;
    // The sums, compensated (Kahan): a column crosses hundreds to thousands of voxels.
    var acc = vec4<f32>(0.0);
    var lost = vec4<f32>(0.0);
    var k = 0u;
    while (k < n && depths[first + k] <= 0.0) {
        put_sample(r, out + k, acc, depths[first + k]);
        k++;
    }
    if (k == n) {
        column_done[j] = 1u;
        return;
    }
    let t_end = depths[first + n - 1u];
    // The walk (CellWalk in grid_integrals.rs).
    var w = walk_start(r, 0.0);
    var entered = vec3<bool>(false);
    var t = 0.0;
    var budget = 16u;
    for (var a = 0; a < 3; a++) {
        budget += u32(abs(d[a] * t_end)) + 1u;
    }
    var prev_cell = vec3<i32>(0);
    var prev: array<f32, 8>;
    var has_prev = false;
    loop {
        if (!(t < t_end)) {
            break;
        }
        if (budget == 0u) {
            // Not walked to the end: the bake marches this column on the CPU.
            column_done[j] = 0u;
            return;
        }
        budget -= 1u;
        let tn = min(min(min(w.next.x, w.next.y), w.next.z), t_end);
        let cell = w.cell;
        let ta = t;
        let was = entered;
        var stepped = vec3<bool>(false);
        if (tn < t_end) {
            for (var a = 0; a < 3; a++) {
                if (w.next[a] <= tn) {
                    w.cell[a] += w.step[a];
                    w.next[a] = face_t(r, w, a);
                    stepped[a] = true;
                }
            }
        }
        t = max(tn, ta);
        if (!(tn > ta)) {
            // A zero-length cell (the ray through an edge): the next inherits both crossings.
            entered = was | stepped;
            continue;
        }
        entered = stepped;
        let tb = tn;
        let v = cell_corners(cell);
        let cf = vec3<f32>(cell);
        if (any(was)) {
            let pe = ray_at(r, ta);
            let sa = job.a0.xyz + job.a1.xyz * ta;
            let sb = job.b0.xyz + job.b1.xyz * ta;
            let g_new = jet(v, pe - cf).gradient;
            var g_old = vec3<f32>(0.0);
            if (has_prev) {
                g_old = jet(prev, pe - vec3<f32>(prev_cell)).gradient;
            }
            var jump = 0.0;
            for (var a = 0; a < 3; a++) {
                if (was[a] && d[a] != 0.0) {
                    jump += (g_new[a] - g_old[a]) * sa[a] * sb[a] / abs(d[a]);
                }
            }
            add(&acc, &lost, vec4<f32>(0.0, 0.0, 0.0, jump));
        }
        // The cell's stretch, cut at the depths in it.
        var u = ta;
        loop {
            var at_depth = k < n;
            if (at_depth) {
                at_depth = depths[first + k] <= tb;
            }
            var e = tb;
            if (at_depth) {
                e = depths[first + k];
            }
            if (e > u) {
                let tm = 0.5 * (u + e);
                let off = GL2_HALF_OFFSET * (e - u);
                let half = 0.5 * (e - u);
                var piece = vec4<f32>(0.0);
                for (var q = 0; q < 2; q++) {
                    var tq = tm - off;
                    if (q == 1) {
                        tq = tm + off;
                    }
                    let f = jet(v, ray_at(r, tq) - cf);
                    let sa = job.a0.xyz + job.a1.xyz * tq;
                    let sb = job.b0.xyz + job.b1.xyz * tq;
                    let sc = job.c0.xyz + job.c1.xyz * tq;
                    let mixed = f.mixed.x * (sa.x * sb.y + sa.y * sb.x)
                        + f.mixed.y * (sa.x * sb.z + sa.z * sb.x)
                        + f.mixed.z * (sa.y * sb.z + sa.z * sb.y);
                    piece += half * vec4<f32>(
                        f.value,
                        dot(f.gradient, sa),
                        dot(f.gradient, sb),
                        mixed + dot(f.gradient, sc),
                    );
                }
                add(&acc, &lost, piece);
            }
            u = e;
            if (!at_depth) {
                break;
            }
            put_sample(r, out + k, acc, depths[first + k]);
            k++;
        }
        prev = v;
        prev_cell = cell;
        has_prev = true;
    }
    while (k < n) {
        put_sample(r, out + k, acc, depths[first + k]);
        k++;
    }
    column_done[j] = 1u;
}
