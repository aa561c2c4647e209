//! What the march reads on the GPU, as flat arrays: the density grid's nodes with each
//! slot's cell range (`tree`, `vals`) and after them those of the grids sampled beside
//! it (grids.rs), every light's deep shadow map (`dsm`), the lights, a phase table, the
//! fast mode's multiple-scattering lattice and the blackbody colours (`meta`), and the
//! uniform parameters, in the layouts grid.wgsl, march.wgsl, dsm.wgsl, lattice.wgsl and
//! emission.wgsl read.

use super::grid_parts::GridBinding;
use crate::field::VoxelGrid;
use crate::field::grid_nodes::GridNodes;
use crate::integrate::ms_lattice::{MOMENTS, MsLattice};
use crate::integrate::phase::PhaseFunction;
use crate::integrate::{MarchSettings, Medium};
use crate::scene::light::{Light, LightKind};
use crate::scene::lights::LightShadow;
use crate::shadow::ShadowQuadrature;
use crate::shadow::flat::FlatChart;
use crate::shadow::map::ChartSelect;
use glam::DVec3;
use rayon::prelude::*;

/// Floats of a result before the per-light radiance (4 a light).
pub const RESULT_BASE: usize = 16;
/// Where the emitted radiance sits in a result.
pub const RESULT_EMISSION: usize = 12;
/// Where the sample count sits in the parameters (see `Params` in grid.wgsl).
pub const N_SAMPLES_AT: usize = 32;
/// Where the shadow maps' part size sits in the parameters.
const DSM_CHUNK_AT: usize = 44;
/// Words of the parameters before those of the grids beside the density.
const DENSITY_PARAM_WORDS: usize = 56;
/// Words of the parameters.
const PARAM_WORDS: usize = DENSITY_PARAM_WORDS + super::grids::WORDS + 4;
/// Floats of a result after the per-light radiance where the ground plane is seen: the
/// irradiance the ground receives without the volume (rgb, 0) and through it (rgb, 0).
pub const GROUND_FLOATS: usize = 8;
/// Where the grid's parts begin in the parameters (`upper_base` in grid.wgsl).
const GRID_BASES_AT: usize = 36;
/// Where the grid's background value sits in the parameters.
const BACKGROUND_AT: usize = 42;
/// The buffers the shadow maps are spread over (`dsm0`..`dsm2` in march.wgsl).
pub const DSM_BUFFERS: usize = 3;
/// Words of a chart's header in `dsm`.
const CHART_WORDS: usize = 32;
/// Entries of the phase table, over the scattering angle from 0 to π (0.011° apart:
/// water drops' bows and their supernumeraries span tenths of a degree).
const PHASE_ENTRIES: usize = 16384;
/// The most lights the march takes (`MAX_LIGHTS` in march.wgsl).
pub const MAX_LIGHTS: usize = 8;

/// A scene's arrays, ready to upload.
pub struct Buffers {
    pub tree: Vec<u32>,
    pub vals: Vec<f32>,
    pub dsm: Vec<u32>,
    /// Words of each of the [`DSM_BUFFERS`] buffers `dsm` is cut into: all of them
    /// while they fit one binding (see [`Buffers::split_maps`]).
    pub dsm_chunk: usize,
    pub meta: Vec<f32>,
    pub params: Vec<u32>,
    pub stride: u32,
    /// The march's parts the scene uses.
    pub features: MarchFeatures,
}

/// The march's optional parts (march.wgsl's overrides) a scene uses: the march's
/// pipeline is compiled for them, the code of the others left out (with the registers
/// it holds, which on a GPU bound how many invocations run at once).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MarchFeatures {
    /// Something emits (`EMITS`).
    pub emits: bool,
    /// A colour grid tints σs (`TINTED`).
    pub tinted: bool,
    /// The fast mode's lattice is gathered (`MULTIPLE`).
    pub multiple: bool,
    /// Some light's shadow rays are marched (`MARCHED`).
    pub marched: bool,
    /// Camera rays may meet a ground plane (`GROUND`).
    pub ground: bool,
    /// How the grids' arrays are bound: whole, or cut into parts (set by the upload).
    pub grid: GridBinding,
}

impl MarchFeatures {
    /// Every part: the march as written, without overrides.
    pub const ALL: MarchFeatures = MarchFeatures {
        emits: true,
        tinted: true,
        multiple: true,
        marched: true,
        ground: true,
        grid: GridBinding::Whole,
    };

    /// The overrides' values (march.wgsl), 1 or 0.
    pub fn constants(self) -> [(&'static str, f64); 5] {
        let b = |on: bool| if on { 1.0 } else { 0.0 };
        [
            ("EMITS", b(self.emits)),
            ("TINTED", b(self.tinted)),
            ("MULTIPLE", b(self.multiple)),
            ("MARCHED", b(self.marched)),
            ("GROUND", b(self.ground)),
        ]
    }
}

impl Buffers {
    /// Each buffer with what it holds, in bytes (the shadow maps: each of their
    /// [`DSM_BUFFERS`] buffers).
    pub fn sizes(&self) -> [(&'static str, u64); 4] {
        [
            ("the grids' node tables", self.tree.len() as u64 * 4),
            ("the grids' values", self.vals.len() as u64 * 4),
            ("the shadow maps", self.dsm_chunk as u64 * 4),
            (
                "the lights, the phase table and the multiple-scattering lattice",
                self.meta.len() as u64 * 4,
            ),
        ]
    }

    /// Bytes of every buffer of the scene (the shadow maps whole).
    pub fn resident_bytes(&self) -> usize {
        4 * (self.tree.len()
            + self.vals.len()
            + self.dsm.len()
            + self.meta.len()
            + self.params.len())
    }

    /// Cuts the shadow maps into [`DSM_BUFFERS`] thirds where they exceed one binding of
    /// `max_bytes`; else they stay whole in the first buffer.
    pub fn split_maps(&mut self, max_bytes: u64) {
        let words = self.dsm.len();
        self.dsm_chunk = if words as u64 * 4 <= max_bytes {
            words
        } else {
            words.div_ceil(DSM_BUFFERS).next_multiple_of(4)
        };
        self.params[DSM_CHUNK_AT] = self.dsm_chunk as u32;
    }

    /// Part `k` of the shadow maps (at least 4 words: a binding is never empty).
    pub fn dsm_part(&self, k: usize) -> std::borrow::Cow<'_, [u32]> {
        let end = self.dsm.len();
        let (a, b) = (
            (k * self.dsm_chunk).min(end),
            ((k + 1) * self.dsm_chunk).min(end),
        );
        let part = &self.dsm[a..b];
        if part.len() >= 4 {
            return part.into();
        }
        let mut padded = part.to_vec();
        padded.resize(4, 0);
        padded.into()
    }
}

/// What the march needs of the scene.
pub struct SceneParts<'a> {
    pub grid: &'a VoxelGrid,
    pub nodes: GridNodes,
    pub medium: Medium,
    pub phase: &'a dyn PhaseFunction,
    pub lights: &'a [Light],
    pub shadows: &'a [LightShadow],
    pub settings: MarchSettings,
    /// Light scatters toward the camera (lights and σs > 0).
    pub scatters: bool,
    /// The fast mode's multiple scattering, gathered in the march.
    pub lattice: Option<&'a MsLattice>,
    /// A ground plane is lit through the volume (its shadows are looked up even where
    /// nothing scatters; each result carries [`GROUND_FLOATS`] more).
    pub ground: bool,
    /// How marched shadow rays integrate, and `∫ρ ds` past which they stop.
    pub quadrature: ShadowQuadrature,
    pub enough: f64,
    /// The emission, temperature and colour grids.
    pub beside: super::grids::Beside<'a>,
    /// The box of the cells a camera ray visits (the density's, and the emission and
    /// temperature grids' on its lattice), local index space.
    pub bounds: crate::field::IndexBox,
}

fn f(v: f64) -> u32 {
    (v as f32).to_bits()
}

fn pad(v: &mut Vec<u32>) {
    while v.len() < 4 {
        v.push(0);
    }
}

/// The density grid's arrays: its nodes (`tree`: root, upper slots, lower slots) and
/// its values (`vals`: leaf values, tile values, then every slot's cell range), with
/// where each part begins.
pub struct GridArrays {
    pub tree: Vec<u32>,
    pub vals: Vec<f32>,
    /// Words of the parameters that say where the parts begin, in the order of `Params`
    /// in grid.wgsl from `upper_base` to `lower_cells`.
    bases: [u32; 6],
}

/// Elements each thread copies at a time in [`grid_arrays`]: a 27 M-voxel grid's
/// arrays are over a hundred megabytes.
const LAYOUT_PIECE: usize = 1 << 16;

/// `parts` one after another in a new array, copied on all threads
/// ([`crate::mem::concat_on_all_threads`]); and where each part begins.
fn joined<T: Copy + Send + Sync, const N: usize>(parts: [&[T]; N]) -> (Vec<T>, [usize; N]) {
    let mut starts = [0; N];
    let mut at = 0;
    for (start, part) in starts.iter_mut().zip(parts) {
        *start = at;
        at += part.len();
    }
    (
        crate::mem::concat_on_all_threads(&parts, LAYOUT_PIECE),
        starts,
    )
}

/// Lays the grid's nodes out.
pub fn grid_arrays(n: &GridNodes) -> GridArrays {
    let (mut tree, [_, upper_base, lower_base]) = joined([&n.root, &n.upper, &n.lower]);
    pad(&mut tree);
    let (mut vals, [_, tile_base, root_cells, upper_cells, lower_cells]) = joined([
        &n.leaf_values,
        &n.tile_values,
        n.root_cells.as_flattened(),
        n.upper_cells.as_flattened(),
        n.lower_cells.as_flattened(),
    ]);
    vals.resize(vals.len().max(4), 0.0);
    let bases = [
        upper_base,
        lower_base,
        tile_base,
        root_cells,
        upper_cells,
        lower_cells,
    ]
    .map(|b| b as u32);
    GridArrays { tree, vals, bases }
}

/// The parameters that the grid's lookups read (the rest 0): the light columns' march.
pub fn grid_params(grid: &VoxelGrid, n: &GridNodes, arrays: &GridArrays) -> Vec<u32> {
    let mut params = vec![0u32; PARAM_WORDS];
    let ivec = |v: glam::IVec3| [v.x as u32, v.y as u32, v.z as u32, 0];
    params[0..4].copy_from_slice(&ivec(n.origin));
    params[4..8].copy_from_slice(&ivec(n.root_min));
    params[8..12].copy_from_slice(&ivec(n.root_dims));
    params[GRID_BASES_AT..GRID_BASES_AT + 6].copy_from_slice(&arrays.bases);
    params[BACKGROUND_AT] = grid.background().to_bits();
    params
}

/// Of [`lattice_words`]: 1 where the march gathers the lattice (`P.multiple`).
const LATTICE_GATHERED: usize = 1;

/// Appends the lattice's moments (every light's nodes in turn) to `meta`; returns the
/// parameters from `lattice_base` to `lattice_dims` in grid.wgsl (all 0 but for
/// `lattice_base` without a lattice: nothing is gathered).
fn lattice_words(s: &SceneParts, meta: &mut Vec<f32>) -> Result<[u32; 11], String> {
    let base = meta.len() as u32;
    let mut words = [0; 11];
    words[0] = base;
    let Some(lattice) = s.lattice.filter(|_| s.scatters) else {
        return Ok(words);
    };
    let ((origin, inv_h, dims, g_mean), values) = (lattice.geometry(), lattice.moments_of());
    let nodes: usize = dims.iter().product();
    if values.len() != s.lights.len() || values.iter().any(|v| v.len() != nodes) || nodes == 0 {
        // An empty lattice (no light, nothing dense): nothing to gather.
        return Ok(words);
    }
    if (meta.len() + values.len() * nodes * MOMENTS) as u64 >= u32::MAX as u64 {
        return Err("a multiple-scattering lattice over 2^32 floats".into());
    }
    for v in values {
        meta.extend(v.iter().flatten());
    }
    words[LATTICE_GATHERED] = 1;
    words[2] = f(g_mean);
    words[3..7].copy_from_slice(&[f(origin.x), f(origin.y), f(origin.z), f(inv_h)]);
    words[7..11].copy_from_slice(&[dims[0] as u32, dims[1] as u32, dims[2] as u32, nodes as u32]);
    Ok(words)
}

/// Where the phase table's nodes lie in θ (`phase_grid` in grid.wgsl).
struct PhaseGrid {
    n: u32,
    n_log: u32,
    /// θ₀, δ, the θ where the log part ends, the uniform part's step.
    grid: [u32; 4],
}

/// Appends the phase table to `meta` (per node the phase function per channel and θ);
/// returns where it begins and its nodes' placing. A phase function that is a table
/// (water drops) gives its own nodes, interpolated as on the CPU; a closed form
/// (Henyey–Greenstein) is sampled at [`PHASE_ENTRIES`] angles evenly.
fn phase_table(
    phase: &dyn PhaseFunction,
    meta: &mut Vec<f32>,
) -> Result<(usize, PhaseGrid), String> {
    let base = meta.len();
    if let Some(t) = phase.table() {
        if t.nodes.len() < 2 || t.nodes.len() != t.values.len() {
            return Err("a phase table of fewer than two nodes".into());
        }
        for (theta, v) in t.nodes.iter().zip(t.values) {
            meta.extend([v.x as f32, v.y as f32, v.z as f32, *theta as f32]);
        }
        let grid = [f(t.theta0), f(t.delta), f(t.theta_split), f(t.step)];
        let (n, n_log) = (t.nodes.len() as u32, t.n_log as u32);
        return Ok((base, PhaseGrid { n, n_log, grid }));
    }
    let step = std::f64::consts::PI / (PHASE_ENTRIES - 1) as f64;
    for i in 0..PHASE_ENTRIES {
        let theta = step * i as f64;
        let p = phase.eval(theta.cos());
        meta.extend([p.x as f32, p.y as f32, p.z as f32, theta as f32]);
    }
    let grid = [f(1.0), f(1.0), f(0.0), f(step)];
    Ok((
        base,
        PhaseGrid {
            n: PHASE_ENTRIES as u32,
            n_log: 0,
            grid,
        },
    ))
}

/// Lays the scene out for the march.
pub fn build(s: &SceneParts) -> Result<Buffers, String> {
    let n = &s.nodes;
    if s.lights.len() > MAX_LIGHTS {
        return Err(format!("more than {MAX_LIGHTS} lights"));
    }
    let GridArrays {
        mut tree,
        mut vals,
        bases,
    } = grid_arrays(n);
    // dsm: one header per chart, then the charts' arrays.
    let mut charts: Vec<FlatChart> = Vec::new();
    let mut first_chart = Vec::new();
    for shadow in s.shadows {
        first_chart.push(charts.len());
        if let LightShadow::Map(m) = shadow {
            let want = match m.select {
                ChartSelect::Single => 1,
                ChartSelect::CubeFaces { .. } => 6,
            };
            if m.charts.len() != want {
                return Err("a shadow map without all its charts".into());
            }
            charts.extend(m.charts.par_iter().map(|c| c.flat()).collect::<Vec<_>>());
        }
    }
    fn parts(c: &FlatChart) -> [&Vec<u32>; 4] {
        [&c.slots, &c.bricks, &c.hermite, &c.linear]
    }
    let words = charts.len() * CHART_WORDS
        + charts
            .iter()
            .flat_map(parts)
            .map(|p| p.len())
            .sum::<usize>();
    // Sized at once (a map's samples run to 10⁸ bytes), the headers filled here and
    // the charts' arrays copied in on every thread below.
    let mut dsm = vec![0u32; words.max(4)];
    for (k, c) in charts.iter().enumerate() {
        let mut put = |at: usize, v: u32| dsm[k * CHART_WORDS + at] = v;
        put(0, c.perspective.into());
        put(1, c.linear_lateral[0].into());
        put(2, c.linear_lateral[1].into());
        for (at, v) in [(4, c.point), (8, c.e1), (12, c.e2), (16, c.e3)] {
            put(at, f(v.x));
            put(at + 1, f(v.y));
            put(at + 2, f(v.z));
        }
        put(7, f(c.scale));
        put(11, f(c.unit));
        for (at, v) in [(20, c.lo), (24, c.dims)] {
            put(at, v.x as u32);
            put(at + 1, v.y as u32);
            put(at + 2, v.z as u32);
        }
    }
    let mut at = charts.len() * CHART_WORDS;
    let mut copies = Vec::with_capacity(charts.len() * 4);
    for (k, c) in charts.iter().enumerate() {
        for (word, part) in (28..).zip(parts(c)) {
            dsm[k * CHART_WORDS + word] = at as u32;
            copies.push(part.as_slice());
            at += part.len();
        }
    }
    // The arrays in turn, each cut into pieces copied in parallel.
    let mut rest = &mut dsm[charts.len() * CHART_WORDS..];
    let mut pieces = Vec::new();
    for part in copies {
        let (here, after) = std::mem::take(&mut rest).split_at_mut(part.len());
        pieces.extend(here.chunks_mut(1 << 16).zip(part.chunks(1 << 16)));
        rest = after;
    }
    pieces
        .into_par_iter()
        .for_each(|(to, from)| to.copy_from_slice(from));
    // Whole, until split_maps knows the adapter's binding size.
    let dsm_chunk = dsm.len();
    // meta: the lights, then the phase table.
    let mut meta = Vec::with_capacity(s.lights.len() * 16 + PHASE_ENTRIES * 4);
    let to_index = crate::field::Field::transform(s.grid);
    for ((light, shadow), first) in s.lights.iter().zip(s.shadows).zip(&first_chart) {
        // In index space, for marched shadow rays: the sun's direction (index units
        // per world unit) or the point light's position.
        let (kind, v, index) = match light.kind {
            LightKind::Sun { toward } => (0.0, toward, to_index.world_dir_to_index(toward)),
            LightKind::Point { position } => (1.0, position, to_index.world_to_index(position)),
        };
        let shadow = match shadow {
            // Nothing scatters and no ground: the lights' shadows are never looked up.
            _ if !s.scatters && !s.ground => 0.0,
            LightShadow::Map(m) if matches!(m.select, ChartSelect::CubeFaces { .. }) => 2.0,
            LightShadow::Map(_) => 1.0,
            LightShadow::Unshadowed => 0.0,
            LightShadow::Marched => 3.0,
        };
        let e = light.color * light.intensity;
        let header = (first * CHART_WORDS) as f32;
        meta.extend([kind, shadow, header, 0.0]);
        meta.extend([v.x as f32, v.y as f32, v.z as f32, 0.0]);
        meta.extend([e.x as f32, e.y as f32, e.z as f32, 0.0]);
        meta.extend([index.x as f32, index.y as f32, index.z as f32, 0.0]);
    }
    let (phase_base, phase) = phase_table(s.phase, &mut meta)?;
    let lattice = lattice_words(s, &mut meta)?;
    let mut beside = super::grids::pack(s.grid, &s.beside, &mut tree, &mut vals, &mut meta)?;
    beside[super::grids::PHASE_N_LOG] = phase.n_log;
    beside[super::grids::PHASE_GRID..super::grids::PHASE_GRID + 4].copy_from_slice(&phase.grid);
    // The parameters.
    let bounds = s.bounds;
    let sigma_t = s.medium.sigma_t();
    let sigma_s = s.medium.sigma_s_scaled();
    let ground = if s.ground { GROUND_FLOATS } else { 0 };
    let stride = (RESULT_BASE + 4 * s.lights.len() + ground) as u32;
    let ivec = |v: glam::IVec3| [v.x as u32, v.y as u32, v.z as u32, 0];
    let fvec = |v: DVec3| [f(v.x), f(v.y), f(v.z), 0];
    let mut params = Vec::with_capacity(PARAM_WORDS);
    params.extend(ivec(n.origin));
    params.extend(ivec(n.root_min));
    params.extend(ivec(n.root_dims));
    params.extend(fvec(bounds.min.as_dvec3()));
    params.extend(fvec(bounds.max.as_dvec3()));
    params.extend(fvec(sigma_t));
    params.extend(fvec(sigma_s));
    params.extend([
        f(s.settings.step_voxels),
        f(s.settings.termination),
        f(s.settings.thin_step_depth()),
        s.lights.len() as u32,
        0, // the samples of a batch, set per dispatch
        stride,
        phase.n,
        phase_base as u32,
    ]);
    params.extend(bases);
    params.extend([
        s.grid.background().to_bits(),
        u32::from(s.scatters),
        dsm_chunk as u32,
    ]);
    params.extend(lattice);
    debug_assert_eq!(params.len(), DENSITY_PARAM_WORDS);
    params.extend(&beside);
    // Marched shadow rays: the midpoint rule's step in voxels (0: exact per voxel), and
    // where they stop.
    let shadow_step = match s.quadrature {
        ShadowQuadrature::Step(v) => v.max(1e-6),
        ShadowQuadrature::Exact => 0.0,
    };
    params.extend([f(shadow_step), f(s.enough.min(f32::MAX as f64)), 0, 0]);
    debug_assert_eq!(params.len(), PARAM_WORDS);
    debug_assert_eq!(params[DSM_CHUNK_AT] as usize, dsm_chunk);
    debug_assert_eq!(params[GRID_BASES_AT..GRID_BASES_AT + 6], bases);
    debug_assert_eq!(params[BACKGROUND_AT], s.grid.background().to_bits());
    let features = MarchFeatures {
        emits: beside[super::grids::EMITS_AT] != 0,
        tinted: beside[super::grids::TINT_AT] != 0,
        multiple: lattice[LATTICE_GATHERED] != 0,
        marched: s
            .shadows
            .iter()
            .any(|sh| matches!(sh, LightShadow::Marched)),
        ground: s.ground,
        grid: GridBinding::Whole,
    };
    Ok(Buffers {
        tree,
        vals,
        dsm,
        dsm_chunk,
        meta,
        params,
        stride,
        features,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn maps_of(words: usize) -> Buffers {
        Buffers {
            tree: vec![],
            vals: vec![],
            dsm: (0..words as u32).map(|w| w + 1).collect(),
            dsm_chunk: words,
            meta: vec![],
            params: vec![0; PARAM_WORDS],
            stride: 0,
            features: MarchFeatures::ALL,
        }
    }

    #[test]
    fn the_maps_parts_hold_every_word_once_in_order_and_none_is_empty() {
        for words in 4..200 {
            for max_words in [words, words - 1, words / 3, 1] {
                let mut b = maps_of(words);
                b.split_maps(max_words as u64 * 4);
                let chunk = b.dsm_chunk;
                assert_eq!(b.params[DSM_CHUNK_AT] as usize, chunk);
                // Whole while it fits one binding, else thirds of whole vec4s.
                if max_words >= words {
                    assert_eq!(chunk, words);
                } else {
                    assert!(chunk * DSM_BUFFERS >= words && chunk.is_multiple_of(4));
                    // Whole vec4s: only maps of over 12 words get shorter parts.
                    assert!(
                        words <= 12 || chunk < words,
                        "{words} words cut into {chunk}"
                    );
                }
                let parts: Vec<Vec<u32>> =
                    (0..DSM_BUFFERS).map(|k| b.dsm_part(k).to_vec()).collect();
                // Word w lies in part w / chunk at w % chunk, as dw() in dsm.wgsl reads it.
                for (w, &v) in b.dsm.iter().enumerate() {
                    assert_eq!(parts[w / chunk][w % chunk], v, "{words} words");
                }
                for p in &parts {
                    assert!(p.len() >= 4 && p.len() <= chunk.max(4), "{words} words");
                }
            }
        }
    }
}
