//! How the grids' two arrays are bound on the GPU: `tree` (the node tables, u32) and
//! `vals` (every grid's leaf and tile values and cell ranges, f32). Each is bound whole
//! (bindings 1 and 2) while both fit the adapter's largest storage binding; else each is
//! cut into up to [`PARTS`] buffers of the same power-of-two word count, the part chosen
//! by an index's high bits (the shadow maps are cut likewise, into three). The shaders
//! read the arrays only through `tree_at(i)` and `val_at(i)`, whose source (with the
//! bindings) is generated here for the one layout or the other: a pipeline is compiled
//! for its layout, and a grid that fits pays nothing for the cut one.

use super::bind::{entry, size_text};

/// What an adapter binds: its name (for errors), the most bytes of one storage binding,
/// and the storage buffers a shader may bind.
pub struct BindingRoom<'a> {
    pub adapter: &'a str,
    pub max_binding: u64,
    pub storage_buffers: u32,
}

/// The most buffers each array is cut into.
pub const PARTS: usize = 4;
/// Where the parts of `tree` and of `vals` are bound: the first where the whole is,
/// the others after every binding a pipeline uses (the march 0–8 and its camera's 10,
/// the path tracer's uniform 9, the column march 9–12).
const TREE_BINDINGS: [u32; PARTS] = [1, 13, 14, 15];
const VALS_BINDINGS: [u32; PARTS] = [2, 16, 17, 18];
/// The largest part: 2^30 words (4 GiB), which four parts of cover every u32 index.
const MAX_SHIFT: u32 = 30;

/// The layout of the grids' arrays on the GPU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GridBinding {
    /// Each array in one buffer.
    Whole,
    /// Each array in parts of `1 << shift` words (the last shorter): word `i` lies in
    /// part `i >> shift`, at `i & ((1 << shift) − 1)`.
    Cut { shift: u32 },
}

impl GridBinding {
    /// The storage buffers a cut layout binds beyond the whole one's.
    pub const MORE_BUFFERS: u32 = 2 * (PARTS as u32 - 1);

    /// The layout for arrays of `tree_words` and `vals_words` words on the adapter
    /// `room` describes (named, in an error, `names`), for a pipeline that binds
    /// `buffers` storage buffers with them whole. Whole while both fit one binding; else cut into parts of the largest
    /// power-of-two word count one binding holds. Why not, where the parts would be
    /// more than [`PARTS`] or the adapter binds too few storage buffers for them.
    pub fn choose(
        room: &BindingRoom,
        names: [&str; 2],
        tree_words: usize,
        vals_words: usize,
        buffers: u32,
    ) -> Result<GridBinding, String> {
        let max = room.max_binding;
        let arrays = [(names[0], tree_words), (names[1], vals_words)];
        if arrays.iter().all(|&(_, w)| w as u64 * 4 <= max) {
            return Ok(GridBinding::Whole);
        }
        let part_words = max / 4;
        let shift = match part_words {
            0 => 0,
            w => (63 - w.leading_zeros()).min(MAX_SHIFT),
        };
        for (what, words) in arrays {
            if part_words == 0 || words as u64 > (PARTS as u64) << shift {
                return Err(format!(
                    "{what} ({}) exceed the largest buffer {} binds ({}) in {PARTS} parts of {}",
                    size_text(words as u64 * 4),
                    room.adapter,
                    size_text(max),
                    size_text(4u64 << shift)
                ));
            }
        }
        let binds = room.storage_buffers;
        let needs = buffers + Self::MORE_BUFFERS;
        if binds < needs {
            return Err(format!(
                "the grids' arrays exceed the largest buffer {} binds ({}), and it binds {binds} \
                 storage buffers per shader, fewer than the {needs} their parts need",
                room.adapter,
                size_text(max)
            ));
        }
        Ok(GridBinding::Cut { shift })
    }

    /// `words` cut into this layout's parts (one, whole; else each `1 << shift` words
    /// but the last).
    pub fn parts<T>(self, words: &[T]) -> Vec<&[T]> {
        match self {
            GridBinding::Whole => vec![words],
            GridBinding::Cut { shift } => words.chunks(1 << shift).collect(),
        }
    }

    /// The bind group's entries of the arrays' parts (`tree` and `vals`, from
    /// [`GridBinding::parts`]): where the cut layout has fewer parts than [`PARTS`],
    /// the last is bound again in the rest (never read).
    pub fn entries<'a>(
        self,
        tree: &'a [wgpu::Buffer],
        vals: &'a [wgpu::Buffer],
    ) -> Vec<wgpu::BindGroupEntry<'a>> {
        let bound = match self {
            GridBinding::Whole => 1,
            GridBinding::Cut { .. } => PARTS,
        };
        let mut entries = Vec::with_capacity(2 * bound);
        for (bindings, parts) in [(TREE_BINDINGS, tree), (VALS_BINDINGS, vals)] {
            for (k, &b) in bindings.iter().enumerate().take(bound) {
                if let Some(buffer) = parts.get(k).or(parts.last()) {
                    entries.push(entry(b, buffer));
                }
            }
        }
        entries
    }

    /// The WGSL of the arrays' bindings and of `tree_at` and `val_at`, compiled with
    /// grid.wgsl.
    pub fn wgsl(self) -> String {
        let GridBinding::Cut { shift } = self else {
            return "@group(0) @binding(1) var<storage, read> tree: array<u32>;\n\
                    @group(0) @binding(2) var<storage, read> vals: array<f32>;\n\
                    fn tree_at(i: u32) -> u32 { return tree[i]; }\n\
                    fn val_at(i: u32) -> f32 { return vals[i]; }\n"
                .into();
        };
        let mut s = format!(
            "const GRID_PART_SHIFT: u32 = {shift}u;\nconst GRID_PART_MASK: u32 = {}u;\n",
            (1u64 << shift) - 1
        );
        for (array, ty, bindings, get) in [
            ("tree", "u32", TREE_BINDINGS, "tree_at"),
            ("vals", "f32", VALS_BINDINGS, "val_at"),
        ] {
            for (k, b) in bindings.iter().enumerate() {
                s += &format!(
                    "@group(0) @binding({b}) var<storage, read> {array}{k}: array<{ty}>;\n"
                );
            }
            s += &format!(
                "fn {get}(i: u32) -> {ty} {{\n    let part = i >> GRID_PART_SHIFT;\n    \
                 let j = i & GRID_PART_MASK;\n"
            );
            for k in 0..PARTS - 1 {
                s += &format!("    if (part == {k}u) {{ return {array}{k}[j]; }}\n");
            }
            s += &format!("    return {array}{}[j];\n}}\n", PARTS - 1);
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_parts_hold_every_word_once_where_the_shaders_index_them() {
        for shift in [0, 1, 3, 9] {
            let binding = GridBinding::Cut { shift };
            let size = 1usize << shift;
            for words in [1, size - 1, size, size + 1, 3 * size + 1, 4 * size] {
                let words = words.max(1);
                let all: Vec<u32> = (0..words as u32).map(|w| w * 7 + 1).collect();
                let parts = binding.parts(&all);
                assert!(parts.len() <= PARTS && parts.iter().all(|p| !p.is_empty()));
                // As tree_at reads word i: part i >> shift, at i & mask.
                for (i, &v) in all.iter().enumerate() {
                    assert_eq!(parts[i >> shift][i & (size - 1)], v, "{words} words");
                }
                assert_eq!(parts.iter().map(|p| p.len()).sum::<usize>(), words);
            }
        }
        assert_eq!(GridBinding::Whole.parts(&[1, 2, 3]), vec![&[1, 2, 3][..]]);
    }

    #[test]
    fn the_whole_layout_indexes_and_the_cut_one_chooses_by_the_high_bits() {
        let whole = GridBinding::Whole.wgsl();
        assert!(whole.contains("return tree[i];") && whole.contains("return vals[i];"));
        assert!(!whole.contains("switch"));
        let cut = GridBinding::Cut { shift: 17 }.wgsl();
        assert!(cut.contains("GRID_PART_SHIFT: u32 = 17u;"));
        assert!(cut.contains("GRID_PART_MASK: u32 = 131071u;"));
        for b in TREE_BINDINGS.iter().chain(&VALS_BINDINGS) {
            assert!(cut.contains(&format!("@binding({b})")), "{b}");
        }
        assert_eq!(cut.matches("part == ").count(), 2 * (PARTS - 1));
    }
}
