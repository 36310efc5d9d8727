//! A render table (fixed spp and adaptive) as a [`Job`]: its shards, `--resume` and merge
//! (issue 31), with the same [`Shard`] split, [`Identity`], unit log and set checks as every job
//! ([`crate::job`]).
//!
//! A table's **units** are its rounds: every variant at one spp (or target sd) and repetition,
//! numbered in the order one run renders them (spp or target, then repetition), `u = 0 … Σ
//! repetitions − 1`; shard `i` of `n` renders the units with `u mod n = i − 1`. A unit is the
//! grain because every output is a function of its rows and of each cell's first render (its
//! repetition 0), which the unit renders whole.
//!
//! `render SPEC --shard i/n --out DIR` writes a shard folder: `units.csv` (its rounds' log: the
//! identity line, then the `rmse.csv` columns, `seconds` and the row's digest, one row per
//! render in unit order; read back, every number must be finite or empty where `rmse.csv` leaves
//! it empty, RMSEs and seconds at least 0, shares — coverage, `share_met`, `within` — in [0, 1],
//! the seed the unit's, and the row its digest's), the first
//! renders' PNGs of its units (named and described as in the table's folder), `reference.exr`
//! (the reference its renders were measured against, read from or written to the cache under
//! `--results-dir`), `shard.json` (`"kind": "render-table"`, the identity, the spec's path and
//! text), a manifest and `timings.json`. [`merge`] checks the set, reads every row back (floats
//! are in shortest round-trip form, so they are the exact `f64`s), copies the PNGs and writes
//! the table's other files with the code one run uses ([`super::write_outputs`],
//! [`super::adaptive::write_outputs`]) — the same bytes as one run, `timings.*` aside.

use super::adaptive::runner::{AdaptiveRow, adaptive_render_seed};
use super::external::ExternalMeasures;
use super::plan::TablePlan;
use super::runner::{Row, render_seed};
use super::{FileSink, TableReport, export, reference};
use crate::error::{Error, InputError};
use crate::files::read::FileKind;
use crate::files::result_folder::{MANIFEST, ResultFolder};
use crate::job::shard_set::{SHARD_FILE, ShardFolder};
use crate::job::unit_log::SHARD_UNITS;
use crate::job::{Identity, Job, LogSet, LogWriter, Shard};
use crate::provenance::Build;
use crate::render::image::Image;
use crate::render::renderer::Renderer;
use crate::util::report::Reporter;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// `shard.json`'s `"kind"` for a render table's shards.
pub const KIND: &str = "render-table";
/// The shard's copy of its reference.
const REFERENCE_COPY: &str = "reference.exr";

/// The table's units: its rounds, `Σ repetitions`.
pub fn units(plan: &TablePlan) -> usize {
    plan.repetitions.iter().sum()
}

/// Where `render SPEC --shard i/n` writes without `--out`: `<results>/<name>-shard-<i>-of-<n>/`.
pub fn default_out(results: &Path, plan: &TablePlan, shard: Shard) -> PathBuf {
    results.join(format!("{}-shard-{}-of-{}", plan.name, shard.index, shard.count))
}

/// What a shard produced.
pub struct ShardReport {
    pub out_dir: PathBuf,
    pub renders: usize,
    pub wall_seconds: f64,
}

/// The log's column line: the table's `rmse.csv` header and `seconds`.
fn columns(plan: &TablePlan) -> String {
    let header = match &plan.adaptive {
        Some(_) => super::adaptive::export::rmse_csv(plan, &[]),
        None => export::rmse_csv(plan, &[]),
    };
    format!("{},seconds", String::from_utf8_lossy(&header).trim_end())
}

/// `rmse.csv`'s rows with each render's seconds appended.
fn log_rows(csv: &[u8], seconds: impl Iterator<Item = f64>) -> String {
    let text = String::from_utf8_lossy(csv);
    let mut out = String::new();
    for (line, s) in text.lines().skip(1).zip(seconds) {
        out.push_str(&format!("{line},{s:?}\n"));
    }
    out
}

/// Runs shard `shard` of the table into `out`: see the module documentation. The reference
/// comes from (or goes to) the cache under `results`, as for a whole table.
pub fn run_shard(
    plan: &TablePlan,
    results: &Path,
    shard: Shard,
    out: &Path,
    resume: bool,
    names: &crate::job::SettingNames,
    reporter: &dyn Reporter,
) -> crate::Result<ShardReport> {
    let mut folder = super::prepare_folder(
        plan,
        results,
        out,
        &format!("{} {}", names.out, out.display()),
        &format!("use another {}", names.out),
    )?;
    let spec_text = crate::files::spec_json::read_spec(&plan.file)?;
    // The rounds' log, checked before any work.
    let rounds = Rounds::open(plan, &folder, shard, resume, names)?;
    let identity = rounds.identity.clone();
    let start = Instant::now();
    let renderer = Renderer::for_scene(plan.scene, plan.width, plan.height, plan.env.clone());
    let reference = reference::reference(plan, &renderer, results, reporter)?;
    folder.write(
        REFERENCE_COPY,
        "the reference this shard's renders were measured against (for workbench merge)",
        &reference.to_exr()?,
    )?;
    let log = rounds.log_path.clone();
    let renders = rounds
        .render(plan, &renderer, &reference, &mut folder, reporter)?
        .renders;
    let job = serde_json::json!({
        "kind": KIND,
        "job": {
            "spec": plan.file.display().to_string(),
            "scene": plan.scene.name(),
            "env": plan.env_arg,
            "text": spec_text,
        },
    });
    crate::job::shard_set::write_shard(
        &mut folder,
        &identity,
        &log,
        "this shard's renders in unit order: the rmse.csv columns, then wall-clock seconds, and each row's digest",
        job,
        "which shard this is, of which render table, and the table file as run (for workbench merge)",
    )?;
    let wall_seconds = start.elapsed().as_secs_f64();
    folder.commit(
        serde_json::json!({
            "kind": KIND,
            "name": plan.name,
            "scene": super::reference::scene_version(plan),
            "shard": shard.to_string(),
        }),
        serde_json::json!({ "seconds": wall_seconds }),
    )?;
    Ok(ShardReport {
        out_dir: out.to_path_buf(),
        renders,
        wall_seconds,
    })
}

/// The log of a shard's finished rounds while it runs (for `--resume`), in its folder.
pub const ROUNDS_LOG: &str = "rounds.partial.csv";

/// A run's rounds' log (a shard's, or a whole table's), opened and checked before any work: a
/// resumed run keeps the rounds it holds (re-rendering only the repetition-0 ones among them,
/// whose images went with the killed run's staging folder).
pub struct Rounds {
    identity: Identity,
    /// The run's rounds, in order.
    mine: Vec<usize>,
    log: LogWriter,
    log_path: PathBuf,
    /// The rows of the rounds done before (`variants` per round), read back and checked.
    done_rows: Vec<RowOf>,
}

/// What [`Rounds::render`] produced: every round's rows in round order.
pub struct Rendered {
    pub rows: Rows,
    /// Renders made now.
    pub renders: usize,
    /// Rounds read back from the log.
    pub resumed: usize,
}

impl Rounds {
    /// Opens `folder`'s [`ROUNDS_LOG`] for `shard` of the table: fresh, or with `resume` (and a
    /// log there) checked and read as the merge reads it ([`crate::job::open_log`]): it must be
    /// this run's, the rows of its complete rounds are checked and kept, and a half-written last
    /// round is cut off.
    pub fn open(
        plan: &TablePlan,
        folder: &ResultFolder,
        shard: Shard,
        resume: bool,
        names: &crate::job::SettingNames,
    ) -> crate::Result<Rounds> {
        let identity = plan.identity(shard);
        let mine: Vec<usize> = shard.units(units(plan)).collect();
        let log_path = folder.partial_path(ROUNDS_LOG)?;
        let mut done_rows = Vec::new();
        let (log, _) = crate::job::open_log(plan, &log_path, shard, resume, names, &mut |_, _, row| {
            done_rows.push(row)
        })?;
        Ok(Rounds {
            identity,
            mine,
            log,
            log_path,
            done_rows,
        })
    }

    /// Renders the rounds not done (and the done repetition-0 ones, for their images) into
    /// `folder` through the table's sink, appending each new round's rows to the log as it
    /// finishes. The rows of rounds rendered now are the renderer's own; those of rounds kept
    /// from the log are read back from their shortest round-trip decimals — the same numbers.
    pub fn render(
        self,
        plan: &TablePlan,
        renderer: &Renderer,
        reference: &Image,
        folder: &mut ResultFolder,
        reporter: &dyn Reporter,
    ) -> crate::Result<Rendered> {
        let shard = self.identity.shard;
        let nv = plan.variants.len();
        let done = self.done_rows.len() / nv;
        let first_new = self.mine.get(done).copied().unwrap_or(usize::MAX);
        let keep =
            |u: usize| u % shard.count == shard.index - 1 && (u >= first_new || repetition(plan, u) == 0);
        let kept: Vec<usize> = self.mine.iter().copied().filter(|&u| keep(u)).collect();
        let mut sink = LogSink {
            inner: FileSink {
                plan,
                folder,
                reference,
            },
            log: self.log,
            kept: &kept,
            next: 0,
            first_new,
            nv,
        };
        let new = match &plan.adaptive {
            Some(a) => Rows::Adaptive(super::adaptive::runner::run(
                plan, a, renderer, reference, &mut sink, reporter, &keep,
            )?),
            None => {
                let geometry = renderer.geometry();
                let edges =
                    crate::render::integrator::neighbours::edge_mask(&geometry, plan.width, plan.height);
                Rows::Fixed(super::runner::run(
                    plan, renderer, reference, &edges, &mut sink, reporter, &keep,
                )?)
            }
        };
        drop(sink);
        // Every round of the run in order: the one rendered now, or the log's.
        let mut next_new = 0;
        let mut rows = match &new {
            Rows::Fixed(_) => Rows::Fixed(Vec::new()),
            Rows::Adaptive(_) => Rows::Adaptive(Vec::new()),
        };
        let mut renders = 0;
        let mut done_rows = self.done_rows.into_iter();
        for &u in &self.mine {
            for _ in 0..nv {
                // A kept round's rows are the new render's (also for a done repetition-0 one).
                let old = if u < first_new { done_rows.next() } else { None };
                if keep(u) {
                    match (&mut rows, &new) {
                        (Rows::Fixed(r), Rows::Fixed(n)) => r.push(n[next_new].clone()),
                        (Rows::Adaptive(r), Rows::Adaptive(n)) => r.push(n[next_new].clone()),
                        _ => unreachable!("the plan decides the kind of row"),
                    }
                    next_new += 1;
                } else {
                    match (&mut rows, old.expect("a done round's rows are in the log")) {
                        (Rows::Fixed(r), RowOf::Fixed(x)) => r.push(x),
                        (Rows::Adaptive(r), RowOf::Adaptive(x)) => r.push(x),
                        _ => unreachable!("the plan decides the kind of row"),
                    }
                }
            }
            if keep(u) {
                renders += nv;
            }
        }
        if done > 0 {
            reporter.note(&format!(
                "resumed: {done} of {} rounds were done already",
                self.mine.len()
            ));
        }
        Ok(Rendered {
            rows,
            renders,
            resumed: done,
        })
    }
}

/// The repetition of unit `u`.
fn repetition(plan: &TablePlan, u: usize) -> usize {
    let mut rep = u;
    for &r in &plan.repetitions {
        if rep < r {
            return rep;
        }
        rep -= r;
    }
    rep
}

/// Saves each cell's first render (through the table's own sink) and appends every new round's
/// rows to the rounds' log as it finishes.
struct LogSink<'a, 'b> {
    inner: FileSink<'a>,
    log: LogWriter,
    /// The units rendered, in order: the `next`-th round to finish is `kept[next]`.
    kept: &'b [usize],
    next: usize,
    /// Units before this one were in the log already (re-rendered only for their images).
    first_new: usize,
    nv: usize,
}

impl LogSink<'_, '_> {
    fn append(&mut self, csv: &[u8], seconds: impl Iterator<Item = f64>) -> crate::Result<()> {
        let u = self.kept[self.next];
        self.next += 1;
        if u < self.first_new {
            return Ok(());
        }
        self.log.append(&log_rows(csv, seconds))
    }
}

impl super::runner::TableSink for LogSink<'_, '_> {
    fn first_image(
        &mut self,
        variant: usize,
        spp: usize,
        image: &Image,
        sds: &crate::render::uncertainty::PixelSds,
    ) -> crate::Result<()> {
        self.inner.first_image(variant, spp, image, sds)
    }

    fn round_done(&mut self, rows: &[Row]) -> crate::Result<()> {
        let last = &rows[rows.len() - self.nv..];
        self.append(
            &export::rmse_csv(self.inner.plan, last),
            last.iter().map(|r| r.seconds),
        )
    }
}

impl super::adaptive::runner::AdaptiveSink for LogSink<'_, '_> {
    fn first_image(
        &mut self,
        variant: usize,
        target: f64,
        image: &crate::render::adaptive::AdaptiveImage,
    ) -> crate::Result<()> {
        self.inner.first_image(variant, target, image)
    }

    fn round_done(&mut self, rows: &[AdaptiveRow]) -> crate::Result<()> {
        let last = &rows[rows.len() - self.nv..];
        self.append(
            &super::adaptive::export::rmse_csv(self.inner.plan, last),
            last.iter().map(|r| r.seconds),
        )
    }
}

/// A run's renders.
pub enum Rows {
    Fixed(Vec<Row>),
    Adaptive(Vec<AdaptiveRow>),
}

/// Parses a field written by [`export::num`] (empty: not finite), checked to lie in
/// `[low, high]`.
fn number_in(s: &str, column: &str, low: f64, high: f64) -> Result<f64, String> {
    if s.is_empty() {
        return Ok(f64::NAN);
    }
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && (low..=high).contains(&v) => Ok(v),
        Ok(v) if v.is_finite() && high == f64::INFINITY => Err(format!("has {column} {s:?}, below {low}")),
        Ok(v) if v.is_finite() => Err(format!("has {column} {s:?}, outside [{low}, {high}]")),
        _ => Err(format!("has {column} {s:?}, not a finite number")),
    }
}

/// A field that is at least 0 (an RMSE, a mean, seconds).
fn non_negative(s: &str, column: &str) -> Result<f64, String> {
    number_in(s, column, 0.0, f64::INFINITY)
}

/// A share, in `[0, 1]`.
fn share(s: &str, column: &str) -> Result<f64, String> {
    number_in(s, column, 0.0, 1.0)
}

/// Reads one log row of unit `u` and variant `v` as it was written: the row that unit renders
/// (variant, spp or target, repetition, seed), every number finite (or empty, as
/// [`export::num`] writes a number that is not), RMSEs, means and seconds at least 0, shares in
/// [0, 1].
fn parse_row(plan: &TablePlan, u: usize, v: usize, line: &str) -> Result<RowOf, String> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .from_reader(line.as_bytes());
    let record = reader
        .records()
        .next()
        .and_then(|r| r.ok())
        .ok_or_else(|| "is not a CSV row".to_string())?;
    let f: Vec<&str> = record.iter().collect();
    let want = export::variant_fields(&plan.variants[v]);
    if f.len() < 4 || f[..4] != want {
        return Err(format!(
            "starts with {:?} where the table renders variant {:?} there",
            f.iter().take(4).collect::<Vec<_>>(),
            want[0]
        ));
    }
    // The unit's column and repetition.
    let (mut column, mut rep) = (0, u);
    while rep >= plan.repetitions[column] {
        rep -= plan.repetitions[column];
        column += 1;
    }
    let whole = |s: &str, what: &str| s.parse::<u64>().map_err(|_| format!("has {what} {s:?}"));
    let external = plan.external.is_some();
    match &plan.adaptive {
        None => {
            let rays = 11 + if external { 3 } else { 0 };
            let n = rays + usize::from(plan.counts_rays()) + 1;
            if f.len() != n {
                return Err(format!("has {} columns, not {n}", f.len()));
            }
            let spp = plan.spp[column];
            let seed = render_seed(plan.seed, spp, rep);
            if (
                whole(f[4], "spp")?,
                whole(f[5], "repetition")?,
                whole(f[6], "seed")?,
            ) != (spp as u64, rep as u64, seed)
            {
                return Err(format!(
                    "is spp {}, repetition {}, seed {} where the unit renders spp {spp}, repetition {rep}, seed {seed}",
                    f[4], f[5], f[6]
                ));
            }
            Ok(RowOf::Fixed(Row {
                variant: v,
                spp,
                repetition: rep,
                seed,
                rmse: non_negative(f[7], "rmse")?,
                rmse_edges: non_negative(f[8], "rmse_edges")?,
                coverage95: share(f[9], "coverage95")?,
                coverage95_edges: share(f[10], "coverage95_edges")?,
                seconds: non_negative(f[n - 1], "seconds")?,
                rays_per_pixel: if plan.counts_rays() {
                    non_negative(f[rays], "rays_per_pixel")?
                } else {
                    spp as f64
                },
                external: if external {
                    Some(ExternalMeasures {
                        rmse_theirs: non_negative(f[11], "rmse_theirs")?,
                        mean_l2_theirs: non_negative(f[12], "mean_l2_theirs")?,
                        mean_l2_ours: non_negative(f[13], "mean_l2")?,
                    })
                } else {
                    None
                },
            }))
        }
        Some(a) => {
            if f.len() != 12 {
                return Err(format!("has {} columns, not 12", f.len()));
            }
            let target = a.targets[column];
            let seed = adaptive_render_seed(plan.seed, target, rep);
            if (f[4], whole(f[5], "repetition")?, whole(f[6], "seed")?)
                != (export::num(target).as_str(), rep as u64, seed)
            {
                return Err(format!(
                    "is target {}, repetition {}, seed {} where the unit renders target {target}, repetition {rep}, seed {seed}",
                    f[4], f[5], f[6]
                ));
            }
            Ok(RowOf::Adaptive(AdaptiveRow {
                variant: v,
                column,
                target,
                repetition: rep,
                seed,
                rmse: non_negative(f[7], "rmse")?,
                mean_spp: non_negative(f[8], "mean_spp")?,
                share_met: share(f[9], "share_met")?,
                within: share(f[10], "within")?,
                seconds: non_negative(f[11], "seconds")?,
            }))
        }
    }
}

/// One log row of either kind of table.
pub enum RowOf {
    Fixed(Row),
    Adaptive(AdaptiveRow),
}

impl Job for TablePlan {
    const KIND: &'static str = KIND;
    const UNIT_NAME: &'static str = "rounds";
    type Row = RowOf;
    type Gathered = Rows;
    type Merged = TableReport;

    fn identity(&self, shard: Shard) -> Identity {
        Identity {
            plan_hash: export::plan_hash(self),
            seed: self.seed,
            units: units(self),
            build: Build::current(),
            shard,
        }
    }

    fn units(&self) -> usize {
        units(self)
    }

    fn rows_per_unit(&self) -> usize {
        self.variants.len()
    }

    fn columns(&self) -> String {
        columns(self)
    }

    fn parse_row(&self, unit: usize, k: usize, line: &str) -> Result<RowOf, String> {
        parse_row(self, unit, k, line)
    }

    /// Another map or scene is another plan too; say which, before the plan hashes.
    fn check_records(set: &[ShardFolder]) -> Result<(), InputError> {
        for field in ["scene", "env"] {
            let of = |s: &ShardFolder| {
                s.spec
                    .get(field)
                    .and_then(|v| v.as_str())
                    .unwrap_or_default()
                    .to_string()
            };
            if let Some(other) = set.iter().find(|s| of(s) != of(&set[0])) {
                return Err(InputError::new(format!(
                    "merge: {} and {} are shards of different render tables ({} {:?} and {:?}); merge the shards of one run",
                    set[0].dir.display(),
                    other.dir.display(),
                    if field == "env" { "maps" } else { "scenes" },
                    of(&set[0]),
                    of(other)
                )));
            }
        }
        Ok(())
    }

    /// The table as run, from the first shard's record; the other shards have its plan hash.
    fn from_record(first: &ShardFolder) -> Result<TablePlan, InputError> {
        let at = first.record();
        let bad = |m: String| InputError::new(format!("merge: {}: {m}", at.display()));
        let (text, spec) = (first.job_text("text")?, first.job_text("spec")?);
        let plan = super::plan::parse(text, Path::new(spec)).map_err(|e| bad(e.0))?;
        if export::plan_hash(&plan) != first.identity.plan_hash {
            return Err(bad(format!(
                "the table resolves to another plan than the one its shards ran (a file it reads, {}, changed?)",
                plan.env_arg
            )));
        }
        Ok(plan)
    }

    fn gather(&self) -> Rows {
        match self.adaptive {
            Some(_) => Rows::Adaptive(Vec::new()),
            None => Rows::Fixed(Vec::new()),
        }
    }

    fn push(&self, rows: &mut Rows, _unit: usize, _k: usize, row: RowOf) {
        match (rows, row) {
            (Rows::Fixed(r), RowOf::Fixed(x)) => r.push(x),
            (Rows::Adaptive(r), RowOf::Adaptive(x)) => r.push(x),
            _ => unreachable!("the plan decides the kind of row"),
        }
    }

    /// `out` is the table's folder; its parent is the results folder whose `cache/` the manifest
    /// names, as `--results-dir` is for one run. The shards' references and first renders are
    /// read and checked before `out` is touched.
    fn write_merged(
        self,
        out: &Path,
        set: &[ShardFolder],
        _logs: &LogSet,
        rows: Rows,
        _reporter: &dyn Reporter,
    ) -> crate::Result<TableReport> {
        let plan = self;
        let start = Instant::now();
        let count = set.len();
        // One reference for all: the shards' copies, byte for byte.
        let reference_bytes: Vec<Vec<u8>> = set
            .iter()
            .map(|s| {
                crate::files::read::read(&s.dir.join(REFERENCE_COPY), FileKind::Image).map_err(|e| {
                    InputError::new(format!("merge: {e}; this shard is half-written, run it again"))
                })
            })
            .collect::<Result<_, _>>()?;
        if let Some(i) = (1..count).find(|&i| reference_bytes[i] != reference_bytes[0]) {
            return Err(InputError::new(format!(
                "merge: {} and {} were measured against different references (another results/cache entry?); \
                 run the shards against one reference",
                set[0].dir.display(),
                set[i].dir.display()
            ))
            .into());
        }
        let reference = Image::read(&set[0].dir.join(REFERENCE_COPY), "the shard's reference")?;
        if (reference.width, reference.height) != (plan.width, plan.height) {
            return Err(InputError::new(format!(
                "merge: {}: {REFERENCE_COPY} is {}×{}, not the table's {}×{}",
                set[0].dir.display(),
                reference.width,
                reference.height,
                plan.width,
                plan.height
            ))
            .into());
        }
        // The first renders' images each shard wrote, as its manifest lists them.
        let mut images: Vec<(String, String, Vec<u8>)> = Vec::new();
        for s in set {
            let path = s.dir.join(MANIFEST);
            let manifest: serde_json::Value = crate::files::read::read_text(&path, FileKind::Record)
                .ok()
                .and_then(|t| serde_json::from_str(&t).ok())
                .ok_or_else(|| InputError::new(format!("merge: {}: missing or not JSON", path.display())))?;
            let files = manifest
                .get("files")
                .and_then(|f| f.as_object())
                .ok_or_else(|| InputError::new(format!("merge: {}: lists no files", path.display())))?;
            for (name, what) in files {
                if [MANIFEST, SHARD_FILE, SHARD_UNITS, REFERENCE_COPY].contains(&name.as_str()) {
                    continue;
                }
                if !name.ends_with(".png") || name.contains('/') || name.starts_with('.') {
                    return Err(InputError::new(format!(
                        "merge: {}: lists {name:?}, not a render of the table",
                        path.display()
                    ))
                    .into());
                }
                if images.iter().any(|(n, _, _)| n == name) {
                    return Err(InputError::new(format!(
                        "merge: {name} is in more than one shard; give each shard once"
                    ))
                    .into());
                }
                let bytes = crate::files::read::read(&s.dir.join(name), FileKind::Image).map_err(|e| {
                    InputError::new(format!("merge: {e}; this shard is half-written, run it again"))
                })?;
                images.push((name.clone(), what.as_str().unwrap_or_default().to_string(), bytes));
            }
        }
        let results = out.parent().map(Path::to_path_buf).unwrap_or_default();
        let mut folder = ResultFolder::prepare_merge(
            out,
            set.iter().map(|s| s.dir.as_path()),
            export::legacy_manifest_files,
        )?;
        folder.write(
            "reference.png",
            "the reference image, tone-mapped",
            &reference.to_png()?,
        )?;
        for (name, what, bytes) in &images {
            folder.write(name, what, bytes)?;
        }
        let (cells, adaptive_cells, table_md, times_md) = match (&rows, &plan.adaptive) {
            (Rows::Fixed(rows), _) => {
                let (cells, md, times) = super::write_outputs(&plan, &mut folder, &reference, rows)?;
                (cells, Vec::new(), md, times)
            }
            (Rows::Adaptive(rows), Some(a)) => {
                let report = super::adaptive::write_outputs(&plan, a, &mut folder, rows)?;
                (Vec::new(), report.cells, report.table_md, report.times_md)
            }
            (Rows::Adaptive(_), None) => unreachable!("adaptive rows come from an adaptive plan"),
        };
        // The cache the manifest names holds the reference, as after one run.
        let cache = reference::cache_path(&plan, &results);
        if !cache.exists() {
            let dir = cache.parent().unwrap_or(&results);
            std::fs::create_dir_all(dir).map_err(|e| Error::io(format!("creating {}", dir.display()), e))?;
            crate::files::atomic::write_atomic(&cache, &reference_bytes[0])?;
            crate::files::atomic::write_atomic(
                &cache.with_extension("json"),
                reference::reference_key(&plan).1.as_bytes(),
            )?;
        }
        let manifest: serde_json::Value =
            serde_json::from_slice(&export::manifest(&plan, &results)).expect("the manifest is JSON");
        // The merge's own seconds, without the plan hash: `reproduce` does not take them for the
        // table's time.
        folder.commit(
            manifest,
            serde_json::json!({ "merge_seconds": start.elapsed().as_secs_f64() }),
        )?;
        Ok(TableReport {
            out_dir: out.to_path_buf(),
            cells,
            adaptive_cells,
            table_md,
            times_md,
        })
    }
}

/// Merges the shard folders `dirs` of a render table into `out` ([`crate::job::merge`]).
pub fn merge(out: &Path, dirs: &[PathBuf], names: &crate::job::SettingNames) -> crate::Result<TableReport> {
    crate::job::merge::<TablePlan>(out, dirs, names, &crate::util::report::Silent)
}
