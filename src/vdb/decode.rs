//! Walks a decoded VDB tree (root → 32³ nodes → 16³ nodes → 8³ leaves) and hands its
//! tiles and leaves, as plain f32 channels, to a [`TreeSink`].

use super::ValueKind;
use super::guard::MAX_INDEX_COORD;
use glam::{DMat4, IVec3};
use openvdb::grid::{AnyGrid, Grid};
use openvdb::math::{Coord, Vec3};
use openvdb::tree::{InternalNode, Node, RootEntry};
use openvdb::types::Value;

/// Receives a grid's tree. Errors are problem descriptions (the caller adds the file
/// and grid names).
pub trait TreeSink {
    /// Called once, first: number of channels (1 or 3) and the background value.
    fn begin(&mut self, channels: usize, background: &[f32]) -> Result<(), String>;
    /// A constant cube of `size` voxels (8, 128 or 4096) at `origin` (file index space).
    fn tile(&mut self, origin: IVec3, size: i32, value: &[f32], active: bool)
    -> Result<(), String>;
    /// An 8³ leaf at `origin`: 512 voxels in OpenVDB's order (offset `x<<6 | y<<3 | z`),
    /// channels interleaved; `active` is the leaf's value mask.
    fn leaf(&mut self, origin: IVec3, values: &[f32], active: &[u64; 8]) -> Result<(), String>;
}

/// What [`super::VdbFile::decode`] found.
#[derive(Clone, Debug)]
pub struct DecodedValues {
    pub channels: usize,
    pub index_to_world: DMat4,
}

/// A value type the renderer reads, as f32 channels.
trait Channels: Value {
    const N: usize;
    fn write(&self, out: &mut [f32]);
    /// A leaf buffer that already is f32 channels, to hand on without a copy.
    fn as_f32(_buf: &[Self]) -> Option<&[f32]> {
        None
    }
}

impl Channels for f32 {
    const N: usize = 1;
    fn write(&self, out: &mut [f32]) {
        out[0] = *self;
    }
    fn as_f32(buf: &[f32]) -> Option<&[f32]> {
        Some(buf)
    }
}
impl Channels for f64 {
    const N: usize = 1;
    fn write(&self, out: &mut [f32]) {
        out[0] = *self as f32;
    }
}
impl Channels for Vec3<f32> {
    const N: usize = 3;
    fn write(&self, out: &mut [f32]) {
        out.copy_from_slice(&self.0);
    }
}
impl Channels for Vec3<f64> {
    const N: usize = 3;
    fn write(&self, out: &mut [f32]) {
        for (o, v) in out.iter_mut().zip(self.0) {
            *o = v as f32;
        }
    }
}

/// Hands `grid`'s tree to `sink`, consuming it: each leaf is freed once the sink has it,
/// so the decoded tree and the sink's copy are not both whole in memory (see
/// [`crate::mem::release_freed_memory`]).
pub(super) fn walk(
    grid: AnyGrid,
    kind: ValueKind,
    m: DMat4,
    sink: &mut dyn TreeSink,
) -> Result<DecodedValues, String> {
    let channels = match (grid, kind) {
        (AnyGrid::Float(g), ValueKind::Scalar) => walk_typed(g, sink)?,
        (AnyGrid::Double(g), ValueKind::Scalar) => walk_typed(g, sink)?,
        (AnyGrid::Vec3S(g), ValueKind::Vector) => walk_typed(g, sink)?,
        (AnyGrid::Vec3D(g), ValueKind::Vector) => walk_typed(g, sink)?,
        _ => return Err("the decoded grid's type does not match its descriptor".to_string()),
    };
    Ok(DecodedValues {
        channels,
        index_to_world: m,
    })
}

fn origin_of(c: &Coord) -> Result<IVec3, String> {
    let o = IVec3::new(c[0], c[1], c[2]);
    if o.to_array()
        .iter()
        .any(|v| (*v as i64).abs() > MAX_INDEX_COORD)
    {
        return Err(format!(
            "index coordinate ({}, {}, {}) is out of the supported range ±2^30",
            o.x, o.y, o.z
        ));
    }
    Ok(o)
}

fn walk_typed<T: Channels>(grid: Grid<T>, sink: &mut dyn TreeSink) -> Result<usize, String> {
    let n = T::N;
    let mut tree = grid.into_tree();
    let root = tree.root_mut();
    let bg = *root.background();
    let bg = &bg;
    let table = std::mem::take(root.table_mut());
    let mut bg_ch = vec![0.0f32; n];
    bg.write(&mut bg_ch);
    if bg_ch.iter().any(|v| !v.is_finite()) {
        return Err("the background value is not finite".to_string());
    }
    sink.begin(n, &bg_ch)?;
    let mut value = vec![0.0f32; n];
    let mut leaf_values = vec![0.0f32; 512 * n];
    let mut emit_tile = |sink: &mut dyn TreeSink, origin: IVec3, size: i32, v: &T, active: bool| {
        if !active && v == bg {
            return Ok(());
        }
        v.write(&mut value);
        sink.tile(origin, size, &value, active)
    };
    for (key, entry) in table {
        let key_origin = origin_of(&key)?;
        if key_origin & IVec3::splat(4095) != IVec3::ZERO {
            return Err(format!(
                "root entry at ({}, {}, {}) is not aligned to a 4096-voxel node",
                key_origin.x, key_origin.y, key_origin.z
            ));
        }
        let upper = match entry {
            RootEntry::Tile { value, active } => {
                emit_tile(sink, key_origin, 4096, &value, active)?;
                continue;
            }
            RootEntry::Child(upper) => upper,
        };
        let mut upper = upper;
        for n1 in 0..32768usize {
            let origin1 = origin_of(&upper.offset_to_global_coord(n1))?;
            let Some(mut lower) = take_child(&mut upper, n1) else {
                emit_tile(
                    sink,
                    origin1,
                    128,
                    &upper.values()[n1],
                    upper.value_mask().is_on(n1),
                )?;
                continue;
            };
            for n2 in 0..4096usize {
                let origin2 = origin_of(&lower.offset_to_global_coord(n2))?;
                let Some(leaf) = take_child(&mut lower, n2) else {
                    emit_tile(
                        sink,
                        origin2,
                        8,
                        &lower.values()[n2],
                        lower.value_mask().is_on(n2),
                    )?;
                    continue;
                };
                // Files before format 222 store each leaf's origin; it must be the leaf's
                // place in the tree (a stray origin would make the builder grow nodes
                // elsewhere, out of proportion to the data).
                let leaf_origin = origin_of(&leaf.origin())?;
                if leaf_origin != origin2 {
                    return Err(format!(
                        "a leaf's stored origin ({}, {}, {}) is not its place in the tree ({}, {}, {})",
                        leaf_origin.x,
                        leaf_origin.y,
                        leaf_origin.z,
                        origin2.x,
                        origin2.y,
                        origin2.z
                    ));
                }
                let buf = leaf.buffer();
                if buf.len() != 512 {
                    return Err(format!("a leaf holds {} values instead of 512", buf.len()));
                }
                let values = match T::as_f32(buf) {
                    Some(values) => values,
                    None => {
                        for (i, v) in buf.iter().enumerate() {
                            v.write(&mut leaf_values[i * n..(i + 1) * n]);
                        }
                        &leaf_values[..]
                    }
                };
                let mut mask = [0u64; 8];
                for (m, w) in mask.iter_mut().zip(leaf.value_mask().words()) {
                    *m = *w;
                }
                sink.leaf(leaf_origin, values, &mask)?;
            }
            // The 16³ node's leaves are freed (in the order they were read, so their
            // memory is contiguous): give it back.
            drop(lower);
            crate::mem::release_freed_memory();
        }
    }
    Ok(n)
}

/// Takes the child in slot `n` out of an internal node, leaving an inactive tile.
fn take_child<C: Node, const LOG2DIM: u32>(
    node: &mut InternalNode<C, LOG2DIM>,
    n: usize,
) -> Option<Box<C>> {
    if !node.is_child(n) {
        return None;
    }
    let value = node.values()[n];
    node.steal_child(n, value, false)
}
