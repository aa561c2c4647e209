//! Tree traversal: rays cross a field's hierarchy cell by cell (hierarchical DDA),
//! skipping cells where the field is zero and reporting each non-empty cell's value range.

pub mod blocks;
pub mod hdda;
pub mod majorant;

pub use crate::field::IndexRay;
pub use blocks::nonzero_blocks;
pub use hdda::{Span, Spans, clip_to_box};
pub use majorant::{MajorantGrid, MajorantSpan, MajorantSpans};
