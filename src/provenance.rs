//! Which build of workbench wrote a file: the package version and, when built from a git
//! checkout, the commit and whether the sources differed from it (`build.rs`). A result folder's
//! committed `manifest.json` records the version only ([`manifest_version`]), so that rerunning
//! a committed experiment with a newer build of the same results leaves a clean checkout clean;
//! the whole [`Build`] goes into its git-ignored `timings.json` ([`manifest_fields`]). Shards
//! and unit logs carry the whole [`Build`] too, so that `merge` and `--resume` only ever combine
//! rows of one build.

/// The build this binary is: see the module documentation.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Build {
    /// The package version (`Cargo.toml`).
    pub version: String,
    /// The git commit the binary was built from; `None` outside a git checkout (a tarball).
    pub commit: Option<String>,
    /// With a commit: a fingerprint (16 hex digits) of the uncommitted changes to the files
    /// that go into the binary (`src/`, `build.rs`, `Cargo.toml`, `Cargo.lock`, untracked files
    /// among them included), `None` if there were none. Two builds of one commit with the same
    /// changes have the same fingerprint.
    pub changes: Option<String>,
}

fn non_empty(s: &str) -> Option<String> {
    (!s.is_empty()).then(|| s.to_string())
}

impl Build {
    /// This binary's build.
    pub fn current() -> Build {
        Build {
            version: env!("CARGO_PKG_VERSION").to_string(),
            commit: non_empty(env!("WORKBENCH_GIT_COMMIT")),
            changes: non_empty(env!("WORKBENCH_GIT_CHANGES")),
        }
    }

    /// Whether the sources differed from the commit.
    pub fn dirty(&self) -> bool {
        self.changes.is_some()
    }

    /// One token for a unit log's first line: `<commit>`, `<commit>+changes.<fingerprint>`, or
    /// `unknown` outside git.
    pub fn token(&self) -> String {
        match (&self.commit, &self.changes) {
            (None, _) => "unknown".into(),
            (Some(c), None) => c.clone(),
            (Some(c), Some(f)) => format!("{c}+changes.{f}"),
        }
    }

    /// Reads [`Build::token`] back, with the version it goes with.
    pub fn from_token(version: &str, token: &str) -> Option<Build> {
        let (commit, changes) = match token {
            "" => return None,
            "unknown" => (None, None),
            t => match t.split_once("+changes.") {
                Some((c, f)) if !c.is_empty() && !f.is_empty() => (Some(c.to_string()), Some(f.to_string())),
                Some(_) => return None,
                None => (Some(t.to_string()), None),
            },
        };
        Some(Build {
            version: version.to_string(),
            commit,
            changes,
        })
    }

    /// For messages: `0.1.0 at commit 1a2b3c4d5e6f`, `… with uncommitted changes 0f1e…`, or
    /// `0.1.0 (no git commit recorded)`.
    pub fn describe(&self) -> String {
        match (&self.commit, &self.changes) {
            (None, _) => format!("{} (no git commit recorded)", self.version),
            (Some(c), None) => format!("{} at commit {}", self.version, short(c)),
            (Some(c), Some(f)) => format!(
                "{} at commit {} with uncommitted changes {f}",
                self.version,
                short(c)
            ),
        }
    }

    /// Reads the fields [`manifest_fields`] writes (from a manifest or a shard's record), or
    /// `None` if the version is missing or a field is malformed.
    pub fn from_json(v: &serde_json::Value) -> Option<Build> {
        let version = v.get("workbench_version")?.as_str()?.to_string();
        let commit = match v.get("workbench_commit") {
            None => None,
            Some(c) => Some(c.as_str()?.to_string()),
        };
        let changes = match v.get("workbench_changes") {
            None => None,
            Some(c) => Some(c.as_str()?.to_string()),
        };
        let dirty = match v.get("workbench_dirty") {
            None => false,
            Some(d) => d.as_bool()?,
        };
        if dirty != changes.is_some()
            || (commit.is_none() && (changes.is_some() || v.get("workbench_dirty").is_some()))
        {
            return None;
        }
        Some(Build {
            version,
            commit,
            changes,
        })
    }
}

fn short(commit: &str) -> &str {
    commit.get(..12).unwrap_or(commit)
}

/// Sets `workbench_version` in `v` (an object) and removes the build fields
/// [`manifest_fields`] writes: what a committed manifest records, because the version changes
/// only with a release while the commit changes with every commit, so that a manifest naming
/// the commit never matches the one a newer build writes for the same results.
pub fn manifest_version(v: &mut serde_json::Value, build: &Build) {
    let Some(o) = v.as_object_mut() else {
        return;
    };
    for k in ["workbench_commit", "workbench_dirty", "workbench_changes"] {
        o.remove(k);
    }
    o.insert("workbench_version".into(), build.version.clone().into());
}

/// Sets `workbench_version` in `v` (an object) and, when built from git, `workbench_commit`,
/// `workbench_dirty` and, if dirty, `workbench_changes` (the fingerprint). Outside git the
/// last three are left out rather than `null`: nothing is known about them.
pub fn manifest_fields(v: &mut serde_json::Value, build: &Build) {
    let Some(o) = v.as_object_mut() else {
        return;
    };
    for k in ["workbench_commit", "workbench_dirty", "workbench_changes"] {
        o.remove(k);
    }
    o.insert("workbench_version".into(), build.version.clone().into());
    if let Some(c) = &build.commit {
        o.insert("workbench_commit".into(), c.clone().into());
        o.insert("workbench_dirty".into(), build.dirty().into());
        if let Some(f) = &build.changes {
            o.insert("workbench_changes".into(), f.clone().into());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn builds() -> [Build; 3] {
        let b = |commit: Option<&str>, changes: Option<&str>| Build {
            version: "0.1.0".into(),
            commit: commit.map(String::from),
            changes: changes.map(String::from),
        };
        [
            b(None, None),
            b(Some("d9ea8fe0c0ffee"), None),
            b(Some("d9ea8fe0c0ffee"), Some("0123456789abcdef")),
        ]
    }

    #[test]
    fn provenance_round_trips_through_tokens_and_manifests() {
        for b in builds() {
            assert_eq!(Build::from_token(&b.version, &b.token()).as_ref(), Some(&b));
            let mut v = serde_json::json!({"plan": {}});
            manifest_fields(&mut v, &b);
            assert_eq!(Build::from_json(&v).as_ref(), Some(&b), "{v}");
            assert_eq!(v.get("workbench_dirty").is_some(), b.commit.is_some());
            // The committed form keeps the version and drops the rest, whatever was there.
            manifest_version(&mut v, &b);
            assert_eq!(v, serde_json::json!({"plan": {}, "workbench_version": b.version}));
        }
        assert_eq!(Build::from_token("0.1.0", ""), None);
        assert_eq!(Build::from_token("0.1.0", "abc+changes."), None);
        // A dirty flag that disagrees with the fingerprint is not a record of ours.
        let v = serde_json::json!({"workbench_version": "0.1.0", "workbench_commit": "ab", "workbench_dirty": true});
        assert_eq!(Build::from_json(&v), None);
    }

    #[test]
    fn provenance_this_build_names_its_version() {
        let b = Build::current();
        assert_eq!(b.version, env!("CARGO_PKG_VERSION"));
        if let Some(c) = &b.commit {
            assert!(c.len() >= 40 && c.bytes().all(|x| x.is_ascii_hexdigit()), "{c}");
        }
        assert!(b.commit.is_some() || b.changes.is_none());
    }
}
