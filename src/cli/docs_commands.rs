//! Every command the README and `docs/guide/` show, parsed by the binary's own parser, so that a
//! renamed subcommand or flag fails here until the docs follow. The convention (what counts as
//! a command, what as a placeholder) is in `docs/guide/README.md`, "Commands in these pages";
//! `tests/it/cli/docs_sync.rs` runs a representative set of them.

use super::Cli;
use clap::{CommandFactory, Parser};
use std::path::{Path, PathBuf};

/// A command as shown: where, and its words from the subcommand on.
#[derive(Debug)]
struct Shown {
    at: String,
    words: Vec<String>,
    /// In a sentence's code span rather than a code block.
    in_prose: bool,
}

impl Shown {
    /// Whether the command holds placeholders (`FILE`, `[--flag]`, `a|b`, `…`, `$VAR`, `{}`) or
    /// is only a subcommand's name (`workbench run` in a sentence), so that only its subcommand
    /// and flag names can be checked.
    fn is_synopsis(&self) -> bool {
        (self.in_prose && self.words.len() == 1) || self.words.iter().any(|w| is_placeholder(w))
    }
}

fn is_placeholder(word: &str) -> bool {
    const MARKS: [&str; 11] = ["[", "]", "|", "…", "...", "$", "{", "}", "<", ">", "*"];
    if MARKS.iter().any(|m| word.contains(m)) {
        return true;
    }
    // FILE, DIR, N, T; SPEC.json, MAP.hdr, SD.exr.
    let stem = word.split_once('.').map_or(word, |(s, _)| s);
    !stem.is_empty()
        && stem.chars().next().is_some_and(|c| c.is_ascii_uppercase())
        && stem
            .chars()
            .all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_')
}

fn doc_files() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = vec![root.join("README.md")];
    let mut guide: Vec<PathBuf> = std::fs::read_dir(root.join("docs/guide"))
        .expect("docs/guide exists")
        .map(|e| e.expect("a readable entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    guide.sort();
    files.extend(guide);
    files
}

/// The commands in `text`: lines of fenced blocks (after a `$ ` prompt, joined over trailing
/// `\` and, in blocks without prompts, over indented continuation lines) and code spans of the
/// prose; in either, from a `workbench` (or `…/workbench`) or `cargo run --release --` token on.
fn commands_in(name: &str, text: &str) -> Vec<Shown> {
    let mut found = Vec::new();
    let lines: Vec<&str> = text.lines().collect();
    let mut in_fence = false;
    let mut block_has_prompt = false;
    // A Python block is Python (`import workbench as wb`), not a command line.
    let mut python_block = false;
    let mut prose = String::new();
    let mut prose_start = 0;
    let mut k = 0;
    while k < lines.len() {
        let line = lines[k];
        if line.trim_start().starts_with("```") {
            if !in_fence {
                scan_spans(name, prose_start, &prose, &mut found);
                prose.clear();
                python_block = line.trim_start().starts_with("```python");
                // Prompted blocks show output after their commands: no indented continuations.
                block_has_prompt = lines[k + 1..]
                    .iter()
                    .take_while(|l| !l.trim_start().starts_with("```"))
                    .any(|l| l.starts_with("$ "));
            } else {
                prose_start = k + 1;
            }
            in_fence = !in_fence;
            k += 1;
            continue;
        }
        if !in_fence {
            prose.push_str(line);
            prose.push('\n');
            k += 1;
            continue;
        }
        if python_block {
            k += 1;
            continue;
        }
        let start = k;
        let mut joined = strip_comment(line.strip_prefix("$ ").unwrap_or(line)).to_string();
        let prompted = line.starts_with("$ ");
        loop {
            let continued = joined.trim_end().ends_with('\\');
            let next = lines.get(k + 1).copied().unwrap_or("```");
            let indented = !block_has_prompt
                && next.starts_with(char::is_whitespace)
                && !next.trim().is_empty()
                && find_start(&words(strip_comment(line))).is_some();
            if next.trim_start().starts_with("```") || !(continued || indented) {
                break;
            }
            joined = format!(
                "{} {}",
                joined.trim_end().trim_end_matches('\\'),
                strip_comment(next).trim()
            );
            k += 1;
        }
        if !block_has_prompt || prompted {
            push_command(format!("{name}:{}", start + 1), &joined, false, &mut found);
        }
        k += 1;
    }
    scan_spans(name, prose_start, &prose, &mut found);
    found
}

/// Code spans of prose (a span may run over a line break).
fn scan_spans(name: &str, first_line: usize, prose: &str, found: &mut Vec<Shown>) {
    let mut rest = prose;
    let mut offset = 0;
    while let Some(open) = rest.find('`') {
        let after = &rest[open + 1..];
        let Some(close) = after.find('`') else { break };
        let span = after[..close].replace('\n', " ");
        let line = first_line + 1 + prose[..offset + open].matches('\n').count();
        push_command(format!("{name}:{line}"), &span, true, found);
        offset += open + close + 2;
        rest = &after[close + 1..];
    }
}

/// A shell comment ends a line; `#` inside a word (a URL) does not.
fn strip_comment(line: &str) -> &str {
    match line.find(" #") {
        Some(i) => &line[..i],
        None => line,
    }
}

fn words(text: &str) -> Vec<String> {
    text.split_whitespace().map(String::from).collect()
}

/// Where the tool's name starts in `words`, and how many words it takes.
fn find_start(words: &[String]) -> Option<(usize, usize)> {
    words.iter().enumerate().find_map(|(i, w)| {
        let w = w.trim_start_matches(['\'', '"']);
        if w == "workbench" || w.ends_with("/workbench") {
            Some((i, 1))
        } else if w == "cargo"
            && words[i + 1..]
                .iter()
                .take(3)
                .eq(["run", "--release", "--"].iter())
        {
            Some((i, 4))
        } else {
            None
        }
    })
}

fn push_command(at: String, text: &str, in_prose: bool, found: &mut Vec<Shown>) {
    let all = words(text);
    let Some((start, len)) = find_start(&all) else {
        return;
    };
    let mut command = Vec::new();
    let mut depth = 0i32;
    for w in &all[start + len..] {
        // Shell syntax outside a synopsis's brackets ends the command.
        if depth == 0 && ["|", ";", "&&", ":::", ">", "2>", "<"].contains(&w.as_str()) {
            break;
        }
        depth += w.matches('[').count() as i32 - w.matches(']').count() as i32;
        let closes_quote = w.ends_with(['\'', '"']);
        command.push(w.trim_end_matches(['\'', '"']).to_string());
        if closes_quote {
            break;
        }
    }
    // The bare name (`workbench` in a sentence) is no command.
    if command
        .first()
        .is_some_and(|w| w.chars().all(|c| c.is_ascii_lowercase() || c == '-'))
    {
        found.push(Shown {
            at,
            words: command,
            in_prose,
        });
    }
}

fn shown_commands() -> Vec<Shown> {
    doc_files()
        .iter()
        .flat_map(|f| {
            let text = std::fs::read_to_string(f).expect("a readable doc");
            let name = f
                .strip_prefix(env!("CARGO_MANIFEST_DIR"))
                .unwrap_or(f)
                .display()
                .to_string();
            commands_in(name.trim_start_matches('/'), &text)
        })
        .collect()
}

/// For a synopsis: the subcommand exists and has every flag the synopsis names.
fn check_names(shown: &Shown) -> Result<(), String> {
    let cli = Cli::command();
    let name = &shown.words[0];
    let sub = cli
        .find_subcommand(name)
        .ok_or_else(|| format!("no subcommand {name:?}"))?;
    for word in &shown.words[1..] {
        for flag in word.split('|') {
            let flag = flag.trim_matches(['[', ']', '(', ')', ',']);
            let flag = flag.split_once('=').map_or(flag, |(f, _)| f);
            if let Some(long) = flag.strip_prefix("--") {
                if long.is_empty() || long == "help" {
                    continue;
                }
                // Global options (`--data`) belong to the top-level command.
                let global = cli
                    .get_arguments()
                    .any(|a| a.is_global_set() && a.get_long() == Some(long));
                if !global && !sub.get_arguments().any(|a| a.get_long() == Some(long)) {
                    return Err(format!("{name} has no flag --{long}"));
                }
            } else if let Some(short) = flag.strip_prefix('-')
                && short.len() == 1
                && short.chars().all(|c| c.is_ascii_alphabetic())
            {
                let c = short.chars().next().expect("one character");
                if c != 'h' && !sub.get_arguments().any(|a| a.get_short() == Some(c)) {
                    return Err(format!("{name} has no flag -{c}"));
                }
            }
        }
    }
    Ok(())
}

#[test]
fn every_command_in_the_docs_parses() {
    let shown = shown_commands();
    let mut failures = Vec::new();
    for s in &shown {
        let outcome = if s.is_synopsis() {
            check_names(s)
        } else {
            Cli::try_parse_from(std::iter::once("workbench".to_string()).chain(s.words.iter().cloned()))
                .map(|_| ())
                .map_err(|e| e.to_string().lines().next().unwrap_or_default().to_string())
        };
        if let Err(e) = outcome {
            failures.push(format!("{}: `{}`: {e}", s.at, s.words.join(" ")));
        }
    }
    if std::env::var_os("WORKBENCH_LIST_DOC_COMMANDS").is_some() {
        for s in &shown {
            println!(
                "{} {}: {}",
                if s.is_synopsis() { "S" } else { "C" },
                s.at,
                s.words.join(" ")
            );
        }
    }
    assert!(
        failures.is_empty(),
        "commands in the docs that the binary does not accept:\n{}",
        failures.join("\n")
    );
    // The extraction itself works: many commands, concrete and synopses, and every
    // subcommand shown somewhere.
    let concrete = shown.iter().filter(|s| !s.is_synopsis()).count();
    assert!(
        concrete >= 30 && shown.len() - concrete >= 10,
        "{concrete} concrete of {}",
        shown.len()
    );
    for sub in Cli::command().get_subcommands() {
        let name = sub.get_name();
        if name != "help" {
            assert!(
                shown.iter().any(|s| s.words[0] == name),
                "no doc shows `workbench {name}`"
            );
        }
    }
}

/// The extraction on a made-up page: what is a command, where it ends, what is a placeholder.
#[test]
fn commands_are_found_where_the_convention_says() {
    let page = "Run `workbench run FILE --shard i/n` or `cargo run\n--release -- validate x.json`; \
                `workbench` alone and `workbench::Error` are not commands.\n\n\
                ```\n$ cargo run --release -- rule --n 4 --out r.csv\nrule: n = 4\n$ head -2 r.csv\n```\n\n\
                ```sh\nworkbench render --integrator mc --spp 4 \\\n    --out a.exr   # a comment --not-a-flag\n\
                parallel -j 4 workbench run e.json --shard {}/4 ::: 1 2 3 4\n\
                sbatch --wrap 'workbench merge out shards/*'\n```\n\n\
                ```\nworkbench rule --n 64 [--design uniform|sobol]   # or: --points p.csv\n               [--noise 0.01 | --scale ml]\n\
                workbench reproduce\n```\n\n\
                ```python\nimport workbench as wb   # Python, not a command\n```\n";
    let found: Vec<String> = commands_in("page", page)
        .iter()
        .map(|s| {
            format!(
                "{} {}",
                if s.is_synopsis() { "S" } else { "C" },
                s.words.join(" ")
            )
        })
        .collect();
    assert_eq!(
        found,
        [
            "C run FILE --shard i/n".replace("C run FILE", "S run FILE"),
            "C validate x.json".to_string(),
            "C rule --n 4 --out r.csv".to_string(),
            "C render --integrator mc --spp 4 --out a.exr".to_string(),
            "S run e.json --shard {}/4".to_string(),
            "S merge out shards/*".to_string(),
            "S rule --n 64 [--design uniform|sobol] [--noise 0.01 | --scale ml]".to_string(),
            "C reproduce".to_string(),
        ]
    );
    let renamed = Shown {
        at: String::new(),
        words: ["render", "--integrator", "bmc", "[--sample-sets", "4]"]
            .map(String::from)
            .to_vec(),
        in_prose: false,
    };
    assert_eq!(
        check_names(&renamed),
        Err("render has no flag --sample-sets".to_string())
    );
}
