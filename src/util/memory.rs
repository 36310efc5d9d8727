//! The memory budget and the one guard every door uses before a large allocation (issue 30): the
//! command line (`rule`, `run`, `validate`, `render`) and the Python package (`Rule`,
//! `q_inverse`, `weights`, `fit`, `run`, and through them the Mitsuba integrator).
//!
//! **The budget.** `WORKBENCH_MEMORY` (bytes, or with a unit: `512MiB`, `8GiB`, `8G`, `1.5e9`)
//! if set; otherwise 3/4 of the smallest of the machine's memory (`MemTotal` in `/proc/meminfo`),
//! the control group's limit (`memory.max`, cgroup v2, or `memory.limit_in_bytes`, v1) and the
//! process's address-space and data limits (`ulimit -v`, `ulimit -d`, from `/proc/self/limits`);
//! the quarter left is for what the estimates leave out (the program, its other buffers, the
//! Python interpreter). Without `/proc` (not Linux) and without the variable: no budget.
//!
//! **The guard.** [`check`] compares an estimate (from the functions here and their callers:
//! `8 N²` bytes per dense `N × N` matrix) with the budget and says, in one line, what needs how
//! much and what the budget is; callers turn it into their error (exit 2 naming the flag or field,
//! a `ValueError` naming the argument). [`try_zeros`] allocates a large buffer fallibly, so that
//! an allocation the budget let through but the system refuses is the same error, not an abort.
//!
//! A leaf: it imports nothing from the rest of the crate; messages are strings.

use std::path::Path;

/// The environment variable that sets the budget.
pub const ENV: &str = "WORKBENCH_MEMORY";

/// The share of the machine's (or the limits') memory the default budget takes.
const DEFAULT_SHARE: f64 = 0.75;

/// How many bytes the program may plan to use, and where that figure comes from.
#[derive(Clone, Debug, PartialEq)]
pub struct Budget {
    /// `None`: no budget known (no `/proc`, no variable).
    pub bytes: Option<u64>,
    /// For messages: `WORKBENCH_MEMORY=8GiB`, `3/4 of the machine's 23.4 GiB`, ….
    pub source: String,
}

impl Budget {
    /// The budget now: `WORKBENCH_MEMORY` if set (an `Err` naming it when malformed), else the
    /// default of the module documentation.
    pub fn current() -> Result<Budget, String> {
        if let Some(v) = std::env::var_os(ENV) {
            let text = v.to_string_lossy().into_owned();
            let bytes = parse_bytes(&text).ok_or_else(|| {
                format!(
                    "{ENV}: {text:?} is not an amount of memory; give bytes (1500000000, 1.5e9) or a \
                     number with a unit (512MiB, 8GiB, 8G)"
                )
            })?;
            return Ok(Budget {
                bytes: Some(bytes),
                source: format!("{ENV}={text}"),
            });
        }
        Ok(default_budget())
    }

    /// `Err` with one line — `what needs 32.0 GiB (34359738368 bytes); the memory budget is …` —
    /// when `needed` exceeds the budget.
    pub fn check(&self, what: &str, needed: u64) -> Result<(), String> {
        match self.bytes {
            Some(budget) if needed > budget => Err(format!(
                "{what} needs {} ({needed} bytes) of memory, more than the budget of {} ({}); use \
                 fewer points or models, or set {ENV} (e.g. {ENV}=64GiB) if the machine has the memory",
                human(needed),
                human(budget),
                self.source
            )),
            _ => Ok(()),
        }
    }
}

/// [`Budget::check`] with the [current](Budget::current) budget, then a [`probe`] of `needed`: a
/// limit the budget does not see (a `ulimit` set after the budget was read, a full machine) is
/// the same one-line error rather than an abort later.
pub fn check(what: &str, needed: u64) -> Result<(), String> {
    Budget::current()?.check(what, needed)?;
    probe(needed, what)
}

/// Bytes of an `n × n` matrix of `f64`: `8 n²`, saturating.
pub fn matrix_bytes(n: usize) -> u64 {
    (n as u64).saturating_mul(n as u64).saturating_mul(8)
}

/// `len` zeros, allocated fallibly: the same one-line error as [`check`] (with `what`) when the
/// system refuses the allocation, instead of an abort.
pub fn try_zeros(len: usize, what: &str) -> Result<Vec<f64>, String> {
    let mut v = try_capacity(len, what)?;
    v.resize(len, 0.0);
    Ok(v)
}

/// Tries to allocate `bytes` and frees them again: before a library call that allocates that much
/// without a fallible path (the dense factor's buffer), so that a refused allocation is an error
/// here rather than an abort there.
pub fn probe(bytes: u64, what: &str) -> Result<(), String> {
    try_capacity(usize::try_from(bytes / 8).unwrap_or(usize::MAX), what).map(drop)
}

/// An empty vector with room for `len` values, or the error.
fn try_capacity(len: usize, what: &str) -> Result<Vec<f64>, String> {
    let mut v: Vec<f64> = Vec::new();
    let bytes = (len as u64).saturating_mul(8);
    v.try_reserve_exact(len).map_err(|_| {
        format!(
            "{what} needs {} ({bytes} bytes) of memory, and the system refused to allocate it; use \
             fewer points or models, or free memory",
            human(bytes)
        )
    })?;
    Ok(v)
}

/// `512 bytes`, `12.0 MiB`, `32.0 GiB`.
pub fn human(bytes: u64) -> String {
    const KIB: f64 = 1024.0;
    let b = bytes as f64;
    if b >= KIB * KIB * KIB * KIB {
        format!("{:.1} TiB", b / (KIB * KIB * KIB * KIB))
    } else if b >= KIB * KIB * KIB {
        format!("{:.1} GiB", b / (KIB * KIB * KIB))
    } else if b >= KIB * KIB {
        format!("{:.1} MiB", b / (KIB * KIB))
    } else if b >= KIB {
        format!("{:.1} KiB", b / KIB)
    } else {
        format!("{bytes} bytes")
    }
}

/// `1500000000`, `1.5e9`, `512MiB`, `8 GiB`, `8G`, `64k` (binary units; `B` optional).
pub fn parse_bytes(text: &str) -> Option<u64> {
    let t = text.trim();
    let split = t
        .find(|c: char| c.is_ascii_alphabetic() && c != 'e' && c != 'E')
        .unwrap_or(t.len());
    let (number, unit) = (t[..split].trim(), t[split..].trim().to_ascii_lowercase());
    let value: f64 = number.parse().ok()?;
    let power = match unit.as_str() {
        "" | "b" => 0,
        "k" | "kb" | "kib" => 1,
        "m" | "mb" | "mib" => 2,
        "g" | "gb" | "gib" => 3,
        "t" | "tb" | "tib" => 4,
        _ => return None,
    };
    let bytes = value * 1024f64.powi(power);
    (0.0..1.8e19).contains(&bytes).then_some(bytes as u64)
}

/// 3/4 of the smallest of the machine's memory and the limits on this process.
fn default_budget() -> Budget {
    let mut limits: Vec<(u64, String)> = Vec::new();
    if let Some(total) = meminfo_total() {
        limits.push((total, format!("the machine's {}", human(total))));
    }
    for (path, what) in [
        ("/sys/fs/cgroup/memory.max", "the control group's limit"),
        (
            "/sys/fs/cgroup/memory/memory.limit_in_bytes",
            "the control group's limit",
        ),
    ] {
        if let Some(v) = read_number(Path::new(path)) {
            limits.push((v, format!("{what} of {}", human(v))));
        }
    }
    for (row, what) in [("Max address space", "ulimit -v"), ("Max data size", "ulimit -d")] {
        if let Some(v) = process_limit(row) {
            limits.push((v, format!("the process limit ({what}) of {}", human(v))));
        }
    }
    match limits.into_iter().min_by_key(|l| l.0) {
        Some((bytes, what)) => Budget {
            bytes: Some((bytes as f64 * DEFAULT_SHARE) as u64),
            source: format!("3/4 of {what}; {ENV} sets another"),
        },
        None => Budget {
            bytes: None,
            source: format!("no budget: the machine's memory is unknown and {ENV} is not set"),
        },
    }
}

fn meminfo_total() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib.saturating_mul(1024))
}

/// A number in a small file (`max` and unreadable: none).
fn read_number(path: &Path) -> Option<u64> {
    let text = std::fs::read_to_string(path).ok()?;
    let v: u64 = text.trim().parse().ok()?;
    // cgroup v1 writes "no limit" as a huge number near 2^63.
    (v < 1 << 60).then_some(v)
}

/// The soft limit of a row of `/proc/self/limits` in bytes (`unlimited`: none).
fn process_limit(row: &str) -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = text.lines().find(|l| l.starts_with(row))?;
    line[row.len()..].split_whitespace().next()?.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn amounts_of_memory_read_as_written() {
        assert_eq!(parse_bytes("1500000000"), Some(1_500_000_000));
        assert_eq!(parse_bytes("1.5e9"), Some(1_500_000_000));
        assert_eq!(parse_bytes("512MiB"), Some(512 << 20));
        assert_eq!(parse_bytes("8 GiB"), Some(8 << 30));
        assert_eq!(parse_bytes("8G"), Some(8 << 30));
        assert_eq!(parse_bytes("64k"), Some(64 << 10));
        assert_eq!(parse_bytes("2TB"), Some(2 << 40));
        for bad in ["", "lots", "-1", "8 parsecs", "1e400", "NaN", "8ib"] {
            assert_eq!(parse_bytes(bad), None, "{bad:?}");
        }
    }

    #[test]
    fn the_guard_names_the_need_and_the_budget() {
        let b = Budget {
            bytes: Some(1 << 30),
            source: "test".into(),
        };
        assert!(b.check("x", 1 << 30).is_ok());
        let m = b.check("n: 65536 points", matrix_bytes(65536)).unwrap_err();
        assert!(
            m.starts_with("n: 65536 points needs 32.0 GiB (34359738368 bytes) of memory, more than the budget of 1.0 GiB (test)"),
            "{m}"
        );
        let none = Budget {
            bytes: None,
            source: "none".into(),
        };
        assert!(none.check("x", u64::MAX).is_ok());
        assert_eq!(human(512), "512 bytes");
        assert_eq!(human(12 << 20), "12.0 MiB");
    }

    #[test]
    fn a_refused_allocation_is_an_error_not_an_abort() {
        let m = try_zeros(usize::MAX / 8, "a test").unwrap_err();
        assert!(m.contains("the system refused to allocate it"), "{m}");
        assert!(probe(u64::MAX, "a test").is_err());
        assert_eq!(try_zeros(3, "a test").unwrap(), vec![0.0; 3]);
    }
}
