//! Ctrl-C, `kill` and a closed terminal: an interrupted command removes the temporary files it
//! was writing (which destructors would remove, but a signal runs none) and exits as a shell
//! expects, 128 + the signal's number: 130 for SIGINT, 143 for SIGTERM, 129 for SIGHUP.
//!
//! A file-size limit (`ulimit -f`) is met as a full disk is: SIGXFSZ is ignored, so the write
//! fails, and the writer removes its temporary file and reports the error.

/// Installs the handler: a thread that waits for SIGINT, SIGTERM or SIGHUP. Call it once,
/// first thing.
#[cfg(unix)]
pub fn install() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    // SAFETY: setting a signal's disposition to "ignore" runs no code in the handler context.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
    // Without a handler the signal's default action still ends the process; only the cleanup
    // of temporary files is lost, which a later run does (stale files of gone processes).
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
        return;
    };
    std::thread::spawn(move || {
        if let Some(signal) = signals.forever().next() {
            volmap::io::atomic::remove_live_temporaries_and_exit(128 + signal);
        }
    });
}

/// Elsewhere the signal's default action ends the process; a later run removes its stale
/// temporary files where it can tell their process is gone.
#[cfg(not(unix))]
pub fn install() {}
