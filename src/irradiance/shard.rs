//! The irradiance protocol as a [`Job`] (issue 31): sharded, merged and resumed with the same
//! [`Shard`] split, [`Identity`], unit log and set checks as every job ([`crate::job`]).
//!
//! The **units** are the rows of the grid of normals: unit `u` holds the normals
//! `k = u·W … u·W + W − 1`, and shard `i` of `n` computes the units with `u mod n = i − 1`. A
//! normal's numbers (its exact irradiance, the error estimate, every (N, estimator)'s estimate:
//! [`NormalValues`]) depend on the normal alone, and every output is a function of them taken in
//! grid order ([`Totals`]): the log holds them as shortest round-trip decimals, so they read back
//! as the same `f64`s and a merge (or a resumed run) writes the same bytes as one run —
//! `irradiance.csv`, `table.md`, `rms_vs_n.svg` and its caption, `exact.exr`, `manifest.json`
//! (`timings.json` aside).
//!
//! The log: the identity line, the column line, then one line per normal,
//! `k,exact_r,exact_g,exact_b,error,` and the three channels of every (N, estimator) in
//! (N, estimator) order, and the row's digest ([`crate::job::unit_log`]). Read back, every
//! number must be finite, the exact irradiance and its error estimate at least 0, and the row
//! its digest's. A run writes it as `irradiance.partial.csv` in its folder while it
//! runs (the one `--resume` continues); a shard's folder keeps it as `units.csv`, beside
//! `shard.json` (`"kind": "irradiance"`, the identity, the file's path and text).

use super::{IrradiancePlan, NormalValues, Totals};
use crate::error::InputError;
use crate::files::result_folder::ResultFolder;
use crate::job::{Identity, Job, LogSet, Shard, ShardFolder, shard_set};
use crate::provenance::Build;
use crate::util::report::Reporter;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// `shard.json`'s `"kind"` for the protocol's shards.
pub const KIND: &str = "irradiance";
/// The log of a run under way, in its folder.
pub const PARTIAL_LOG: &str = "irradiance.partial.csv";

/// Normals computed together (then appended to the log at once): at least this many, in whole
/// units.
const BATCH_NORMALS: usize = 2048;

/// FNV-1a (64 bits) of `text`, hex ([`crate::util::hash`]).
fn fnv(text: &str) -> String {
    crate::util::hash::fnv1a_hex(text.bytes())
}

/// Where `run FILE --shard i/n` writes without `--out`: `results/<name>-shard-<i>-of-<n>/`.
pub fn default_out(results: &Path, plan: &IrradiancePlan, shard: Shard) -> PathBuf {
    results.join(format!("{}-shard-{}-of-{}", plan.name, shard.index, shard.count))
}

/// One log line (with its newline).
fn line(k: usize, v: &NormalValues, out: &mut String) {
    let _ = write!(
        out,
        "{k},{:e},{:e},{:e},{:e}",
        v.exact[0], v.exact[1], v.exact[2], v.error
    );
    for e in &v.estimates {
        let _ = write!(out, ",{:e},{:e},{:e}", e[0], e[1], e[2]);
    }
    out.push('\n');
}

/// Reads a line written by [`line`] for normal `k`, checked as it was written: every number
/// finite, the exact irradiance and its error estimate at least 0. The error says what is wrong.
fn parse(plan: &IrradiancePlan, k: usize, text: &str) -> Result<NormalValues, String> {
    let rules = plan.n.len() * plan.estimators.len();
    let fields: Vec<&str> = text.split(',').collect();
    if fields.len() != 5 + 3 * rules {
        return Err(format!("has {} fields, not {}", fields.len(), 5 + 3 * rules));
    }
    if fields[0] != k.to_string() {
        return Err(format!("is normal {:?} where normal {k} was expected", fields[0]));
    }
    let names = column_names(plan);
    let num = |i: usize| -> Result<f64, String> {
        match fields[i].parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(format!(
                "has {} {:?} (field {}), not a finite number",
                names[i],
                fields[i],
                i + 1
            )),
        }
    };
    let non_negative = |i: usize| -> Result<f64, String> {
        let v = num(i)?;
        if v < 0.0 {
            return Err(format!("has {} {v:?} (field {}), below 0", names[i], i + 1));
        }
        Ok(v)
    };
    let three = |i: usize| -> Result<[f64; 3], String> { Ok([num(i)?, num(i + 1)?, num(i + 2)?]) };
    Ok(NormalValues {
        exact: [non_negative(1)?, non_negative(2)?, non_negative(3)?],
        error: non_negative(4)?,
        estimates: (0..rules).map(|r| three(5 + 3 * r)).collect::<Result<_, _>>()?,
    })
}

/// The log's column names, in order.
fn column_names(plan: &IrradiancePlan) -> Vec<String> {
    let mut names: Vec<String> = ["k", "exact_r", "exact_g", "exact_b", "error"]
        .map(String::from)
        .to_vec();
    for n in &plan.n {
        for e in &plan.estimators {
            for c in ["r", "g", "b"] {
                names.push(format!("{}@{n}_{c}", e.name));
            }
        }
    }
    names
}

impl Job for IrradiancePlan {
    const KIND: &'static str = KIND;
    const UNIT_NAME: &'static str = "rows of normals";
    type Row = NormalValues;
    type Gathered = (Totals, Instant);
    type Merged = (IrradiancePlan, super::Report);

    /// The plan ([`super::plan_hash`]) and the map's content ([`IrradiancePlan::map_key`])
    /// hashed together.
    fn identity(&self, shard: Shard) -> Identity {
        Identity {
            plan_hash: fnv(&format!("{} {}", super::plan_hash(self), self.map_key())),
            seed: self.seed,
            units: self.height,
            build: Build::current(),
            shard,
        }
    }

    /// The rows of the grid.
    fn units(&self) -> usize {
        self.height
    }

    fn rows_per_unit(&self) -> usize {
        self.width
    }

    fn columns(&self) -> String {
        column_names(self).join(",")
    }

    fn parse_row(&self, unit: usize, k: usize, line: &str) -> Result<NormalValues, String> {
        parse(self, unit * self.width + k, line)
    }

    /// The file is read back from the first shard's record and resolved again (its map must be
    /// readable, and be the one the shards ran under).
    fn from_record(first: &ShardFolder) -> Result<IrradiancePlan, InputError> {
        let at = first.record();
        let bad = |m: String| InputError::new(format!("merge: {}: {m}", at.display()));
        let text = first.job_text("text")?;
        let spec: super::IrradianceSpec = crate::files::spec_json::parse(text, "the irradiance file")
            .map_err(|m| bad(format!("\"job\": {m}")))?;
        let plan = super::resolve(&spec).map_err(|m| bad(format!("\"job\": {m}")))?;
        if plan.identity(Shard::WHOLE).plan_hash != first.identity.plan_hash {
            return Err(bad(format!(
                "the file resolves to another plan than the one its shards ran (its map, {}, changed?)",
                plan.env_name
            )));
        }
        Ok(plan)
    }

    fn gather(&self) -> Self::Gathered {
        (Totals::new(self), Instant::now())
    }

    fn push(&self, gathered: &mut Self::Gathered, _unit: usize, _k: usize, row: NormalValues) {
        gathered.0.push(&row);
    }

    /// The files one run writes, byte for byte (`timings.json` aside).
    fn write_merged(
        self,
        out: &Path,
        set: &[ShardFolder],
        _logs: &LogSet,
        (totals, start): Self::Gathered,
        _reporter: &dyn Reporter,
    ) -> crate::Result<(IrradiancePlan, super::Report)> {
        let plan = self;
        let (exact, rows) = totals.finish(&plan);
        let mut folder = ResultFolder::prepare_merge(
            out,
            set.iter().map(|s| s.dir.as_path()),
            super::export::legacy_manifest_files,
        )?;
        super::export::write(&mut folder, &plan, &exact, &rows)?;
        let wall_seconds = start.elapsed().as_secs_f64();
        // The merge's own seconds, without the plan hash: `reproduce` does not take them for the
        // protocol's time.
        folder.commit(
            super::export::manifest(&plan, &exact, &rows),
            serde_json::json!({ "merge_seconds": wall_seconds }),
        )?;
        Ok((
            plan,
            super::Report {
                out_dir: out.to_path_buf(),
                rows,
                wall_seconds,
                threads: 1,
                resumed: 0,
            },
        ))
    }
}

/// Computes the units of `shard`, appending each batch's lines to the log at `path`, and hands
/// every normal's values to `each` in grid order. With `resume` and a log there (checked to be
/// this run's and read back row by row, [`crate::job::open_log`]), the units it holds are read
/// back instead. Returns how many units were read back.
pub fn compute(
    plan: &IrradiancePlan,
    shard: Shard,
    path: &Path,
    resume: bool,
    names: &crate::job::SettingNames,
    reporter: &dyn Reporter,
    each: &mut dyn FnMut(&NormalValues),
) -> crate::Result<usize> {
    let w = plan.width;
    let mine: Vec<usize> = shard.units(plan.height).collect();
    let (mut log, done) = crate::job::open_log(plan, path, shard, resume, names, &mut |_, _, v| each(&v))?;
    let rules = plan.rules()?;
    let tolerance = plan.exact_tolerance();
    let todo = &mine[done..];
    reporter.start("normals", (todo.len() * w) as u64);
    let per_batch = BATCH_NORMALS.div_ceil(w).max(1);
    let mut text = String::new();
    for batch in todo.chunks(per_batch) {
        let normals: Vec<usize> = batch.iter().flat_map(|&u| u * w..(u + 1) * w).collect();
        let values = plan.values(&normals, &rules, tolerance, reporter);
        text.clear();
        for (&k, v) in normals.iter().zip(&values) {
            line(k, v, &mut text);
            each(v);
        }
        log.append(&text)?;
    }
    reporter.finish();
    Ok(done)
}

/// What a shard produced.
pub struct ShardReport {
    pub out_dir: PathBuf,
    pub units: usize,
    pub resumed: usize,
    pub wall_seconds: f64,
    pub threads: usize,
}

/// Runs shard `shard` of the protocol into the shard folder `out` (see the module
/// documentation); with `resume`, continues from the log an interrupted shard left there.
#[allow(clippy::too_many_arguments)]
pub fn run_shard(
    plan: &IrradiancePlan,
    spec_path: &Path,
    shard: Shard,
    out: &Path,
    threads: Option<usize>,
    resume: bool,
    names: &crate::job::SettingNames,
    reporter: &dyn Reporter,
) -> crate::Result<ShardReport> {
    let mut folder = ResultFolder::prepare(
        out,
        &format!("{} {}", names.out, out.display()),
        &format!("use another {}", names.out),
        &[("the irradiance file", spec_path)],
        super::export::legacy_manifest_files,
    )?;
    let spec_text = crate::files::spec_json::read_spec(spec_path)?;
    let pool = crate::util::threads::pool(threads)?;
    let identity = plan.identity(shard);
    let start = Instant::now();
    let log = folder.partial_path(PARTIAL_LOG)?;
    let resumed = pool.install(|| compute(plan, shard, &log, resume, names, reporter, &mut |_| {}))?;
    let job = serde_json::json!({
        "kind": KIND,
        "job": {
            "spec": spec_path.display().to_string(),
            "text": spec_text,
        },
    });
    shard_set::write_shard(
        &mut folder,
        &identity,
        &log,
        "this shard's normals in grid order: k, the exact irradiance, its error estimate, every (N, estimator)'s estimate, and each row's digest",
        job,
        "which shard this is, of which irradiance protocol, and the file as run (for workbench merge)",
    )?;
    let wall_seconds = start.elapsed().as_secs_f64();
    folder.commit(
        serde_json::json!({ "kind": KIND, "name": plan.name, "shard": shard.to_string() }),
        serde_json::json!({ "seconds": wall_seconds, "threads": pool.current_num_threads() }),
    )?;
    Ok(ShardReport {
        out_dir: out.to_path_buf(),
        units: shard.len(plan.height),
        resumed,
        wall_seconds,
        threads: pool.current_num_threads(),
    })
}

/// Merges the shard folders `dirs` of one irradiance protocol into `out` ([`crate::job::merge`]):
/// the files one run writes, byte for byte (`timings.json` aside); every check is made before
/// `out` is touched.
pub fn merge(
    out: &Path,
    dirs: &[PathBuf],
    names: &crate::job::SettingNames,
    reporter: &dyn Reporter,
) -> crate::Result<(IrradiancePlan, super::Report)> {
    crate::job::merge::<IrradiancePlan>(out, dirs, names, reporter)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_lines_read_back_as_the_same_numbers() {
        let v = NormalValues {
            exact: [0.1, 1.0 / 3.0, 2.5e-300],
            error: 7.570786944598702e-10,
            estimates: vec![
                [f64::MIN_POSITIVE, -0.0, 1e300],
                [0.2, 0.30000000000000004, 12345.678],
            ],
        };
        let mut s = String::new();
        line(7, &v, &mut s);
        let fields: Vec<&str> = s.trim_end().split(',').collect();
        assert_eq!(fields.len(), 11);
        let parsed: Vec<f64> = fields[1..].iter().map(|f| f.parse().unwrap()).collect();
        let want = [
            v.exact[0],
            v.exact[1],
            v.exact[2],
            v.error,
            v.estimates[0][0],
            v.estimates[0][1],
            v.estimates[0][2],
            v.estimates[1][0],
            v.estimates[1][1],
            v.estimates[1][2],
        ];
        for (a, b) in parsed.iter().zip(want) {
            assert_eq!(a.to_bits(), b.to_bits(), "{s}");
        }
    }
}
