//! What each execution costs: the heap it holds at most, its largest single request, and the
//! work it does counted as its allocations and the bytes they ask for in all (a counting global
//! allocator, which every binary that runs campaigns installs), and the CPU time of the thread
//! that runs it (read by that thread after each execution, and by a watchdog while it runs: only
//! to catch a hang, as a clock depends on the build and the load and a count does not).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

/// The most heap one execution may hold, or ask for at once.
pub const MEMORY_LIMIT_BYTES: u64 = 1 << 30;

/// The most allocations one execution may make: 16 for each of the 4,000,000 words an NC
/// program may expand to, the largest count of items any reader admits (subprogram calls and
/// cycles; `volmap::limits`). A reader that stays within its bounds makes far fewer; one that
/// loops without a bound passes it, in any build and under any load.
pub const MOST_ALLOCATIONS: u64 = 16 * 4_000_000;

/// The most bytes one execution's allocations may ask for in all (freed or not): the largest file
/// a reader takes (64 MiB of text), copied 256 times.
pub const MOST_ALLOCATED_BYTES: u64 = 256 * volmap::io::source::TEXT_LIMIT_BYTES;

/// A request that would take the execution beyond this is refused, not made and reported: the
/// allocation fails, so the process stops, with the input kept in the campaign's slot file.
pub const REFUSED_BYTES: u64 = 4 << 30;

thread_local! {
    static WATCHED: Cell<bool> = const { Cell::new(false) };
    static LIVE: Cell<i64> = const { Cell::new(0) };
    static PEAK: Cell<i64> = const { Cell::new(0) };
    static LARGEST: Cell<u64> = const { Cell::new(0) };
    static COUNT: Cell<u64> = const { Cell::new(0) };
    static ALLOCATED: Cell<u64> = const { Cell::new(0) };
    /// What to say of the thread when a request is refused: its target and where its input is.
    static CONTEXT: Cell<(&'static str, &'static str)> = const { Cell::new(("", "")) };
}

/// Names the target this thread runs and the file its input under way is kept in, for the
/// message of a refused request.
pub fn describe_thread(target: &'static str, slot: &'static str) {
    CONTEXT.with(|c| c.set((target, slot)));
}

/// The global allocator of a campaign's binary: the system's, counting the heap of the thread
/// being watched.
pub struct CountingAllocator;

/// Notes a request of `size` bytes; false where it is refused.
fn note_alloc(size: usize) -> bool {
    if !WATCHED.with(Cell::get) {
        return true;
    }
    let size = size as u64;
    let live = LIVE.with(|l| l.get()) + size as i64;
    if size > REFUSED_BYTES || live > REFUSED_BYTES as i64 {
        refused(size);
        return false;
    }
    LIVE.with(|l| l.set(live));
    PEAK.with(|p| p.set(p.get().max(live)));
    LARGEST.with(|l| l.set(l.get().max(size)));
    COUNT.with(|c| c.set(c.get() + 1));
    ALLOCATED.with(|a| a.set(a.get().saturating_add(size)));
    true
}

fn note_free(size: usize) {
    if WATCHED.with(Cell::get) {
        LIVE.with(|l| l.set(l.get() - size as i64));
    }
}

/// Says why the process is about to stop, without allocating.
fn refused(size: u64) {
    let mut digits = [0u8; 24];
    let mut at = digits.len();
    let mut n = size;
    loop {
        at -= 1;
        digits[at] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    let (target, slot) = CONTEXT.with(Cell::get);
    emergency(b"\nfuzz: FINDING (allocation) in ");
    emergency(target.as_bytes());
    emergency(b": a request of ");
    emergency(&digits[at..]);
    emergency(b" bytes would take the execution past 4 GiB; it is refused and the process stops; the input is kept in ");
    emergency(slot.as_bytes());
    emergency(b"\n");
}

#[cfg(unix)]
fn emergency(bytes: &[u8]) {
    // SAFETY: writing a valid buffer to standard error.
    unsafe {
        libc::write(2, bytes.as_ptr().cast(), bytes.len());
    }
}

#[cfg(not(unix))]
fn emergency(_bytes: &[u8]) {}

// SAFETY: every request goes to the system allocator unchanged; the counting touches only
// constant-initialised thread-locals, which never allocate.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if !note_alloc(layout.size()) {
            return std::ptr::null_mut();
        }
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if !note_alloc(layout.size()) {
            return std::ptr::null_mut();
        }
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        note_free(layout.size());
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note_free(layout.size());
        if !note_alloc(new_size) {
            // The old block stays the caller's.
            let _ = note_alloc(layout.size());
            return std::ptr::null_mut();
        }
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// The heap an execution used.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Usage {
    /// The most it held at once, beyond what it started with.
    pub peak_bytes: u64,
    /// Its largest single request.
    pub largest_request_bytes: u64,
    /// How many allocations it made (a growth in place counts as one).
    pub allocations: u64,
    /// The bytes they asked for in all, freed or not.
    pub allocated_bytes: u64,
}

/// Starts counting this thread's heap.
pub fn begin() {
    LIVE.with(|l| l.set(0));
    PEAK.with(|p| p.set(0));
    LARGEST.with(|l| l.set(0));
    COUNT.with(|c| c.set(0));
    ALLOCATED.with(|a| a.set(0));
    WATCHED.with(|w| w.set(true));
}

/// Stops counting; what the thread used since [`begin`].
pub fn end() -> Usage {
    WATCHED.with(|w| w.set(false));
    Usage {
        peak_bytes: PEAK.with(Cell::get).max(0) as u64,
        largest_request_bytes: LARGEST.with(Cell::get),
        allocations: COUNT.with(Cell::get),
        allocated_bytes: ALLOCATED.with(Cell::get),
    }
}

/// Whether [`CountingAllocator`] is this binary's global allocator: a campaign without it could
/// not see a large allocation, so it refuses to run.
pub fn allocator_installed() -> bool {
    begin();
    let probe: Vec<u8> = Vec::with_capacity(4096);
    std::hint::black_box(&probe);
    drop(probe);
    end().largest_request_bytes >= 4096
}

/// The CPU time a thread has used, readable from any thread (the watchdog reads the campaign
/// thread's); wall time where the platform has no per-thread clock.
#[derive(Debug, Clone, Copy)]
pub struct ThreadClock {
    #[cfg(target_os = "linux")]
    id: libc::clockid_t,
}

impl ThreadClock {
    /// The clock of the calling thread.
    pub fn current() -> ThreadClock {
        #[cfg(target_os = "linux")]
        {
            let mut id: libc::clockid_t = 0;
            // SAFETY: asks for the CPU clock of the calling thread into a valid location.
            let status = unsafe { libc::pthread_getcpuclockid(libc::pthread_self(), &mut id) };
            if status != 0 {
                id = libc::CLOCK_THREAD_CPUTIME_ID;
            }
            ThreadClock { id }
        }
        #[cfg(not(target_os = "linux"))]
        ThreadClock {}
    }

    /// Nanoseconds on this clock.
    pub fn now_ns(&self) -> u64 {
        #[cfg(target_os = "linux")]
        {
            let mut t = libc::timespec {
                tv_sec: 0,
                tv_nsec: 0,
            };
            // SAFETY: reads a clock into a valid timespec.
            unsafe { libc::clock_gettime(self.id, &mut t) };
            t.tv_sec as u64 * 1_000_000_000 + t.tv_nsec as u64
        }
        #[cfg(not(target_os = "linux"))]
        {
            use std::sync::OnceLock;
            static START: OnceLock<std::time::Instant> = OnceLock::new();
            START
                .get_or_init(std::time::Instant::now)
                .elapsed()
                .as_nanos() as u64
        }
    }
}
