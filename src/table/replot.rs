//! Redraws the committed render tables' figures (`rmse_vs_spp.svg` and its caption) from
//! their `rmse.csv`, without rendering: for a change that only changes how a table is drawn,
//! whose tables would take minutes to an hour to render again. Every other file stays as it
//! was (`git diff --stat` shows only figures). The rows are read back exactly (shortest
//! round-trip numbers) and summarised in file order, as the table's run summarised them, so
//! the figure is the one a run would draw.
//!
//! `cargo test --release --lib replot_committed_tables -- --ignored` (with `WORKBENCH_DATA`
//! for the tables of real maps; a table whose file does not load is skipped, named).

use super::adaptive::runner::AdaptiveRow;
use super::export::RAYS_COLUMN;
use super::external::ExternalMeasures;
use super::plan::TablePlan;
use super::runner::Row;
use std::path::Path;

/// The rows of a fixed-spp table's `rmse.csv` (its seconds, not in the file, as 0: no figure
/// draws them).
fn fixed_rows(plan: &TablePlan, text: &str) -> Vec<Row> {
    let mut reader = csv::Reader::from_reader(text.as_bytes());
    let head: Vec<String> = reader.headers().unwrap().iter().map(String::from).collect();
    let col = |name: &str| {
        head.iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("{name}"))
    };
    reader
        .records()
        .map(|r| {
            let r = r.unwrap();
            let f = |name: &str| -> f64 { r[col(name)].parse().unwrap() };
            let u = |name: &str| -> u64 { r[col(name)].parse().unwrap() };
            Row {
                variant: variant_of(plan, &r[0]),
                spp: u("spp") as usize,
                repetition: u("repetition") as usize,
                seed: u("seed"),
                rmse: f("rmse"),
                rmse_edges: f("rmse_edges"),
                coverage95: f("coverage95"),
                coverage95_edges: f("coverage95_edges"),
                seconds: 0.0,
                rays_per_pixel: match head.iter().position(|h| h == RAYS_COLUMN) {
                    Some(i) => r[i].parse().unwrap(),
                    None => u("spp") as f64,
                },
                external: plan.external.as_ref().map(|_| ExternalMeasures {
                    rmse_theirs: f("rmse_theirs"),
                    mean_l2_theirs: f("mean_l2_theirs"),
                    mean_l2_ours: f("mean_l2"),
                }),
            }
        })
        .collect()
}

/// The rows of an adaptive table's `rmse.csv`.
fn adaptive_rows(plan: &TablePlan, targets: &[f64], text: &str) -> Vec<AdaptiveRow> {
    let mut reader = csv::Reader::from_reader(text.as_bytes());
    reader
        .records()
        .map(|r| {
            let r = r.unwrap();
            let f = |i: usize| -> f64 { r[i].parse().unwrap() };
            let target = f(4);
            AdaptiveRow {
                variant: variant_of(plan, &r[0]),
                column: targets
                    .iter()
                    .position(|&t| t == target)
                    .expect("a target of the plan"),
                target,
                repetition: r[5].parse().unwrap(),
                seed: r[6].parse().unwrap(),
                rmse: f(7),
                mean_spp: f(8),
                share_met: f(9),
                within: f(10),
                seconds: 0.0,
            }
        })
        .collect()
}

fn variant_of(plan: &TablePlan, label: &str) -> usize {
    plan.variants
        .iter()
        .position(|v| v.label == label)
        .unwrap_or_else(|| panic!("variant {label:?}"))
}

/// Writes `bytes` to `path` through a temporary file beside it and a rename.
fn write_atomically(path: &Path, bytes: &[u8]) {
    let tmp = path.with_extension("replot-tmp");
    std::fs::write(&tmp, bytes).unwrap();
    std::fs::rename(&tmp, path).unwrap();
}

#[test]
#[ignore = "rewrites results/*/rmse_vs_spp.*: run by hand after a change to how tables are drawn"]
fn replot_committed_tables() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut specs: Vec<_> = std::fs::read_dir(root.join("experiments"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    specs.sort();
    for spec in specs {
        let text = std::fs::read_to_string(&spec).unwrap();
        if crate::files::spec_json::spec_kind(&text) == Some(crate::files::spec_json::SpecKind::Experiment) {
            continue;
        }
        let plan = match super::plan::load(&spec) {
            Ok(p) => p,
            Err(e) => {
                eprintln!("skipped {}: {e}", spec.display());
                continue;
            }
        };
        let dir = root.join("results").join(&plan.name);
        let Ok(csv) = std::fs::read_to_string(dir.join("rmse.csv")) else {
            eprintln!("skipped {}: no {}/rmse.csv", spec.display(), dir.display());
            continue;
        };
        let figure = match &plan.adaptive {
            None => super::plot::plot_svg(&plan, &super::summary::summarise(&plan, &fixed_rows(&plan, &csv))),
            Some(a) => {
                let targets = a.targets.clone();
                let rows = adaptive_rows(&plan, &targets, &csv);
                let cells = super::adaptive::summary::summarise(&plan, &targets, &rows);
                super::adaptive::plot::plot_svg(&plan, &targets, &cells)
            }
        }
        .unwrap();
        write_atomically(&dir.join("rmse_vs_spp.svg"), figure.svg.as_bytes());
        write_atomically(&dir.join("rmse_vs_spp.caption.txt"), figure.caption.as_bytes());
        eprintln!("redrew {}/rmse_vs_spp.svg", dir.display());
    }
}
