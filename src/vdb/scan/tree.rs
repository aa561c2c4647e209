//! The tree part of the scan: node masks, node values and leaf buffers, walked in the
//! reader's order, with every chunk header (zip sizes, Blosc frames) checked against the
//! bytes left — nothing decompressed, nothing allocated from sizes read in the file.

use super::*;

/// Codec parameters of one value chunk.
#[derive(Clone, Copy)]
pub(super) struct Codec {
    version: u32,
    compression: u32,
    half: bool,
}

pub(super) struct TreeScan {
    pub(super) version: u32,
}

impl TreeScan {
    /// Walks a tree as `read_tree` reads it: topology (root table, node masks, node
    /// values), then the leaf buffers in root-key order.
    pub(super) fn tree<R: Read + Seek>(
        &self,
        b: &mut Bytes<R>,
        v: ValueLayout,
        compression: u32,
        half: bool,
    ) -> Result<(), String> {
        let codec = Codec {
            version: self.version,
            compression,
            half,
        };
        let _buffer_count = b.i32()?;
        b.skip(v.size)?; // background
        let num_tiles = b.u32()?;
        let num_children = b.u32()?;
        // Root entries by key; a later entry replaces an earlier one, as in the reader's
        // BTreeMap. A child is recorded as the leaf count of each of its 16³ nodes.
        let mut table: BTreeMap<[i32; 3], Option<Vec<u32>>> = BTreeMap::new();
        for _ in 0..num_tiles {
            let key = b.coord()?;
            b.skip(v.size + 1)?;
            table.insert(key, None);
        }
        for _ in 0..num_children {
            let key = b.coord()?;
            let lowers = self.internal(b, v, codec, 5)?;
            table.insert(key, Some(lowers));
        }
        if v.leaf == LeafFormat::Points {
            return Ok(()); // never read past the topology here
        }
        for lowers in table.values().flatten() {
            for &leaves in lowers {
                for _ in 0..leaves {
                    self.leaf_buffers(b, v, codec)?;
                }
            }
        }
        Ok(())
    }

    /// An internal node's topology (`log2dim` 5: 32³ node; 4: 16³ node). Returns, for a
    /// 32³ node, the leaf counts of its children; for a 16³ node, its own leaf count.
    fn internal<R: Read + Seek>(
        &self,
        b: &mut Bytes<R>,
        v: ValueLayout,
        codec: Codec,
        log2dim: u32,
    ) -> Result<Vec<u32>, String> {
        let size = 1u64 << (3 * log2dim);
        let words = (size / 64) as usize;
        let child_mask = b.mask(words)?;
        let value_mask = b.mask(words)?;
        let children = popcount(&child_mask);
        let num_values = if self.version < NODE_MASK_COMPRESSION {
            size - children
        } else {
            size
        };
        self.values(b, v, codec, num_values, &value_mask, size)?;
        if log2dim == 4 {
            b.skip(children * 64)?; // leaf value masks
            return Ok(vec![children as u32]);
        }
        let mut lowers = Vec::with_capacity(children as usize);
        for _ in 0..children {
            lowers.extend(self.internal(b, v, codec, 4)?);
        }
        Ok(lowers)
    }

    fn leaf_buffers<R: Read + Seek>(
        &self,
        b: &mut Bytes<R>,
        v: ValueLayout,
        codec: Codec,
    ) -> Result<(), String> {
        match v.leaf {
            LeafFormat::Standard => {
                let mask = b.mask(8)?;
                let mut num_buffers = 1i8;
                if self.version < NODE_MASK_COMPRESSION {
                    b.skip(12)?; // origin
                    num_buffers = b.i8()?;
                }
                self.values(b, v, codec, 512, &mask, 512)?;
                let aux = Codec {
                    version: 0,
                    compression: codec.compression & ZIP,
                    half: codec.half,
                };
                for _ in 1..num_buffers.max(1) {
                    self.values(b, v, aux, 512, &mask, 512)?;
                }
                Ok(())
            }
            LeafFormat::Bool => b.skip(64 + 12 + 64),
            LeafFormat::Mask => b.skip(64 + 12),
            LeafFormat::Points => Ok(()),
        }
    }

    /// `read_compressed_values`: per-node metadata, inactive values, selection mask and
    /// the value chunk.
    fn values<R: Read + Seek>(
        &self,
        b: &mut Bytes<R>,
        v: ValueLayout,
        codec: Codec,
        dest_count: u64,
        value_mask: &[u64],
        node_size: u64,
    ) -> Result<(), String> {
        let metadata = if codec.version >= NODE_MASK_COMPRESSION {
            b.i8()?
        } else {
            6
        };
        if matches!(metadata, 2 | 4 | 5) {
            b.skip(v.size)?;
            if metadata == 5 {
                b.skip(v.size)?;
            }
        }
        if matches!(metadata, 3..=5) {
            b.skip(node_size / 8)?;
        }
        if !(0..=6).contains(&metadata) {
            return Err(format!("invalid node compression metadata {metadata}"));
        }
        let count = if codec.compression & ACTIVE_MASK != 0 && metadata != 6 {
            popcount(value_mask)
        } else {
            dest_count
        };
        if count != dest_count && dest_count != node_size {
            return Err("mask-compressed values with an unexpected buffer size".to_string());
        }
        let half_values = codec.half && v.real;
        if count == 0 && half_values {
            return Ok(());
        }
        let nbytes = count * if half_values { v.half_size } else { v.size };
        if codec.compression & (BLOSC | ZIP) == 0 {
            return b.skip(nbytes);
        }
        let n = b.i64()?;
        if n <= 0 {
            if n.unsigned_abs() != nbytes {
                return Err(format!(
                    "expected a {nbytes}-byte chunk, got a {}-byte chunk",
                    n.unsigned_abs()
                ));
            }
            return b.skip(nbytes);
        }
        let n = n as u64;
        b.need(n)?;
        if codec.compression & BLOSC != 0 && n >= 16 {
            let h = b.array::<16>()?;
            let data = u32::from_le_bytes([h[4], h[5], h[6], h[7]]);
            let block = u32::from_le_bytes([h[8], h[9], h[10], h[11]]);
            if h[2] & BLOSC_MEMCPYED == 0 && data > 0 && block > data {
                return Err(format!(
                    "a Blosc frame's block size ({block} bytes) exceeds its data size ({data} bytes)"
                ));
            }
            return b.skip(n - 16);
        }
        b.skip(n)
    }
}
