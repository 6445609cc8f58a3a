//! What a study would do, without running it: its conditions, how many realisations, and
//! an estimate of the run time on this machine and of the output size.
//!
//! The model is prepared as `run` prepares it (so every study error a run would report is
//! reported here), then a few realisations of every condition are timed on one thread and
//! a sample of realisation rows is encoded with the writer's settings. Nothing is written.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use crate::model::{self, ConditionInfo, Layout, Model};
use crate::output::{self, FileMetadata, OutputError};
use crate::run::RunError;
use crate::study::Study;

/// Timings per draw group (after one untimed warm-up), each of [`SIDE_BY_SIDE`] realisations
/// of every member; the median is kept, so one slowed by another process does not count.
const TIMED_PER_CONDITION: u64 = 7;

/// Realisations computed side by side in each timing, as a run computes them.
const SIDE_BY_SIDE: usize = 4;

/// Realisations of condition 0 encoded to measure the bytes per realisation.
const SIZE_SAMPLE: u64 = 256;

/// What `check` found.
#[derive(Debug, Clone)]
pub struct StudyCheck {
    /// The row layout.
    pub layout: Layout,
    /// Every condition.
    pub infos: Vec<ConditionInfo>,
    /// Realisations per condition.
    pub realisations: u64,
    /// Time to prepare the model (simulate the drive cycles).
    pub prepare: Duration,
    /// Median single-thread time of one realisation, per condition.
    pub per_realisation: Vec<Duration>,
    /// Worker threads the estimate assumes.
    pub threads: usize,
    /// Estimated bytes of realisations.parquet.
    pub realisation_bytes: f64,
    /// Estimated bytes of the model's extra tables (the cycles).
    pub extra_bytes: f64,
}

impl StudyCheck {
    /// Estimated wall time of the Monte Carlo on `threads` threads: the single-thread time of
    /// every realisation divided by the threads, plus preparing the model (a lower bound when
    /// the cores are shared).
    pub fn estimated_run_time(&self) -> Duration {
        let serial: f64 = self
            .per_realisation
            .iter()
            .map(|d| d.as_secs_f64() * self.realisations as f64)
            .sum();
        Duration::from_secs_f64(serial / self.threads as f64 + self.prepare.as_secs_f64())
    }
}

/// Check `study` as it would run on `threads` threads (all cores when `None`).
pub fn check(study: &Study, threads: Option<usize>) -> Result<StudyCheck, RunError> {
    let started = Instant::now();
    let model = model::prepare(study)?;
    let prepare = started.elapsed();
    let layout = model.layout().clone();
    let infos = model.infos();
    // Timed as a run computes them: the conditions of a draw group together (one draw
    // serving all), a few realisations side by side; each member gets its share.
    let stride = layout.realisation_stride();
    let mut per_realisation = vec![Duration::ZERO; infos.len()];
    let mut grouped: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for c in 0..infos.len() {
        grouped.entry(model.draw_group(c)).or_default().push(c);
    }
    for members in grouped.values() {
        let mut slots = vec![0.0; SIDE_BY_SIDE * members.len() * stride];
        model.realise_group(study.seed(), members, 0, SIDE_BY_SIDE, &mut slots);
        let mut times: Vec<Duration> = (1..=TIMED_PER_CONDITION)
            .map(|k| {
                let t = Instant::now();
                let first = k * SIDE_BY_SIDE as u64;
                model.realise_group(study.seed(), members, first, SIDE_BY_SIDE, &mut slots);
                t.elapsed()
            })
            .collect();
        times.sort();
        let each = times[times.len() / 2] / (SIDE_BY_SIDE * members.len()) as u32;
        for &c in members {
            per_realisation[c] = each;
        }
    }
    let threads = threads
        .or_else(|| std::thread::available_parallelism().ok().map(usize::from))
        .unwrap_or(1);
    let meta = FileMetadata::of_study(study, String::new());
    let realisation_bytes = bytes_per_realisation(&*model, study, &meta)?
        * study.realisations() as f64
        * infos.len() as f64;
    let extra_bytes = extra_table_bytes(&*model, &meta)?;
    Ok(StudyCheck {
        layout,
        infos,
        realisations: study.realisations(),
        prepare,
        per_realisation,
        threads,
        realisation_bytes,
        extra_bytes,
    })
}

/// Encoded bytes per realisation (all its estimator rows) in a sample of condition 0.
fn bytes_per_realisation(
    model: &dyn Model,
    study: &Study,
    meta: &FileMetadata,
) -> Result<f64, RunError> {
    let layout = model.layout();
    let n = SIZE_SAMPLE.min(study.realisations()).max(1);
    let stride = layout.realisation_stride();
    let mut slots = vec![0.0; n as usize * stride];
    for (r, s) in slots.chunks_mut(stride).enumerate() {
        model.realise(study.seed(), 0, r as u64, s);
    }
    let schema = output::realisation_schema(layout);
    let chunk = crate::montecarlo::Chunk {
        condition: 0,
        first: 0,
        item: 0..n,
        slots: &slots,
    };
    let batch = output::realisations_batch(layout, &schema, model.condition_info(0), &chunk)
        .map_err(|e| OutputError::arrow(std::path::Path::new("sample"), e))?;
    let bytes = output::encoded_len(&batch, meta, "realisations")?;
    Ok(bytes as f64 / n as f64)
}

/// Encoded bytes of the model's extra tables, from their first batch.
fn extra_table_bytes(model: &dyn Model, meta: &FileMetadata) -> Result<f64, RunError> {
    let mut total = 0.0;
    for (t, table) in model.extra_tables().iter().enumerate() {
        let batches = (0..).map_while(|i| model.extra_batch(t, i)).count();
        if let Some(first) = model.extra_batch(t, 0) {
            let first =
                first.map_err(|e| OutputError::arrow(std::path::Path::new(table.file), e))?;
            total += output::encoded_len(&first, meta, table.table)? as f64 * batches as f64;
        }
    }
    Ok(total)
}
