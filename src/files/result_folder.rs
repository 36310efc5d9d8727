//! A run's or a table's folder (`results/<name>/`), changed whole or not at all: see
//! [`ResultFolder`]. Every file is written into a hidden staging folder beside it,
//! `.workbench-<pid>-staging-<name>/`, and the finished set takes the folder's place in one step
//! (`renameat2(RENAME_EXCHANGE)` on Linux; elsewhere two renames, between which the folder is
//! briefly absent). A reader sees the old set or the new one, never a mix; a command that fails
//! or is killed leaves the old set as it was. So a folder holds exactly one run's files, listed
//! in its `manifest.json` — but for the machine-dependent ones (wall-clock seconds), which are
//! not committed with the results and are listed in its `timings.json` instead.
//!
//! Outputs named one by one are written as a [`crate::files::file_set::FileSet`]. Both hold a
//! [`Lock`] on what they write, so two commands writing the same outputs cannot interleave, and
//! clear what killed commands left behind ([`crate::files::atomic::sweep_stale`]).

use crate::error::{Error, InputError, Result};
use crate::files::atomic::{
    HIDDEN_PREFIX, MAX_NAME_BYTES, hidden_name, hidden_name_writer, parent_or_dot, remove_any, resolve,
    writer,
};
use crate::files::lock::Lock;
use std::collections::{BTreeMap, BTreeSet};
use std::ffi::{OsStr, OsString};
use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The manifest of a result folder: the last file written, listing every file of the set that
/// is the same on every machine.
pub const MANIFEST: &str = "manifest.json";

/// The record of a result folder's machine-dependent files (wall-clock seconds), which lists
/// them: they are not in the manifest, which is committed with the results while they are
/// git-ignored, so that a checkout has every file its manifest lists.
pub const TIMINGS: &str = "timings.json";

/// Files a command may write into its result folder while it runs (outside the staging folder),
/// so that an interrupted command keeps what it measured. They are never part of a finished
/// set: the next successful run replaces the folder, and them with it.
pub const PARTIAL_FILES: &[&str] = &[
    "rmse.partial.csv",
    "trials.partial.csv",
    "rounds.partial.csv",
    "irradiance.partial.csv",
];

/// Reads a manifest of the caller's kind for the names it accounts for beyond its `files`, or
/// `None` if it is not one: every file of its run, for manifests written before they listed
/// their files; the machine-dependent files of its run (listed in [`TIMINGS`], before that in
/// the manifest itself), for the others — so that a folder whose manifest was replaced by a
/// newer committed one still counts its run's timing files as ours. Each kind of result folder
/// passes its own to [`ResultFolder::prepare`] (the rule lives with the kind that wrote them).
pub type LegacyManifest = fn(&serde_json::Value) -> Option<Vec<String>>;

/// A result folder being rebuilt: see the module documentation. Dropped without
/// [`ResultFolder::commit`] (an error, a panic), it removes its staging folder and leaves the
/// folder as it was, apart from [`PARTIAL_FILES`].
pub struct ResultFolder {
    /// The folder as the user named it, for messages.
    shown: PathBuf,
    /// Where it really is ([`resolve`]).
    target: PathBuf,
    staging: PathBuf,
    /// Every file written so far, with what it holds (the manifest's `files`).
    files: BTreeMap<String, String>,
    /// The machine-dependent files written so far, with what they hold ([`TIMINGS`]'s `files`).
    local: BTreeMap<String, String>,
    lock: Option<Lock>,
    /// Reads the folder's manifest if it predates the file list.
    legacy: LegacyManifest,
    /// Folders created to hold the result folder, removed again if nothing comes of it.
    created: Vec<PathBuf>,
    /// Whether the folder itself was there before the command.
    existed: bool,
    committed: bool,
}

impl ResultFolder {
    /// [`ResultFolder::prepare`] for a merge writing `out` from the shard folders `shards`
    /// (the inputs that must not lie inside it).
    pub fn prepare_merge<'a>(
        out: &Path,
        shards: impl IntoIterator<Item = &'a Path>,
        legacy: LegacyManifest,
    ) -> Result<ResultFolder> {
        let inputs: Vec<(&str, &Path)> = shards.into_iter().map(|dir| ("the shard folder", dir)).collect();
        Self::prepare(
            out,
            &out.display().to_string(),
            "give another OUT",
            &inputs,
            legacy,
        )
    }

    /// Checks everything that can be checked before the work — the folder is a folder, its
    /// name fits, no input lies inside it (it is replaced as a whole), nothing in it is foreign
    /// to us, its parent is writable, no other command is writing it — then locks it, clears
    /// what killed commands left beside it, and creates the staging folder.
    ///
    /// `what` names the folder in messages (`--out o`, `results/tiny`), `fix` says what else the
    /// user can do (`use another --out`), and `inputs` are the command's input files
    /// (`(description, path)`). `legacy` reads the manifests of this kind written before
    /// manifests listed their files, so that their files count as ours.
    pub fn prepare(
        out: &Path,
        what: &str,
        fix: &str,
        inputs: &[(&str, &Path)],
        legacy: LegacyManifest,
    ) -> Result<ResultFolder> {
        let refuse =
            |problem: String| -> Error { InputError::new(format!("{what}: {problem}; {fix}")).into() };
        // The same, with a first remedy before the caller's.
        let refuse_or = |problem: String, remedy: &str| -> Error {
            InputError::new(format!("{what}: {problem}; {remedy}, or {fix}")).into()
        };
        let target = resolve(out).map_err(|e| Error::io(format!("resolving {}", out.display()), e))?;
        let (Some(parent), Some(name)) = (target.parent(), target.file_name()) else {
            return Err(refuse("cannot be replaced as a whole".into()));
        };
        let parent = parent.to_path_buf();
        if name.len() > MAX_NAME_BYTES {
            return Err(refuse(format!(
                "the folder's name is {} bytes long, and at most {MAX_NAME_BYTES} are supported",
                name.len()
            )));
        }
        if std::fs::metadata(&target).is_ok_and(|m| !m.is_dir()) {
            return Err(refuse("is a file, not a folder".into()));
        }
        for (label, input) in inputs {
            if resolve(input).is_ok_and(|p| p.starts_with(&target)) {
                return Err(refuse_or(
                    format!("would replace {label} {}, which lies inside it", input.display()),
                    "move that file elsewhere",
                ));
            }
        }
        if std::env::current_dir()
            .and_then(|d| d.canonicalize())
            .is_ok_and(|d| d.starts_with(&target))
        {
            return Err(refuse_or(
                "is the current folder or holds it, and the results replace the folder as a whole".into(),
                "run from another folder",
            ));
        }

        let mut created = Vec::new();
        let mut missing = parent.as_path();
        while std::fs::symlink_metadata(missing).is_err() {
            created.push(missing.to_path_buf());
            match missing.parent() {
                Some(p) => missing = p,
                None => break,
            }
        }
        created.reverse();
        std::fs::create_dir_all(&parent)
            .map_err(|e| Error::io(format!("creating folder {}", parent.display()), e))?;
        let mut folder = ResultFolder {
            shown: out.to_path_buf(),
            staging: parent.join(staged_name("staging", name, &writer(std::process::id()))),
            target: target.clone(),
            files: BTreeMap::new(),
            local: BTreeMap::new(),
            lock: None,
            legacy,
            created,
            existed: std::fs::metadata(&target).is_ok(),
            committed: false,
        };
        // From here on, dropping `folder` undoes what was done.
        folder.lock = Some(Lock::acquire(&target, what, fix)?);
        crate::files::atomic::sweep_stale(&parent);
        if folder.lock.as_ref().is_some_and(|l| l.exclusive) {
            // We hold the lock, so staging folders for this name are abandoned whoever made them.
            for entry in std::fs::read_dir(&parent).into_iter().flatten().flatten() {
                let n = entry.file_name();
                if hidden_name_writer(&n).is_some_and(|(w, _, _)| {
                    n == staged_name("staging", name, w) || n == staged_name("old", name, w)
                }) {
                    remove_any(&entry.path());
                }
            }
        }
        crate::files::atomic::sweep_stale(&target);
        if let Some(foreign) = unexplained(&target, legacy) {
            return Err(refuse_or(
                format!(
                    "holds {foreign}, which no workbench manifest there lists, and the results replace the \
                     folder as a whole"
                ),
                "move that elsewhere",
            ));
        }
        std::fs::create_dir(&folder.staging)
            .map_err(|e| Error::io(format!("creating folder {}", folder.staging.display()), e))?;
        Ok(folder)
    }

    /// Writes one file of the set (into the staging folder), and what it holds for the
    /// manifest.
    pub fn write(&mut self, name: &str, description: &str, bytes: &[u8]) -> Result<()> {
        self.write_bytes(name, bytes)?;
        self.files.insert(name.into(), description.into());
        Ok(())
    }

    /// Writes one machine-dependent file of the set (wall-clock seconds), listed in
    /// [`TIMINGS`] rather than in the manifest.
    pub fn write_local(&mut self, name: &str, description: &str, bytes: &[u8]) -> Result<()> {
        self.write_bytes(name, bytes)?;
        self.local.insert(name.into(), description.into());
        Ok(())
    }

    fn write_bytes(&mut self, name: &str, bytes: &[u8]) -> Result<()> {
        assert!(is_plain_name(name), "{name:?} is not a plain file name");
        let path = self.staging.join(name);
        let written = File::create(&path).and_then(|mut f| {
            crate::files::atomic::write_all_checked(&mut f, &path, bytes)?;
            f.sync_all()
        });
        written.map_err(|e| {
            Error::io(
                format!(
                    "writing {} ({} is left as it was)",
                    self.shown.join(name).display(),
                    self.shown.display()
                ),
                e,
            )
        })
    }

    /// Writes one file of the set (into the staging folder) by streaming it: `fill` writes
    /// the bytes, buffered. For files too large to hold in memory.
    pub fn write_stream(
        &mut self,
        name: &str,
        description: &str,
        fill: &mut dyn FnMut(&mut dyn Write) -> Result<()>,
    ) -> Result<()> {
        self.stream(name, fill)?;
        self.files.insert(name.into(), description.into());
        Ok(())
    }

    /// [`ResultFolder::write_stream`] for a machine-dependent file ([`ResultFolder::write_local`]).
    pub fn write_stream_local(
        &mut self,
        name: &str,
        description: &str,
        fill: &mut dyn FnMut(&mut dyn Write) -> Result<()>,
    ) -> Result<()> {
        self.stream(name, fill)?;
        self.local.insert(name.into(), description.into());
        Ok(())
    }

    fn stream(&mut self, name: &str, fill: &mut dyn FnMut(&mut dyn Write) -> Result<()>) -> Result<()> {
        assert!(is_plain_name(name), "{name:?} is not a plain file name");
        let path = self.staging.join(name);
        let failed = |e: std::io::Error| {
            Error::io(
                format!(
                    "writing {} ({} is left as it was)",
                    self.shown.join(name).display(),
                    self.shown.display()
                ),
                e,
            )
        };
        let file = File::create(&path).map_err(failed)?;
        let mut writer = std::io::BufWriter::with_capacity(1 << 16, file);
        fill(&mut writer)?;
        crate::files::atomic::injected_failure(&path).map_err(failed)?;
        let file = writer.into_inner().map_err(|e| failed(e.into_error()))?;
        file.sync_all().map_err(failed)
    }

    /// Where one of [`PARTIAL_FILES`] goes: straight in the folder (created if need be), so
    /// that it survives the command failing or being interrupted. As the user named the
    /// folder, for messages.
    pub fn partial_path(&self, name: &str) -> Result<PathBuf> {
        assert!(PARTIAL_FILES.contains(&name), "{name} is not a partial file");
        std::fs::create_dir_all(&self.target)
            .map_err(|e| Error::io(format!("creating folder {}", self.shown.display()), e))?;
        Ok(self.shown.join(name))
    }

    /// Removes one of [`PARTIAL_FILES`] again, and the folder with it if the command created it
    /// and it is now empty: for a failure that a resume would only repeat (a Python integrand
    /// that raises), where keeping the partial work would invite a `--resume` that fails again.
    pub fn discard_partial(&self, name: &str) {
        assert!(PARTIAL_FILES.contains(&name), "{name} is not a partial file");
        let _ = std::fs::remove_file(self.target.join(name));
        if !self.existed {
            // Only if empty: the partial file was its only file.
            let _ = std::fs::remove_dir(&self.target);
        }
    }

    /// Writes one of [`PARTIAL_FILES`] straight into the folder (atomically), so that it
    /// survives the command being interrupted.
    pub fn write_partial(&mut self, name: &str, bytes: &[u8]) -> Result<()> {
        assert!(PARTIAL_FILES.contains(&name), "{name} is not a partial file");
        crate::files::atomic::write_atomic(&self.target.join(name), bytes)
    }

    /// Writes [`TIMINGS`] — `timings` (an object: wall-clock seconds, threads) with `files`
    /// listing the machine-dependent files (itself included) and the build that wrote the set
    /// (version, commit, uncommitted changes: [`crate::provenance::manifest_fields`]) — and the
    /// manifest — `manifest` with `files` listing every other file of the set (itself included)
    /// and the package version ([`crate::provenance::manifest_version`]): the exact build stays
    /// beside the results in the git-ignored record, so that regenerating committed results with
    /// a later commit rewrites them byte for byte — and puts the set in the folder's place.
    pub fn commit(mut self, mut manifest: serde_json::Value, mut timings: serde_json::Value) -> Result<()> {
        let listing = |files: &BTreeMap<String, String>, this: &str, what: &str| {
            let mut list: serde_json::Map<String, serde_json::Value> = files
                .iter()
                .map(|(k, v)| (k.clone(), serde_json::Value::from(v.as_str())))
                .collect();
            list.insert(this.into(), what.into());
            serde_json::Value::Object(list)
        };
        timings["files"] = listing(
            &self.local,
            TIMINGS,
            "this file: the run's wall-clock record, the exact build that wrote the set (commit and \
             uncommitted changes), and its files that differ from machine to machine (not committed)",
        );
        let build = crate::provenance::Build::current();
        crate::provenance::manifest_fields(&mut timings, &build);
        self.write_bytes(TIMINGS, &pretty(&timings))?;
        crate::provenance::manifest_version(&mut manifest, &build);
        manifest["files"] = listing(
            &self.files,
            MANIFEST,
            "this file: what was run, by which version, and every file of the set but the \
             machine-dependent ones (listed in timings.json, with the exact build)",
        );
        self.write_bytes(MANIFEST, &pretty(&manifest))?;
        let sync_dir = |dir: &Path| {
            File::open(dir)
                .and_then(|d| d.sync_all())
                .map_err(|e| Error::io(format!("syncing folder {}", dir.display()), e))
        };
        // The folder keeps its mode across the replacement (its files are new and get the
        // umask's). Only now: a read-only mode would have stopped the writes.
        if let Ok(m) = std::fs::metadata(&self.target) {
            let _ = std::fs::set_permissions(&self.staging, m.permissions());
        }
        sync_dir(&self.staging)?;

        // Another program may have put something in the folder while we worked; it would be
        // lost with the old set, so keep the new set beside the folder instead.
        if let Some(foreign) = unexplained(&self.target, self.legacy) {
            let name = self.target.file_name().unwrap_or_default();
            let mut kept = name.to_os_string();
            kept.push(format!(".new-{}", std::process::id()));
            let kept = parent_or_dot(&self.target).join(kept);
            std::fs::rename(&self.staging, &kept).map_err(|e| {
                Error::io(
                    format!("renaming {} to {}", self.staging.display(), kept.display()),
                    e,
                )
            })?;
            return Err(InputError::new(format!(
                "{}: {foreign} appeared in it during the run, so it was left as it was; the new results are in {}",
                self.shown.display(),
                kept.display()
            ))
            .into());
        }
        let old = parent_or_dot(&self.target).join(staged_name(
            "old",
            self.target.file_name().unwrap_or_default(),
            &writer(std::process::id()),
        ));
        swap_into_place(&self.staging, &self.target, &old)
            .map_err(|e| Error::io(format!("moving the new results into {}", self.shown.display()), e))?;
        self.committed = true;
        sync_dir(parent_or_dot(&self.target))
    }
}

impl Drop for ResultFolder {
    fn drop(&mut self) {
        if self.committed {
            return;
        }
        remove_any(&self.staging);
        drop(self.lock.take());
        for dir in self.created.iter().rev() {
            // Only if empty: something else may have been put there meanwhile.
            let _ = std::fs::remove_dir(dir);
        }
    }
}

fn pretty(v: &serde_json::Value) -> Vec<u8> {
    let mut bytes = serde_json::to_vec_pretty(v).expect("a JSON value serialises");
    bytes.push(b'\n');
    bytes
}

/// `.workbench-<writer>-<role>-<name>`: a staging folder, or the old set on its way out.
fn staged_name(role: &str, name: &OsStr, writer: &str) -> OsString {
    hidden_name(&format!("{HIDDEN_PREFIX}{writer}-{role}-"), name)
}

fn is_plain_name(name: &str) -> bool {
    !name.is_empty() && name != "." && name != ".." && !name.contains(['/', '\\', '\0'])
}

/// Puts `staging` where `target` is, in one step where the system can exchange two folders.
fn swap_into_place(staging: &Path, target: &Path, old: &Path) -> std::io::Result<()> {
    if std::fs::symlink_metadata(target).is_err() {
        return std::fs::rename(staging, target);
    }
    match exchange(staging, target) {
        Ok(()) => {
            // `staging` now holds the old set.
            remove_any(staging);
            Ok(())
        }
        Err(_) => swap_by_two_renames(staging, target, old),
    }
}

/// Where folders cannot be exchanged: the old folder steps aside, the new one steps in. In
/// between, the folder is briefly absent (never mixed); if the second step fails, the first
/// is undone.
fn swap_by_two_renames(staging: &Path, target: &Path, old: &Path) -> std::io::Result<()> {
    std::fs::rename(target, old)?;
    if let Err(e) = std::fs::rename(staging, target) {
        let _ = std::fs::rename(old, target);
        return Err(e);
    }
    remove_any(old);
    Ok(())
}

#[cfg(target_os = "linux")]
fn exchange(a: &Path, b: &Path) -> std::io::Result<()> {
    use rustix::fs::{CWD, RenameFlags, renameat_with};
    renameat_with(CWD, a, CWD, b, RenameFlags::EXCHANGE).map_err(std::io::Error::from)
}

#[cfg(not(target_os = "linux"))]
fn exchange(_: &Path, _: &Path) -> std::io::Result<()> {
    Err(std::io::ErrorKind::Unsupported.into())
}

/// The names a manifest of ours accounts for, or `None` if `manifest` is not one of ours.
/// Manifests written before they listed their files are read by what they describe
/// (`legacy`, from the caller).
fn manifest_files(manifest: &serde_json::Value, legacy: LegacyManifest) -> Option<Vec<String>> {
    match (listed_in(manifest, MANIFEST), legacy(manifest)) {
        (None, None) => None,
        (listed, more) => {
            let mut names: Vec<String> = listed.into_iter().chain(more).flatten().collect();
            names.sort();
            names.dedup();
            Some(names)
        }
    }
}

/// The names `record`'s `files` lists, if it lists `itself` among them (a record of ours).
fn listed_in(record: &serde_json::Value, itself: &str) -> Option<Vec<String>> {
    let files = record.get("files")?.as_object()?;
    files
        .contains_key(itself)
        .then(|| files.keys().cloned().collect())
}

/// What in `dir` is not ours, for the message ("notes.txt", "notes.txt, data/ and 2 more"),
/// or `None` if everything is. Ours: the files the manifest lists (and, beside a manifest of
/// ours, those its [`TIMINGS`] lists), [`PARTIAL_FILES`], and our
/// hidden files (`.workbench-…`).
fn unexplained(dir: &Path, legacy: LegacyManifest) -> Option<String> {
    let entries = std::fs::read_dir(dir).ok()?;
    let read = |name: &str| {
        super::read::read(&dir.join(name), super::read::FileKind::Record)
            .ok()
            .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
    };
    let mut listed: BTreeSet<String> = BTreeSet::new();
    if let Some(names) = read(MANIFEST).and_then(|v| manifest_files(&v, legacy)) {
        listed.extend(names);
        // Only beside a manifest of ours: the machine-dependent files its run wrote.
        if let Some(names) = read(TIMINGS).and_then(|v| listed_in(&v, TIMINGS)) {
            listed.extend(names);
        }
    }
    listed.retain(|n| is_plain_name(n));
    let mut foreign: Vec<String> = Vec::new();
    for entry in entries.flatten() {
        let name = entry.file_name();
        let is_file = entry.file_type().is_ok_and(|t| t.is_file());
        let ours = name.to_str().is_some_and(|n| {
            n.starts_with(HIDDEN_PREFIX) || (is_file && (listed.contains(n) || PARTIAL_FILES.contains(&n)))
        });
        if !ours {
            let mut shown = name.to_string_lossy().into_owned();
            if entry.file_type().is_ok_and(|t| t.is_dir()) {
                shown.push('/');
            }
            foreign.push(shown);
        }
    }
    foreign.sort();
    match foreign.len() {
        0 => None,
        1 => Some(foreign[0].clone()),
        2 => Some(format!("{} and {}", foreign[0], foreign[1])),
        n => Some(format!("{}, {} and {} more", foreign[0], foreign[1], n - 2)),
    }
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;

    fn listing(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn half_replaced_result_set_two_renames_swap_whole_folders() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        for (f, text) in [("target", "old"), ("staging", "new")] {
            std::fs::create_dir(d.join(f)).unwrap();
            std::fs::write(d.join(f).join("a.csv"), text).unwrap();
        }
        std::fs::write(d.join("target/stale.svg"), "old").unwrap();
        swap_by_two_renames(&d.join("staging"), &d.join("target"), &d.join("old")).unwrap();
        assert_eq!(listing(d), ["target"]);
        assert_eq!(listing(&d.join("target")), ["a.csv"]);
        assert_eq!(std::fs::read_to_string(d.join("target/a.csv")).unwrap(), "new");
    }

    #[test]
    fn results_folder_holds_one_run_manifests_list_their_files() {
        let none: LegacyManifest = |_| None;
        let listed = serde_json::json!({"files": {"a.csv": "…", "manifest.json": "…"}});
        assert_eq!(manifest_files(&listed, none).unwrap(), ["a.csv", "manifest.json"]);
        let old: LegacyManifest = |_| Some(vec!["old.csv".into()]);
        assert_eq!(
            manifest_files(&listed, old).unwrap(),
            ["a.csv", "manifest.json", "old.csv"]
        );
        assert!(manifest_files(&serde_json::json!({"files": {"a": "b"}}), none).is_none());
        assert_eq!(
            manifest_files(&serde_json::json!({"files": {"a": "b"}}), old).unwrap(),
            ["old.csv"]
        );
    }
}
