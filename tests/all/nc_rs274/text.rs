//! Program text: line numbers, the Fanuc subprograms of a program in LinuxCNC's words, the line
//! by which a program has named every axis.

use std::collections::HashMap;

/// The text of each line with an `N` word, by that number.
pub fn numbered_lines(program: &str) -> HashMap<u32, String> {
    program
        .lines()
        .filter_map(|l| Some((label(l)?, l.trim_start().to_ascii_uppercase())))
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

/// The N words of the moves volmap leaves uncorrected by design after a home: after G28 the axes
/// it names are unknown (the reference point is the control's), and every move until a block
/// sets them all absolutely again, that block included, passes as it is; after G53 the axes it
/// names stand uncorrected until a block names them, so the moves before that one miss by their
/// error there. A scan of the text in order (subprogram bodies as they stand in it).
pub fn left_after_homes(program: &str) -> std::collections::HashSet<u32> {
    let mut left = std::collections::HashSet::new();
    // Per axis X Y Z: sent home by G28 (true) or G53 (false), not set since.
    let mut home: [Option<bool>; 3] = [None; 3];
    let mut absolute = true;
    for line in program.lines() {
        let code: String = line
            .split(['(', ';'])
            .next()
            .unwrap()
            .to_ascii_uppercase()
            .replace(' ', "");
        let label: Option<u32> = code.strip_prefix('N').and_then(|r| {
            r.chars()
                .take_while(char::is_ascii_digit)
                .collect::<String>()
                .parse()
                .ok()
        });
        let g = |n: &str| {
            code.match_indices(&format!("G{n}"))
                .any(|(i, m)| !code[i + m.len()..].starts_with(|c: char| c.is_ascii_digit()))
        };
        if g("91") {
            absolute = false;
        }
        if g("90") {
            absolute = true;
        }
        let named: [bool; 3] = std::array::from_fn(|d| code.contains(['X', 'Y', 'Z'][d]));
        if g("28") || g("53") {
            for d in (0..3).filter(|&d| named[d]) {
                home[d] = Some(g("28"));
            }
            continue;
        }
        if !named.iter().any(|&n| n) || home.iter().all(Option::is_none) {
            continue;
        }
        let g28 = home.contains(&Some(true));
        let g53_all_named = (0..3).all(|d| home[d] != Some(false) || named[d]);
        if g28 || !g53_all_named {
            if let Some(n) = label {
                left.insert(n);
            }
        }
        for d in (0..3).filter(|&d| named[d]) {
            if home[d] == Some(false) || absolute {
                home[d] = None;
            }
        }
    }
    left
}

/// The N word a line starts with.
pub fn label(line: &str) -> Option<u32> {
    let rest = line.trim_start().strip_prefix(['N', 'n'])?;
    let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
    digits.parse().ok()
}
