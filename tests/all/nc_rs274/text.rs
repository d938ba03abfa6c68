//! Program text: line numbers, the Fanuc subprograms of a program in LinuxCNC's words, the line
//! by which a program has named every axis.

use std::collections::HashMap;

/// The text of each line with an `N` word, by that number.
pub fn numbered_lines(program: &str) -> HashMap<u32, String> {
    program
        .lines()
        .filter_map(|l| {
            let l = l.trim_start();
            let rest = l.strip_prefix(['N', 'n'])?;
            let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
            Some((digits.parse().ok()?, l.to_ascii_uppercase()))
        })
        .collect()
}

/// The N word of the line by which the program has named X, Y and Z. Before it an axis stands
/// where the machine started, which volmap cannot know: it takes the axis's first programmed
/// value (docs/nc.md), rs274 its zero, so the moves before it are only paired.
pub fn all_axes_named(program: &str) -> u32 {
    let mut named = [false; 3];
    for line in program.lines() {
        let code: String = line
            .split('(')
            .next()
            .unwrap()
            .to_ascii_uppercase()
            .replace(' ', "");
        for (d, letter) in ['X', 'Y', 'Z'].into_iter().enumerate() {
            named[d] |= code.contains(letter);
        }
        if named == [true; 3] {
            let digits: String = code
                .strip_prefix('N')
                .unwrap_or("")
                .chars()
                .take_while(char::is_ascii_digit)
                .collect();
            return digits.parse().unwrap_or(0);
        }
    }
    u32::MAX
}

/// `N<line>` before every code line that has no N word, so that rs274's output names the line.
pub fn with_line_numbers(program: &str) -> String {
    program
        .lines()
        .enumerate()
        .map(|(i, line)| {
            let t = line.trim_start();
            let code = t
                .chars()
                .next()
                .is_some_and(|c| "GMTSXYZFgmtsxyzf".contains(c));
            if code {
                format!("N{} {line}\n", i + 1)
            } else {
                format!("{line}\n")
            }
        })
        .collect()
}

/// A Fanuc program's subprograms as LinuxCNC writes them: the bodies after the program end
/// (`O1234` to `M99`) become `o1234 sub` … `o1234 endsub` before it, and each `M98 P1234 L n`
/// n lines `o1234 call`.
pub fn as_linuxcnc(program: &str) -> String {
    let mut main = Vec::new();
    let mut subs = Vec::new();
    let mut body: Option<String> = None;
    let mut ended = false;
    for line in program.lines() {
        let code = line.split('(').next().unwrap().trim();
        let word = |letter: char| {
            code.split_whitespace()
                .find_map(|w| w.strip_prefix(letter).map(str::to_string))
        };
        if ended && code.starts_with('O') {
            let number = code[1..].trim_start_matches('0').to_string();
            subs.push(format!("o{number} sub"));
            body = Some(number);
            continue;
        }
        if let Some(number) = &body {
            if code.ends_with("M99") {
                subs.push(format!("o{number} endsub"));
                body = None;
            } else {
                subs.push(line.to_string());
            }
            continue;
        }
        if code.split_whitespace().any(|w| w == "M98") {
            let number = word('P').unwrap().trim_start_matches('0').to_string();
            let times: usize = word('L').map_or(1, |l| l.parse().unwrap());
            for _ in 0..times {
                main.push(format!("o{number} call"));
            }
            continue;
        }
        if code.ends_with("M30") || code.ends_with("M2") {
            ended = true;
        }
        main.push(line.to_string());
    }
    let mut text = Vec::new();
    if main.first().is_some_and(|f| f == "%") {
        text.push(main.remove(0));
    }
    text.extend(subs);
    text.extend(main);
    text.join("\n") + "\n"
}

/// `line` with its X word (or a new one) at `x`.
pub fn with_x(line: &str, x: f64) -> String {
    let mut words: Vec<String> = line
        .split_whitespace()
        .filter(|w| !w.starts_with('X'))
        .map(str::to_string)
        .collect();
    words.push(format!("X{x}"));
    words.join(" ")
}
