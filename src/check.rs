//! What a study would do, without running it: its conditions, how many realisations, and
//! an estimate of the run time on this machine and of the size of every file a run writes.
//!
//! The model is prepared as `run` prepares it (so every study error a run would report is
//! reported here), then a few realisations of every condition are timed on one thread.
//! The sizes: realisations.parquet from sample files of a few conditions (its bytes per
//! realisation, per row group and fixed); every other file — summary, cycles, figures,
//! report — written for real, as a run writes them, from a summary of a few realisations
//! per condition, into a temporary directory that is removed again. Nothing is written to
//! the study's output directory.

use std::collections::BTreeMap;
use std::fs;
use std::path::Path;
use std::time::{Duration, Instant};

use crate::model::{self, ConditionInfo, Layout, Model};
use crate::montecarlo;
use crate::output::{self, FileMetadata, OutputError, ParquetSink, ROW_GROUP_ROWS};
use crate::run::{self, RunError};
use crate::study::Study;

/// Timings per draw group (after one untimed warm-up), each of [`SIDE_BY_SIDE`] realisations
/// of every member; the median is kept, so one slowed by another process does not count.
const TIMED_PER_CONDITION: u64 = 7;

/// Realisations computed side by side in each timing, as a run computes them.
const SIDE_BY_SIDE: usize = 4;

/// Realisations of each sampled condition encoded to measure realisations.parquet (and half
/// as many, for the part of a row group that does not grow with its rows).
const SIZE_SAMPLE: u64 = 128;

/// Conditions sampled for realisations.parquet: the first, the middle and the last.
const SIZE_CONDITIONS: usize = 3;

/// Realisations per condition of the summary that the other files are written from.
const OUTPUT_SAMPLE: u64 = 8;

/// A file a run writes, with its estimated size.
#[derive(Debug, Clone, PartialEq)]
pub struct FileEstimate {
    /// Its path inside the output directory, e.g. `figures/cycles.svg`.
    pub name: String,
    /// Estimated bytes.
    pub bytes: f64,
}

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
    /// Worker threads asked for (all cores when not given).
    pub threads: usize,
    /// Cores of this machine: the realisations run on at most this many threads at once.
    pub cores: usize,
    /// Time to write the summary, cycles, figures and report of a few realisations per
    /// condition (the figures and report cost as much at any R).
    pub outputs: Duration,
    /// Every file a run writes, with its estimated size, realisations.parquet first.
    pub files: Vec<FileEstimate>,
}

impl StudyCheck {
    /// Estimated wall time of the run: the single-thread time of every realisation divided
    /// by the threads that run at once (the threads asked for, at most the cores), plus
    /// preparing the model and writing the other outputs (a lower bound when the cores are
    /// shared).
    pub fn estimated_run_time(&self) -> Duration {
        let serial: f64 = self
            .per_realisation
            .iter()
            .map(|d| d.as_secs_f64() * self.realisations as f64)
            .sum();
        let parallel = self.threads.min(self.cores).max(1) as f64;
        Duration::from_secs_f64(
            serial / parallel + self.prepare.as_secs_f64() + self.outputs.as_secs_f64(),
        )
    }

    /// Estimated bytes of every file together.
    pub fn total_bytes(&self) -> f64 {
        self.files.iter().map(|f| f.bytes).sum()
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
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    let threads = threads.unwrap_or(cores);
    // A directory of its own in the system's temporary directory, removed when dropped
    // (also when several checks run at once, e.g. in one process's threads).
    let scratch = tempfile::Builder::new()
        .prefix("chassis-mc-check-")
        .tempdir()
        .map_err(|e| OutputError::io(&std::env::temp_dir(), e))?;
    let meta = FileMetadata::of_study(study, String::new());
    let mut files = vec![FileEstimate {
        name: run::files::REALISATIONS.to_string(),
        bytes: realisations_bytes(&*model, study, &meta, scratch.path())?,
    }];
    let started = Instant::now();
    files.extend(other_files(&*model, study, &meta, scratch.path())?);
    let outputs = started.elapsed();
    Ok(StudyCheck {
        layout,
        infos,
        realisations: study.realisations(),
        prepare,
        per_realisation,
        threads,
        cores,
        outputs,
        files,
    })
}

/// Estimated bytes of realisations.parquet, whose row groups hold [`ROW_GROUP_ROWS`] rows
/// each, across conditions: fixed bytes F, per row group g, per realisation b. Measured on
/// sample files of the n realisations of [`SIZE_CONDITIONS`] conditions (k of them): all as
/// one row group (A = F + g + b n k), the same twice as two (A₂ = A + g + b n k), and n/2
/// realisations each as one (B = F + g + b n k / 2).
fn realisations_bytes(
    model: &dyn Model,
    study: &Study,
    meta: &FileMetadata,
    dir: &Path,
) -> Result<f64, RunError> {
    let layout = model.layout();
    let count = model.condition_count();
    let mut sampled: Vec<usize> = (0..SIZE_CONDITIONS)
        .map(|k| k * (count - 1) / (SIZE_CONDITIONS - 1).max(1))
        .collect();
    sampled.dedup();
    let n = SIZE_SAMPLE.min(study.realisations()).max(2) & !1;
    let stride = layout.realisation_stride();
    let schema = output::realisation_schema(layout);
    let slots = montecarlo::in_memory(model, study.seed(), &sampled, 0..n, &montecarlo::Silent);
    let batches = sampled
        .iter()
        .zip(slots.chunks_exact(n as usize * stride))
        .map(|(&c, slots)| {
            let chunk = montecarlo::Chunk {
                condition: c,
                first: 0,
                item: 0..n,
                slots,
            };
            output::realisations_batch(layout, &schema, model.condition_info(c), &chunk)
                .map_err(|e| OutputError::arrow(dir, e))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let rows = |batch: &arrow::array::RecordBatch, m: u64| {
        batch.slice(0, m as usize * layout.estimators.len())
    };
    let size = |name: &str, groups: &[&[arrow::array::RecordBatch]]| -> Result<f64, OutputError> {
        let mut sink = ParquetSink::create(dir, name, schema.clone(), meta, "realisations")?;
        for group in groups {
            let batch = arrow::compute::concat_batches(&schema, group.iter())
                .map_err(|e| OutputError::arrow(dir, e))?;
            sink.write(&batch)?;
            sink.flush()?;
        }
        let file = sink.finish()?;
        let len = fs::metadata(file.tmp_path()).map_err(|e| OutputError::io(file.tmp_path(), e))?;
        Ok(len.len() as f64)
    };
    let whole: Vec<_> = batches.iter().map(|b| rows(b, n)).collect();
    let half: Vec<_> = batches.iter().map(|b| rows(b, n / 2)).collect();
    let (a, a2, b) = (
        size("a", &[&whole])?,
        size("a2", &[&whole, &whole])?,
        size("b", &[&half])?,
    );
    let sampled_realisations = (n * sampled.len() as u64) as f64;
    let per_realisation = (2.0 * (a - b) / sampled_realisations).max(0.0);
    let per_group = (a2 - a - per_realisation * sampled_realisations).max(0.0);
    let fixed = (a - per_group - per_realisation * sampled_realisations).max(0.0);
    let realisations = count as u64 * study.realisations();
    let groups = (realisations * layout.estimators.len() as u64)
        .div_ceil(ROW_GROUP_ROWS as u64)
        .max(1);
    Ok(fixed + groups as f64 * per_group + per_realisation * realisations as f64)
}

/// Every other file a run writes, written as a run writes them into `dir` from a summary of
/// [`OUTPUT_SAMPLE`] realisations per condition, with its size: the same rows and figures
/// as the run's, with other numbers in them.
fn other_files(
    model: &dyn Model,
    study: &Study,
    meta: &FileMetadata,
    dir: &Path,
) -> Result<Vec<FileEstimate>, RunError> {
    let sample = study
        .clone()
        .with_overrides(Some(OUTPUT_SAMPLE.min(study.realisations()).max(2)), None)?;
    let summary = run::summarise_in_memory(&sample, model)?;
    let layout = model.layout();
    let infos = model.infos();
    let mut pending = run::write_summary(dir, layout, &infos, &summary, meta)?;
    pending.extend(run::write_extra_tables(model, dir, meta)?);
    pending.extend(run::draw_figures(dir, layout, &pending)?);
    pending.push(run::write_report(
        dir,
        "run",
        study.name(),
        meta,
        (layout, &infos, &summary),
        &pending,
    )?);
    pending
        .iter()
        .map(|file| {
            let len = fs::metadata(file.tmp_path())
                .map_err(|e| OutputError::io(file.tmp_path(), e))?
                .len();
            let name = file
                .final_path()
                .strip_prefix(dir)
                .unwrap_or(file.final_path());
            Ok(FileEstimate {
                name: name.to_string_lossy().into_owned(),
                bytes: len as f64,
            })
        })
        .collect()
}
