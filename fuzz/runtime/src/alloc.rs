//! A global allocator that remembers the largest single request, so the operator targets can
//! check the loader's promise: it "allocates no more than the input justifies" (lrr-formats).
//! libFuzzer runs one input at a time on one thread, so a process-wide maximum is the input's.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

struct Metered;

static LARGEST: AtomicUsize = AtomicUsize::new(0);

// SAFETY: every method forwards to `System` with the caller's arguments unchanged; the meter
// only reads the sizes.
unsafe impl GlobalAlloc for Metered {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        LARGEST.fetch_max(layout.size(), Ordering::Relaxed);
        // SAFETY: forwarded contract of GlobalAlloc::alloc.
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        LARGEST.fetch_max(layout.size(), Ordering::Relaxed);
        // SAFETY: forwarded contract of GlobalAlloc::alloc_zeroed.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: forwarded contract of GlobalAlloc::dealloc.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        LARGEST.fetch_max(new_size, Ordering::Relaxed);
        // SAFETY: forwarded contract of GlobalAlloc::realloc.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static METERED: Metered = Metered;

/// The largest single allocation `run` may make for an input of `len` bytes: the loader copies
/// payloads out of the input and widens binary16 `F_k` to f32 (twice its bytes); 64 KiB covers
/// fixed-size buffers (error messages, small tables).
pub fn limit(len: usize) -> usize {
    2 * len + 64 * 1024
}

/// Runs `run` and panics when one of its allocations exceeded [`limit`]`(len)`.
pub fn check<T>(len: usize, run: impl FnOnce() -> T) -> T {
    LARGEST.store(0, Ordering::Relaxed);
    let out = run();
    let largest = LARGEST.load(Ordering::Relaxed);
    assert!(
        largest <= limit(len),
        "an allocation of {largest} bytes for an input of {len} bytes (limit {})",
        limit(len)
    );
    out
}
