//! The planner's heap, measured and bounded: a counting global allocator (the live heap
//! and its peak, in bytes, as the program asked for them), glibc told to give big blocks
//! back to the system when freed, and the default bound (`--max-memory-mb`).

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

/// The system allocator, counting the bytes live and the most ever live.
#[derive(Debug, Default)]
pub struct HeapMeter;

#[inline]
fn grew(bytes: usize) {
    let now = LIVE.fetch_add(bytes, Ordering::Relaxed) + bytes;
    PEAK.fetch_max(now, Ordering::Relaxed);
}

#[inline]
fn shrank(bytes: usize) {
    LIVE.fetch_sub(bytes, Ordering::Relaxed);
}

// SAFETY: every method forwards to `System` unchanged; the counting touches only atomics,
// which do not allocate.
unsafe impl GlobalAlloc for HeapMeter {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: same contract as the caller's.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            grew(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: same contract as the caller's.
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            grew(layout.size());
        }
        p
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: same contract as the caller's.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            // The old block is gone and the new one live (glibc moves big blocks with
            // mremap, without holding both).
            if new_size >= layout.size() {
                grew(new_size - layout.size());
            } else {
                shrank(layout.size() - new_size);
            }
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) };
        shrank(layout.size());
    }
}

/// Bytes live on the heap now.
pub fn live_bytes() -> usize {
    LIVE.load(Ordering::Relaxed)
}

/// The most bytes ever live at once.
pub fn peak_bytes() -> usize {
    PEAK.load(Ordering::Relaxed)
}

/// Blocks of this size and more are mapped on their own and unmapped when freed.
const MMAP_THRESHOLD_BYTES: libc::c_int = 256 * 1024;

/// Makes glibc give freed memory back: big blocks (a tree's arena and index) are mapped
/// on their own at a fixed threshold (glibc's default threshold grows with every big block
/// freed, after which big blocks stay in the heap and the process's RSS keeps what a shed
/// dropped), and each thread's arena is trimmed past 1 MB free at its top.
pub fn return_freed_memory() {
    // SAFETY: mallopt only sets allocator parameters; it is called before the planner's
    // threads start.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 1 << 20);
    }
}

/// A default bound, MiB: a quarter of the machine's memory, at most 4 GiB, at least
/// 256 MiB, and under four fifths of the cgroup's own limit (systemd's `MemoryMax`) where
/// one is set. The loop (tens of MB) and the rest of the machine keep three quarters;
/// two planners (a restarted local one and a remote one) fit twice over.
pub fn default_bound_mb() -> u64 {
    let total_mb = meminfo_total_kb().map_or(4096, |kb| kb / 1024);
    let mut mb = (total_mb / 4).clamp(256, 4096);
    if let Some(limit) = cgroup_limit_bytes() {
        mb = mb.min(limit * 4 / 5 / (1 << 20));
    }
    mb
}

fn meminfo_total_kb() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// The cgroup v2 `memory.max` of this process, when a number.
fn cgroup_limit_bytes() -> Option<u64> {
    let cgroup = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let path = cgroup.lines().find_map(|l| l.strip_prefix("0::"))?;
    let max = std::fs::read_to_string(format!("/sys/fs/cgroup{}/memory.max", path.trim())).ok()?;
    max.trim().parse().ok()
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_default_bound_is_within_its_limits() {
        let mb = super::default_bound_mb();
        assert!((1..=4096).contains(&mb), "{mb}");
    }
}
