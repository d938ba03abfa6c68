//! A word while a step keeps the user waiting: the first build of a machine's GPU kernels can
//! take seconds with nothing on the screen. The command line registers what to say
//! ([`on_slow_compile`]); the library says nothing itself.

use std::sync::mpsc;
use std::sync::OnceLock;
use std::time::Duration;

/// How long a kernel build runs before the hook is called.
pub const SLOW_COMPILE: Duration = Duration::from_secs(1);

static HOOK: OnceLock<fn()> = OnceLock::new();

/// Registers what to do when building kernels takes longer than [`SLOW_COMPILE`] (once a
/// process); a second registration is ignored.
pub fn on_slow_compile(hook: fn()) {
    let _ = HOOK.set(hook);
}

/// Until dropped, calls `notify` once if `after` passes first.
pub struct Watch {
    done: Option<mpsc::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Watch {
    pub fn start(after: Duration, notify: fn()) -> Watch {
        let (done, waiting) = mpsc::channel::<()>();
        let thread = std::thread::spawn(move || {
            // A timeout (not a drop of the sender) means the step still runs.
            if let Err(mpsc::RecvTimeoutError::Timeout) = waiting.recv_timeout(after) {
                notify();
            }
        });
        Watch {
            done: Some(done),
            thread: Some(thread),
        }
    }
}

impl Drop for Watch {
    fn drop(&mut self) {
        drop(self.done.take());
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// A watch of a kernel build, where the command line asked for one.
pub fn compile_watch() -> Option<Watch> {
    HOOK.get().map(|&hook| Watch::start(SLOW_COMPILE, hook))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    static CALLS: AtomicUsize = AtomicUsize::new(0);

    fn count() {
        CALLS.fetch_add(1, Ordering::SeqCst);
    }

    #[test]
    fn the_hook_fires_only_when_the_step_outlasts_its_time() {
        drop(Watch::start(Duration::from_secs(5), count));
        assert_eq!(CALLS.load(Ordering::SeqCst), 0);
        let slow = Watch::start(Duration::from_millis(10), count);
        std::thread::sleep(Duration::from_millis(100));
        drop(slow);
        assert_eq!(CALLS.load(Ordering::SeqCst), 1);
    }
}
