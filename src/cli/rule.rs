//! `workbench rule`: a BMC quadrature rule (points and weights) as a file.

use super::model_args::ModelArgs;
use super::output::{status, stdout};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use workbench::bq::estimator::Method;
use workbench::files::file_set::FileSet;
use workbench::files::read::{FileKind, read_text};
use workbench::sampling::Design;
use workbench::util::geometry::Vec3;

#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:\n  \
    workbench rule --n 64 --seed 7 --out rule.csv --summary rule.json\n  \
    workbench rule --points my-points.csv --kernel se --length 0.3 > rule.csv\n\n\
    The CSV and summary fields are documented in docs/guide/rule.md.\n\n\
    Exit codes: 0 success; 2 any error (bad input, I/O).")]
pub struct RuleArgs {
    /// Number of points to generate (not with --points) [default: 64].
    #[arg(long, conflicts_with = "points")]
    n: Option<usize>,
    /// Seed of the generated points (and of the MC kernel means).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Sampling design of the generated points (not with --points) [default: uniform].
    #[arg(long, value_parser = design_names(), conflicts_with = "points")]
    design: Option<String>,
    /// Read the points from a CSV with header `x,y,z` instead of generating them.
    #[arg(long)]
    points: Option<PathBuf>,
    /// The rule: `bmc` (w = Q⁻¹z) or `bsq` (Bayes–Sard, math.md §8: weights summing to 2π;
    /// needs at least 2 points).
    #[arg(long, default_value = "bmc", value_parser = ["bmc", "bsq"])]
    method: String,
    /// The kernel amplitude an integration with this rule should use (math.md §7): `unit`,
    /// `ml` or `loo`. A rule has no integrand values, so it always reports the unit-amplitude
    /// posterior variance Var₁; the summary records the scale and its interval law (`ml`:
    /// Student-t with N, for bsq N − 1, degrees of freedom), to be applied as λ̂ · Var₁ once
    /// values are known.
    #[arg(long, default_value = "unit", value_parser = ["unit", "ml", "loo"])]
    scale: String,
    #[command(flatten)]
    model: ModelArgs,
    /// The integrand's values at the rule's points (CSV with header `value`, one row per point
    /// in the rule's order), for `--kernel fitted`: the model with the largest marginal
    /// likelihood of these values gives the weights (math.md §9).
    #[arg(long)]
    values: Option<PathBuf>,
    /// Write the rule (CSV `x,y,z,weight`) here instead of to stdout.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write the diagnostics as JSON here.
    #[arg(long)]
    summary: Option<PathBuf>,
}

fn design_names() -> Vec<&'static str> {
    Design::ALL.iter().map(|d| d.name()).collect()
}

/// Default number of generated points.
const DEFAULT_N: usize = 64;

pub fn rule(args: RuleArgs) -> anyhow::Result<ExitCode> {
    let outputs: Vec<(&str, &Path)> = [("--out", &args.out), ("--summary", &args.summary)]
        .into_iter()
        .filter_map(|(f, p)| p.as_deref().map(|p| (f, p)))
        .collect();
    let inputs: Vec<(&str, &Path)> = [("--points", &args.points), ("--values", &args.values)]
        .into_iter()
        .filter_map(|(f, p)| p.as_deref().map(|p| (f, p)))
        .collect();
    workbench::files::atomic::check_distinct(&outputs, &inputs)?;
    let n = args.n.unwrap_or(DEFAULT_N);
    let design = args
        .design
        .as_deref()
        .and_then(Design::from_name)
        .unwrap_or(Design::Iid(workbench::sampling::Density::Uniform));
    let exact_kernel_means = args.model.resolve()?.kernel_mean == workbench::bq::model::KernelMeanName::Exact;
    let points = match &args.points {
        Some(path) => {
            let points = read_points_csv(path)?;
            workbench::bq::rule::check_point_count(points.len(), "--points")?;
            points
        }
        None => {
            workbench::bq::rule::check_generated_count(n, design, exact_kernel_means, "--n", "--design")?;
            workbench::bq::rule::generate_points(n, args.seed, design)
        }
    };
    let method = Method::from_name(&args.method).expect("clap checks the names");
    let bsq = args.method == "bsq";
    if bsq && points.len() < 2 {
        anyhow::bail!(workbench::error::InputError::new(format!(
            "--method bsq: Bayes–Sard fits a constant and needs at least 2 points, got {}",
            points.len()
        )));
    }
    let resolved = args.model.resolve()?;
    let values = match (&args.values, resolved.is_fitted()) {
        (Some(path), true) => Some(read_values_csv(path, points.len())?),
        (None, true) => anyhow::bail!(workbench::error::InputError::new(
            "--kernel fitted: needs --values FILE (the model is chosen by the marginal likelihood of the \
             integrand's values at the rule's points)"
        )),
        (Some(_), false) => anyhow::bail!(workbench::error::InputError::new(
            "--values: only used with --kernel fitted (a fixed kernel's weights do not depend on the values)"
        )),
        (None, false) => None,
    };
    let model = args.model.build()?;
    // The rule and its summary are one set: both are written in full before either replaces an
    // earlier file, and no other command may write them meanwhile. Taken once the input is
    // known to be good, so that bad input leaves no trace.
    let mut files = FileSet::lock(&outputs, "use another --out or --summary")?;
    // Points from a file count as i.i.d. uniform (a dense solve); a fitted model chooses the grid
    // model whose marginal likelihood of the values is largest (for bsq the restricted one).
    let design = if args.points.is_some() {
        Design::Iid(workbench::sampling::Density::Uniform)
    } else {
        design
    };
    let flag = if args.points.is_some() { "--points" } else { "--n" };
    workbench::bq::rule::check_factor_memory(
        flag,
        &workbench::bq::rule::FactorMemory::weight_set(points.len(), design, exact_kernel_means),
    )?;
    let (weights, choice) =
        workbench::bq::rule::rule_weights(&points, design, &model, method, values.as_deref(), args.seed)?;
    // The model the weights are of: the chosen one of a fitted grid.
    let model = match &choice {
        Some(c) => model.candidates()[c.chosen].clone(),
        None => model,
    };
    for w in &weights.diagnostics.warnings {
        status!("warning: {}", w.message());
    }
    let csv = workbench::bq::rule::rule_csv(&points, &weights.weights);
    if let Some(path) = &args.out {
        files.stage(path, &csv)?;
    }
    if let Some(path) = &args.summary {
        // Everything needed to make the same rule again.
        let source = match &args.points {
            Some(file) => serde_json::json!({ "points": file.display().to_string() }),
            None => {
                serde_json::json!({ "generated": { "n": n, "seed": args.seed, "design": design.name() } })
            }
        };
        let mut summary =
            workbench::bq::rule::rule_summary(&model, resolved.kernel_mean.name(), &points, &weights);
        summary["source"] = source;
        summary["seed"] = serde_json::json!(args.seed);
        summary["method"] = serde_json::json!(args.method);
        summary["scale"] = serde_json::json!({
            "scale": args.scale,
            "posterior_variance_is": "Var₁, the unit-amplitude posterior variance; with values Y the \
                interval is Î ± q · sqrt(λ̂ · Var₁) (math.md §7)",
            "amplitude": match args.scale.as_str() {
                "unit" => "1",
                "ml" if bsq => "rᵀQ⁻¹r / (N − 1), r = Y − β̂·1",
                "ml" => "rᵀQ⁻¹r / N, r = Y (BMC) or Y − c·1 (BMCP)",
                _ => "(1/N) Σ (Q⁻¹r)_i² / (Q⁻¹)_ii",
            },
            "interval": if args.scale == "ml" { "student_t" } else { "normal" },
        });
        // The degrees of freedom exist only for the Student-t interval of `ml`: elsewhere the key
        // is left out rather than written as null (which a NaN would also give).
        if args.scale == "ml" {
            summary["scale"]["student_t_dof"] = serde_json::json!(method.ml_dof(points.len()));
        }
        if let Some(m) = resolved.samples() {
            summary["kernel_mean_samples"] = serde_json::json!(m);
        }
        if let Some(c) = &choice {
            // Which grid model won and every candidate's ℓ, so the choice can be checked.
            summary["fitted"] = serde_json::json!({
                "values": args.values.as_ref().map(|p| p.display().to_string()),
                "chosen": c.chosen,
                "criterion": if bsq {
                    "restricted profiled log marginal likelihood (math.md §9)"
                } else {
                    "profiled log marginal likelihood (math.md §9)"
                },
                "grid": resolved_grid(&resolved).iter().zip(&c.log_likelihoods).map(|((s, noise), l)| {
                    serde_json::json!({"s": s, "noise": noise, "log_marginal_likelihood": l})
                }).collect::<Vec<_>>(),
            });
        }
        let mut bytes = serde_json::to_vec_pretty(&summary)?;
        bytes.push(b'\n');
        files.stage(path, &bytes)?;
    }
    files.commit()?;
    if args.out.is_none() {
        stdout(std::str::from_utf8(&csv).expect("the CSV is ASCII"))?;
    }
    if let Some(c) = &choice {
        status!(
            "rule: fitted model {} (of {})",
            model.label(),
            c.log_likelihoods.len()
        );
    }
    let d = &weights.diagnostics;
    status!(
        "rule: n = {}, Σw = {:.6} (2π = {:.6}), posterior sd = {:.3e}, {} negative weights",
        d.n,
        d.weight_sum,
        std::f64::consts::TAU,
        weights.posterior_sd(),
        d.negative_weights
    );
    Ok(ExitCode::SUCCESS)
}

/// A fitted model's grid as `(s, noise)` pairs, in grid order.
fn resolved_grid(model: &workbench::bq::model::ResolvedModel) -> Vec<(f64, f64)> {
    model
        .grid
        .iter()
        .flatten()
        .map(|(k, noise)| match k {
            workbench::bq::kernel::Kernel::Sobolev(k) => (k.s(), *noise),
            other => unreachable!("a fitted grid holds Sobolev kernels, not {other}"),
        })
        .collect()
}

/// Reads a values CSV (header `value`, one finite number per row) with exactly `n` rows; errors
/// name the file, the line and the value.
fn read_values_csv(path: &Path, n: usize) -> Result<Vec<f64>, workbench::error::InputError> {
    let name = path.display();
    let in_file = |m: String| workbench::error::InputError::new(format!("{name}: {m}"));
    let text =
        read_text(path, FileKind::Values).map_err(|e| workbench::error::InputError::new(e.to_string()))?;
    let values = parse_values_csv(&text).map_err(in_file)?;
    if values.len() != n {
        return Err(in_file(format!(
            "{} values for {n} points (one value per point, in the rule's order)",
            values.len()
        )));
    }
    Ok(values)
}

/// Parses the text of a values CSV; errors name the line and the value.
fn parse_values_csv(text: &str) -> Result<Vec<f64>, String> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, header)) if header.trim() == "value" => {}
        Some((_, header)) => return Err(format!("line 1: header must be `value`, got `{}`", header.trim())),
        None => return Err("empty file (need a `value` header and one row per point)".into()),
    }
    lines
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| {
            l.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("line {}: value = `{}` is not a finite number", i + 1, l.trim()))
        })
        .collect()
}

/// Reads a CSV with header `x,y,z` (or a rule's `x,y,z,weight`, weights ignored) of unit vectors
/// (`|‖p‖ − 1| ≤ 1e-9`) with `z ≥ 0`. The file must be UTF-8 (a byte-order mark is accepted);
/// errors name the file and the line.
fn read_points_csv(path: &Path) -> Result<Vec<Vec3>, workbench::error::InputError> {
    let name = path.display();
    let in_file = |m: String| workbench::error::InputError::new(format!("{name}: {m}"));
    let text =
        read_text(path, FileKind::Points).map_err(|e| workbench::error::InputError::new(e.to_string()))?;
    parse_points_csv(&text).map_err(in_file)
}

/// Parses the text of a points CSV; errors name the line and the value.
fn parse_points_csv(text: &str) -> Result<Vec<Vec3>, String> {
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let header = reader.headers().map_err(|e| format!("line 1: {e}"))?.clone();
    // A rule's own output (`x,y,z,weight`) is accepted too; its weights are ignored.
    let names: Vec<&str> = header.iter().collect();
    if names != ["x", "y", "z"] && names != ["x", "y", "z", "weight"] {
        return Err(format!(
            "line 1: header must be `x,y,z` (or a rule's `x,y,z,weight`), got `{}`",
            header.iter().collect::<Vec<_>>().join(",")
        ));
    }
    let mut points = Vec::new();
    for record in reader.records() {
        let record = record.map_err(|e| {
            let line = e.position().map_or(0, |p| p.line());
            format!("line {line}: {e}")
        })?;
        let line = record.position().map_or(0, |p| p.line());
        let mut p = [0.0; 3];
        for (k, axis) in ["x", "y", "z"].iter().enumerate() {
            let field = &record[k];
            p[k] = field
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("line {line}: {axis} = `{field}` is not a finite number"))?;
        }
        let v = Vec3::new(p[0], p[1], p[2]);
        workbench::bq::rule::check_point(v).map_err(|m| format!("line {line}: {m}"))?;
        points.push(v);
    }
    if points.is_empty() {
        return Err("no points (need at least one row after the header)".into());
    }
    Ok(points)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_points_name_the_line_and_value() {
        let cases = [
            ("x,y,z\n1,0,0\n0,0,2\n", "line 3"),
            ("x,y,z\n0,0,-1\n", "below the horizon"),
            ("x,y\n1,0\n", "header"),
            ("x,y,z\n0,zero,1\n", "`zero`"),
            ("x,y,z\n", "no points"),
            ("\u{feff}x,y,z\n0,0,1\n0,1,1\n", "line 3"),
        ];
        for (text, needle) in cases {
            let e = parse_points_csv(text).unwrap_err();
            assert!(e.contains(needle), "{text:?}: {e}");
        }
    }

    /// Spreadsheet programs on Windows start CSV files with a byte-order mark.
    #[test]
    fn a_byte_order_mark_is_accepted() {
        let points = parse_points_csv("\u{feff}x,y,z\n0,0,1\n").unwrap();
        assert_eq!(points.len(), 1);
        assert_eq!((points[0].x, points[0].y, points[0].z), (0.0, 0.0, 1.0));
    }

    /// A byte that is not UTF-8 is reported with its line, as every other bad value is.
    #[test]
    fn a_non_utf8_byte_names_the_line() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("points.csv");
        std::fs::write(&path, b"x,y,z\n0,0,1\n0,\xff,1\n").unwrap();
        assert_eq!(
            read_points_csv(&path).unwrap_err().to_string(),
            format!(
                "{}: line 3, column 3: byte 0xFF is not UTF-8 text; save the file as UTF-8",
                path.display()
            )
        );
        assert_eq!(
            read_points_csv(dir.path()).unwrap_err().to_string(),
            format!("{}: is a folder, not a file", dir.path().display())
        );
    }
}
