//! `volmap completions SHELL`: the shell's completion script on standard output.

use std::process::ExitCode;

use super::failure::Failure;

#[derive(clap::Args)]
pub struct CompletionsArgs {
    /// The shell: bash, zsh, fish, powershell or elvish. Bash: `volmap completions bash >
    /// ~/.local/share/bash-completion/completions/volmap`; zsh: into a folder of `$fpath` as
    /// `_volmap`; fish: `~/.config/fish/completions/volmap.fish`.
    shell: clap_complete::Shell,
}

pub fn run(args: CompletionsArgs, mut command: clap::Command) -> Result<ExitCode, Failure> {
    let mut script = Vec::new();
    clap_complete::generate(args.shell, &mut command, "volmap", &mut script);
    out!("{}", String::from_utf8_lossy(&script));
    Ok(ExitCode::SUCCESS)
}
