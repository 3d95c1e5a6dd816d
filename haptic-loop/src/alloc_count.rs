//! A counting global allocator: proves the RT thread allocates nothing after init.
//!
//! Install [`CountingAllocator`] as `#[global_allocator]` in a binary or test. Threads that
//! call [`count_this_thread`]`(true)` have every allocation and reallocation they make
//! counted in one process-wide counter; other threads cost one thread-local read per
//! allocation. The haptic-loop binary installs it, so the demo summary's "allocations per
//! tick" is measured on the real RT thread, not estimated.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicU64, Ordering};

thread_local! {
    // `const` initialisation: reading it never allocates (no lazy init, no destructor).
    static COUNTING: Cell<bool> = const { Cell::new(false) };
}

static COUNTED: AtomicU64 = AtomicU64::new(0);

/// The system allocator plus a counter of allocations made by marked threads.
#[derive(Debug, Default)]
pub struct CountingAllocator;

impl CountingAllocator {
    #[inline]
    fn note(&self) {
        if COUNTING.with(Cell::get) {
            COUNTED.fetch_add(1, Ordering::Relaxed);
        }
    }
}

// SAFETY: every method forwards to `System` unchanged; the counting touches only a
// thread-local `Cell<bool>` and an atomic, neither of which allocates.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        self.note();
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        self.note();
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        self.note();
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
}

/// Starts or stops counting the allocations of the calling thread.
pub fn count_this_thread(on: bool) {
    COUNTING.with(|c| c.set(on));
}

/// Allocations counted so far, over all marked threads.
pub fn counted() -> u64 {
    COUNTED.load(Ordering::Relaxed)
}

/// Whether [`CountingAllocator`] is the global allocator of this process, found by making
/// one counted allocation. Without it [`counted`] stays 0, and a report must say "not
/// measured" rather than "zero".
pub fn is_installed() -> bool {
    let before = counted();
    count_this_thread(true);
    let probe = std::hint::black_box(Box::new(0u64));
    count_this_thread(false);
    drop(probe);
    counted() > before
}
