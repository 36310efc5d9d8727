//! Records which source the binary is built from, for the manifests ([`workbench::provenance`]):
//! the git commit of the checkout and, if the files that go into the binary differ from it, a
//! fingerprint of those differences. Outside a git checkout (a source tarball, a vendored copy)
//! both are empty and the manifests give the package version only.
//!
//! Only local `git` commands that read the repository run (no network, no writes: an
//! opportunistic index refresh by `git status` is turned off, so the build never touches `.git`).
//! The script reruns when the sources change or HEAD moves (a commit, a checkout), and only
//! then, so an edit that leaves the sources alone (README, results, tests) rebuilds nothing.

use std::path::{Path, PathBuf};
use std::process::Command;

/// What goes into the binary: a change here changes what it computes.
const SOURCES: &[&str] = &["src", "build.rs", "Cargo.toml", "Cargo.lock"];

fn main() {
    for s in SOURCES {
        println!("cargo:rerun-if-changed={s}");
    }
    let (commit, changes) = git_state().unwrap_or_default();
    println!("cargo:rustc-env=WORKBENCH_GIT_COMMIT={commit}");
    println!("cargo:rustc-env=WORKBENCH_GIT_CHANGES={changes}");
}

/// `git` in the package folder, reading only; its stdout if it succeeded.
fn git(args: &[&str]) -> Option<Vec<u8>> {
    let dir = std::env::var_os("CARGO_MANIFEST_DIR")?;
    let out = Command::new("git")
        .args(args)
        .current_dir(dir)
        .env("GIT_OPTIONAL_LOCKS", "0")
        .output()
        .ok()?;
    out.status.success().then_some(out.stdout)
}

fn git_line(args: &[&str]) -> Option<String> {
    let out = String::from_utf8(git(args)?).ok()?;
    let line = out.trim();
    (!line.is_empty()).then(|| line.to_string())
}

/// The commit and the fingerprint of the uncommitted changes to [`SOURCES`] (empty if there are
/// none), or `None` outside a git checkout of this package.
fn git_state() -> Option<(String, String)> {
    // Inside some other repository (a tarball unpacked into one), Cargo.toml is not tracked.
    git(&["ls-files", "--error-unmatch", "Cargo.toml"])?;
    let commit = git_line(&["rev-parse", "--verify", "HEAD^{commit}"])?;
    watch_head();

    // Every changed or untracked (not ignored) file among the sources, by path and current
    // content: with the commit, that determines the sources exactly, and unlike a diff's text it
    // does not depend on the user's git configuration.
    let mut args = vec![
        "status",
        "--porcelain=v1",
        "-z",
        "--no-renames",
        "--untracked-files=all",
        "--",
    ];
    args.extend(SOURCES);
    let status = git(&args)?;
    let mut paths: Vec<&[u8]> = status
        .split(|&b| b == 0)
        .filter(|e| e.len() > 3)
        .map(|e| &e[3..])
        .collect();
    paths.sort();
    paths.dedup();
    if paths.is_empty() {
        return Some((commit, String::new()));
    }
    let dir = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR")?);
    let mut h = Fnv::new();
    for p in paths {
        h.write(p);
        h.write(&[0]);
        match std::str::from_utf8(p)
            .ok()
            .and_then(|p| std::fs::read(dir.join(p)).ok())
        {
            Some(bytes) => {
                h.write(&(bytes.len() as u64).to_le_bytes());
                h.write(&bytes);
            }
            None => h.write(b"absent"),
        }
    }
    Some((commit, format!("{:016x}", h.0)))
}

/// Reruns the script when HEAD moves: HEAD itself (a checkout, a detached commit), its reflog
/// (every move of HEAD appends to it) and the branch it names (a commit). Only files that exist:
/// Cargo reruns a script every time for a path that does not.
fn watch_head() {
    let watch = |p: PathBuf| {
        if p.is_file() {
            println!("cargo:rerun-if-changed={}", p.display());
        }
    };
    let path = |args: &[&str]| git_line(args).map(PathBuf::from);
    if let Some(git_dir) = path(&["rev-parse", "--absolute-git-dir"]) {
        watch(git_dir.join("HEAD"));
        watch(git_dir.join("logs").join("HEAD"));
    }
    if let Some(branch) = git_line(&["symbolic-ref", "-q", "HEAD"])
        && let Some(common) = path(&["rev-parse", "--git-common-dir"])
    {
        let common = absolute(&common);
        watch(common.join(&branch));
        watch(common.join("packed-refs"));
    }
}

/// `--git-common-dir` may be relative to the package folder.
fn absolute(p: &Path) -> PathBuf {
    match std::env::var_os("CARGO_MANIFEST_DIR") {
        Some(dir) if p.is_relative() => PathBuf::from(dir).join(p),
        _ => p.to_path_buf(),
    }
}

/// FNV-1a, 64 bits (as for the plan hash): tells sources apart, not a security measure.
struct Fnv(u64);

impl Fnv {
    fn new() -> Fnv {
        Fnv(0xcbf2_9ce4_8422_2325)
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
        }
    }
}
