// What every shader over the density grid shares (WGSL has no include: this source is
// put before each shader's own when it is compiled, see context.rs): the uniform
// parameters, the grid's nodes (`tree`, `vals`: see upload.rs), the tree lookups of a
// voxel and of the coarsest cell holding it, rays in index space, and the voxel-cell
// walk with each cell's eight corners and their trilinear blend.

struct Params {
    offset: vec4<i32>,       // global index = local index + offset
    root_min: vec4<i32>,
    root_dims: vec4<i32>,
    bounds_lo: vec4<f32>,    // active bounds, local index space
    bounds_hi: vec4<f32>,
    sigma_t: vec4<f32>,
    sigma_s: vec4<f32>,
    step_voxels: f32,
    termination: f32,
    thin_depth: f32,
    n_lights: u32,
    n_samples: u32,
    stride: u32,
    phase_n: u32,
    phase_base: u32,
    upper_base: u32,         // in `tree`
    lower_base: u32,
    tile_base: u32,          // in `vals`
    root_cells: u32,         // in `vals`, two floats a cell
    upper_cells: u32,
    lower_cells: u32,
    background: f32,
    scatters: u32,
    dsm_chunk: u32,          // words of each of dsm0, dsm1, dsm2
    lattice_base: u32,       // in `meta_`: the fast mode's lattice (lattice.wgsl)
    multiple: u32,           // 1: the lattice's multiple scattering is gathered
    g_mean: f32,             // the phase function's mean cosine
    lattice_lo: vec4<f32>,   // the lattice's first node (world), w: 1 / cell side
    lattice_dims: vec4<u32>, // nodes per axis, w: nodes per light
    // The emission, temperature and colour grids (emission.wgsl); a grid is named by
    // k ≥ 1, its header `grids[k − 1]`, 0 naming none.
    emit_rgb: vec4<f32>,     // emission colour × intensity
    blackbody: vec4<f32>,    // Kelvin = value × x + y; z: blackbody intensity
    bb_table: vec4<f32>,     // the colour table: 1/t_max, 1/Δ(1/T), t_min, t_max
    emit_grids: vec4<u32>,   // emission grid, 1: its segment means exact (on the density's
                             // lattice), temperature grid, the table's start in `meta_`
    flags: vec4<u32>,        // 1: something emits, the colour table's entries, the phase
                             // table's log-spaced bins
    color_grids: vec4<u32>,  // the grid of r, g, b (0: no colour tint)
    color_chans: vec4<u32>,  // the channel of each
    traverse: vec4<u32>,     // grids whose cells are visited beside the density's
    phase_grid: vec4<f32>,   // the phase table's nodes: θ₀ and δ of θᵢ = θ₀(e^{iδ} − 1),
                             // then from θ = z on steps of w (march.wgsl, phase_at)
    grids: array<Grid, 5>,
    shadow: vec4<f32>,       // marched shadow rays: the midpoint step in voxels (0:
                             // exact), ∫ρ ds past which a ray stops, 0, 0
};

// A grid beside the density, its nodes in `tree` and `vals` after the density's.
struct Grid {
    offset: vec4<i32>,       // global index = local index + offset; w: values a voxel
    root_min: vec4<i32>,     // w: its root table's start in `tree`
    root_dims: vec4<i32>,    // w: its leaf values' start in `vals`
    bases: vec4<u32>,        // upper_base, lower_base (in `tree`), tile_base, root_cells
    cells: vec4<u32>,        // upper_cells, lower_cells, the background's bits, 0
    to_x: vec4<f32>,         // the density's local index → this grid's local index,
    to_y: vec4<f32>,         // an affine map's rows (on the density's lattice: the
    to_z: vec4<f32>,         // identity and an integer shift)
};

@group(0) @binding(0) var<uniform> P: Params;
// The grid's nodes, `tree` (u32) and `vals` (f32), are read only through `tree_at(i)`
// and `val_at(i)`: their bindings and those two functions are generated (grid_parts.rs),
// the arrays bound whole or each cut into parts.

const CHILD: u32 = 0x80000000u;
const BIG: f32 = 3.0e38;
const GL2_HALF_OFFSET: f32 = 0.2886751345948129;

// ---- the grid's tree ----

fn root_entry(key: vec3<i32>) -> u32 {
    let r = key - P.root_min.xyz;
    let d = P.root_dims.xyz;
    if (any(r < vec3<i32>(0)) || any(r >= d)) {
        return 0xffffffffu;
    }
    return u32((r.x * d.y + r.y) * d.z + r.z);
}

fn upper_off(g: vec3<i32>) -> u32 {
    return u32((((g.x >> 7u) & 31) << 10u) | (((g.y >> 7u) & 31) << 5u) | ((g.z >> 7u) & 31));
}
fn lower_off(g: vec3<i32>) -> u32 {
    return u32((((g.x >> 3u) & 15) << 8u) | (((g.y >> 3u) & 15) << 4u) | ((g.z >> 3u) & 15));
}
fn leaf_off(g: vec3<i32>) -> u32 {
    return u32(((g.x & 7) << 6u) | ((g.y & 7) << 3u) | (g.z & 7));
}

// The slot of global voxel g: a tile index, or CHILD | leaf index.
fn lookup(g: vec3<i32>) -> u32 {
    let ri = root_entry(g >> vec3<u32>(12u));
    if (ri == 0xffffffffu) {
        return 0u;
    }
    var e = tree_at(ri);
    if ((e & CHILD) == 0u) {
        return e;
    }
    e = tree_at(P.upper_base + (e & ~CHILD) * 32768u + upper_off(g));
    if ((e & CHILD) == 0u) {
        return e;
    }
    return tree_at(P.lower_base + (e & ~CHILD) * 4096u + lower_off(g));
}

fn voxel(g: vec3<i32>) -> f32 {
    let s = lookup(g);
    if ((s & CHILD) == 0u) {
        return val_at(P.tile_base + s);
    }
    return val_at((s & ~CHILD) * 512u + leaf_off(g));
}

struct Cell {
    origin: vec3<i32>,  // local
    size: i32,
    lo: f32,
    hi: f32,
};

fn cell_range(at: u32) -> vec2<f32> {
    return vec2<f32>(val_at(at), val_at(at + 1u));
}

fn align(g: vec3<i32>, s: i32) -> vec3<i32> {
    return g & vec3<i32>(~(s - 1));
}

// The coarsest cell holding local voxel ijk, with its value range (Field::cell_at).
fn cell_at(ijk: vec3<i32>) -> Cell {
    let g = ijk + P.offset.xyz;
    let o = P.offset.xyz;
    let ri = root_entry(g >> vec3<u32>(12u));
    if (ri == 0xffffffffu) {
        return Cell(align(g, 4096) - o, 4096, P.background, P.background);
    }
    let e = tree_at(ri);
    if ((e & CHILD) == 0u) {
        let r = cell_range(P.root_cells + 2u * ri);
        return Cell(align(g, 4096) - o, 4096, r.x, r.y);
    }
    let ui = (e & ~CHILD) * 32768u + upper_off(g);
    let e2 = tree_at(P.upper_base + ui);
    if ((e2 & CHILD) == 0u) {
        let r = cell_range(P.upper_cells + 2u * ui);
        return Cell(align(g, 128) - o, 128, r.x, r.y);
    }
    let li = (e2 & ~CHILD) * 4096u + lower_off(g);
    let r = cell_range(P.lower_cells + 2u * li);
    return Cell(align(g, 8) - o, 8, r.x, r.y);
}

// ---- rays in index space ----

struct Ray {
    o: vec3<f32>,
    d: vec3<f32>,
};

fn ray_at(r: Ray, t: f32) -> vec3<f32> {
    return r.o + r.d * t;
}

struct Walk {
    cell: vec3<i32>,
    next: vec3<f32>,
    step: vec3<i32>,
    inv: vec3<f32>,
    loaded: vec3<i32>,
    corners0: vec4<f32>,  // corners 0..3 (x = 0)
    corners1: vec4<f32>,  // corners 4..7 (x = 1)
    has: bool,
    leaf: vec3<i32>,      // the density's leaf (global voxel >> 3) last looked up,
    slot: u32,            // its slot (lookup), valid when leaf_ok (walk_corners)
    leaf_ok: bool,
};

fn face_t(r: Ray, w: Walk, a: i32) -> f32 {
    let d = r.d[a];
    if (d > 0.0) {
        return (f32(w.cell[a]) + 1.0 - r.o[a]) * w.inv[a];
    }
    if (d < 0.0) {
        return (f32(w.cell[a]) - r.o[a]) * w.inv[a];
    }
    return BIG;
}

fn walk_start(r: Ray, t0: f32) -> Walk {
    var w: Walk;
    let p = ray_at(r, t0);
    for (var a = 0; a < 3; a++) {
        if (r.d[a] < 0.0) {
            w.cell[a] = -i32(floor(-p[a])) - 1;
        } else {
            w.cell[a] = i32(floor(p[a]));
        }
    }
    w.step = vec3<i32>(sign(r.d));
    w.inv = 1.0 / r.d;
    w.has = false;
    w.leaf_ok = false;
    for (var a = 0; a < 3; a++) {
        w.next[a] = face_t(r, w, a);
    }
    return w;
}

// The eight corners of local cell c, corner k at (k>>2 & 1, k>>1 & 1, k & 1).
fn cell_corners(c: vec3<i32>) -> array<f32, 8> {
    let g = c + P.offset.xyz;
    var v: array<f32, 8>;
    if ((g.x & 7) != 7 && (g.y & 7) != 7 && (g.z & 7) != 7) {
        let s = lookup(g);
        if ((s & CHILD) == 0u) {
            let x = val_at(P.tile_base + s);
            for (var k = 0; k < 8; k++) {
                v[k] = x;
            }
        } else {
            let base = (s & ~CHILD) * 512u + leaf_off(g);
            v[0] = val_at(base);
            v[1] = val_at(base + 1u);
            v[2] = val_at(base + 8u);
            v[3] = val_at(base + 9u);
            v[4] = val_at(base + 64u);
            v[5] = val_at(base + 65u);
            v[6] = val_at(base + 72u);
            v[7] = val_at(base + 73u);
        }
    } else {
        for (var k = 0; k < 8; k++) {
            v[k] = voxel(g + vec3<i32>((k >> 2u) & 1, (k >> 1u) & 1, k & 1));
        }
    }
    return v;
}

// cell_corners() of the density at the walk's cell, each leaf's slot looked up once
// rather than once per cell or corner: the walk keeps the slot of the leaf its cell was
// last in (a ray crosses several voxel cells of a leaf, each a descent of the tree
// otherwise), and a cell on a leaf's last voxel looks up each leaf its corners lie in
// once. The same values as cell_corners().
fn walk_corners(w: ptr<function, Walk>) -> array<f32, 8> {
    let g = (*w).cell + P.offset.xyz;
    let key = g >> vec3<u32>(3u);
    if (!(*w).leaf_ok || any(key != (*w).leaf)) {
        (*w).slot = lookup(g);
        (*w).leaf = key;
        (*w).leaf_ok = true;
    }
    // Corner k lies in leaf j = k & across: across the axes where the cell is on its
    // leaf's last voxel.
    let edge = (g & vec3<i32>(7)) == vec3<i32>(7);
    let across = select(0, 4, edge.x) | select(0, 2, edge.y) | select(0, 1, edge.z);
    var slots: array<u32, 8>;
    slots[0] = (*w).slot;
    for (var j = 1; j < 8; j++) {
        if ((j & across) == j) {
            slots[j] = lookup(g + vec3<i32>((j >> 2u) & 1, (j >> 1u) & 1, j & 1));
        }
    }
    var v: array<f32, 8>;
    for (var k = 0; k < 8; k++) {
        let s = slots[k & across];
        if ((s & CHILD) == 0u) {
            v[k] = val_at(P.tile_base + s);
        } else {
            let c = g + vec3<i32>((k >> 2u) & 1, (k >> 1u) & 1, k & 1);
            v[k] = val_at((s & ~CHILD) * 512u + leaf_off(c));
        }
    }
    return v;
}

fn trilinear(c0: vec4<f32>, c1: vec4<f32>, t: vec3<f32>) -> f32 {
    let a = mix(vec2<f32>(c0.x, c0.z), vec2<f32>(c0.y, c0.w), t.z); // (x0,y0) (x0,y1)
    let b = mix(vec2<f32>(c1.x, c1.z), vec2<f32>(c1.y, c1.w), t.z);
    return mix(mix(a.x, a.y, t.y), mix(b.x, b.y, t.y), t.x);
}


// ---- the grids beside the density (emission, temperature, colour) ----

fn grid_of(k: u32) -> Grid {
    return P.grids[k - 1u];
}

// The local index point of grid h at the density's local index point p.
fn to_grid(h: Grid, p: vec3<f32>) -> vec3<f32> {
    let q = vec4<f32>(p, 1.0);
    return vec3<f32>(dot(h.to_x, q), dot(h.to_y, q), dot(h.to_z, q));
}

// The integer shift of a grid on the density's lattice.
fn grid_shift(h: Grid) -> vec3<i32> {
    return vec3<i32>(round(vec3<f32>(h.to_x.w, h.to_y.w, h.to_z.w)));
}

fn root_entry_in(h: Grid, key: vec3<i32>) -> u32 {
    let r = key - h.root_min.xyz;
    let d = h.root_dims.xyz;
    if (any(r < vec3<i32>(0)) || any(r >= d)) {
        return 0xffffffffu;
    }
    return u32((r.x * d.y + r.y) * d.z + r.z);
}

// lookup() in grid h.
fn lookup_in(h: Grid, g: vec3<i32>) -> u32 {
    let ri = root_entry_in(h, g >> vec3<u32>(12u));
    if (ri == 0xffffffffu) {
        return 0u;
    }
    var e = tree_at(u32(h.root_min.w) + ri);
    if ((e & CHILD) == 0u) {
        return e;
    }
    e = tree_at(h.bases.x + (e & ~CHILD) * 32768u + upper_off(g));
    if ((e & CHILD) == 0u) {
        return e;
    }
    return tree_at(h.bases.y + (e & ~CHILD) * 4096u + lower_off(g));
}

// Channel c of global voxel g of grid h.
fn voxel_in(h: Grid, g: vec3<i32>, c: u32) -> f32 {
    let s = lookup_in(h, g);
    let n = u32(h.offset.w);
    if ((s & CHILD) == 0u) {
        return val_at(h.bases.z + s * n + c);
    }
    return val_at(u32(h.root_dims.w) + ((s & ~CHILD) * 512u + leaf_off(g)) * n + c);
}

// cell_corners() of channel ch of grid h, at its local cell c.
fn cell_corners_in(h: Grid, c: vec3<i32>, ch: u32) -> array<f32, 8> {
    let g = c + h.offset.xyz;
    var v: array<f32, 8>;
    let n = u32(h.offset.w);
    if ((g.x & 7) != 7 && (g.y & 7) != 7 && (g.z & 7) != 7) {
        let s = lookup_in(h, g);
        if ((s & CHILD) == 0u) {
            let x = val_at(h.bases.z + s * n + ch);
            for (var k = 0; k < 8; k++) {
                v[k] = x;
            }
        } else {
            let base = u32(h.root_dims.w) + ((s & ~CHILD) * 512u + leaf_off(g)) * n + ch;
            v[0] = val_at(base);
            v[1] = val_at(base + n);
            v[2] = val_at(base + 8u * n);
            v[3] = val_at(base + 9u * n);
            v[4] = val_at(base + 64u * n);
            v[5] = val_at(base + 65u * n);
            v[6] = val_at(base + 72u * n);
            v[7] = val_at(base + 73u * n);
        }
    } else {
        for (var k = 0; k < 8; k++) {
            v[k] = voxel_in(h, g + vec3<i32>((k >> 2u) & 1, (k >> 1u) & 1, k & 1), ch);
        }
    }
    return v;
}

// Channel ch of grid h, trilinear at its local index point q.
fn sample_in(h: Grid, q: vec3<f32>, ch: u32) -> f32 {
    let c = floor(q);
    if (!all(abs(c) < vec3<f32>(1073741824.0))) {
        return val_at(h.bases.z + ch);
    }
    let v = cell_corners_in(h, vec3<i32>(c), ch);
    return trilinear(vec4<f32>(v[0], v[1], v[2], v[3]), vec4<f32>(v[4], v[5], v[6], v[7]), q - c);
}

// cell_at() in grid h (local voxel ijk of h).
fn cell_at_in(h: Grid, ijk: vec3<i32>) -> Cell {
    let g = ijk + h.offset.xyz;
    let o = h.offset.xyz;
    let background = bitcast<f32>(h.cells.z);
    let ri = root_entry_in(h, g >> vec3<u32>(12u));
    if (ri == 0xffffffffu) {
        return Cell(align(g, 4096) - o, 4096, background, background);
    }
    let e = tree_at(u32(h.root_min.w) + ri);
    if ((e & CHILD) == 0u) {
        let r = cell_range(h.bases.w + 2u * ri);
        return Cell(align(g, 4096) - o, 4096, r.x, r.y);
    }
    let ui = (e & ~CHILD) * 32768u + upper_off(g);
    let e2 = tree_at(h.bases.x + ui);
    if ((e2 & CHILD) == 0u) {
        let r = cell_range(h.cells.x + 2u * ui);
        return Cell(align(g, 128) - o, 128, r.x, r.y);
    }
    let li = (e2 & ~CHILD) * 4096u + lower_off(g);
    let r = cell_range(h.cells.y + 2u * li);
    return Cell(align(g, 8) - o, 8, r.x, r.y);
}
