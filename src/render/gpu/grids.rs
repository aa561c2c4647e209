//! The grids the march samples beside the density — the emission (flame) and
//! temperature grids and the colour grid's channels — packed after the density's nodes
//! in `tree` and `vals` (no further bindings: the march has WebGPU's least number), each
//! with a header in the parameters (`Grid` in grid.wgsl: where its parts begin and the
//! map from the density's index space to its own), with the emission's settings and
//! the blackbody colours the CPU interpolates (`meta`). emission.wgsl reads them.

use crate::field::grid_nodes::{FlatGridError, GridNodes};
use crate::field::{ColorField, ColorParts, Field, IndexToWorld, VoxelGrid, lattice_offset};
use crate::integrate::{Emission, Volume};
use glam::{DMat3, DVec3};

/// The most grids beside the density (`grids` in grid.wgsl's `Params`): emission,
/// temperature, and a colour of three.
pub const MAX_GRIDS: usize = 5;
/// Words of a grid's header.
const HEADER_WORDS: usize = 32;
/// Words of the parameters from `emit_rgb` on (grid.wgsl).
pub const WORDS: usize = GRIDS_AT + MAX_GRIDS * HEADER_WORDS;
/// Where the headers begin in those words.
const GRIDS_AT: usize = 36;
/// Where, in those words, the phase table's number of log-spaced bins sits (`flags.z`).
pub const PHASE_N_LOG: usize = 18;
/// Where, in those words, 1 says something emits (`flags.x`).
pub const EMITS_AT: usize = 16;
/// Where, in those words, the red tint's grid sits (`color_grids.x`; 0: no tint).
pub const TINT_AT: usize = 20;
/// Where the phase table's placing sits (`phase_grid`).
pub const PHASE_GRID: usize = 32;

/// What the march samples beside the density: the volume's emission and colour.
pub struct Beside<'a> {
    pub emission: Option<&'a Emission<'a>>,
    pub color: Option<&'a dyn ColorField>,
}

impl<'a> Beside<'a> {
    /// The volume's emission (where active) and colour tint.
    pub fn of(vol: &'a Volume<'a>) -> Self {
        Beside {
            emission: vol.emission.as_ref().filter(|e| e.is_active()),
            color: vol.color.as_ref().map(|c| c.grid()),
        }
    }
}

/// A grid the GPU can walk, or why not (`what`: its role).
fn walkable<'f>(f: &'f dyn Field, what: &str) -> Result<&'f VoxelGrid, String> {
    let g = f
        .as_voxel_grid()
        .ok_or_else(|| format!("{what} that is not a voxel grid"))?;
    g.nodes_check().map_err(|e| match e {
        FlatGridError::Channels => format!("{what} of more than one channel"),
        FlatGridError::SparseRoot => format!("{what} whose nodes lie far apart"),
    })?;
    Ok(g)
}

/// The colour's grids with the channel of each, or why the GPU cannot read them.
fn color_grids(c: &dyn ColorField) -> Result<[(&VoxelGrid, u32); 3], String> {
    match c.parts() {
        Some(ColorParts::Vector(g)) => {
            let n = g.channels() as u32;
            let ch = |c: u32| if n >= 3 { c } else { 0 };
            match g.nodes_check() {
                Ok(()) | Err(FlatGridError::Channels) => Ok([(g, ch(0)), (g, ch(1)), (g, ch(2))]),
                Err(FlatGridError::SparseRoot) => {
                    Err("a colour grid whose nodes lie far apart".into())
                }
            }
        }
        Some(ColorParts::Channels(fs)) => {
            let mut out = Vec::with_capacity(3);
            for f in fs {
                out.push((walkable(f, "a colour channel")?, 0));
            }
            Ok([out[0], out[1], out[2]])
        }
        None => Err("a colour field that is not a voxel grid".into()),
    }
}

/// Why the GPU cannot sample what `b` holds, if it cannot.
pub fn unsupported(b: &Beside) -> Option<String> {
    if let Some(e) = b.emission {
        if !e.more.is_empty() {
            return Some("several glowing volumes".into());
        }
        if let Some(c) = &e.grid
            && let Err(why) = walkable(c.field, "an emission grid")
        {
            return Some(why);
        }
        if let Some(c) = &e.temperature
            && let Err(why) = walkable(c.field, "a temperature grid")
        {
            return Some(why);
        }
    }
    if let Some(c) = b.color
        && let Err(why) = color_grids(c)
    {
        return Some(why);
    }
    None
}

/// The affine map from `d`'s local index space to `g`'s, as three rows: on one lattice
/// the identity and the integer shift the CPU adds ([`lattice_offset`]).
fn index_map(g: &IndexToWorld, d: &IndexToWorld) -> [[f64; 4]; 3] {
    let (m, t) = match lattice_offset(g, d) {
        Some(o) => (DMat3::IDENTITY, o),
        None => (
            g.inverse_linear() * d.linear(),
            g.world_to_index(d.index_to_world(DVec3::ZERO)),
        ),
    };
    let row = |r: usize| [m.col(0)[r], m.col(1)[r], m.col(2)[r], t[r]];
    [row(0), row(1), row(2)]
}

/// Packs the grids beside the density into `tree`, `vals` and `meta`, returning the
/// parameters from `emit_rgb` on (all 0 when there are none).
pub fn pack(
    density: &dyn Field,
    b: &Beside,
    tree: &mut Vec<u32>,
    vals: &mut Vec<f32>,
    meta: &mut Vec<f32>,
) -> Result<Vec<u32>, String> {
    let f = |v: f64| (v as f32).to_bits();
    let mut words = vec![0u32; WORDS];
    let mut grids: Vec<(*const VoxelGrid, u32)> = Vec::new();
    // The grid's number (1 on), packing it the first time it is asked for.
    let mut add = |g: &VoxelGrid, ranged: bool, words: &mut Vec<u32>| -> Result<u32, String> {
        if let Some((_, k)) = grids.iter().find(|(p, _)| std::ptr::eq(*p, g)) {
            return Ok(*k);
        }
        if grids.len() >= MAX_GRIDS {
            return Err(format!("more than {MAX_GRIDS} grids beside the density"));
        }
        let n = if ranged {
            g.nodes()
        } else {
            g.nodes_unranged()
        }
        .map_err(|_| format!("grid \"{}\": nodes it cannot flatten", g.name()))?;
        let k = grids.len() as u32 + 1;
        let header = header(g, &n, density.transform(), tree, vals)?;
        let at = GRIDS_AT + (k as usize - 1) * HEADER_WORDS;
        words[at..at + HEADER_WORDS].copy_from_slice(&header);
        grids.push((g as *const _, k));
        Ok(k)
    };
    let mut traverse = Vec::new();
    if let Some(e) = b.emission {
        words[0..3].copy_from_slice(&(e.color * e.intensity).to_array().map(f));
        words[4..7].copy_from_slice(&[
            f(e.temperature_scale),
            f(e.temperature_offset),
            f(e.blackbody_intensity),
        ]);
        words[EMITS_AT] = 1;
        if let Some(c) = &e.grid {
            let g = walkable(c.field, "an emission grid")?;
            let k = add(g, true, &mut words)?;
            words[12] = k;
            words[13] = u32::from(c.same_lattice());
            if c.same_lattice() {
                traverse.push(words[12]);
            }
        }
        if let Some(c) = &e.temperature {
            let g = walkable(c.field, "a temperature grid")?;
            let k = add(g, true, &mut words)?;
            words[14] = k;
            if c.same_lattice() {
                traverse.push(words[14]);
            }
            let (u_min, inv_du, rgb) = e.table.rgb_samples();
            let (t_min, t_max) = e.table.range();
            if rgb.len() < 2 {
                return Err("a blackbody table of fewer than two samples".into());
            }
            words[8..12].copy_from_slice(&[f(u_min), f(inv_du), f(t_min), f(t_max)]);
            words[15] = meta.len() as u32;
            words[17] = rgb.len() as u32;
            for c in rgb {
                meta.extend([c[0] as f32, c[1] as f32, c[2] as f32, 0.0]);
            }
        }
    }
    if let Some(c) = b.color {
        for (i, (g, ch)) in color_grids(c)?.into_iter().enumerate() {
            let k = add(g, false, &mut words)?;
            words[20 + i] = k;
            words[24 + i] = ch;
        }
    }
    words[28..28 + traverse.len()].copy_from_slice(&traverse);
    Ok(words)
}

/// Appends grid `g`'s nodes `n` to `tree` and `vals`; returns its header.
fn header(
    g: &VoxelGrid,
    n: &GridNodes,
    density: &IndexToWorld,
    tree: &mut Vec<u32>,
    vals: &mut Vec<f32>,
) -> Result<[u32; HEADER_WORDS], String> {
    let root_base = tree.len();
    tree.extend(&n.root);
    let upper_base = tree.len();
    tree.extend(&n.upper);
    let lower_base = tree.len();
    tree.extend(&n.lower);
    let leaf_base = vals.len();
    vals.extend(&n.leaf_values);
    let tile_base = vals.len();
    vals.extend(&n.tile_values);
    let mut cells = |c: &[[f32; 2]]| {
        let at = vals.len();
        vals.extend(c.iter().flatten());
        at
    };
    let root_cells = cells(&n.root_cells);
    let upper_cells = cells(&n.upper_cells);
    let lower_cells = cells(&n.lower_cells);
    if tree.len() as u64 >= u32::MAX as u64 || vals.len() as u64 >= u32::MAX as u64 {
        return Err("grids of over 2^32 words".into());
    }
    let mut h = [0u32; HEADER_WORDS];
    let i = |v: i32| v as u32;
    let (o, rmin, rdims) = (n.origin, n.root_min, n.root_dims);
    h[0..4].copy_from_slice(&[i(o.x), i(o.y), i(o.z), g.channels() as u32]);
    h[4..8].copy_from_slice(&[i(rmin.x), i(rmin.y), i(rmin.z), root_base as u32]);
    h[8..12].copy_from_slice(&[i(rdims.x), i(rdims.y), i(rdims.z), leaf_base as u32]);
    h[12..16].copy_from_slice(&[
        upper_base as u32,
        lower_base as u32,
        tile_base as u32,
        root_cells as u32,
    ]);
    h[16..20].copy_from_slice(&[
        upper_cells as u32,
        lower_cells as u32,
        g.background().to_bits(),
        0,
    ]);
    for (r, row) in index_map(Field::transform(g), density).iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            h[20 + 4 * r + c] = (*v as f32).to_bits();
        }
    }
    Ok(h)
}
