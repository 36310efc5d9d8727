//! The docs and the binary agree.
//!
//! - `docs/math.md` and `docs/render-scene.md` are copies of the team's shared specification
//!   (`../shared/docs/`), kept in the repository so that a clone has the formulas its README
//!   cites. Where the shared folder sits beside the checkout (as in CI), the copies must match.
//! - Every command the README and `docs/guide/` show is parsed by the binary's own parser in
//!   `src/cli/docs_commands.rs` (a unit test of the binary, which owns the parser). Here a
//!   representative set of them runs, as shown, in a scratch folder holding the shipped
//!   experiment files, and what they print is compared with what the docs show. The renders
//!   run at 48×48 (`--width 48 --height 48` added) to keep the suite fast.
//! - Every relative link and image of the README and the guide leads to a file, and every
//!   `#anchor` to a heading or `<a id>` of it.

use crate::common::*;
use std::path::{Path, PathBuf};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn doc(name: &str) -> String {
    std::fs::read_to_string(root().join(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

#[test]
fn docs_match_the_shared_specification() {
    let shared = root().join("../shared/docs");
    for name in ["math.md", "render-scene.md"] {
        let ours = std::fs::read_to_string(root().join("docs").join(name)).expect("docs/ copy exists");
        assert!(ours.contains("# "), "docs/{name} is empty");
        match std::fs::read_to_string(shared.join(name)) {
            Ok(theirs) => assert!(
                ours == theirs,
                "docs/{name} differs from ../shared/docs/{name}: copy it again"
            ),
            Err(_) => eprintln!("note: ../shared/docs/{name} not found; docs/{name} not compared"),
        }
    }
}

/// A scratch folder holding a copy of `experiments/` (and `benches/`' specs), like a clone.
fn clone_like() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for folder in ["experiments"] {
        std::fs::create_dir(dir.path().join(folder)).unwrap();
        for entry in std::fs::read_dir(root().join(folder)).unwrap() {
            let path = entry.unwrap().path();
            std::fs::copy(&path, dir.path().join(folder).join(path.file_name().unwrap())).unwrap();
        }
    }
    dir
}

/// The arguments of `command` as `doc_name` shows it in a code block (after a `$ ` prompt or
/// not, before any `# comment`): fails unless the doc shows exactly that line.
fn shown(doc_name: &str, command: &str) -> Vec<String> {
    let text = doc(doc_name);
    let found = text.lines().any(|l| {
        let l = l.strip_prefix("$ ").unwrap_or(l);
        let l = l.split(" #").next().unwrap_or(l).trim_end();
        l == command
    });
    assert!(
        found,
        "{doc_name} no longer shows `{command}`: update this test with the docs"
    );
    let rest = command
        .strip_prefix("cargo run --release -- ")
        .or_else(|| command.strip_prefix("workbench "))
        .unwrap_or_else(|| panic!("`{command}` is not a workbench command"));
    rest.split_whitespace().map(String::from).collect()
}

/// The output lines `doc_name` shows after `$ command`, up to the next prompt or the block's end.
fn shown_output(doc_name: &str, command: &str) -> Vec<String> {
    let text = doc(doc_name);
    let mut lines = text.lines().skip_while(|l| *l != format!("$ {command}"));
    assert!(lines.next().is_some(), "{doc_name} shows no `$ {command}`");
    lines
        .take_while(|l| !l.starts_with("$ ") && !l.starts_with("```"))
        .map(String::from)
        .collect()
}

fn run_shown(dir: &Path, args: &[String], extra: &[&str]) -> std::process::Output {
    let mut all: Vec<&str> = args.iter().map(String::as_str).collect();
    all.extend_from_slice(extra);
    let o = workbench(dir, &all);
    assert!(
        o.status.success(),
        "`workbench {}` failed:\n{}",
        all.join(" "),
        stderr(&o)
    );
    o
}

/// The same text, numbers equal to 1e-9 relative: the last bits of weights depend on the
/// machine (math libraries, SIMD kernels; see "How trials are run" in docs/guide/run.md).
fn same_numbers(a: &str, b: &str) -> bool {
    let split = |s: &str| -> Vec<String> {
        s.split([',', ' ', ':'])
            .filter(|w| !w.is_empty())
            .map(String::from)
            .collect()
    };
    let (a, b) = (split(a), split(b));
    a.len() == b.len()
        && a.iter()
            .zip(&b)
            .all(|(x, y)| match (x.parse::<f64>(), y.parse::<f64>()) {
                (Ok(x), Ok(y)) => (x - y).abs() <= 1e-9 * x.abs().max(y.abs()),
                _ => x == y,
            })
}

/// Every line shown (but the timing line) is a line the command printed.
fn assert_prints(shown_lines: &[String], o: &std::process::Output, what: &str) {
    let printed = format!("{}\n{}", stdout(o), stderr(o));
    let printed: Vec<&str> = printed.lines().collect();
    let mut compared = 0;
    for line in shown_lines {
        if line.trim().is_empty() || line == "..." {
            continue;
        }
        if let Some(prefix) = line.strip_prefix("wrote ").and_then(|l| l.split(" (").next()) {
            let prefix = format!("wrote {prefix} (");
            assert!(
                printed.iter().any(|p| p.starts_with(&prefix)),
                "{what}: no `{prefix}…` line"
            );
            continue;
        }
        assert!(
            printed.contains(&line.as_str()),
            "{what} shows a line the command did not print:\n{line}\nprinted:\n{}",
            printed.join("\n")
        );
        compared += 1;
    }
    assert!(compared > 0, "{what}: no output compared");
}

#[test]
fn the_readmes_run_rule_validate_and_reproduce_work_as_shown() {
    let dir = clone_like();
    let d = dir.path();

    let run = "cargo run --release -- run experiments/cos3.json";
    let o = run_shown(d, &shown("README.md", run), &[]);
    assert_prints(&shown_output("README.md", run), &o, "README's run");
    assert_prints(&shown_output("docs/guide/run.md", run), &o, "run.md's run");
    assert!(d.join("results/cos3/cos3.svg").is_file());

    let rule = "cargo run --release -- rule --n 64 --seed 7 --out rule.csv --summary rule.json";
    let o = run_shown(d, &shown("README.md", rule), &[]);
    assert_prints(&shown_output("README.md", rule), &o, "README's rule");
    assert_prints(&shown_output("docs/guide/rule.md", rule), &o, "rule.md's rule");
    // rule.md's `head` and `grep` of the files it wrote.
    let csv = std::fs::read_to_string(d.join("rule.csv")).unwrap();
    let head = shown_output("docs/guide/rule.md", "head -4 rule.csv");
    assert_eq!(head.len(), 5, "{head:?}");
    for (shown, written) in head[..4].iter().zip(csv.lines()) {
        assert!(
            same_numbers(shown, written),
            "rule.md's head -4 rule.csv shows\n{shown}\nnot\n{written}"
        );
    }
    let json = std::fs::read_to_string(d.join("rule.json")).unwrap();
    let grep = shown_output(
        "docs/guide/rule.md",
        r#"grep -E 'weight_sum"|posterior_variance"|prior_variance' rule.json"#,
    );
    assert_eq!(grep.len(), 3, "{grep:?}");
    for line in grep {
        assert!(
            json.lines().any(|l| same_numbers(l, &line)),
            "rule.md's grep shows {line:?}, not in rule.json"
        );
    }

    let o = run_shown(
        d,
        &shown(
            "README.md",
            "cargo run --release -- validate experiments/cos3.json",
        ),
        &[],
    );
    assert!(stdout(&o).starts_with("cos3: 1 integrand(s)"), "{}", stdout(&o));

    let o = run_shown(
        d,
        &shown("README.md", "cargo run --release -- reproduce --list"),
        &[],
    );
    let files = std::fs::read_dir(d.join("experiments")).unwrap().count();
    assert_eq!(stdout(&o).lines().count(), 1 + files, "{}", stdout(&o));
    assert!(!d.join("results/adaptive").exists(), "--list ran something");
}

#[test]
fn the_readmes_renders_and_the_fig_3_14_commands_work_as_shown() {
    let dir = clone_like();
    let d = dir.path();
    let small = ["--width", "48", "--height", "48"];
    run_shown(
        d,
        &shown(
            "README.md",
            "cargo run --release -- render --integrator exact --out ref.exr",
        ),
        &small,
    );
    let o = run_shown(
        d,
        &shown(
            "README.md",
            "cargo run --release -- render --integrator bmc --spp 40 --reference ref.exr --out bmc.exr",
        ),
        &small,
    );
    assert!(stdout(&o).starts_with("rmse = "), "{}", stdout(&o));
    for file in ["ref.exr", "bmc.exr", "bmc.png", "bmc-error.png"] {
        assert!(d.join(file).is_file(), "{file}");
    }

    let page = "docs/guide/reproducing-the-thesis.md";
    for (command, error_png) in [
        (
            "workbench render --integrator mc --spp 30 --reference ref.exr --out mc30.exr",
            "mc30-error.png",
        ),
        (
            "workbench render --integrator mc --spp 30 --reference ref.exr --out mc30-grey.exr --error-colours grey",
            "mc30-grey-error.png",
        ),
        (
            "workbench render --integrator mc --spp 30 --reference ref.exr --out mc30-norm.exr --error-scale normalised",
            "mc30-norm-error.png",
        ),
        (
            "workbench render --integrator mc --spp 30 --reference ref.exr --out mc30-norm-grey.exr --error-scale normalised --error-colours grey",
            "mc30-norm-grey-error.png",
        ),
    ] {
        run_shown(d, &shown(page, command), &small);
        assert!(d.join(error_png).is_file(), "{error_png}");
    }
}

/// merge-and-clusters.md's GNU parallel example, its `{}` filled in as parallel would.
#[test]
fn the_guides_shard_and_merge_example_works_as_shown() {
    let dir = clone_like();
    let d = dir.path();
    let page = "docs/guide/merge-and-clusters.md";
    let text = doc(page);
    let line = text
        .lines()
        .find(|l| l.starts_with("parallel -j 4 workbench run "))
        .expect("merge-and-clusters.md shows the GNU parallel example");
    let (command, values) = line.split_once(" ::: ").expect("parallel's ::: list");
    let command = command.strip_prefix("parallel -j 4 ").unwrap();
    for i in values.split_whitespace() {
        run_shown(d, &shown_words(&command.replace("{}", i)), &[]);
    }
    let o = run_shown(
        d,
        &shown(
            page,
            "workbench merge results/glossy shards/1 shards/2 shards/3 shards/4",
        ),
        &[],
    );
    assert!(
        stderr(&o).contains("merged 4 shards into results/glossy"),
        "{}",
        stderr(&o)
    );
    assert!(d.join("results/glossy/summary.csv").is_file());
}

fn shown_words(command: &str) -> Vec<String> {
    command
        .strip_prefix("workbench ")
        .expect("a workbench command")
        .split_whitespace()
        .map(String::from)
        .collect()
}

/// GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

fn anchors(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut fence = false;
    for line in text.lines() {
        if line.starts_with("```") {
            fence = !fence;
        }
        if fence {
            continue;
        }
        if let Some(h) = line.strip_prefix('#') {
            out.push(slug(h.trim_start_matches('#')));
        }
        let mut rest = line;
        while let Some(i) = rest.find("<a id=\"") {
            let after = &rest[i + 7..];
            let end = after.find('"').unwrap_or(after.len());
            out.push(after[..end].to_string());
            rest = &after[end..];
        }
    }
    out
}

/// `[text](target)` links and images outside code.
fn links(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut fence = false;
    for line in text.lines() {
        if line.starts_with("```") {
            fence = !fence;
        }
        if fence {
            continue;
        }
        // Code spans hold no links.
        let prose: String = line.split('`').step_by(2).collect::<Vec<_>>().join(" ");
        let mut rest = prose.as_str();
        while let Some(i) = rest.find("](") {
            let after = &rest[i + 2..];
            let end = after.find(')').unwrap_or(after.len());
            out.push(after[..end].to_string());
            rest = &after[end..];
        }
    }
    out
}

fn doc_files() -> Vec<PathBuf> {
    let mut files = vec![root().join("README.md")];
    let mut guide: Vec<PathBuf> = std::fs::read_dir(root().join("docs/guide"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    guide.sort();
    files.extend(guide);
    files
}

#[test]
fn every_link_of_the_readme_and_the_guide_resolves() {
    let mut broken = Vec::new();
    let mut checked = 0;
    for file in doc_files() {
        let text = std::fs::read_to_string(&file).unwrap();
        for link in links(&text) {
            if link.starts_with("http://") || link.starts_with("https://") {
                continue;
            }
            checked += 1;
            let (path, anchor) = link.split_once('#').unwrap_or((&link, ""));
            let target = if path.is_empty() {
                file.clone()
            } else {
                file.parent().unwrap().join(path)
            };
            if !target.exists() {
                broken.push(format!("{}: {link}: no such file", file.display()));
                continue;
            }
            if !anchor.is_empty() {
                let text = std::fs::read_to_string(&target).unwrap_or_default();
                if !anchors(&text).iter().any(|a| a == anchor) {
                    broken.push(format!(
                        "{}: {link}: no heading or <a id> `{anchor}`",
                        file.display()
                    ));
                }
            }
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
    assert!(checked > 100, "only {checked} links checked");
}

#[test]
fn the_readme_stays_short() {
    let lines = doc("README.md").lines().count();
    assert!(
        lines <= 300,
        "README.md has {lines} lines; move detail to docs/guide/"
    );
}

#[test]
fn slugs_follow_githubs_rule() {
    assert_eq!(slug(" Smoother kernels (s > 2)"), "smoother-kernels-s--2");
    assert_eq!(
        slug(" Integrand families (math.md §1, \"Rendering-like integrands\")"),
        "integrand-families-mathmd-1-rendering-like-integrands"
    );
    assert_eq!(
        slug(" Does BMC's lead survive rendering-like integrands?"),
        "does-bmcs-lead-survive-rendering-like-integrands"
    );
}
