//! Giving freed heap memory back to the system, and filling fresh memory on all threads.
//!
//! Loading and baking build large structures out of many small allocations (a decoded
//! VDB tree's leaves, a shadow bake's per-brick samples) and free them once their
//! contents are packed into a few large arrays. The allocator keeps freed small blocks for
//! reuse, still resident, so without this they would count toward the peak next to the
//! packed copy, and stay resident through the render.

/// Returns the free pages of the heap to the system (glibc's `malloc_trim`; elsewhere
/// nothing).
pub fn release_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only returns free heap memory to the system.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// Appends `parts` to `store` in order, each part copied by whichever thread takes it
/// straight into the store's spare room (not zeroed first). Where a copy is hundreds of
/// megabytes into pages it touches first (a bake's bricks, a GPU's results), one thread
/// alone is that thread's page faults and reads while the others wait.
pub fn extend_on_all_threads<T: Copy + Send + Sync>(store: &mut Vec<T>, parts: &[&[T]]) {
    use rayon::prelude::*;
    let total: usize = parts.iter().map(|p| p.len()).sum();
    if parts.len() < 2 {
        // One part (a brick pushed alone, as a cache's are): no threads to hand it to.
        parts.iter().for_each(|p| store.extend_from_slice(p));
        return;
    }
    store.reserve(total);
    let len = store.len();
    let mut room = &mut store.spare_capacity_mut()[..total];
    let mut pieces = Vec::with_capacity(parts.len());
    for &part in parts {
        let (piece, rest) = room.split_at_mut(part.len());
        pieces.push((piece, part));
        room = rest;
    }
    pieces
        .into_par_iter()
        .for_each(|(piece, part)| _ = piece.write_copy_of_slice(part));
    // SAFETY: the pieces cover the `total` elements after `len`, and each was written.
    unsafe { store.set_len(len + total) };
}

/// `parts` one after another in a new array, sized once and copied on all threads in
/// pieces of at most `piece` elements ([`extend_on_all_threads`]), however few and
/// large the parts.
pub fn concat_on_all_threads<T: Copy + Send + Sync>(parts: &[&[T]], piece: usize) -> Vec<T> {
    let pieces: Vec<&[T]> = parts.iter().flat_map(|p| p.chunks(piece.max(1))).collect();
    let mut out = Vec::new();
    extend_on_all_threads(&mut out, &pieces);
    out
}

#[cfg(test)]
mod tests {
    use super::{concat_on_all_threads, extend_on_all_threads};

    #[test]
    fn parts_copied_on_all_threads_are_the_parts_in_order() {
        // Empty parts among them, parts of every length, and a store not empty before.
        let parts: Vec<Vec<u32>> = (0..300u32)
            .map(|p| (0..(p * 37) % 1000).map(|k| p * 10_000 + k).collect())
            .collect();
        let slices: Vec<&[u32]> = parts.iter().map(Vec::as_slice).collect();
        let mut store = vec![7, 8, 9];
        extend_on_all_threads(&mut store, &slices);
        let mut expected = vec![7, 8, 9];
        for p in &parts {
            expected.extend_from_slice(p);
        }
        assert_eq!(store, expected);
        // One part (copied on this thread) and none.
        extend_on_all_threads(&mut store, &[&[5, 6]]);
        extend_on_all_threads(&mut store, &[]);
        expected.extend([5, 6]);
        assert_eq!(store, expected);
        // Parts cut into pieces of 7 (some parts shorter, one empty) join as they were.
        assert_eq!(
            concat_on_all_threads(&slices[..40], 7),
            expected[3..3 + slices[..40].iter().map(|p| p.len()).sum::<usize>()]
        );
    }
}
