//! Everything a command puts out besides its printed table: files written whole or not at all,
//! JSON, plots, progress bars on standard error.

use std::io::Write;
use std::path::{Path, PathBuf};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use volmap::io::atomic::write_atomically;
use volmap::io::source::Identity;
use volmap::plot::Drawing;

use super::failure::{Failure, FlagContext};

/// Writes to standard output. A closed standard output (`volmap … | head`) ends the command
/// quietly, as Unix tools end, with 141 (128 + SIGPIPE); any other failure to write it ends the
/// command with an error and exit code 1 (`> /dev/full`). Either way the temporary files of the
/// command are removed first, and nothing panics.
///
/// What is printed is [`volmap::error::terminal_safe`]: a name read from an input cannot drive
/// the terminal (a feature named `\e[2K\r… fit` rewriting its row).
pub fn print_out(args: std::fmt::Arguments) {
    let result = match args.as_str() {
        Some(text) => std::io::stdout().lock().write_all(text.as_bytes()),
        None => {
            let text = args.to_string();
            let safe = volmap::error::terminal_safe(&text);
            std::io::stdout().lock().write_all(safe.as_bytes())
        }
    };
    if let Err(e) = result {
        stdout_failed(&e)
    }
}

/// Writes to standard error: warnings and notes beside a command's output. A closed standard
/// error ends the command quietly as a closed standard output does; a message nobody can read
/// is dropped.
pub fn print_err(args: std::fmt::Arguments) {
    let text = args.to_string();
    let safe = volmap::error::terminal_safe(&text);
    if let Err(e) = std::io::stderr().lock().write_all(safe.as_bytes()) {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            volmap::io::atomic::remove_live_temporaries_and_exit(141)
        }
    }
}

/// Ends the command on a failed write to standard output (see [`print_out`]).
pub fn stdout_failed(error: &std::io::Error) -> ! {
    if error.kind() != std::io::ErrorKind::BrokenPipe {
        let _ = writeln!(
            std::io::stderr(),
            "error: writing to standard output: {error}"
        );
        volmap::io::atomic::remove_live_temporaries_and_exit(1)
    }
    volmap::io::atomic::remove_live_temporaries_and_exit(141)
}

/// The progress bar of long work, on standard error: `verb` (`mapping`) and what is counted
/// (`points`). `len` may be set later, when the work knows it.
pub fn progress(len: Option<u64>, verb: &str, unit: &str) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(len, ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template(&format!(
            "{{spinner}} {verb} [{{bar:40}}] {{percent:>3}}% {{human_pos}}/{{human_len}} {unit}, {{eta}} left"
        ))
        .expect("a valid template")
        .progress_chars("=> "),
    );
    bar
}

/// The folder a file written at `path` lies in (`.` for a bare file name).
pub fn out_folder(path: &std::path::Path) -> std::path::PathBuf {
    volmap::io::outputs::folder_of(path).to_path_buf()
}

/// The first line of the header of a machine file a command writes: volmap's version, the date
/// and time (UTC) and the command line that wrote it.
pub fn written_by() -> String {
    let words: Vec<String> = std::env::args()
        .skip(1)
        .map(|a| {
            if a.is_empty() || a.contains(char::is_whitespace) {
                format!("{a:?}")
            } else {
                a
            }
        })
        .collect();
    format!(
        "Written by volmap {} on {}: volmap {}",
        env!("CARGO_PKG_VERSION"),
        humantime::format_rfc3339_seconds(std::time::SystemTime::now()),
        words.join(" ")
    )
}

/// Says, once, that the GPU kernels are being built, where standard error is a terminal (as the
/// progress bars show only there): registered with [`volmap::gpu::slow::on_slow_compile`].
pub fn say_slow_compile() {
    use std::io::IsTerminal;
    static SAID: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
    if std::io::stderr().is_terminal() && !SAID.swap(true, std::sync::atomic::Ordering::SeqCst) {
        errln!("volmap: building the GPU kernels for this machine (the first run takes seconds)");
    }
}

/// Writes a file whole or not at all.
pub fn write_file(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), Failure> {
    Ok(write_atomically(path, write)?)
}

/// Copies the tables a machine file written into `folder` names as copies (`(source, name
/// relative to folder)`), each written whole; the flag `flag` is the machine file's.
pub fn copy_tables(folder: &Path, copies: &[(PathBuf, String)], flag: &str) -> Result<(), Failure> {
    for (source, name) in copies {
        let bytes = std::fs::read(source).map_err(|e| {
            Failure::from(volmap::io::FileError::read(source, e)).context(flag.to_string())
        })?;
        let dest = folder.join(name);
        if let Some(parent) = dest.parent() {
            std::fs::create_dir_all(parent).map_err(|e| {
                Failure::from(volmap::io::FileError::write(parent, e)).context(flag.to_string())
            })?;
        }
        write_file(&dest, |out| out.write_all(&bytes)).flag(flag)?;
    }
    Ok(())
}

/// Writes `value` as pretty JSON to the file `flag` names.
pub fn write_json_for(
    path: &Path,
    value: &impl serde::Serialize,
    flag: &str,
) -> Result<(), Failure> {
    let text = serde_json::to_string_pretty(value).map_err(Failure::work)?;
    write_file(path, |out| writeln!(out, "{text}")).flag(flag)
}

/// Writes a plot (SVG or PNG by the extension) to the file `flag` names and says where.
pub fn write_plot(drawing: &Drawing, path: &Path, flag: &str) -> Result<(), Failure> {
    // A text off the canvas or a legend over a curve is a bug of the plot's layout: debug builds
    // (the tests' runs of every command) refuse it rather than write a picture that misleads.
    #[cfg(debug_assertions)]
    if let Some(problem) = drawing.layout().problems().into_iter().next() {
        return Err(Failure::work(anyhow::anyhow!(
            "{}: the plot's layout: {problem}",
            path.display()
        ))
        .context(flag.to_string()));
    }
    drawing.write(path).flag(flag)?;
    errln!("plot: {}", path.display());
    Ok(())
}

/// Checks, before any work, that every plot file asked for has a format volmap writes.
pub fn check_plot_paths(paths: &[impl AsRef<Path>], flag: &str) -> Result<(), Failure> {
    for path in paths {
        volmap::plot::format_of(path.as_ref()).flag(flag)?;
    }
    Ok(())
}

/// Checks that a machine file about to be written to `path` reads back as a machine, its CSV
/// tables named from `folder` (the file's own) and lying there or below (copied there where the
/// base's lie elsewhere), as every command will read it.
pub fn check_machine_text(text: &str, path: &Path, folder: &Path) -> Result<(), Failure> {
    let name = path.display().to_string();
    volmap::model::Machine::from_toml(text, &name, Some(folder))?;
    Ok(())
}

/// Checks every output of a run before any work: each at a path of its own (two flags naming
/// one file would leave the one written last, and the run would report both), in a folder that
/// exists, not a folder, a link to nothing or a file the user could not write
/// ([`volmap::io::outputs::check_writable`]), and not a file the run has read so far. Each is
/// noted as an output of the run, so an input read later that is one of them is refused too.
///
/// Two names are one file when they resolve to one path (links followed, in the file's name or
/// its folder's) or, for files that exist, to one inode (a hard link).
pub fn check_distinct_outputs(outputs: &[(&str, Option<&Path>)]) -> Result<(), Failure> {
    let given: Vec<(&str, &Path, Identity)> = outputs
        .iter()
        .filter_map(|(flag, path)| path.map(|p| (*flag, p, Identity::of_named(p))))
        .collect();
    for (i, (flag, path, identity)) in given.iter().enumerate() {
        if let Some((first, _, _)) = given[..i].iter().find(|(_, _, other)| other.is(identity)) {
            return Err(Failure::input(format!(
                "{flag}: {} is also the output of {first}: each output needs a file of its own",
                volmap::io::shown_path(path)
            )));
        }
    }
    for (flag, path, _) in &given {
        volmap::io::source::check_not_source(path).flag(flag)?;
        volmap::io::outputs::check_writable(path).flag(flag)?;
        volmap::io::source::note_output(path);
    }
    Ok(())
}
