//! A structural scan of a `.vdb` file, made before the reader crate sees the data.
//!
//! The reader trusts what it finds: a Blosc frame's block size and a frustum map's
//! second-map name length become allocations of up to 4 GiB, frustum maps nest by
//! recursion, a file without grid offsets is loaded whole when opened (point grids
//! included) and instanced trees are cloned. A failed allocation or a stack overflow
//! aborts the process, which `catch_unwind` cannot turn into an error. So this module
//! walks the same structure first — header, metadata, descriptors, grid heads and, before
//! a grid is decoded, its tree's node masks and chunk headers — without decompressing
//! anything, and reports the inputs that would crash or exhaust the reader as problems.
//!
//! The scan mirrors the reader's parsing step by step (it must stay in step with it to
//! find the same chunks). Nothing here allocates in proportion to a size read from the
//! file: every length is checked against the bytes left first.

use super::guard::{self, printable};
use std::collections::{BTreeMap, HashMap};
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;

mod bytes;
mod tree;
use bytes::{Bytes, popcount};
use tree::TreeScan;

/// `OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION`: per-node metadata bytes, per-grid
/// compression flags.
const NODE_MASK_COMPRESSION: u32 = 222;
/// Files before this version default to zip instead of Blosc.
const BLOSC_COMPRESSION: u32 = 223;
const ZIP: u32 = 0x1;
const ACTIVE_MASK: u32 = 0x2;
const BLOSC: u32 = 0x4;
/// Blosc frame flag: the data is stored uncompressed after the header.
const BLOSC_MEMCPYED: u8 = 0x2;
const FRUSTUM: &str = "NonlinearFrustumMap";

/// How a grid's values are laid out in the file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum LeafFormat {
    Standard,
    Bool,
    Mask,
    /// Point data and point index grids: standard topology, own buffer layout.
    Points,
}

#[derive(Clone, Copy, Debug)]
struct ValueLayout {
    size: u64,
    half_size: u64,
    real: bool,
    leaf: LeafFormat,
}

/// The tree types the reader loads (everything else it lists and skips).
fn value_layout(grid_type: &str) -> Option<ValueLayout> {
    let (size, half_size, real, leaf) = match grid_type {
        "Tree_float_5_4_3" => (4, 2, true, LeafFormat::Standard),
        "Tree_double_5_4_3" => (8, 2, true, LeafFormat::Standard),
        "Tree_int32_5_4_3" => (4, 4, false, LeafFormat::Standard),
        "Tree_int64_5_4_3" => (8, 8, false, LeafFormat::Standard),
        "Tree_bool_5_4_3" => (1, 1, false, LeafFormat::Bool),
        "Tree_mask_5_4_3" => (1, 1, false, LeafFormat::Mask),
        "Tree_vec3s_5_4_3" => (12, 6, true, LeafFormat::Standard),
        "Tree_vec3d_5_4_3" => (24, 6, true, LeafFormat::Standard),
        "Tree_vec3i_5_4_3" => (12, 12, false, LeafFormat::Standard),
        "Tree_ptdataidx32_5_4_3" | "Tree_ptidx32_5_4_3" => (4, 4, false, LeafFormat::Points),
        _ => return None,
    };
    Some(ValueLayout {
        size,
        half_size,
        real,
        leaf,
    })
}

/// Bytes of a linear map's payload, by type name (`None`: not a registered linear map).
fn linear_map_size(name: &str) -> Option<u64> {
    Some(match name {
        "AffineMap" | "UnitaryMap" => 16 * 8,
        "ScaleMap" | "UniformScaleMap" => 15 * 8,
        "TranslationMap" => 3 * 8,
        "ScaleTranslateMap" | "UniformScaleTranslateMap" => 18 * 8,
        _ => return None,
    })
}

/// One grid as the reader sees it.
#[derive(Clone, Debug)]
pub(super) struct ScannedGrid {
    /// The raw unique name (`name\x1e<n>` for duplicates), as the reader looks it up.
    pub unique_name: String,
    grid_name: String,
    grid_type: String,
    half: bool,
    parent: String,
    grid_pos: u64,
    end_pos: u64,
    /// Compression flags from the grid head.
    compression: u32,
    /// Where the tree starts (right after the head), if the head's map is one the reader
    /// reads (otherwise the reader refuses to read the tree).
    tree_pos: Option<u64>,
}

/// What the scan of a whole file found.
#[derive(Clone, Debug)]
pub(super) struct ScannedFile {
    version: u32,
    /// False for files written as streams: the reader loads those whole when opening.
    has_offsets: bool,
    pub grids: Vec<ScannedGrid>,
}

/// Scans the header, file metadata, descriptors and every grid head (and, for files
/// without grid offsets, which the reader loads whole, every tree).
pub(super) fn scan_file(path: &Path) -> Result<ScannedFile, String> {
    let file = std::fs::File::open(path).map_err(|e| super::io_problem(&e))?;
    let len = file.metadata().map_err(|e| super::io_problem(&e))?.len();
    let mut b = Bytes {
        r: BufReader::new(file),
        pos: 0,
        len,
        what: "the file",
    };

    if len < 8 || b.i64()? != openvdb::io::MAGIC {
        return Err("not a VDB file (bad magic number)".to_string());
    }
    let version = b.u32()?;
    if !(openvdb::io::MIN_FILE_VERSION..=openvdb::io::MAX_FILE_VERSION).contains(&version) {
        return Err(format!(
            "unsupported VDB file format version {version} (supported: {} to {})",
            openvdb::io::MIN_FILE_VERSION,
            openvdb::io::MAX_FILE_VERSION
        ));
    }
    b.skip(8)?; // library version
    let has_offsets = b.u8()? != 0;
    let mut header_compression = if version < BLOSC_COMPRESSION {
        ZIP | ACTIVE_MASK
    } else {
        BLOSC | ACTIVE_MASK
    };
    if version < NODE_MASK_COMPRESSION {
        header_compression = if b.u8()? != 0 { ZIP } else { 0 };
    }
    b.skip(36)?; // UUID
    b.meta_map()?;
    let count = b.i32()?.max(0);

    let mut grids = Vec::new();
    let scan = TreeScan { version };
    // Stream layout: descriptor, head and tree (or a skip to the end offset) in turn.
    let mut tree_bytes: HashMap<String, u64> = HashMap::new();
    for _ in 0..count {
        let mut g = descriptor(&mut b)?;
        if has_offsets {
            if (g.end_pos as i64) < b.pos as i64 {
                return Err(format!(
                    "grid \"{}\": invalid end offset (before the grid's own descriptor ends)",
                    printable(&g.display_name())
                ));
            }
            b.seek(g.end_pos)?;
        } else {
            let (compression, tree_pos) = head(&mut b, header_compression, version, &g)?;
            g.compression = compression;
            g.tree_pos = tree_pos;
            match value_layout(&g.grid_type) {
                None => {
                    if g.end_pos == 0 || (g.end_pos as i64) < b.pos as i64 || g.end_pos > len {
                        return Err(format!(
                            "grid \"{}\": invalid end offset for a grid of unsupported type",
                            printable(&g.display_name())
                        ));
                    }
                    b.seek(g.end_pos)?;
                }
                Some(_) if !g.parent.is_empty() => {} // an instance: no tree of its own
                Some(v) if v.leaf == LeafFormat::Points => {
                    return Err(format!(
                        "grid \"{}\": point grids in files without grid offsets (written as streams) are not supported",
                        printable(&g.display_name())
                    ));
                }
                Some(v) => {
                    let Some(tree_pos) = tree_pos else {
                        // The reader stops here: it cannot read a tree without a transform.
                        grids.push(g);
                        break;
                    };
                    b.seek(tree_pos)?;
                    scan.tree(&mut b, v, compression, g.half)
                        .map_err(|p| grid_problem(&g, p))?;
                    tree_bytes.insert(g.unique_name.clone(), b.pos - tree_pos);
                }
            }
        }
        grids.push(g);
    }
    let scanned = ScannedFile {
        version,
        has_offsets,
        grids,
    };
    scanned.check_names()?;
    scanned.check_instance_counts()?;
    if !has_offsets {
        // The reader copies the parent's tree into every instance when it opens a stream.
        let copied: u64 = scanned
            .grids
            .iter()
            .filter(|g| !g.parent.is_empty())
            .map(|g| tree_bytes.get(&g.parent).copied().unwrap_or(0))
            .sum();
        if copied > 2 * len + (1 << 20) {
            return Err(format!(
                "instanced grids would copy {copied} bytes of tree data, out of proportion to the file's {len}"
            ));
        }
    }
    if has_offsets {
        scanned.check_offsets(len)?;
        let mut grids = scanned.grids;
        for g in &mut grids {
            b.seek(g.grid_pos)?;
            let (compression, tree_pos) = head(&mut b, header_compression, version, g)?;
            if b.pos > g.end_pos {
                return Err(format!(
                    "grid \"{}\": its header runs past its end offset",
                    printable(&g.display_name())
                ));
            }
            g.compression = compression;
            g.tree_pos = tree_pos;
        }
        return Ok(ScannedFile { grids, ..scanned });
    }
    Ok(scanned)
}

fn grid_problem(g: &ScannedGrid, problem: String) -> String {
    format!("grid \"{}\": {problem}", printable(&g.display_name()))
}

impl ScannedGrid {
    fn display_name(&self) -> String {
        openvdb::io::name_as_string(&self.unique_name)
    }
}

/// A grid descriptor: names, type and the three offsets.
fn descriptor<R: Read + Seek>(b: &mut Bytes<R>) -> Result<ScannedGrid, String> {
    let unique_name = b.string()?;
    let mut grid_type = b.string()?;
    let mut half = false;
    if let Some(t) = grid_type.strip_suffix("_HalfFloat") {
        grid_type = t.to_string();
        half = true;
    }
    let parent = b.string()?;
    let grid_pos = b.i64()?;
    let _block_pos = b.i64()?;
    let end_pos = b.i64()?;
    // Negative offsets become huge ones, which the offset checks reject.
    Ok(ScannedGrid {
        grid_name: openvdb::io::strip_suffix(&unique_name).to_string(),
        unique_name,
        grid_type,
        half,
        parent,
        grid_pos: grid_pos as u64,
        end_pos: end_pos as u64,
        compression: 0,
        tree_pos: None,
    })
}

/// A grid head: compression, metadata, transform. Returns the compression flags and,
/// if the map is one the reader reads, where the tree starts.
fn head<R: Read + Seek>(
    b: &mut Bytes<R>,
    header_compression: u32,
    version: u32,
    g: &ScannedGrid,
) -> Result<(u32, Option<u64>), String> {
    let compression = if version >= NODE_MASK_COMPRESSION {
        b.u32()?
    } else {
        header_compression
    };
    b.meta_map()?;
    let map_type = b.string()?;
    if let Some(n) = linear_map_size(&map_type) {
        b.skip(n)?;
        return Ok((compression, Some(b.pos)));
    }
    if map_type != FRUSTUM {
        return Ok((compression, None)); // the reader reports the map as unsupported
    }
    b.skip(8 * 8)?; // bbox, taper, depth
    let second = b.string()?;
    if second == FRUSTUM {
        return Err(grid_problem(
            g,
            "the transform nests a frustum map inside a frustum map".to_string(),
        ));
    }
    match linear_map_size(&second) {
        Some(n) => {
            b.skip(n)?;
            Ok((compression, Some(b.pos)))
        }
        None => Ok((compression, None)), // the reader rejects the unknown second map
    }
}

impl ScannedFile {
    /// Unique names must be unique; instance parents must exist and chains must end.
    fn check_names(&self) -> Result<(), String> {
        let mut seen = HashMap::new();
        for g in &self.grids {
            if seen.insert(g.unique_name.as_str(), ()).is_some() {
                return Err(format!(
                    "two grids have the unique name \"{}\"",
                    printable(&g.display_name())
                ));
            }
        }
        let names: Vec<String> = self.grids.iter().map(|g| g.unique_name.clone()).collect();
        let parents: Vec<String> = self.grids.iter().map(|g| g.parent.clone()).collect();
        guard::check_instance_chains(&names, &parents)
    }

    /// Grid regions (`grid_pos..end_pos`) lie inside the file and do not overlap, so each
    /// tree is read from its own bytes only.
    fn check_offsets(&self, len: u64) -> Result<(), String> {
        let mut regions: Vec<(u64, u64, usize)> = Vec::with_capacity(self.grids.len());
        for (i, g) in self.grids.iter().enumerate() {
            if g.grid_pos == 0 || g.grid_pos >= g.end_pos || g.end_pos > len {
                return Err(grid_problem(
                    g,
                    format!(
                        "invalid grid offsets (data from byte {} to {} in a file of {len} bytes)",
                        g.grid_pos as i64, g.end_pos as i64
                    ),
                ));
            }
            regions.push((g.grid_pos, g.end_pos, i));
        }
        regions.sort_unstable();
        for w in regions.windows(2) {
            if w[1].0 < w[0].1 {
                return Err(format!(
                    "the data of grids \"{}\" and \"{}\" overlap",
                    printable(&self.grids[w[0].2].display_name()),
                    printable(&self.grids[w[1].2].display_name())
                ));
            }
        }
        Ok(())
    }

    /// Decoding an instance reads its parent's tree again (and a stream copies it when
    /// opened), so a few dozen bytes per instance descriptor could make decoding every grid
    /// take time out of all proportion to the file. Refuses more instances of one tree
    /// than [`guard::MAX_INSTANCES_PER_TREE`].
    fn check_instance_counts(&self) -> Result<(), String> {
        let index: HashMap<&str, usize> = self
            .grids
            .iter()
            .enumerate()
            .map(|(i, g)| (g.unique_name.as_str(), i))
            .collect();
        let mut count: HashMap<usize, usize> = HashMap::new();
        for g in self.grids.iter().filter(|g| !g.parent.is_empty()) {
            let mut root = index.get(g.parent.as_str()).copied();
            for _ in 0..guard::MAX_INSTANCE_CHAIN {
                match root.map(|r| &self.grids[r]) {
                    Some(r) if !r.parent.is_empty() => root = index.get(r.parent.as_str()).copied(),
                    _ => break,
                }
            }
            let Some(root) = root else { continue };
            let n = count.entry(root).or_default();
            *n += 1;
            if *n > guard::MAX_INSTANCES_PER_TREE {
                return Err(format!(
                    "grid \"{}\" is shared by more than {} instanced grids",
                    printable(&self.grids[root].display_name()),
                    guard::MAX_INSTANCES_PER_TREE
                ));
            }
        }
        Ok(())
    }

    /// The descriptor the reader picks for `name` (`File::read_grid`): a unique name, also
    /// in the printable `name[n]` form, else the first grid with that grid name.
    fn reader_index(&self, name: &str) -> Option<usize> {
        let unique = openvdb::io::string_as_unique_name(name);
        self.grids
            .iter()
            .position(|g| g.unique_name == name || g.unique_name == unique)
            .or_else(|| self.grids.iter().position(|g| g.grid_name == name))
    }

    /// Before `File::read_grid(name)`: the instance chain holds one grid type, and the tree
    /// the reader will read (the chain's last grid's) is sound and ends inside its grid's
    /// data. Problems are about grid `name` (the caller names it).
    pub(super) fn check_tree(&self, path: &Path, name: &str) -> Result<(), String> {
        if !self.has_offsets {
            return Ok(()); // loaded (and scanned) when the file was opened
        }
        let Some(first) = self.reader_index(name) else {
            return Ok(()); // the reader reports it
        };
        let grid_type = &self.grids[first].grid_type;
        let mut i = first;
        let mut steps = 0;
        while !self.grids[i].parent.is_empty() {
            let child = &self.grids[i];
            let Some(p) = self
                .grids
                .iter()
                .position(|g| g.unique_name == child.parent)
            else {
                return Ok(()); // the reader reports it
            };
            steps += 1;
            if p == i || steps > guard::MAX_INSTANCE_CHAIN {
                return Err("its instance chain is cyclic or too long".to_string());
            }
            if self.grids[p].grid_type != *grid_type {
                return Err(format!(
                    "it is an instance of grid \"{}\", which has a different type ({})",
                    printable(&self.grids[p].display_name()),
                    printable(&self.grids[p].grid_type)
                ));
            }
            i = p;
        }
        let g = &self.grids[i];
        let in_parent = |p: String| {
            if i == first {
                p
            } else {
                format!(
                    "in the tree of its instance parent \"{}\": {p}",
                    printable(&g.display_name())
                )
            }
        };
        let (Some(v), Some(tree_pos)) = (value_layout(&g.grid_type), g.tree_pos) else {
            return Ok(()); // the reader refuses to read this tree
        };
        if v.leaf == LeafFormat::Points {
            return Err(in_parent("point grids are not decoded".to_string()));
        }
        let file = std::fs::File::open(path).map_err(|e| super::io_problem(&e))?;
        let mut b = Bytes {
            r: BufReader::new(file),
            pos: 0,
            len: g.end_pos,
            what: "the grid's data",
        };
        b.seek(tree_pos)?;
        let scan = TreeScan {
            version: self.version,
        };
        scan.tree(&mut b, v, g.compression, g.half)
            .map_err(in_parent)?;
        #[cfg(test)]
        TREE_END.with(|t| t.set(Some((b.pos, g.end_pos))));
        Ok(())
    }
}

#[cfg(test)]
thread_local! {
    /// Where the last checked tree ended, and its grid's end offset.
    static TREE_END: std::cell::Cell<Option<(u64, u64)>> = const { std::cell::Cell::new(None) };
}

#[cfg(test)]
mod tests;
