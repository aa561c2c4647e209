//! The water-drop tables on disk, so a render after the first (in any process) loads
//! them in milliseconds instead of summing Mie series for seconds to a minute.
//!
//! Where: `$MURK_CACHE_DIR` if set (`off` or empty disables the cache), else
//! `$XDG_CACHE_HOME/murk`, else `$HOME/.cache/murk`. One file per radius,
//! `water_drop-v1-<radius bits>-<grid>-<radii>.bin`: the per-wavelength tables and
//! their Mie integrals as little-endian f64 after a header repeating the grid's nodes,
//! so a file made with another grid, wavelength set or radius averaging is not used.
//! Anything unreadable, short, of another size or kind (a FIFO, a device) or non-finite
//! is ignored (never read past the expected size) and recomputed; a failed write
//! only costs the next render the computation again. Bump the `v1` in the name when
//! the computation itself changes (Mie code, index fit, colour weights).

use super::{AngleGrid, WAVELENGTHS_NM};
use crate::integrate::phase::mie::{RADIUS_SAMPLES, RADIUS_SPREAD};
use std::path::PathBuf;

const MAGIC: &[u8; 8] = b"MURKWD1\n";

/// The cache folder, or `None` when disabled or no home is known.
pub fn dir() -> Option<PathBuf> {
    match std::env::var_os("MURK_CACHE_DIR") {
        Some(v) if v.is_empty() || v == "off" => None,
        Some(v) => Some(PathBuf::from(v)),
        None => std::env::var_os("XDG_CACHE_HOME")
            .filter(|v| !v.is_empty())
            .map(|v| PathBuf::from(v).join("murk"))
            .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache/murk"))),
    }
}

/// The file for `radius_um` on `grid` in `dir`.
pub fn file(dir: &std::path::Path, radius_um: f64, grid: &AngleGrid) -> PathBuf {
    dir.join(format!(
        "water_drop-v1-{:016x}-g{}-k{}s{:016x}.bin",
        radius_um.to_bits(),
        grid.nodes().len(),
        RADIUS_SAMPLES,
        RADIUS_SPREAD.to_bits()
    ))
}

/// The tables stored in `path` for `grid`, if it holds valid ones.
pub fn load(path: &std::path::Path, grid: &AngleGrid) -> Option<(Vec<Vec<f64>>, Vec<f64>)> {
    let (n_wl, n_nodes) = (WAVELENGTHS_NM.len(), grid.nodes().len());
    let expected = MAGIC.len() + 8 * (n_nodes + n_wl + n_wl * n_nodes);
    let bytes = read_bounded(path, expected)?;
    if bytes.len() != expected || &bytes[..MAGIC.len()] != MAGIC {
        return None;
    }
    let mut values = bytes[MAGIC.len()..]
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("chunks of 8")));
    let nodes: Vec<f64> = values.by_ref().take(n_nodes).collect();
    if nodes
        .iter()
        .zip(grid.nodes())
        .any(|(a, b)| a.to_bits() != b.to_bits())
    {
        return None;
    }
    let integrals: Vec<f64> = values.by_ref().take(n_wl).collect();
    let spectral: Vec<Vec<f64>> = (0..n_wl)
        .map(|_| values.by_ref().take(n_nodes).collect())
        .collect();
    let finite = integrals
        .iter()
        .chain(spectral.iter().flatten())
        .all(|v| v.is_finite());
    finite.then_some((spectral, integrals))
}

/// The file's bytes when it is a regular file of exactly `len` bytes: its kind and size
/// are checked before it is opened (a FIFO would block, a device or a huge sparse file
/// would be read whole), and the read stops after `len + 1` bytes whatever the file
/// turns into meanwhile.
fn read_bounded(path: &std::path::Path, len: usize) -> Option<Vec<u8>> {
    use std::io::Read;
    let fits = |m: std::fs::Metadata| m.is_file() && m.len() == len as u64;
    if !fits(std::fs::metadata(path).ok()?) {
        return None;
    }
    let file = std::fs::File::open(path).ok()?;
    if !fits(file.metadata().ok()?) {
        return None;
    }
    let mut bytes = Vec::with_capacity(len);
    file.take(len as u64 + 1).read_to_end(&mut bytes).ok()?;
    Some(bytes)
}

/// Stores the tables in `path` (atomically); false when it could not.
pub fn store(
    path: &std::path::Path,
    grid: &AngleGrid,
    spectral: &[Vec<f64>],
    integrals: &[f64],
) -> bool {
    let mut bytes = MAGIC.to_vec();
    for v in grid
        .nodes()
        .iter()
        .chain(integrals)
        .chain(spectral.iter().flatten())
    {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    if let Some(parent) = path.parent()
        && std::fs::create_dir_all(parent).is_err()
    {
        return false;
    }
    crate::files::write_atomically(path, |tmp| {
        std::fs::write(tmp, &bytes).map_err(|source| crate::files::FileError::Io {
            path: path.to_owned(),
            source,
        })
    })
    .is_ok()
}
