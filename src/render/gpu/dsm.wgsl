// The deep shadow map lookup of src/shadow/map.rs: ∫ρ ds toward a light at a world
// point, from the chart's bricks (Hermite, linear or constant), as ChartMap does it.
// A chart is 32 words in `dsm` (see src/render/gpu/upload.rs), its arrays after it.

// Word `at` of the maps: in dsm0 when they fit one buffer (P.dsm_chunk is then all of
// them), else in three buffers of P.dsm_chunk words each. Compared, not divided: a
// division by a uniform costs tens of instructions on every read.
fn dw(at: u32) -> u32 {
    if (at < P.dsm_chunk) {
        return dsm0[at];
    }
    if (at < 2u * P.dsm_chunk) {
        return dsm1[at - P.dsm_chunk];
    }
    return dsm2[at - 2u * P.dsm_chunk];
}

fn df(at: u32) -> f32 {
    return bitcast<f32>(dw(at));
}
fn dv(at: u32) -> vec3<f32> {
    return vec3<f32>(df(at), df(at + 1u), df(at + 2u));
}
fn di(at: u32) -> vec3<i32> {
    return vec3<i32>(bitcast<i32>(dw(at)), bitcast<i32>(dw(at + 1u)), bitcast<i32>(dw(at + 2u)));
}

const NO_BRICK: u32 = 0xffffffffu;

// Lattice coordinates of world point p, or w < 0 when the chart does not hold it.
fn to_lattice(c: u32, p: vec3<f32>) -> vec4<f32> {
    let point = dv(c + 4u);
    let unit = df(c + 11u);
    let e1 = dv(c + 8u);
    let e2 = dv(c + 12u);
    let e3 = dv(c + 16u);
    if (dw(c) == 0u) {
        let d = (p - point) / unit;
        return vec4<f32>(dot(d, e1), dot(d, e2), dot(d, e3), 1.0);
    }
    let d = p - point;
    let w = dot(d, e3);
    let r = length(d);
    if (!(w > 1e-9 * r)) {
        return vec4<f32>(0.0, 0.0, 0.0, -1.0);
    }
    let scale = df(c + 7u);
    return vec4<f32>(scale * dot(d, e1) / w, scale * dot(d, e2) / w, r / unit, 1.0);
}

// The brick with key b, or NO_BRICK.
fn brick_with_key(c: u32, b: vec3<i32>) -> u32 {
    let r = b - di(c + 20u);
    let dims = di(c + 24u);
    if (any(r < vec3<i32>(0)) || any(r >= dims)) {
        return NO_BRICK;
    }
    return dw(dw(c + 28u) + u32(r.x + dims.x * (r.y + dims.y * r.z)));
}

fn brick_at(c: u32, q: vec3<f32>) -> u32 {
    let s = q / 8.0;
    let bf = floor(s);
    let b = vec3<i32>(bf);
    let found = brick_with_key(c, b);
    if (found != NO_BRICK) {
        return found;
    }
    let on_face = s == bf;
    if (!any(on_face)) {
        return NO_BRICK;
    }
    for (var m = 1u; m < 8u; m++) {
        let dx = (m & 1u) != 0u;
        let dy = (m & 2u) != 0u;
        let dz = (m & 4u) != 0u;
        if ((dx && !on_face.x) || (dy && !on_face.y) || (dz && !on_face.z)) {
            continue;
        }
        let k = b - vec3<i32>(select(0, 1, dx), select(0, 1, dy), select(0, 1, dz));
        let f = brick_with_key(c, k);
        if (f != NO_BRICK) {
            return f;
        }
    }
    return NO_BRICK;
}

fn hermite(t: f32) -> vec4<f32> {
    let t2 = t * t;
    let t3 = t2 * t;
    return vec4<f32>(2.0 * t3 - 3.0 * t2 + 1.0, t3 - 2.0 * t2 + t, -2.0 * t3 + 3.0 * t2, t3 - t2);
}

// Quantity q of Hermite sample k of the brick whose samples start at `base`.
fn hq(base: u32, scales: vec4<f32>, q: u32, k: u32) -> f32 {
    let at = base + 3u * k;
    if (q == 0u) {
        return bitcast<f32>(dw(at));
    }
    let w = dw(at + 1u + (q - 1u) / 2u);
    var v: i32;
    if (((q - 1u) & 1u) == 0u) {
        v = bitcast<i32>(w << 16u) >> 16u;
    } else {
        v = bitcast<i32>(w) >> 16u;
    }
    return f32(v) * scales[q - 1u];
}

fn blend(c: u32, brick: u32, q: vec3<f32>) -> f32 {
    let at = dw(c + 29u) + 9u * brick;
    let key = di(at);
    let lf = dw(at + 3u);
    let level = lf & 255u;
    let form = lf >> 8u;
    let offset = dw(at + 4u);
    let scales = vec4<f32>(df(at + 5u), df(at + 6u), df(at + 7u), df(at + 8u));
    if (form == 2u) {
        return scales.x;
    }
    let n = f32(1u << level);
    let h = 8.0 / n;
    let local = clamp((q - vec3<f32>(key) * 8.0) * (n / 8.0), vec3<f32>(0.0), vec3<f32>(n));
    let i = min(floor(local), vec3<f32>(n - 1.0));
    let f = local - i;
    let iu = vec3<u32>(i);
    let m = (1u << level) + 1u;
    let base = iu.x + m * (iu.y + m * iu.z);
    let dz = m * m;
    if (form == 1u) {
        let lb = dw(c + 31u) + offset;
        var plane: array<f32, 2>;
        for (var z = 0u; z < 2u; z++) {
            var row: array<f32, 2>;
            for (var y = 0u; y < 2u; y++) {
                let d = base + z * dz + y * m;
                let v0 = f32(dw(lb + d));
                let v1 = f32(dw(lb + d + 1u));
                row[y] = v0 + (v1 - v0) * f.x;
            }
            plane[z] = row[0] + (row[1] - row[0]) * f.y;
        }
        return scales.x + scales.y * (plane[0] + (plane[1] - plane[0]) * f.z);
    }
    let hb = dw(c + 30u) + 3u * offset;
    let unit = df(c + 11u);
    let zw = hermite(f.z);
    let step = h * unit;
    var wx = hermite(f.x);
    if (dw(c + 1u) != 0u) {
        wx = vec4<f32>(1.0 - f.x, 0.0, f.x, 0.0);
    }
    var wy = hermite(f.y);
    if (dw(c + 2u) != 0u) {
        wy = vec4<f32>(1.0 - f.y, 0.0, f.y, 0.0);
    }
    var sum = 0.0;
    for (var corner = 0u; corner < 4u; corner++) {
        let cx = corner & 1u;
        let cy = corner >> 1u;
        let a = base + cx + cy * m;
        let b = a + dz;
        let col0 = zw.x * hq(hb, scales, 0u, a) + zw.z * hq(hb, scales, 0u, b)
            + step * (zw.y * hq(hb, scales, 1u, a) + zw.w * hq(hb, scales, 1u, b));
        let col1 = h * (hq(hb, scales, 2u, a) + (hq(hb, scales, 2u, b) - hq(hb, scales, 2u, a)) * f.z);
        let col2 = h * (hq(hb, scales, 3u, a) + (hq(hb, scales, 3u, b) - hq(hb, scales, 3u, a)) * f.z);
        let col3 = h * h * (hq(hb, scales, 4u, a) + (hq(hb, scales, 4u, b) - hq(hb, scales, 4u, a)) * f.z);
        let x0 = select(wx.x, wx.z, cx == 1u);
        let xs = select(wx.y, wx.w, cx == 1u);
        let y0 = select(wy.x, wy.z, cy == 1u);
        let ys = select(wy.y, wy.w, cy == 1u);
        sum += col0 * x0 * y0 + col1 * xs * y0 + col2 * x0 * ys + col3 * xs * ys;
    }
    return sum;
}

fn density_integral_at(c: u32, q: vec3<f32>) -> f32 {
    let brick = brick_at(c, q);
    if (brick != NO_BRICK) {
        return blend(c, brick, q);
    }
    let b = floor(q / 8.0);
    let lo = vec3<f32>(di(c + 20u));
    let hi = lo + vec3<f32>(di(c + 24u));
    if (!(b.x >= lo.x && b.x < hi.x && b.y >= lo.y && b.y < hi.y && b.z >= lo.z)) {
        return 0.0;
    }
    let top = i32(min(b.z, hi.z)) - 1;
    for (var bz = top; bz >= i32(lo.z); bz--) {
        let k = vec3<i32>(i32(b.x), i32(b.y), bz);
        let found = brick_with_key(c, k);
        if (found != NO_BRICK) {
            return blend(c, found, vec3<f32>(q.x, q.y, f32(bz + 1) * 8.0));
        }
    }
    return 0.0;
}

fn cube_face(d: vec3<f32>) -> u32 {
    let a = abs(d);
    var axis = 2u;
    if (a.x >= a.y && a.x >= a.z) {
        axis = 0u;
    } else if (a.y >= a.z) {
        axis = 1u;
    }
    return 2u * axis + select(0u, 1u, d[axis] < 0.0);
}

// ∫ρ ds from world point p toward light l (0 without a map).
fn density_to_light(l: u32, p: vec3<f32>) -> f32 {
    let shadow = light_f(l, 1u);
    if (shadow == 0.0) {
        return 0.0;
    }
    var c = u32(light_f(l, 2u));
    if (shadow == 2.0) {
        let light = vec3<f32>(light_f(l, 4u), light_f(l, 5u), light_f(l, 6u));
        c += 32u * cube_face(p - light);
    }
    let q = to_lattice(c, p);
    if (q.w < 0.0) {
        return 0.0;
    }
    return density_integral_at(c, q.xyz);
}
