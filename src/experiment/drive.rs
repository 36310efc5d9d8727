//! Runs a share of a plan's units in batches: each batch in parallel ([`runner::run_units`]),
//! then its rows appended to the unit log in unit order and handed to the summary. Memory holds
//! one batch, not the run; the log holds every finished batch, so a killed run can resume.

use super::plan::Plan;
use super::runner;
use super::summary::Accumulator;
use crate::job::{LogWriter, Shard};
use std::time::Instant;

/// Batches grow while they take less than this (fewer pauses between batches) …
const GROW_BELOW_SECONDS: f64 = 0.25;
/// … and shrink while they take more (less work lost to a kill, fewer idle workers at a
/// batch's end).
const SHRINK_ABOVE_SECONDS: f64 = 2.0;
const MAX_BATCH: usize = 1 << 14;

/// Runs the units of `shard` from the `done`-th on (the earlier ones are in the log already),
/// appending each batch to `log` and, if given, to `summary`. `tick` is called once per
/// finished unit. Returns the weight sets' numerical warnings, grouped by their first words
/// (tolerance estimators' stopping outcomes are in the log's rows, [`super::adaptive`]).
pub fn run_units(
    plan: &Plan,
    pool: &rayon::ThreadPool,
    shard: Shard,
    done: usize,
    log: &mut LogWriter,
    mut summary: Option<&mut Accumulator>,
    tick: &(dyn Fn() + Sync),
) -> crate::Result<Vec<(String, usize)>> {
    let threads = pool.current_num_threads();
    let todo: Vec<usize> = shard.units(plan.samples.len() * plan.trials).skip(done).collect();
    let mut warnings: Vec<(String, usize)> = Vec::new();
    let mut batch = 2 * threads;
    let mut text = String::new();
    let mut start = 0;
    while start < todo.len() {
        let units = &todo[start..(start + batch).min(todo.len())];
        let clock = Instant::now();
        let results = pool.install(|| runner::run_units(plan, units, tick))?;
        text.clear();
        for (&u, r) in units.iter().zip(&results) {
            let (ni, t) = (u / plan.trials, u % plan.trials);
            let values = super::rows::unit_rows(plan, r, ni, t, &mut text);
            if let Some(s) = summary.as_deref_mut() {
                for (k, v) in values.iter().enumerate() {
                    s.push(k / plan.estimators.len(), k % plan.estimators.len(), ni, v);
                }
            }
            group_warnings(&mut warnings, &r.messages);
        }
        log.append(&text)?;
        start += units.len();
        let seconds = clock.elapsed().as_secs_f64();
        if seconds < GROW_BELOW_SECONDS {
            batch = (batch * 2).min(MAX_BATCH);
        } else if seconds > SHRINK_ABOVE_SECONDS {
            batch = (batch / 2).max(threads);
        }
    }
    Ok(warnings)
}

/// Counts messages by their first words (the amounts differ): what the CLI prints once per
/// group (`warning: 3 weight set(s): …`).
pub fn group_warnings(warnings: &mut Vec<(String, usize)>, messages: &[String]) {
    for m in messages {
        let key = m
            .split(';')
            .next()
            .unwrap_or(m)
            .split(" (")
            .next()
            .unwrap_or(m)
            .to_string();
        match warnings.iter_mut().find(|(k, _)| *k == key) {
            Some((_, c)) => *c += 1,
            None => warnings.push((key, 1)),
        }
    }
}
