//! All integration tests, one binary (the counting allocator below is global to it; it only
//! counts threads that mark themselves, i.e. the haptic loop's RT thread).

use haptic_loop::alloc_count::CountingAllocator;

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

mod alloc;
mod bridge;
mod bridge_in_planner;
mod cad_exports;
mod devices;
mod external_c;
mod issue_16;
mod live;
mod memory;
mod no_way;
mod oom;
mod ros2;
mod rt_deps;
mod security;
mod startup;
mod two_process;
mod view;
