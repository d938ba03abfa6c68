//! The fuzzing harness's tests, one binary: short campaigns of every target and the harness's
//! own checks (`campaigns`), and the findings whose measure is the heap a reader takes (`heap`).

/// The harness counts the heap of the campaigns' threads; other threads only pass through it.
#[global_allocator]
static ALLOCATOR: volmap_fuzz::watch::CountingAllocator = volmap_fuzz::watch::CountingAllocator;

mod campaigns;
mod heap;
