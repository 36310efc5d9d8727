//! `workbench data`: the catalogue of external files, and which of them are present and intact
//! in the data folder (`--data DIR` or `WORKBENCH_DATA`).

use super::output::{status, stdout};
use std::fmt::Write as _;
use std::process::ExitCode;
use workbench::data::{self, DataError, catalog};

/// Options of `workbench data`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:\n  \
    workbench data --data ../shared/data\n  \
    WORKBENCH_DATA=../shared/data workbench data\n  \
    workbench data --list\n\n\
    Without --list every file is checked (size and sha256) in the data folder: one line on stderr \
    per file that is missing, altered or unreadable, naming its expected sha256 and where to obtain \
    it. Maps are named by catalogue name wherever a map is expected (`render --env pisa`, \
    \"env\": \"pisa\"). docs/guide/data.md.\n\n\
    Exit codes: 0 every file present and intact (or --list); 2 a file is not, no data folder is set, \
    or any other error.")]
pub struct DataArgs {
    /// Only list the catalogue; do not look at the data folder.
    #[arg(long)]
    list: bool,
}

/// A file's state in the folder, for the table.
enum State {
    Intact,
    Bad(DataError),
}

pub fn data(args: DataArgs) -> anyhow::Result<ExitCode> {
    let entries = catalog::entries();
    let folder = if args.list { None } else { data::folder()? };
    let states: Option<Vec<State>> = folder.as_ref().map(|f| {
        entries
            .iter()
            .map(|e| match data::check(f, e) {
                Ok(_) => State::Intact,
                Err(err) => State::Bad(err),
            })
            .collect()
    });
    // Sources and terms, numbered in order of first use.
    let mut sources: Vec<(&str, &str)> = Vec::new();
    let mut out = String::new();
    match &folder {
        Some(f) => writeln!(out, "data folder: {}", f.shown())?,
        None if args.list => {}
        None => writeln!(
            out,
            "data folder: none (pass --data DIR or set {})",
            data::ENV_VAR
        )?,
    }
    let name_width = entries.iter().map(|e| e.name.len()).max().unwrap_or(4);
    let state_col = states.is_some();
    write!(out, "{:name_width$}  {:7}  {:>9}  ", "name", "kind", "size")?;
    if state_col {
        write!(out, "{:8}  ", "state")?;
    }
    writeln!(out, "{:6}  path", "source")?;
    for (k, e) in entries.iter().enumerate() {
        let key = (e.source.as_str(), e.terms.as_str());
        let source = match sources.iter().position(|s| *s == key) {
            Some(i) => i + 1,
            None => {
                sources.push(key);
                sources.len()
            }
        };
        write!(
            out,
            "{:name_width$}  {:7}  {:>9}  ",
            e.name,
            e.kind.name(),
            size(e.bytes)
        )?;
        if let Some(states) = &states {
            let state = match &states[k] {
                State::Intact => "ok",
                State::Bad(DataError::File { problem, .. }) => match problem {
                    data::FileProblem::Missing => "missing",
                    data::FileProblem::Altered { .. } => "altered",
                    data::FileProblem::Unreadable(_) => "bad",
                },
                State::Bad(_) => "bad",
            };
            write!(out, "{state:8}  ")?;
        }
        writeln!(out, "{:6}  {}", format!("[{source}]"), e.path)?;
    }
    writeln!(out, "\nsources and terms:")?;
    for (i, (source, terms)) in sources.iter().enumerate() {
        writeln!(out, "[{}] {source}; terms: {terms}", i + 1)?;
    }
    let bad: Vec<&DataError> = states
        .iter()
        .flatten()
        .filter_map(|s| match s {
            State::Bad(e) => Some(e),
            State::Intact => None,
        })
        .collect();
    if let Some(states) = &states {
        writeln!(
            out,
            "\n{} files: {} intact, {} not",
            states.len(),
            states.len() - bad.len(),
            bad.len()
        )?;
    }
    stdout(&out)?;
    if args.list {
        return Ok(ExitCode::SUCCESS);
    }
    if folder.is_none() {
        status!(
            "Error: no data folder is set: pass --data DIR or set {}=DIR (the folder that holds envmaps/, thesis/, mitsuba-data/)",
            data::ENV_VAR
        );
        return Ok(ExitCode::from(2));
    }
    for e in &bad {
        status!("{e}");
    }
    Ok(if bad.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(2)
    })
}

/// `141 B`, `91.2 KiB`, `1.3 MiB`: a column of sizes of one width (the catalogue has the bytes).
fn size(n: u64) -> String {
    match n {
        0..1024 => format!("{n} B"),
        1024..1_048_576 => format!("{:.1} KiB", n as f64 / 1024.0),
        _ => format!("{:.1} MiB", n as f64 / 1_048_576.0),
    }
}
