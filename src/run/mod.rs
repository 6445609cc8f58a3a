//! Running a study end to end: prepare the model, execute the realisations, summarise,
//! write the Parquet files and the figures, and commit them together as one set.
//!
//! Nothing in the output directory changes until every file is complete: each is written
//! under a temporary name, and the whole set replaces the previous one through a journal
//! ([`output::set`]), so a reader sees the old set or the new one, never a mix. The
//! directory is locked while a run writes it ([`output::lock`]). A bad study is rejected
//! before the directory is touched.

use std::fs;
use std::path::{Path, PathBuf};

use arrow::record_batch::RecordBatch;
use thiserror::Error;

use crate::figures::{self, FigureError};
use crate::model::{self, ConditionInfo, Layout, Model};
use crate::montecarlo::{DEFAULT_CHUNK, Observer};
pub use crate::output::files;
pub use memory::{
    RunInMemory, TableInMemory, extra_tables_in_memory, run_in_memory, summarise_in_memory,
};
pub use shard::Shard;
pub use summarize::{realisation_files, summarise_files, summarize, summarize_assembled};

mod guard;
mod memory;
mod realise;
mod rows;
mod shard;
mod summarize;

use crate::output::{self, FileMetadata, OutputError, ParquetSink, PendingFile, set};
use crate::stats::summary::{SummaryError, SummaryRow};
use crate::study::{Study, StudyError};
use guard::{lock, refuse_other_runs_shards, refuse_shards};
use realise::{identity, realise};

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
    /// Drawing the figures failed.
    #[error(transparent)]
    Figures(#[from] FigureError),
    /// The caller asked the run to stop ([`Observer::stop_requested`]); the parts completed
    /// so far stay in `parts`, and running the study again into the same directory resumes
    /// from them.
    #[error(
        "interrupted: the completed parts are kept in {}; run the study again into the same \
         directory to resume",
        parts.display()
    )]
    Interrupted {
        /// The staging directory holding the completed parts.
        parts: PathBuf,
    },
    /// The caller asked a run held in memory ([`run_in_memory`]) to stop: it had no
    /// output directory, so nothing was kept.
    #[error("interrupted: a run without an output directory keeps nothing")]
    Stopped,
    /// The thread pool could not be built.
    #[error("cannot start {threads} worker threads: {reason}")]
    Threads {
        /// Threads requested.
        threads: usize,
        /// The reason.
        reason: String,
    },
}

impl RunError {
    /// Whether the cause is the user's input (exit status 2 at the command line): an invalid
    /// study, or an output directory or file that cannot be used as it is
    /// ([`OutputError::is_bad_input`]); otherwise a failure while running (exit status 1).
    pub fn is_bad_input(&self) -> bool {
        match self {
            RunError::Study(_) => true,
            RunError::Output(e) => e.is_bad_input(),
            RunError::Figures(e) => e.is_bad_input(),
            RunError::Summary { .. }
            | RunError::Threads { .. }
            | RunError::Interrupted { .. }
            | RunError::Stopped => false,
        }
    }
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
    /// Run only this shard of every condition (written to `out_dir/shard=K/`).
    pub shard: Option<Shard>,
    /// Draw the figures into `out_dir/figures/` (not for a shard).
    pub figures: bool,
    /// Keep the realisation file's rows in memory too ([`RunReport::realisations`]).
    pub keep_realisations: bool,
}

impl RunOptions {
    /// Defaults: all cores, [`DEFAULT_CHUNK`] realisations per chunk.
    pub fn new(out_dir: impl Into<PathBuf>) -> Self {
        RunOptions {
            out_dir: out_dir.into(),
            threads: None,
            chunk: DEFAULT_CHUNK,
            shard: None,
            figures: true,
            keep_realisations: false,
        }
    }
}

/// Write the model's extra tables (the vehicle's cycles) under temporary names in `dir`.
pub(super) fn write_extra_tables(
    model: &dyn Model,
    dir: &Path,
    meta: &FileMetadata,
) -> Result<Vec<PendingFile>, OutputError> {
    let mut written = Vec::new();
    for (t, table) in model.extra_tables().iter().enumerate() {
        let mut sink =
            ParquetSink::create(dir, table.file, table.schema.clone(), meta, table.table)?;
        for batch in (0..).map_while(|i| model.extra_batch(t, i)) {
            sink.write(&batch.map_err(|e| OutputError::arrow(dir, e))?)?;
        }
        written.push(sink.finish()?);
    }
    Ok(written)
}

/// What a finished run produced.
#[derive(Debug)]
pub struct RunReport {
    /// Layout of the model's rows.
    pub layout: Layout,
    /// The conditions.
    pub infos: Vec<ConditionInfo>,
    /// The summary rows (also in summary.parquet); empty for a shard.
    pub summary: Vec<SummaryRow>,
    /// The files written.
    pub files: Vec<PathBuf>,
    /// Realisations (per condition, summed) kept from earlier, interrupted or smaller runs.
    pub reused: u64,
    /// Realisations computed by this run.
    pub computed: u64,
    /// The rows of the realisation file written, with [`RunOptions::keep_realisations`].
    pub realisations: Option<Vec<RecordBatch>>,
    /// What the footers of the files written say (the study as run, its identity).
    pub metadata: FileMetadata,
}

/// Staging directory for parts, inside the directory of the realisation file.
pub const STAGING: &str = ".chassis-mc-parts";

/// Run `study` into `options.out_dir`.
pub fn run_study(
    study: &Study,
    options: &RunOptions,
    observer: &dyn Observer,
) -> Result<RunReport, RunError> {
    let pool = thread_pool(options.threads)?;
    pool.install(|| {
        let model = model::prepare(study)?;
        run_prepared(study, model, options, observer)
    })
}

/// A rayon pool of `threads` workers (`None`: one per core), as a run uses.
pub fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool, RunError> {
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(t) = threads {
        builder = builder.num_threads(t);
    }
    builder.build().map_err(|e| RunError::Threads {
        threads: threads.unwrap_or(0),
        reason: e.to_string(),
    })
}

/// Delete what killed runs left under temporary names: files, and the figures' staging
/// directory.
pub(super) fn remove_temporaries(dir: &Path) -> Result<(), OutputError> {
    for entry in fs::read_dir(dir).map_err(|e| OutputError::io(dir, e))? {
        let entry = entry.map_err(|e| OutputError::io(dir, e))?;
        if output::is_temporary(&entry.file_name().to_string_lossy()) {
            let path = entry.path();
            // A symbolic link goes itself: what it points to is never touched.
            let is_dir = entry.file_type().is_ok_and(|t| t.is_dir());
            let removed = if is_dir {
                fs::remove_dir_all(&path)
            } else {
                fs::remove_file(&path)
            };
            removed.map_err(|e| OutputError::io(&path, e))?;
        }
    }
    Ok(())
}

/// Run `study` with its prepared `model`, which is dropped as soon as the realisations and
/// the extra tables are written: the summary, figures and report need only the layout and
/// the conditions, so the model's cycles and regressions do not add to their memory.
fn run_prepared(
    study: &Study,
    model: Box<dyn Model>,
    options: &RunOptions,
    observer: &dyn Observer,
) -> Result<RunReport, RunError> {
    let out_dir = &options.out_dir;
    let dir = match options.shard {
        Some(shard) => out_dir.join(shard.dir_name()),
        None => out_dir.clone(),
    };
    let _lock = lock(&dir, observer)?;
    if set::recover(&dir)? {
        observer.notice(&format!(
            "{}: completed the replacement of the output files that an interrupted run had \
             begun",
            dir.display()
        ));
    }
    // Refused before any work: shards, or a user's file where this run writes a table, the
    // report or any figure it may draw (checked again when they are committed).
    let mut writes = vec![files::REALISATIONS.to_string()];
    if options.shard.is_none() {
        refuse_shards(&dir)?;
        writes.extend(written_beside(model.as_ref(), options.figures));
    }
    set::ensure_owned(&dir, &writes)?;
    let layout = model.layout().clone();
    let infos = model.infos();
    let meta = FileMetadata::of_study(study, identity(study, &*model, &infos));
    if let Some(shard) = options.shard {
        refuse_other_runs_shards(out_dir, shard, &meta)?;
    }
    let staging = dir.join(STAGING);
    output::store::ensure_staging(&staging)?;
    remove_temporaries(&dir)?;
    fs::create_dir_all(&staging).map_err(|e| OutputError::io(&staging, e))?;

    // The model's extra tables (the cycles) do not depend on the realisations: they are
    // written while the realisations are computed.
    let (realised, extra) = rayon::join(
        || realise(study, &*model, &infos, options, observer, &dir, &meta),
        || match options.shard {
            None => write_extra_tables(&*model, out_dir, &meta),
            Some(_) => Ok(Vec::new()),
        },
    );
    drop(model);
    let (realisations, reused, computed, kept) = realised?;
    let extra = extra?;

    // The summary, from the assembled file itself (two passes), so `run` and `summarize`
    // agree by construction; a shard's summary comes from `summarize` over all shards.
    let mut pending = vec![realisations];
    let mut summary = Vec::new();
    if options.shard.is_none() {
        summary = summarise_files(
            &layout,
            &infos,
            study.realisations(),
            &[output::OpenedFile::open(pending[0].tmp_path())?],
        )?;
        pending.extend(write_summary(out_dir, &layout, &infos, &summary, &meta)?);
        pending.extend(extra);
        if options.figures {
            let figures = draw_figures(out_dir, &layout, &pending)?;
            pending.extend(figures);
        }
        let report = write_report(
            out_dir,
            "run",
            study.name(),
            &meta,
            (&layout, &infos, &summary),
            &pending,
        )?;
        pending.push(report);
    }
    let files = set::commit(&dir, pending, &|_| true)?;
    output::failpoint("committed");
    fs::remove_dir_all(&staging).map_err(|e| OutputError::io(&staging, e))?;
    remove_temporaries(&dir)?; // the figures' emptied staging directory
    Ok(RunReport {
        layout,
        infos,
        summary,
        files,
        reused,
        computed,
        realisations: kept.map(|k| std::mem::take(&mut *k.lock().expect("kept batches"))),
        metadata: meta,
    })
}

/// The files a summary writes beside the realisations: the summary, the model's extra
/// tables, the report and, with `figures`, every figure it may draw.
pub(super) fn written_beside(model: &dyn Model, figures: bool) -> Vec<String> {
    let mut names = vec![files::SUMMARY.to_string(), REPORT.to_string()];
    names.extend(model.extra_tables().iter().map(|t| t.file.to_string()));
    if figures {
        let cycles = names.iter().any(|n| n == files::CYCLES);
        names.extend(
            figures::possible_names(model.layout(), cycles)
                .into_iter()
                .map(|name| format!("{}/{name}", figures::FIGURES)),
        );
    }
    names
}

/// Draw the figures of the summary and cycles among `pending` (still under temporary
/// names) of a run with `layout`, to be committed with them.
pub(super) fn draw_figures(
    out_dir: &Path,
    layout: &Layout,
    pending: &[PendingFile],
) -> Result<Vec<PendingFile>, RunError> {
    let find = |name: &str| {
        pending
            .iter()
            .find(|p| p.final_path().file_name() == Some(name.as_ref()))
            .map(|p| p.tmp_path())
    };
    let summary = find(files::SUMMARY).expect("the summary is written before the figures");
    Ok(figures::draw_staged(
        out_dir,
        layout,
        summary,
        find(files::CYCLES),
    )?)
}

/// Name of the report page in an output directory.
pub const REPORT: &str = "report.html";

/// Write `report.html` into `out_dir` (under a temporary name, to be committed with the
/// rest): the study, provenance, the per-condition table and the figures among `pending`.
pub(super) fn write_report(
    out_dir: &Path,
    command: &str,
    study_name: &str,
    meta: &FileMetadata,
    (layout, infos, summary): (&Layout, &[ConditionInfo], &[SummaryRow]),
    pending: &[PendingFile],
) -> Result<PendingFile, OutputError> {
    let figures_dir = out_dir.join(figures::FIGURES);
    let mut figures = Vec::new();
    for file in pending {
        let path = file.final_path();
        if path.parent() == Some(figures_dir.as_path())
            && path.extension().is_some_and(|e| e == "svg")
        {
            let svg = fs::read_to_string(file.tmp_path())
                .map_err(|e| OutputError::io(file.tmp_path(), e))?;
            let name = path.file_name().unwrap_or_default().to_string_lossy();
            figures.push((name.into_owned(), svg));
        }
    }
    let html = crate::report::page(&crate::report::Page {
        command,
        study_name,
        meta,
        layout,
        infos,
        summary,
        figures: &figures,
    });
    output::write_pending(out_dir, REPORT, html.as_bytes())
}

pub(super) fn write_summary(
    dir: &Path,
    layout: &Layout,
    infos: &[ConditionInfo],
    summary: &[SummaryRow],
    meta: &FileMetadata,
) -> Result<Vec<PendingFile>, OutputError> {
    let mut sink = ParquetSink::create(
        dir,
        files::SUMMARY,
        output::summary_schema(layout),
        meta,
        "summary",
    )?;
    // In row groups of SUMMARY_GROUP_ROWS, each built and written on its own: the writer
    // holds one group's columns at a time, not the whole table's (120 MB for a grid of
    // 10 000 conditions in one group).
    for rows in summary.chunks(SUMMARY_GROUP_ROWS) {
        let batch =
            output::summary_batch(layout, infos, rows).map_err(|e| OutputError::arrow(dir, e))?;
        sink.write(&batch)?;
        sink.flush()?;
    }
    Ok(vec![sink.finish()?])
}

/// Rows per row group of summary.parquet.
pub(super) const SUMMARY_GROUP_ROWS: usize = 4096;
