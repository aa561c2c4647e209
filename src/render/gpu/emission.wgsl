// Emission, blackbody temperature and the colour tint in the march, as
// src/integrate/march.rs and src/integrate/medium.rs take them: the grids beside the
// density (grid.wgsl's `Grid`s), the cells a camera ray visits (the density's and those
// of the emission and temperature grids on its lattice, FieldUnion of
// src/field/union.rs), each segment's emission coefficient and the scattering colour.
// Compiled with march.wgsl (after grid.wgsl).

// The coarsest cell holding the density's local voxel ijk over the density and the
// grids visited beside it: the smallest of their cells, with the union of their ranges.
fn visited_cell(ijk: vec3<i32>) -> Cell {
    var c = cell_at(ijk);
    for (var i = 0u; i < 3u; i++) {
        let k = P.traverse[i];
        if (k == 0u) {
            break;
        }
        let h = grid_of(k);
        let o = grid_shift(h);
        var d = cell_at_in(h, ijk + o);
        d.origin -= o;
        let lo = min(c.lo, d.lo);
        let hi = max(c.hi, d.hi);
        if (d.size < c.size) {
            c = d;
        }
        c.lo = lo;
        c.hi = hi;
    }
    return c;
}

// The normalised blackbody colour at k Kelvin: BlackbodyTable::rgb_normalized_clamped,
// the CPU's own samples (uniform in 1/T) interpolated as it does.
fn blackbody_rgb(k: f32) -> vec3<f32> {
    let n = P.flags.y;
    let t = clamp(k, P.bb_table.z, P.bb_table.w);
    let x = (1.0 / t - P.bb_table.x) * P.bb_table.y;
    let i = min(u32(max(x, 0.0)), n - 2u);
    let f = clamp(x - f32(i), 0.0, 1.0);
    let at = P.emit_grids.w + 4u * i;
    let c0 = vec3<f32>(meta_[at], meta_[at + 1u], meta_[at + 2u]);
    let c1 = vec3<f32>(meta_[at + 4u], meta_[at + 5u], meta_[at + 6u]);
    return c0 + (c1 - c0) * f;
}

// The emission coefficient (rgb per world unit) of the segment [a, b] of ray r (the
// density's local index space), p its midpoint, as Emission::mean: the emission grid's
// exact mean over the segment where it is on the density's lattice (walked by `w`),
// else its value at the midpoint; the temperature grid's value at the midpoint.
fn emitted(r: Ray, w: ptr<function, Walk>, a: f32, b: f32, p: vec3<f32>, budget: ptr<function, u32>) -> vec3<f32> {
    var e = vec3<f32>(0.0);
    let ke = P.emit_grids.x;
    if (ke != 0u) {
        var v: f32;
        if (P.emit_grids.y != 0u && b > a) {
            let o = vec3<f32>(grid_shift(grid_of(ke)));
            v = integral_in(ke, Ray(r.o + o, r.d), w, a, b, budget) / (b - a);
        } else {
            let h = grid_of(ke);
            v = sample_in(h, to_grid(h, p), 0u);
        }
        if (v > 0.0) {
            e += P.emit_rgb.xyz * v;
        }
    }
    let kt = P.emit_grids.z;
    if (kt != 0u) {
        let h = grid_of(kt);
        let k = sample_in(h, to_grid(h, p), 0u) * P.blackbody.x + P.blackbody.y;
        if (k > 0.0 && k < BIG) {
            let kk = k / 1000.0;
            e += blackbody_rgb(k) * (kk * kk * kk * kk * P.blackbody.z);
        }
    }
    return e;
}

// The colour grid's tint of σs at the density's local index point p (each channel
// clamped to [0, 1]); 1 without a colour grid.
fn tint(p: vec3<f32>) -> vec3<f32> {
    if (P.color_grids.x == 0u) {
        return vec3<f32>(1.0);
    }
    var c: vec3<f32>;
    for (var i = 0u; i < 3u; i++) {
        let h = grid_of(P.color_grids[i]);
        c[i] = sample_in(h, to_grid(h, p), P.color_chans[i]);
    }
    return clamp(c, vec3<f32>(0.0), vec3<f32>(1.0));
}
