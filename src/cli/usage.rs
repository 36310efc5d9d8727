//! What clap parses and how its refusals read: every option that takes a value also takes a
//! negative number, and a usage error is one line naming the flag and the value, like every
//! other bad input (issue 42).
//!
//! Why: `--spp -4` and `--tolerance -1e-6` were clap's four-line "unexpected argument '-1'",
//! naming neither the flag nor the value, and clap's other errors ended in a usage block and
//! "For more information, try '--help'.". Here `-4` reaches the flag's parser and the project's
//! checks, and a value the parser refuses is `--spp: must be a whole number ≥ 0, got -4`.

use clap::error::{ContextKind, ContextValue, ErrorKind};
use std::num::{IntErrorKind, ParseFloatError, ParseIntError};

/// `cmd` with negative numbers accepted as the values of its options and of every subcommand's
/// options, at any depth, so that a new subcommand or option gets it without being listed.
/// clap's own test for a negative number knows no negative exponent (`-1e-6` is to it a flag),
/// so a numeric option (its parser yields a number) takes any value that starts with `-`, and
/// its parser names what is wrong; other options take negative numbers only, so that a
/// forgotten path (`--out --quiet`) is still a usage error.
pub fn with_negative_numbers(cmd: clap::Command) -> clap::Command {
    let numeric: Vec<clap::Id> = cmd
        .get_arguments()
        .filter(|a| is_numeric(a))
        .map(|a| a.get_id().clone())
        .collect();
    let cmd = numeric
        .into_iter()
        .fold(cmd.allow_negative_numbers(true), |cmd, id| {
            cmd.mut_arg(id, |a| a.allow_hyphen_values(true))
        });
    let names: Vec<String> = cmd.get_subcommands().map(|c| c.get_name().to_owned()).collect();
    names
        .into_iter()
        .fold(cmd, |cmd, name| cmd.mut_subcommand(name, with_negative_numbers))
}

/// Whether `arg` takes a value that its parser reads as a number.
fn is_numeric(arg: &clap::Arg) -> bool {
    use std::any::TypeId;
    let id = arg.get_value_parser().type_id();
    arg.get_num_args().is_none_or(|n| n.takes_values())
        && !arg.is_positional()
        && [
            TypeId::of::<f64>(),
            TypeId::of::<usize>(),
            TypeId::of::<u64>(),
            TypeId::of::<u32>(),
            TypeId::of::<i64>(),
        ]
        .iter()
        .any(|t| id == *t)
}

/// A clap usage error as one line without the `Error: ` prefix: for a value that its flag's
/// parser refused, `FLAG: REASON, got VALUE` (the project's form); for any other error, clap's
/// first paragraph joined into one line, with its tips (`a similar argument exists: '--out'`)
/// after a `;` and without the usage block and the "try '--help'" line.
pub fn one_line(e: &clap::Error) -> String {
    if let Some(line) = invalid_value(e) {
        return line;
    }
    let text = e.render().to_string();
    let mut paragraphs = text.split("\n\n").map(str::trim).filter(|p| !p.is_empty());
    let first = paragraphs.next().unwrap_or_default();
    let mut line = first.lines().map(str::trim).collect::<Vec<_>>().join(" ");
    if let Some(rest) = line.strip_prefix("error: ") {
        line = rest.to_owned();
    }
    for tip in paragraphs
        .flat_map(str::lines)
        .filter_map(|l| l.trim().strip_prefix("tip: "))
    {
        line.push_str("; ");
        line.push_str(tip);
    }
    line
}

/// `FLAG: REASON, got VALUE` for a value its flag's parser refused (`ValueValidation`) or that
/// is not among the flag's possible values (`InvalidValue`); `None` for any other error.
fn invalid_value(e: &clap::Error) -> Option<String> {
    let string = |kind| match e.get(kind) {
        Some(ContextValue::String(s)) => Some(s.clone()),
        _ => None,
    };
    // `--spp <SPP>` → `--spp`; a positional `<SPEC.json>` stays as it is.
    let arg = string(ContextKind::InvalidArg)?;
    let flag = arg.split(' ').next().unwrap_or(&arg).to_owned();
    let value = string(ContextKind::InvalidValue)?;
    match e.kind() {
        ErrorKind::ValueValidation => {
            let source = std::error::Error::source(e)?;
            let reason = if let Some(p) = source.downcast_ref::<ParseIntError>() {
                integer_reason(p, &value)
            } else if source.downcast_ref::<ParseFloatError>().is_some() {
                "must be a number".to_owned()
            } else {
                // The flag's own parser (`--integrator`, `--scene`) names the value itself.
                let reason = source.to_string();
                if reason.contains(&value) {
                    return Some(format!("{flag}: {reason}"));
                }
                reason
            };
            Some(format!("{flag}: {reason}, got {}", shown_value(&value)))
        }
        ErrorKind::InvalidValue => {
            let expected = match e.get(ContextKind::ValidValue) {
                Some(ContextValue::Strings(v)) => format!("; expected one of {}", v.join(", ")),
                _ => String::new(),
            };
            Some(format!("{flag}: unknown value {value:?}{expected}"))
        }
        _ => None,
    }
}

/// `--threads`: a count in the range the pool accepts, so that a refused value, negative or
/// not, is told the real range (`must be in 1..=256, got -1`), as a refused 0 is.
pub fn parse_threads(value: &str) -> Result<usize, String> {
    let max = workbench::util::threads::MAX_THREADS;
    match value.trim().parse::<i128>() {
        Ok(t) if (1..=max as i128).contains(&t) => Ok(t as usize),
        _ => Err(format!("must be in 1..={max}, got {}", shown_value(value))),
    }
}

/// Why an unsigned integer flag refused `value`.
fn integer_reason(p: &ParseIntError, value: &str) -> String {
    match p.kind() {
        IntErrorKind::Empty => "needs a value".to_owned(),
        IntErrorKind::PosOverflow => "is too large".to_owned(),
        _ if value.trim_start().starts_with('-') && value.trim_start()[1..].parse::<u128>().is_ok() => {
            "must be a whole number ≥ 0".to_owned()
        }
        _ => "must be a whole number".to_owned(),
    }
}

/// A refused value as the user typed it, cut short if it is long (a 300-digit number stays one
/// readable line).
fn shown_value(value: &str) -> String {
    const MAX: usize = 40;
    if value.chars().count() <= MAX {
        value.to_owned()
    } else {
        let head: String = value.chars().take(MAX).collect();
        format!("{head}… ({} characters)", value.chars().count())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    /// Every option that takes a value, in every subcommand, takes a negative number, and every
    /// numeric one any value starting with `-` (`-1e-6`): the class guard, so that a flag added
    /// later cannot bring clap's "unexpected argument '-1'" back.
    #[test]
    fn every_option_of_every_subcommand_takes_negative_numbers() {
        let mut cmd = with_negative_numbers(super::super::Cli::command());
        cmd.build();
        let (mut missing, mut numeric) = (Vec::new(), 0);
        for sub in cmd.get_subcommands() {
            for arg in sub.get_arguments() {
                let takes_value = arg.get_num_args().is_some_and(|n| n.takes_values());
                let ok = if is_numeric(arg) {
                    numeric += 1;
                    arg.is_allow_hyphen_values_set()
                } else {
                    !takes_value || arg.is_allow_negative_numbers_set() || arg.is_allow_hyphen_values_set()
                };
                if !ok {
                    missing.push(format!("{} --{}", sub.get_name(), arg.get_id()));
                }
            }
        }
        assert!(missing.is_empty(), "{missing:?}");
        // --trials, --threads, --spp, --tolerance, --n, … are seen as numeric.
        assert!(numeric >= 20, "{numeric} numeric options");
    }

    #[test]
    fn refused_values_read_as_one_line_naming_flag_and_value() {
        let cmd = || with_negative_numbers(super::super::Cli::command());
        let line = |args: &[&str]| {
            let e = cmd().try_get_matches_from(args).unwrap_err();
            one_line(&e)
        };
        assert_eq!(
            line(&["workbench", "render", "--spp", "-4", "--out", "x.exr"]),
            "--spp: must be a whole number ≥ 0, got -4"
        );
        assert_eq!(
            line(&["workbench", "run", "x.json", "--threads=-1"]),
            "--threads: must be in 1..=256, got -1"
        );
        assert_eq!(
            line(&["workbench", "reproduce", "--threads", "300"]),
            "--threads: must be in 1..=256, got 300"
        );
        assert_eq!(
            line(&["workbench", "render", "--spp", "--out", "x.exr"]),
            "--spp: must be a whole number, got --out"
        );
        assert_eq!(
            line(&["workbench", "render", "--tolerance", "abc", "--out", "x.exr"]),
            "--tolerance: must be a number, got abc"
        );
        assert_eq!(
            line(&["workbench", "rule", "--n", "99999999999999999999999"]),
            "--n: is too large, got 99999999999999999999999"
        );
        let unknown = line(&["workbench", "run", "x.json", "--outt", "d"]);
        assert!(
            unknown.starts_with("unexpected argument '--outt' found"),
            "{unknown}"
        );
        assert!(
            !unknown.contains('\n') && !unknown.contains("--help"),
            "{unknown}"
        );
    }
}
