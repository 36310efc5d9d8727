//! Shard folders and their sets, for every kind of job: `shard.json` ([`write_record`],
//! [`read_shard`]), a set read and checked ([`read_set`]: one kind of job, one build, the shards
//! 1…n of one run each once).

use super::shard::{Identity, Shard, UNITS_KEY};
use super::unit_log::SHARD_UNITS;
use crate::error::InputError;
use crate::files::read::FileKind;
use crate::files::result_folder::ResultFolder;
use crate::provenance::Build;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

/// A shard folder's record of what it holds.
pub const SHARD_FILE: &str = "shard.json";

/// The kind of job of an experiment's shards (`shard.json` without `"kind"`).
pub const EXPERIMENT: &str = "experiment";

/// How messages name a kind of job (`shard.json`'s `"kind"`; render tables' is
/// `"render-table"`).
fn kind_name(kind: &str) -> &'static str {
    match kind {
        EXPERIMENT => "an experiment",
        "irradiance" => "an irradiance protocol",
        _ => "a render table",
    }
}

/// Writes a shard's `shard.json` as every kind of shard does, so that `workbench merge` reads one
/// form: the shard's [`Identity`] (which shard, of which plan, seed and units, and the build
/// that wrote it) with `job`'s fields (what kind of job, the job as run).
pub fn write_record(
    folder: &mut ResultFolder,
    identity: &Identity,
    job: serde_json::Value,
    what: &str,
) -> crate::Result<()> {
    let mut record = serde_json::json!({
        "shard": identity.shard.to_string(),
        "plan_hash": identity.plan_hash,
        "seed": identity.seed,
        UNITS_KEY: identity.units,
    });
    if let (Some(fields), serde_json::Value::Object(job)) = (record.as_object_mut(), job) {
        fields.extend(job);
    }
    crate::provenance::manifest_fields(&mut record, &identity.build);
    let mut bytes = serde_json::to_vec_pretty(&record).expect("the record serializes");
    bytes.push(b'\n');
    folder.write(SHARD_FILE, what, &bytes)
}

/// Writes a shard's own files into its folder: its unit log `log` as [`SHARD_UNITS`] (described
/// as `units_what`), and `shard.json` ([`write_record`]).
pub fn write_shard(
    folder: &mut ResultFolder,
    identity: &Identity,
    log: &Path,
    units_what: &str,
    job: serde_json::Value,
    record_what: &str,
) -> crate::Result<()> {
    folder.write_stream(SHARD_UNITS, units_what, &mut |w| {
        let mut file = super::unit_log::bounded_open(log)?;
        std::io::copy(&mut file, w).map_err(|e| crate::Error::io(format!("copying {}", log.display()), e))?;
        Ok(())
    })?;
    write_record(folder, identity, job, record_what)
}

/// One shard folder, read.
pub struct ShardFolder {
    pub dir: PathBuf,
    /// What was sharded: [`EXPERIMENT`] or another kind of job (named in `shard.json`'s
    /// `"kind"`).
    pub kind: String,
    pub identity: Identity,
    /// The job as run: the experiment spec, or the kind's own record.
    pub spec: serde_json::Value,
}

impl ShardFolder {
    /// Its unit log.
    pub fn units(&self) -> PathBuf {
        self.dir.join(SHARD_UNITS)
    }

    /// Its `shard.json`.
    pub fn record(&self) -> PathBuf {
        self.dir.join(SHARD_FILE)
    }

    /// The text field `key` of the job's own record (`shard.json`'s `"job"`).
    pub fn job_text(&self, key: &str) -> Result<&str, InputError> {
        self.spec.get(key).and_then(|t| t.as_str()).ok_or_else(|| {
            InputError::new(format!(
                "merge: {}: \"job\" has no \"{key}\"",
                self.record().display()
            ))
        })
    }
}

/// What kind of job the shard in `dir` is of (None if it has no readable `shard.json`).
pub fn shard_kind(dir: &Path) -> Option<String> {
    let text = crate::files::read::read_text(&dir.join(SHARD_FILE), FileKind::Record).ok()?;
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
            return Err(InputError::new(format!(
                "merge: {} is a shard of {} and {} a shard of {}; merge the shards of one run",
                dirs[first].display(),
                kind_name(a),
                d.display(),
                kind_name(b)
            )));
        }
    }
    Ok(kinds[first].clone().unwrap_or_else(|| EXPERIMENT.to_string()))
}

/// Reads a shard folder of any kind: its `shard.json` and the first line of its `units.csv`.
pub fn read_shard(dir: &Path, names: &super::SettingNames) -> Result<ShardFolder, InputError> {
    let shown = dir.display();
    let path = dir.join(SHARD_FILE);
    let text = crate::files::read::read_text(&path, FileKind::Record).map_err(|_| {
        InputError::new(format!(
            "merge: {shown} is not a shard folder (no readable {SHARD_FILE}); make shards with {} i/n and {} DIR",
            names.shard, names.out
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
    let units = Identity::units_of_record(&v)
        .ok_or_else(|| bad(&format!("has no \"{UNITS_KEY}\"")))?
        .as_u64()
        .ok_or_else(|| bad(&format!("\"{UNITS_KEY}\" is not a whole number")))?;
    let identity = Identity {
        plan_hash: string("plan_hash")?,
        seed: number("seed")?,
        units: units as usize,
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
        if a.units != b.units {
            return Err(differ("units", a.units.to_string(), b.units.to_string()));
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

/// The shard folders `dirs` of one merge, read: refused if there are none or they are shards of
/// different kinds of job ([`check_kinds`]), before any is read ([`read_shard`]).
pub fn read_shards(dirs: &[PathBuf], names: &super::SettingNames) -> Result<Vec<ShardFolder>, InputError> {
    if dirs.is_empty() {
        return Err(InputError::new("merge: give the shard folders to merge"));
    }
    check_kinds(dirs)?;
    dirs.iter().map(|d| read_shard(d, names)).collect()
}
