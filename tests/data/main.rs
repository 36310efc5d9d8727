//! Tests that need the external data folder (`data/catalog.json`, docs/guide/data.md): a second
//! test target with libtest-compatible output (`libtest-mimic`), so that filters and
//! `--list` work as in `cargo test`.
//!
//! The folder is `WORKBENCH_DATA`. Unset, every test here is *ignored with the reason*, so that
//! `cargo test --release` passes on a machine without the data and says how many data tests it
//! did not run and why; with `WORKBENCH_REQUIRE_DATA=1` (as `.ci/run` sets) a missing folder
//! *fails* every test instead.
//!
//! Adding a test: write `fn name(data: &Data)` in the module of its topic (it fails by
//! panicking, as any test) and add `("name", name)` to that module's `TESTS`; a new topic is a
//! new module and one line in [`TOPICS`].

#[path = "../support/brute_force.rs"]
mod brute_force;
mod catalog;
mod envmap;
mod light;
#[path = "../support/light_baselines.rs"]
mod light_baselines;
mod thesis;

use libtest_mimic::{Arguments, Completion, Failed, Trial};
use std::path::{Path, PathBuf};

/// The data folder the tests read.
pub struct Data {
    pub dir: PathBuf,
}

impl Data {
    /// The catalogue entry `name` (panics if the catalogue has none).
    pub fn entry(&self, name: &str) -> &'static workbench::data::Entry {
        workbench::data::catalog::find(name).unwrap_or_else(|| panic!("no `{name}` in data/catalog.json"))
    }

    /// Where the catalogue file `name` is in the folder.
    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.join(&self.entry(name).path)
    }

    /// Runs `workbench args…` in `cwd` with this data folder as `WORKBENCH_DATA`.
    pub fn workbench(&self, cwd: &Path, args: &[&str]) -> std::process::Output {
        std::process::Command::new(env!("CARGO_BIN_EXE_workbench"))
            .args(args)
            .current_dir(cwd)
            .env("WORKBENCH_DATA", &self.dir)
            .output()
            .expect("the binary runs")
    }
}

/// A data test: its name and its body.
pub type Test = (&'static str, fn(&Data));

/// Every topic's tests.
const TOPICS: &[(&str, &[Test])] = &[
    ("catalog", catalog::TESTS),
    ("envmap", envmap::TESTS),
    ("light", light::TESTS),
    ("thesis", thesis::TESTS),
];

/// The data folder, or why there is none.
fn data_folder() -> Result<Data, String> {
    let Some(dir) = std::env::var_os("WORKBENCH_DATA").filter(|d| !d.is_empty()) else {
        return Err(
            "WORKBENCH_DATA is not set (set it to the data folder, e.g. ../shared/data; docs/guide/data.md)"
                .into(),
        );
    };
    let dir = PathBuf::from(dir);
    if !dir.is_dir() {
        return Err(format!("WORKBENCH_DATA={} is not a folder", dir.display()));
    }
    // Absolute, so that tests may run the binary in other folders.
    let dir = std::fs::canonicalize(&dir).map_err(|e| format!("WORKBENCH_DATA={}: {e}", dir.display()))?;
    Ok(Data { dir })
}

fn main() {
    let args = Arguments::from_args();
    let required = std::env::var("WORKBENCH_REQUIRE_DATA").is_ok_and(|v| v == "1");
    let folder = std::sync::Arc::new(data_folder());
    let mut trials = Vec::new();
    for (topic, tests) in TOPICS {
        for &(name, body) in *tests {
            let folder = folder.clone();
            trials.push(Trial::ignorable_test(
                format!("{topic}::{name}"),
                move || match folder.as_ref() {
                    Ok(data) => {
                        body(data);
                        Ok(Completion::Completed)
                    }
                    Err(why) if required => Err(Failed::from(format!("WORKBENCH_REQUIRE_DATA=1 but {why}"))),
                    Err(why) => Ok(Completion::ignored_with(why)),
                },
            ));
        }
    }
    let conclusion = libtest_mimic::run(&args, trials);
    if let Err(why) = folder.as_ref()
        && !required
        && conclusion.num_ignored > 0
    {
        println!("note: {} data tests did not run: {why}", conclusion.num_ignored);
    }
    conclusion.exit();
}
