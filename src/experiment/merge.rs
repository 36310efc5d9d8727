//! Shards and `workbench merge OUT DIR…`.
//!
//! `run FILE --shard i/n` runs the units of shard i ([`Shard`]) and writes a shard folder:
//! `units.csv` (its unit log: rows in unit order, with the cost columns), `shard.json` (the
//! experiment as run, and the [`Identity`] the merge checks), `timings.json` and a manifest.
//! `merge` checks that the folders are the shards 1…n of one run (same plan, seed, trials and
//! tool build — version, commit and uncommitted changes —, each shard once), reads their rows in unit order and writes the run's files
//! with the code a single run uses ([`super::finish`]) — so they are the same bytes as one run
//! of the whole file, the wall-clock `timings*` files and `*-cost.svg` aside.

use super::export;
use super::finish::{self, Findings};
use super::plan::{self, Plan};
use super::rows::check_row;
use super::spec::ExperimentSpec;
use super::summary::Accumulator;
use super::unit_log::{Identity, LogSet, SHARD_UNITS, Shard};
use crate::error::{Error, InputError};
use crate::files::result_folder::ResultFolder;
use crate::provenance::Build;
use crate::util::report::Reporter;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A shard folder's record of what it holds.
pub const SHARD_FILE: &str = "shard.json";

/// Writes a shard's own files into its folder: its unit log as `units.csv`, and `shard.json`.
pub fn write_shard(
    spec: &ExperimentSpec,
    identity: &Identity,
    folder: &mut ResultFolder,
    log: &Path,
) -> crate::Result<()> {
    folder.write_stream(
        SHARD_UNITS,
        "this shard's rows in unit order: the trials.csv columns, then integrand evaluations and wall-clock seconds",
        &mut |w| {
            let mut file = super::unit_log::bounded_open(log)?;
            std::io::copy(&mut file, w).map_err(|e| Error::io(format!("copying {}", log.display()), e))?;
            Ok(())
        },
    )?;
    write_shard_record(
        folder,
        identity,
        serde_json::json!({ "experiment": spec }),
        "which shard this is, of which run, and the experiment as run (for workbench merge)",
    )
}

/// Writes a shard's `shard.json` as every kind of shard does, so that `workbench merge` reads one
/// form: the shard's [`Identity`] (which shard, of which plan, seed and trials, and the build
/// that wrote it) with `job`'s fields (what kind of job, the job as run).
pub fn write_shard_record(
    folder: &mut ResultFolder,
    identity: &Identity,
    job: serde_json::Value,
    what: &str,
) -> crate::Result<()> {
    let mut record = serde_json::json!({
        "shard": identity.shard.to_string(),
        "plan_hash": identity.plan_hash,
        "seed": identity.seed,
        "trials": identity.trials,
    });
    if let (Some(fields), serde_json::Value::Object(job)) = (record.as_object_mut(), job) {
        fields.extend(job);
    }
    crate::provenance::manifest_fields(&mut record, &identity.build);
    let mut bytes = serde_json::to_vec_pretty(&record).expect("the record serializes");
    bytes.push(b'\n');
    folder.write(SHARD_FILE, what, &bytes)
}

/// A shard folder's manifest: the plan and the shard (the build is added on commit, as to
/// every manifest).
pub fn shard_manifest(plan: &Plan, identity: &Identity) -> Vec<u8> {
    let v = serde_json::json!({
        "plan": export::plan_json(plan),
        "seed": plan.seed,
        "shard": identity.shard.to_string(),
    });
    serde_json::to_vec_pretty(&v).expect("the manifest serializes")
}

/// One shard folder, read.
pub struct ShardFolder {
    pub dir: PathBuf,
    /// What was sharded: [`EXPERIMENT`] or another kind of job (a render table's shards name
    /// theirs in `shard.json`'s `"kind"`).
    pub kind: String,
    pub identity: Identity,
    /// The job as run: the experiment spec, or the kind's own record.
    pub spec: serde_json::Value,
}

/// The kind of job of an experiment's shards (`shard.json` without `"kind"`).
pub const EXPERIMENT: &str = "experiment";

/// What kind of job the shard in `dir` is of (None if it has no readable `shard.json`).
pub fn shard_kind(dir: &Path) -> Option<String> {
    let text =
        crate::files::read::read_text(&dir.join(SHARD_FILE), crate::files::read::FileKind::Record).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    Some(
        v.get("kind")
            .and_then(|k| k.as_str())
            .unwrap_or(EXPERIMENT)
            .to_string(),
    )
}

/// Refuses, in one line, shards of different kinds of job (an experiment's and a render
/// table's), before anything else is read; returns the kind.
pub fn check_kinds(dirs: &[PathBuf]) -> Result<String, InputError> {
    let kinds: Vec<Option<String>> = dirs.iter().map(|d| shard_kind(d)).collect();
    let first = kinds.iter().position(Option::is_some).unwrap_or(0);
    for (d, k) in dirs.iter().zip(&kinds) {
        if let (Some(a), Some(b)) = (&kinds[first], k)
            && a != b
        {
            let a_n = |k: &str| match k {
                EXPERIMENT => "an experiment",
                "irradiance" => "an irradiance protocol",
                _ => "a render table",
            };
            return Err(InputError::new(format!(
                "merge: {} is a shard of {} and {} a shard of {}; merge the shards of one run",
                dirs[first].display(),
                a_n(a),
                d.display(),
                a_n(b)
            )));
        }
    }
    Ok(kinds[first].clone().unwrap_or_else(|| EXPERIMENT.to_string()))
}

/// Reads a shard folder of any kind: its `shard.json` and the first line of its `units.csv`.
pub fn read_shard(dir: &Path) -> Result<ShardFolder, InputError> {
    let shown = dir.display();
    let path = dir.join(SHARD_FILE);
    let text = crate::files::read::read_text(&path, crate::files::read::FileKind::Record).map_err(|_| {
        InputError::new(format!(
            "merge: {shown} is not a shard folder (no readable {SHARD_FILE}); make shards with `workbench run FILE --shard i/n --out DIR`"
        ))
    })?;
    let bad = |what: &str| InputError::new(format!("merge: {}: {what}", path.display()));
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| bad(&format!("not JSON ({e})")))?;
    let field = |k: &str| v.get(k).ok_or_else(|| bad(&format!("has no \"{k}\"")));
    let string = |k: &str| -> Result<String, InputError> {
        Ok(field(k)?
            .as_str()
            .ok_or_else(|| bad(&format!("\"{k}\" is not a string")))?
            .to_string())
    };
    let number = |k: &str| -> Result<u64, InputError> {
        field(k)?
            .as_u64()
            .ok_or_else(|| bad(&format!("\"{k}\" is not a whole number")))
    };
    let shard = Shard::parse(&string("shard")?).map_err(|m| bad(&format!("\"shard\": {m}")))?;
    string("workbench_version")?;
    let build = Build::from_json(&v).ok_or_else(|| {
        bad("\"workbench_commit\", \"workbench_dirty\" and \"workbench_changes\" do not describe a build")
    })?;
    let identity = Identity {
        plan_hash: string("plan_hash")?,
        seed: number("seed")?,
        trials: number("trials")? as usize,
        build,
        shard,
    };
    // The log must be this shard's, and complete (checked while reading it).
    let units = dir.join(SHARD_UNITS);
    let mut first = String::new();
    super::unit_log::bounded_open(&units)
        .ok()
        .map(BufReader::new)
        .and_then(|mut r| r.read_line(&mut first).ok())
        .ok_or(())
        .map_err(|_| InputError::new(format!("merge: {shown}: {SHARD_UNITS} is missing or unreadable")))?;
    if Identity::from_header(&first).as_ref() != Some(&identity) {
        return Err(InputError::new(format!(
            "merge: {}: its first line does not match {SHARD_FILE}",
            units.display()
        )));
    }
    let kind = v
        .get("kind")
        .and_then(|k| k.as_str())
        .unwrap_or(EXPERIMENT)
        .to_string();
    Ok(ShardFolder {
        dir: dir.to_path_buf(),
        spec: field(if kind == EXPERIMENT { "experiment" } else { "job" })?.clone(),
        kind,
        identity,
    })
}

/// Checks that the shards were written by this build (the merged manifest records one build,
/// the one writing it: that must be the build whose rows it holds).
pub fn check_build(shards: &[ShardFolder]) -> Result<(), InputError> {
    let (ours, theirs) = (Build::current(), &shards[0].identity.build);
    if theirs != &ours {
        return Err(InputError::new(format!(
            "merge: the shards in {} were written by workbench {}, this is workbench {}; merge them \
             with the build that wrote them",
            shards[0].dir.display(),
            theirs.describe(),
            ours.describe()
        )));
    }
    Ok(())
}

/// Checks that `shards` are the shards 1…n of one run, and puts them in shard order.
pub fn check_set(mut shards: Vec<ShardFolder>) -> Result<Vec<ShardFolder>, InputError> {
    let first = &shards[0];
    let (d0, a) = (first.dir.display(), &first.identity);
    for s in &shards[1..] {
        let (d, b) = (s.dir.display(), &s.identity);
        let differ = |what: &str, x: String, y: String| {
            InputError::new(format!(
                "merge: {d0} and {d} are shards of different runs ({what} {x} and {y}); merge the shards of one run"
            ))
        };
        // Rows of two builds are never merged: another version, another commit, or the same
        // commit with other (or no) uncommitted changes may compute other numbers.
        if a.build != b.build {
            return Err(differ("workbench builds", a.build.describe(), b.build.describe()));
        }
        if a.seed != b.seed {
            return Err(differ("seeds", a.seed.to_string(), b.seed.to_string()));
        }
        if a.trials != b.trials {
            return Err(differ("trials", a.trials.to_string(), b.trials.to_string()));
        }
        if a.plan_hash != b.plan_hash {
            return Err(differ(
                if first.kind == EXPERIMENT {
                    "experiment plans"
                } else {
                    "plans"
                },
                a.plan_hash.clone(),
                b.plan_hash.clone(),
            ));
        }
        if a.shard.count != b.shard.count {
            return Err(differ("shard counts", a.shard.to_string(), b.shard.to_string()));
        }
    }
    let count = a.shard.count;
    shards.sort_by_key(|s| s.identity.shard.index);
    for w in shards.windows(2) {
        if w[0].identity.shard == w[1].identity.shard {
            return Err(InputError::new(format!(
                "merge: {} and {} are both shard {}; give each shard once",
                w[0].dir.display(),
                w[1].dir.display(),
                w[0].identity.shard
            )));
        }
    }
    if shards.len() < count {
        let missing: Vec<String> = (1..=count)
            .filter(|i| !shards.iter().any(|s| s.identity.shard.index == *i))
            .map(|i| format!("{i}/{count}"))
            .collect();
        return Err(InputError::new(format!(
            "merge: shard {} missing: the run was split in {count}; give every shard folder",
            missing.join(", ")
        )));
    }
    Ok(shards)
}

/// The plan the shards were run from, checked against their identity.
fn rebuild_plan(shard: &ShardFolder) -> Result<Plan, InputError> {
    let path = shard.dir.join(SHARD_FILE);
    let bad = |m: String| InputError::new(format!("merge: {}: \"experiment\": {m}", path.display()));
    let spec: ExperimentSpec = serde_json::from_value(shard.spec.clone()).map_err(|e| bad(e.to_string()))?;
    let plan = plan::resolve(&spec).map_err(bad)?;
    if super::unit_log::plan_hash(&plan) != shard.identity.plan_hash {
        return Err(bad("does not resolve to the plan its shards were run from".into()));
    }
    Ok(plan)
}

/// What a merge produced.
pub struct MergeReport {
    pub out_dir: PathBuf,
    pub findings: Findings,
    /// Tolerance estimators' cells and checks (empty without tolerance estimators).
    pub stopping: Vec<super::adaptive::Cell>,
    pub tolerance_checks: Vec<super::adaptive::CheckOutcome>,
    pub shards: usize,
    pub wall_seconds: f64,
}

/// The shard folders `dirs` of one merge, read: refused if there are none or they are shards of
/// different kinds of job ([`check_kinds`]), before any is read ([`read_shard`]).
pub fn read_shards(dirs: &[PathBuf]) -> Result<Vec<ShardFolder>, InputError> {
    if dirs.is_empty() {
        return Err(InputError::new("merge: give the shard folders to merge"));
    }
    check_kinds(dirs)?;
    dirs.iter().map(|d| read_shard(d)).collect()
}

/// Merges shard folders into `out`: see the module documentation. Every check is made before
/// `out` is touched.
pub fn merge(out: &Path, dirs: &[PathBuf], reporter: &dyn Reporter) -> crate::Result<(Plan, MergeReport)> {
    let shards = read_shards(dirs)?;
    let shards = check_set(shards)?;
    // The merged manifest records one build, the one writing it: that must be the build whose
    // rows it holds (its summary, fits and plots are computed again here).
    check_build(&shards)?;
    let plan = rebuild_plan(&shards[0])?;
    let mut folder = ResultFolder::prepare_merge(
        out,
        shards.iter().map(|s| s.dir.as_path()),
        super::export::legacy_manifest_files,
    )?;
    let start = Instant::now();
    let logs = LogSet {
        paths: shards.iter().map(|s| s.dir.join(SHARD_UNITS)).collect(),
    };
    let units = plan.samples.len() * plan.trials;
    reporter.start("trials×N", units as u64);
    let mut summary = Accumulator::new(&plan);
    let per_unit = super::unit_log::rows_per_unit(&plan);
    let count = logs.paths.len();
    logs.for_each_row(&plan, &mut |u, fi, ei, line| {
        let (ni, t) = (u / plan.trials, u % plan.trials);
        let shard_log = &logs.paths[u % count];
        // Two header lines, then this shard's units in order, `per_unit` rows each.
        let line_no = 3 + (u / count) * per_unit + fi * plan.estimators.len() + ei;
        let wrong = |m: String| -> Error {
            InputError::new(format!(
                "merge: {}: line {line_no} (N = {}, trial {t}): {m}; this shard is damaged, run it again",
                shard_log.display(),
                plan.samples[ni]
            ))
            .into()
        };
        // Every column is checked: its text goes into the merged trials.csv as it is.
        let (n, trial, values) = check_row(&plan, fi, ei, line).map_err(|m| wrong(format!("the row {m}")))?;
        if (n, trial) != (plan.samples[ni], t) {
            return Err(wrong(format!("found a row of N = {n}, trial {trial}")));
        }
        summary.push(fi, ei, ni, &values);
        if fi * plan.estimators.len() + ei + 1 == per_unit {
            reporter.advance(1);
        }
        Ok(())
    })?;
    reporter.finish();
    let findings = finish::write_set(&plan, &mut folder, &summary, &logs)?;
    let (stopping, tolerance_checks) = finish::write_stopping(&plan, &mut folder, &logs)?;
    let wall_seconds = start.elapsed().as_secs_f64();
    let manifest = finish::manifest(&plan, &findings, &tolerance_checks);
    // The merge's own seconds, not the run's: no plan hash, so `reproduce` does not take them
    // for the run's time.
    folder.commit(manifest, export::timings_json(1, wall_seconds, None))?;
    Ok((
        plan,
        MergeReport {
            out_dir: out.to_path_buf(),
            findings,
            stopping,
            tolerance_checks,
            shards: shards.len(),
            wall_seconds,
        },
    ))
}
