//! Hints to the processor to fetch memory the dynamics will soon read:
//! at large N the bodies, lists and calendar slots of a collision are far
//! apart in memory, and asking for them at once overlaps their latencies.

/// Asks for every cache line of `items` at once.
#[inline]
pub(crate) fn prefetch_lines<T>(items: &[T]) {
    let bytes = std::mem::size_of_val(items);
    let start = items.as_ptr().cast::<u8>();
    for offset in (0..bytes).step_by(64) {
        prefetch_address(start.wrapping_add(offset));
    }
}

/// Asks for the cache line at `address` (a hint: nothing is read).
#[inline(always)]
pub(crate) fn prefetch_address(address: *const u8) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: SSE is part of the x86_64 baseline, and a prefetch is a hint
    // that reads and writes no memory and never faults.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(address.cast::<i8>());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = address;
}
