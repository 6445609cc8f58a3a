//! Running a study end to end: prepare the model, execute the realisations, summarise,
//! write the three Parquet files and commit them together.
//!
//! Nothing in the output directory changes until every file is complete: each is written
//! under a temporary name and all are renamed at the end. A bad study is rejected before
//! the directory is touched.

use std::fs;
use std::path::{Path, PathBuf};

use thiserror::Error;

use crate::model::line_fit::LineFitModel;
use crate::model::vehicle::VehicleModel;
use crate::model::{ConditionInfo, Layout, Model};
use crate::montecarlo::{self, DEFAULT_CHUNK, Observer, Work};
use crate::output::{
    self, FileMetadata, OutputError, ParquetSink, PendingFile, RealisationBatches,
};
use crate::stats::measures::Z_95;
use crate::stats::summary::{Summarizer, SummaryError, SummaryRow};
use crate::study::{ModelSpec, Study, StudyError};

/// File names inside the output directory.
pub mod files {
    /// One row per realisation × estimator.
    pub const REALISATIONS: &str = "realisations.parquet";
    /// One row per condition × estimator × parameter.
    pub const SUMMARY: &str = "summary.parquet";
    /// Noise-free drive cycles.
    pub const CYCLES: &str = "cycles.parquet";
}

/// Why a run failed.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum RunError {
    /// The study cannot be run (bad value, or a condition the model cannot simulate).
    #[error(transparent)]
    Study(#[from] StudyError),
    /// Writing or reading output failed.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// The realisation rows do not add up (e.g. a truncated file).
    #[error("{path}: {source}")]
    Summary {
        /// The realisation file summarised.
        path: PathBuf,
        /// What is inconsistent.
        source: SummaryError,
    },
    /// The thread pool could not be built.
    #[error("cannot start {threads} worker threads: {reason}")]
    Threads {
        /// Threads requested.
        threads: usize,
        /// The reason.
        reason: String,
    },
}

/// How to run a study.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Output directory (created if missing).
    pub out_dir: PathBuf,
    /// Worker threads; `None` uses every core.
    pub threads: Option<usize>,
    /// Realisations per computed chunk.
    pub chunk: u64,
}

impl RunOptions {
    /// Defaults: all cores, [`DEFAULT_CHUNK`] realisations per chunk.
    pub fn new(out_dir: impl Into<PathBuf>) -> Self {
        RunOptions {
            out_dir: out_dir.into(),
            threads: None,
            chunk: DEFAULT_CHUNK,
        }
    }
}

/// A model ready to run, whichever kind the study asked for.
#[derive(Debug)]
pub enum PreparedModel {
    /// The vehicle model.
    Vehicle(VehicleModel),
    /// The line-fit example.
    LineFit(LineFitModel),
}

impl PreparedModel {
    /// Prepare the study's model (simulates drive cycles; a stall is a [`StudyError`]).
    pub fn new(study: &Study) -> Result<Self, StudyError> {
        match &study.model {
            ModelSpec::Vehicle(_) => Ok(PreparedModel::Vehicle(VehicleModel::new(study)?)),
            ModelSpec::LineFit(_) => Ok(PreparedModel::LineFit(LineFitModel::new(study)?)),
        }
    }

    /// The model as a trait object.
    pub fn model(&self) -> &dyn DynModel {
        match self {
            PreparedModel::Vehicle(m) => m,
            PreparedModel::LineFit(m) => m,
        }
    }
}

/// Object-safe view of a [`Model`] (the trait itself is used generically in the executor).
pub trait DynModel: Sync {
    /// Layout of the rows.
    fn layout(&self) -> &Layout;
    /// All condition infos.
    fn infos(&self) -> Vec<ConditionInfo>;
    /// Execute `work`, passing chunks to the sink.
    fn execute(
        &self,
        seed: u64,
        work: &[Work],
        chunk: u64,
        observer: &dyn Observer,
        sink: &mut dyn FnMut(montecarlo::Chunk<'_>) -> Result<(), OutputError>,
    ) -> Result<(), OutputError>;
    /// Write model-specific extra tables (the vehicle's cycles) into `dir`.
    fn extra_files(&self, dir: &Path, meta: &FileMetadata)
    -> Result<Vec<PendingFile>, OutputError>;
}

impl<M: Model + ExtraFiles> DynModel for M {
    fn layout(&self) -> &Layout {
        Model::layout(self)
    }

    fn infos(&self) -> Vec<ConditionInfo> {
        (0..self.condition_count())
            .map(|c| self.condition_info(c).clone())
            .collect()
    }

    fn execute(
        &self,
        seed: u64,
        work: &[Work],
        chunk: u64,
        observer: &dyn Observer,
        sink: &mut dyn FnMut(montecarlo::Chunk<'_>) -> Result<(), OutputError>,
    ) -> Result<(), OutputError> {
        montecarlo::execute(self, seed, work, chunk, observer, sink)
    }

    fn extra_files(
        &self,
        dir: &Path,
        meta: &FileMetadata,
    ) -> Result<Vec<PendingFile>, OutputError> {
        ExtraFiles::write(self, dir, meta)
    }
}

/// Tables a model writes besides realisations and summary.
pub trait ExtraFiles {
    /// Write them under temporary names in `dir`.
    fn write(&self, dir: &Path, meta: &FileMetadata) -> Result<Vec<PendingFile>, OutputError>;
}

impl ExtraFiles for VehicleModel {
    fn write(&self, dir: &Path, meta: &FileMetadata) -> Result<Vec<PendingFile>, OutputError> {
        let mut sink =
            ParquetSink::create(dir, files::CYCLES, output::cycles_schema(), meta, "cycles")?;
        for c in 0..self.condition_count() {
            let batch = output::cycles_batch(c, &self.cycle(c)).map_err(|e| arrow_error(dir, e))?;
            sink.write(&batch)?;
        }
        Ok(vec![sink.finish()?])
    }
}

impl ExtraFiles for LineFitModel {
    fn write(&self, _dir: &Path, _meta: &FileMetadata) -> Result<Vec<PendingFile>, OutputError> {
        Ok(Vec::new())
    }
}

fn arrow_error(path: &Path, source: arrow::error::ArrowError) -> OutputError {
    OutputError::Arrow {
        path: path.to_path_buf(),
        source,
    }
}

/// What a finished run produced.
#[derive(Debug)]
pub struct RunReport {
    /// Layout of the model's rows.
    pub layout: Layout,
    /// The conditions.
    pub infos: Vec<ConditionInfo>,
    /// The summary rows (also in summary.parquet).
    pub summary: Vec<SummaryRow>,
    /// The files written.
    pub files: Vec<PathBuf>,
}

/// Run `study` into `options.out_dir`.
pub fn run_study(
    study: &Study,
    options: &RunOptions,
    observer: &dyn Observer,
) -> Result<RunReport, RunError> {
    let prepared = PreparedModel::new(study)?;
    let pool = thread_pool(options.threads)?;
    pool.install(|| run_prepared(study, prepared.model(), options, observer))
}

fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool, RunError> {
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(t) = threads {
        builder = builder.num_threads(t);
    }
    builder.build().map_err(|e| RunError::Threads {
        threads: threads.unwrap_or(0),
        reason: e.to_string(),
    })
}

fn run_prepared(
    study: &Study,
    model: &dyn DynModel,
    options: &RunOptions,
    observer: &dyn Observer,
) -> Result<RunReport, RunError> {
    let dir = &options.out_dir;
    fs::create_dir_all(dir).map_err(|e| OutputError::io(dir, e))?;
    let meta = FileMetadata {
        study_toml: study.to_toml(),
        seed: study.seed,
        realisations: study.realisations,
    };
    let layout = model.layout().clone();
    let infos = model.infos();

    // 1. Realisations, streamed to Parquet chunk by chunk.
    let schema = output::realisation_schema(&layout);
    let mut sink = ParquetSink::create(
        dir,
        files::REALISATIONS,
        schema.clone(),
        &meta,
        "realisations",
    )?;
    let work: Vec<Work> = (0..infos.len())
        .map(|c| Work {
            condition: c,
            realisations: 0..study.realisations,
        })
        .collect();
    model.execute(study.seed, &work, options.chunk, observer, &mut |chunk| {
        let batch = output::realisations_batch(&layout, &schema, &infos[chunk.condition], &chunk)
            .map_err(|e| arrow_error(dir, e))?;
        sink.write(&batch)
    })?;
    let realisations = sink.finish()?;

    // 2. Summary, from the realisation file itself (two passes), so `run` and any later
    //    re-summary of the same rows agree by construction.
    let summary = summarise_files(
        &layout,
        &infos,
        study.realisations,
        &[realisations.tmp_path()],
    )?;
    let mut sink = ParquetSink::create(
        dir,
        files::SUMMARY,
        output::summary_schema(&layout),
        &meta,
        "summary",
    )?;
    let batch =
        output::summary_batch(&layout, &infos, &summary).map_err(|e| arrow_error(dir, e))?;
    sink.write(&batch)?;
    let summary_file = sink.finish()?;

    // 3. Model-specific tables, then commit everything together.
    let mut pending = vec![realisations, summary_file];
    pending.extend(model.extra_files(dir, &meta)?);
    let files = output::commit_all(pending)?;
    Ok(RunReport {
        layout,
        infos,
        summary,
        files,
    })
}

/// Rows per batch when reading realisation files back.
const READ_BATCH_ROWS: usize = 65_536;

/// Summarise the realisation rows stored in `paths` (any split of one study's rows).
pub fn summarise_files(
    layout: &Layout,
    infos: &[ConditionInfo],
    realisations: u64,
    paths: &[&Path],
) -> Result<Vec<SummaryRow>, RunError> {
    let mut summarizer = Summarizer::new(layout, infos, realisations, Z_95);
    for pass in 0..2 {
        for path in paths {
            let summary_error = |source| RunError::Summary {
                path: path.to_path_buf(),
                source,
            };
            for batch in output::open_reader(path, READ_BATCH_ROWS)? {
                let batch = batch.map_err(|e| arrow_error(path, e))?;
                let rows = RealisationBatches::decode(layout, &batch, path)?;
                for record in rows.records() {
                    if pass == 0 {
                        summarizer.first_pass(&record).map_err(summary_error)?;
                    } else {
                        summarizer.second_pass(&record).map_err(summary_error)?;
                    }
                }
            }
        }
        if pass == 0 {
            summarizer
                .end_first_pass()
                .map_err(|source| RunError::Summary {
                    path: paths.first().map(|p| p.to_path_buf()).unwrap_or_default(),
                    source,
                })?;
        }
    }
    Ok(summarizer.finish())
}
