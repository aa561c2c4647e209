//! Giving freed heap memory back to the system.
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
