//! Ctrl-C and `kill`: an interrupted command removes the temporary files it was writing (which
//! destructors would remove, but a signal runs none) and exits as a shell expects, 130 for SIGINT
//! and 143 for SIGTERM (128 + the signal's number).

/// Installs the handler: a thread that waits for SIGINT or SIGTERM. Call it once, first thing.
#[cfg(unix)]
pub fn install() {
    use signal_hook::consts::{SIGINT, SIGTERM};
    // Without a handler the signal's default action still ends the process; only the cleanup
    // of temporary files is lost, which a later run does (stale files of gone processes).
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM]) else {
        return;
    };
    std::thread::spawn(move || {
        if let Some(signal) = signals.forever().next() {
            volmap::io::atomic::remove_live_temporaries();
            std::process::exit(128 + signal);
        }
    });
}

/// Elsewhere the signal's default action ends the process; a later run removes its stale
/// temporary files where it can tell their process is gone.
#[cfg(not(unix))]
pub fn install() {}
