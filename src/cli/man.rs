//! `volmap man --out DIR`: a man page per command (`volmap.1`, `volmap-map.1`,
//! `volmap-test-circular.1`, …), each written whole or not at all.

use std::path::PathBuf;
use std::process::ExitCode;

use super::failure::Failure;
use super::output::write_file;

#[derive(clap::Args)]
pub struct ManArgs {
    /// The folder the pages are written into (created); read one with `man -l DIR/volmap-map.1`
    /// or put the folder in `MANPATH` as `man1`.
    #[arg(long)]
    out: PathBuf,
}

pub fn run(args: ManArgs, command: clap::Command) -> Result<ExitCode, Failure> {
    std::fs::create_dir_all(&args.out).map_err(|e| {
        Failure::input(format!(
            "--out: cannot make the folder {}: {e}",
            args.out.display()
        ))
    })?;
    let mut command = command.disable_help_subcommand(true);
    command.build();
    let mut written = 0;
    write_pages(command, &args.out, &mut written)?;
    outln!("wrote {written} man pages into {}", args.out.display());
    Ok(ExitCode::SUCCESS)
}

/// The page of `command` and of each of its subcommands (hidden ones left out), named by clap's
/// `volmap-sub-sub.1`.
fn write_pages(command: clap::Command, out: &PathBuf, written: &mut usize) -> Result<(), Failure> {
    for sub in command.get_subcommands().filter(|s| !s.is_hide_set()) {
        write_pages(sub.clone(), out, written)?;
    }
    let man = clap_mangen::Man::new(command);
    let path = out.join(man.get_filename());
    write_file(&path, |w| man.render(w))?;
    *written += 1;
    Ok(())
}
