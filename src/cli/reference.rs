//! `volmap cli-reference` (hidden): the command-line reference as Markdown, walked from the clap
//! definitions themselves, so the page in `docs/cli.md` cannot drift from the binary (a test
//! compares the two).

use std::fmt::Write;
use std::process::ExitCode;

use clap::{Arg, ArgAction, Command};

use super::failure::Failure;

/// Prints the reference of `root` (the whole command line, `Cli::command()`).
pub fn run(mut root: Command) -> Result<ExitCode, Failure> {
    // Building sets each subcommand's full name (`volmap test positioning`) for its usage line.
    root.build();
    outln!("{}", markdown(&root));
    Ok(ExitCode::SUCCESS)
}

/// The page: what it is, a list of the commands, then each command with its arguments.
fn markdown(root: &Command) -> String {
    let mut page = String::new();
    let name = root.get_name();
    page += "# Command-line reference\n\n";
    page += &format!(
        "Every command and argument of `{name}`, with its help, default and possible values. \
         This page is generated from the command line's own definitions by the hidden command \
         `{name} cli-reference`; `VOLMAP_BLESS=1 cargo test docs` writes it again, and the \
         tests fail when it differs from what the binary prints.\n\n"
    );
    if let Some(about) = root.get_long_about().or(root.get_about()) {
        page += &format!("{about}\n\n");
    }
    page += "| command | what it does |\n| --- | --- |\n";
    for command in visible(root) {
        contents(command, &[name], &mut page);
    }
    page += "\nEvery command also takes `-h` (a summary of its help) and `--help` (all of it); ";
    page += &format!("`{name} --version` prints the version.\n");
    for command in visible(root) {
        section(command, &[name], 2, &mut page);
    }
    page.truncate(page.trim_end().len());
    page
}

/// The subcommands a user sees: not `help`, not hidden ones such as this one.
fn visible(command: &Command) -> impl Iterator<Item = &Command> {
    command
        .get_subcommands()
        .filter(|c| !c.is_hide_set() && c.get_name() != "help")
}

/// One row of the list of commands per command and nested command, linking to its section.
fn contents(command: &Command, parents: &[&str], page: &mut String) {
    let path = full_name(command, parents);
    let about = command
        .get_about()
        .map(|a| a.to_string())
        .unwrap_or_default();
    let _ = writeln!(
        page,
        "| [`{path}`](#{}) | {} |",
        path.replace(' ', "-"),
        one_line(&about)
    );
    let mut parents = parents.to_vec();
    parents.push(command.get_name());
    for sub in visible(command) {
        contents(sub, &parents, page);
    }
}

/// A command's section: its help, its usage, each argument; then its nested commands.
fn section(command: &Command, parents: &[&str], depth: usize, page: &mut String) {
    let path = full_name(command, parents);
    let _ = write!(page, "\n{} {path}\n\n", "#".repeat(depth));
    if let Some(about) = command.get_long_about().or(command.get_about()) {
        let _ = write!(page, "{}\n\n", about.to_string().trim_end());
    }
    let usage = command.clone().render_usage().to_string();
    let usage = usage.trim_start_matches("Usage:").trim();
    let _ = write!(page, "```text\n{usage}\n```\n");
    let args: Vec<&Arg> = command.get_arguments().filter(|a| shown(a)).collect();
    if !args.is_empty() {
        page.push('\n');
    }
    for arg in args {
        page.push_str(&argument(arg));
    }
    let mut parents = parents.to_vec();
    parents.push(command.get_name());
    for sub in visible(command) {
        section(sub, &parents, depth + 1, page);
    }
}

/// Whether an argument is listed: not hidden, not the `--help` and `--version` every command has.
fn shown(arg: &Arg) -> bool {
    !arg.is_hide_set() && !matches!(arg.get_id().as_str(), "help" | "version")
}

/// One list item: the argument as typed, then in brackets whether it is required, the values it
/// takes and its default, then its help.
fn argument(arg: &Arg) -> String {
    let mut notes = Vec::new();
    if arg.is_required_set() {
        notes.push("required".to_string());
    }
    if matches!(arg.get_action(), ArgAction::Append) {
        notes.push("repeatable".to_string());
    }
    if takes_value(arg) {
        let values: Vec<String> = arg
            .get_possible_values()
            .iter()
            .filter(|v| !v.is_hide_set())
            .map(|v| match v.get_help() {
                Some(help) => format!("`{}` ({})", v.get_name(), one_line(&help.to_string())),
                None => format!("`{}`", v.get_name()),
            })
            .collect();
        if !values.is_empty() {
            notes.push(format!("one of {}", values.join(", ")));
        }
        let defaults: Vec<String> = arg
            .get_default_values()
            .iter()
            .map(|v| v.to_string_lossy().to_string())
            .filter(|v| !v.is_empty())
            .map(|v| format!("`{v}`"))
            .collect();
        if !defaults.is_empty() {
            notes.push(format!("default {}", defaults.join(", ")));
        }
    }
    let mut item = format!("- `{}`", spelling(arg));
    if !notes.is_empty() {
        item += &format!(" ({})", notes.join("; "));
    }
    let help = arg
        .get_long_help()
        .or(arg.get_help())
        .map(|h| h.to_string())
        .unwrap_or_default();
    if !help.is_empty() {
        item += ": ";
        item += &indent(help.trim_end());
    }
    item.push('\n');
    item
}

/// How the argument is typed: `--grid <GRID>`, `--half`, `<FIELD>` for a positional one.
fn spelling(arg: &Arg) -> String {
    let value = arg
        .get_value_names()
        .map(|names| {
            names
                .iter()
                .map(|n| format!("<{n}>"))
                .collect::<Vec<_>>()
                .join(" ")
        })
        .unwrap_or_else(|| format!("<{}>", arg.get_id().as_str().to_uppercase()));
    let flag = match (arg.get_long(), arg.get_short()) {
        (Some(long), Some(short)) => format!("-{short}, --{long}"),
        (Some(long), None) => format!("--{long}"),
        (None, Some(short)) => format!("-{short}"),
        (None, None) => return value,
    };
    if takes_value(arg) {
        format!("{flag} {value}")
    } else {
        flag
    }
}

fn takes_value(arg: &Arg) -> bool {
    arg.get_action().takes_values()
}

/// `volmap test positioning` for `positioning` under `volmap test`.
fn full_name(command: &Command, parents: &[&str]) -> String {
    let mut words = parents.to_vec();
    words.push(command.get_name());
    words.join(" ")
}

/// A help text in a table cell: its lines joined, a `|` escaped so it does not end the cell.
fn one_line(text: &str) -> String {
    text.split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
        .replace('|', "\\|")
}

/// A help text of several paragraphs inside a list item: later lines indented to stay in it.
fn indent(text: &str) -> String {
    text.lines()
        .map(|l| {
            if l.is_empty() {
                String::new()
            } else {
                format!("  {l}")
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
        .trim_start()
        .to_string()
}
