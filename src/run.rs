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

use thiserror::Error;

use crate::figures::{self, FigureError};
use crate::model::{self, ConditionInfo, Layout, Model};
use crate::montecarlo::{self, DEFAULT_CHUNK, Observer, Work};
pub use crate::output::files;
use crate::output::lock::DirLock;
use crate::output::{
    self, FileMetadata, OutputError, ParquetSink, PendingFile, RealisationBatches, keys, set, store,
};
use crate::stats::measures::Z_95;
use crate::stats::summary::{Summarizer, SummaryError, SummaryRow};
use crate::study::{Study, StudyError};

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
    /// Run only this shard of every condition (written to `out_dir/shard=K/`).
    pub shard: Option<Shard>,
    /// Draw the figures into `out_dir/figures/` (not for a shard).
    pub figures: bool,
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
        }
    }
}

/// Write the model's extra tables (the vehicle's cycles) under temporary names in `dir`.
fn write_extra_tables(
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
}

/// Shard K of N: the contiguous realisations ⌊K·R/N⌋ … ⌊(K+1)·R/N⌋ − 1 of every condition.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// K, 0-based.
    pub index: u64,
    /// N ≥ 1.
    pub count: u64,
}

impl Shard {
    /// Parse "K/N" with 0 ≤ K < N.
    pub fn parse(text: &str) -> Result<Shard, String> {
        let (k, n) = text
            .split_once('/')
            .ok_or_else(|| format!("expected K/N (e.g. 0/4), got \"{text}\""))?;
        let index: u64 = k
            .trim()
            .parse()
            .map_err(|_| format!("K in K/N must be a whole number, got \"{k}\""))?;
        let count: u64 = n
            .trim()
            .parse()
            .map_err(|_| format!("N in K/N must be a whole number, got \"{n}\""))?;
        if count == 0 || index >= count {
            return Err(format!("need 0 <= K < N, got {index}/{count}"));
        }
        Ok(Shard { index, count })
    }

    /// The realisations of this shard out of `r` per condition.
    pub fn range(&self, r: u64) -> std::ops::Range<u64> {
        let at = |k: u64| (u128::from(k) * u128::from(r) / u128::from(self.count)) as u64;
        at(self.index)..at(self.index + 1)
    }

    /// Directory of this shard inside the output directory (`shard=K`, hive style).
    pub fn dir_name(&self) -> String {
        format!("shard={}", self.index)
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
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
        run_prepared(study, &*model, options, observer)
    })
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

/// Delete what killed runs left under temporary names: files, and the figures' staging
/// directory.
fn remove_temporaries(dir: &Path) -> Result<(), OutputError> {
    for entry in fs::read_dir(dir).map_err(|e| OutputError::io(dir, e))? {
        let entry = entry.map_err(|e| OutputError::io(dir, e))?;
        if output::is_temporary(&entry.file_name().to_string_lossy()) {
            let path = entry.path();
            let removed = if path.is_dir() {
                fs::remove_dir_all(&path)
            } else {
                fs::remove_file(&path)
            };
            removed.map_err(|e| OutputError::io(&path, e))?;
        }
    }
    Ok(())
}

fn run_prepared(
    study: &Study,
    model: &dyn Model,
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
    remove_temporaries(&dir)?;
    let staging = dir.join(STAGING);
    fs::create_dir_all(&staging).map_err(|e| OutputError::io(&staging, e))?;
    let layout = model.layout().clone();
    let infos = model.infos();
    let meta = FileMetadata {
        study_toml: study.to_toml(),
        seed: study.seed,
        realisations: study.realisations,
        identity: identity(study, model, &infos),
        extra: Vec::new(),
    };

    // The model's extra tables (the cycles) do not depend on the realisations: they are
    // written while the realisations are computed.
    let (realised, extra) = rayon::join(
        || realise(study, model, &infos, options, observer, &dir, &meta),
        || match options.shard {
            None => write_extra_tables(model, out_dir, &meta),
            Some(_) => Ok(Vec::new()),
        },
    );
    let (realisations, reused, computed) = realised?;
    let extra = extra?;

    // The summary, from the assembled file itself (two passes), so `run` and `summarize`
    // agree by construction; a shard's summary comes from `summarize` over all shards.
    let mut pending = vec![realisations];
    let mut summary = Vec::new();
    if options.shard.is_none() {
        summary = summarise_files(
            &layout,
            &infos,
            study.realisations,
            &[pending[0].tmp_path()],
        )?;
        pending.extend(write_summary(out_dir, &layout, &infos, &summary, &meta)?);
        pending.extend(extra);
        if options.figures {
            let figures = draw_figures(out_dir, &pending)?;
            pending.extend(figures);
        }
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
    })
}

/// Lock `dir` for this process (creating it), telling `observer` when the lock of a killed
/// process is taken over.
fn lock(dir: &Path, observer: &dyn Observer) -> Result<DirLock, OutputError> {
    let lock = DirLock::acquire(dir)?;
    if let Some(pid) = lock.taken_over_from {
        observer.notice(&format!(
            "{}: taking over the lock of process {pid}, which ended without releasing it",
            dir.display()
        ));
    }
    Ok(lock)
}

/// Draw the figures of the summary and cycles among `pending` (still under temporary
/// names), to be committed with them.
fn draw_figures(out_dir: &Path, pending: &[PendingFile]) -> Result<Vec<PendingFile>, RunError> {
    let find = |name: &str| {
        pending
            .iter()
            .find(|p| p.final_path().file_name() == Some(name.as_ref()))
            .map(|p| p.tmp_path())
    };
    let summary = find(files::SUMMARY).expect("the summary is written before the figures");
    Ok(figures::draw_staged(out_dir, summary, find(files::CYCLES))?)
}

/// What makes realisations of two runs interchangeable: the study without its realisation
/// count and the engine version ([`Study::identity`]), plus a check of this build's
/// numbers — a hash of every condition's metrics and of realisation 0 of condition 0 — so
/// that a rebuilt engine whose arithmetic changed never reuses an older run's parts.
fn identity(study: &Study, model: &dyn Model, infos: &[ConditionInfo]) -> String {
    let mut canary = vec![0.0; model.layout().realisation_stride()];
    model.realise(study.seed, 0, 0, &mut canary);
    let metrics = infos.iter().flat_map(|i| i.metrics.iter().copied());
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325; // FNV-1a, 64 bit
    for v in canary.into_iter().chain(metrics) {
        for byte in v.to_bits().to_le_bytes() {
            hash = (hash ^ u64::from(byte)).wrapping_mul(0x0100_0000_01b3);
        }
    }
    format!("{}# numbers {hash:016x}\n", study.identity())
}

/// Make every needed realisation exist and assemble them, in order, into the realisation
/// file (still under its temporary name). Returns it with the counts reused and computed.
fn realise(
    study: &Study,
    model: &dyn Model,
    infos: &[ConditionInfo],
    options: &RunOptions,
    observer: &dyn Observer,
    dir: &Path,
    meta: &FileMetadata,
) -> Result<(PendingFile, u64, u64), RunError> {
    let staging = dir.join(STAGING);
    let layout = model.layout();
    let schema = output::realisation_schema(layout);
    let range = options
        .shard
        .map_or(0..study.realisations, |s| s.range(study.realisations));
    let needed = vec![range; infos.len()];
    // 1. What exists already: completed parts of an interrupted run, and the realisation
    //    file of an earlier run of the same study (e.g. with a smaller R).
    let notice = |message: &str| observer.notice(message);
    let mut sources = store::scan_parts(&staging, &meta.identity, &notice)?;
    sources.extend(store::existing_file(
        &dir.join(files::REALISATIONS),
        &meta.identity,
        &notice,
    )?);
    let segments = store::plan(&needed, &sources);
    let length = |s: &store::Segment| s.range.end - s.range.start;
    let total: u64 = segments.iter().map(length).sum();
    let computed: u64 = segments
        .iter()
        .filter(|s| s.source.is_none())
        .map(length)
        .sum();
    observer.planned(total, total - computed);

    // 2. Compute what is missing into staged parts, each renamed into place when complete
    //    (so a killed run resumes), and assemble the final file as the rows arrive. One
    //    pass over every part keeps the executor's compute/write pipeline full; the parts
    //    are planned lazily, so the plan's memory does not grow with R.
    let mut pieces = segments
        .iter()
        .filter(|s| s.source.is_none())
        .flat_map(|seg| {
            let (condition, range) = (seg.condition, seg.range.clone());
            let step = usize::try_from(store::PART_REALISATIONS).unwrap_or(usize::MAX);
            (range.start..range.end)
                .step_by(step)
                .map(move |start| Work {
                    condition,
                    realisations: start..(start + store::PART_REALISATIONS).min(range.end),
                })
        });
    let file_meta = match options.shard {
        Some(shard) => meta.with(keys::SHARD, shard.to_string()),
        None => meta.clone(),
    };
    let file = ParquetSink::create(
        dir,
        files::REALISATIONS,
        schema.clone(),
        &file_meta,
        "realisations",
    )?;
    let mut assembler = store::Assembler::new(&sources, &segments, file);
    let mut part: Option<ParquetSink> = None; // the part of the current work item
    montecarlo::execute(
        model,
        study.seed,
        &mut pieces,
        options.chunk,
        observer,
        |chunk| {
            if chunk.first == chunk.item.start {
                let part_meta =
                    meta.with(keys::PART, store::part_value(chunk.condition, &chunk.item));
                part = Some(ParquetSink::create(
                    &staging,
                    &store::part_name(chunk.condition, chunk.item.start, 0),
                    schema.clone(),
                    &part_meta,
                    "realisations",
                )?);
            }
            let batch =
                output::realisations_batch(layout, &schema, &infos[chunk.condition], &chunk)
                    .map_err(|e| OutputError::arrow(&staging, e))?;
            part.as_mut().expect("a part is open").write(&batch)?;
            assembler.computed(chunk.condition, chunk.first, &batch)?;
            let rows = (chunk.slots.len() / layout.realisation_stride()) as u64;
            if chunk.first + rows == chunk.item.end {
                let done = part.take().expect("a part is open").finish()?;
                store::commit_part(done, chunk.condition, chunk.item.start)?;
                output::failpoint("part-committed");
            }
            Ok::<(), OutputError>(())
        },
    )?;

    Ok((assembler.finish()?, total - computed, computed))
}

fn write_summary(
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
    let batch =
        output::summary_batch(layout, infos, summary).map_err(|e| OutputError::arrow(dir, e))?;
    sink.write(&batch)?;
    Ok(vec![sink.finish()?])
}

/// The realisation files in `input`: the file itself, or in a directory its
/// `realisations.parquet` and every `shard=*/realisations.parquet`. A directory whose output
/// set is incomplete (an interrupted commit) or whose realisation file does not match the
/// checksum recorded for it is an error.
pub fn realisation_files(input: &Path) -> Result<Vec<PathBuf>, OutputError> {
    let found = find_realisation_files(input)?;
    for path in &found {
        let dir = path.parent().unwrap_or(Path::new("."));
        set::ensure_complete(dir)?;
        let manifest = set::Manifest::read(dir)?;
        if let Some(entry) = manifest.as_ref().and_then(|m| m.get(files::REALISATIONS))
            && path.file_name() == Some(files::REALISATIONS.as_ref())
            && set::checksum(path)? != entry.checksum
        {
            return Err(OutputError::format(
                path,
                "damaged: its bytes do not match the checksum recorded when it was written; \
                 run its study (or shard) again",
            ));
        }
    }
    Ok(found)
}

fn find_realisation_files(input: &Path) -> Result<Vec<PathBuf>, OutputError> {
    if input.is_file() {
        return Ok(vec![input.to_path_buf()]);
    }
    let mut found = Vec::new();
    let direct = input.join(files::REALISATIONS);
    if direct.is_file() {
        found.push(direct);
    }
    let entries = fs::read_dir(input).map_err(|e| OutputError::io(input, e))?;
    let mut shards = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| OutputError::io(input, e))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        let file = entry.path().join(files::REALISATIONS);
        if name.starts_with("shard=") && file.is_file() {
            shards.push(file);
        }
    }
    shards.sort();
    found.extend(shards);
    Ok(found)
}

/// Rebuild `summary.parquet` (and the model's extra tables, and the figures if `figures`)
/// in `out_dir` from realisation files of one study: any split into shards, in any order.
/// The study is read from the files' footers; every realisation of every condition must be
/// present exactly once. The new files replace the summary, tables and figures of
/// `out_dir`'s output set together; a realisation file there stays.
pub fn summarize(inputs: &[PathBuf], out_dir: &Path, figures: bool) -> Result<RunReport, RunError> {
    let mut paths = Vec::new();
    for input in inputs {
        paths.extend(realisation_files(input)?);
    }
    let first = paths.first().ok_or_else(|| {
        RunError::Study(StudyError {
            file: inputs
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", "),
            key: None,
            line: None,
            reason: "no realisation files found (expected realisations.parquet or shard=*/realisations.parquet)".into(),
        })
    })?;
    let footer = |path: &Path| -> Result<(String, String, u64), RunError> {
        let footer = output::read_metadata(path)?;
        let get = |k: &str| footer.get(k).map(str::to_string);
        let missing = || {
            OutputError::format(
                path,
                "not a chassis-mc realisation file (footer metadata missing)",
            )
        };
        let study = get(keys::STUDY).ok_or_else(missing)?;
        let identity = get(keys::IDENTITY).ok_or_else(missing)?;
        let r = get(keys::REALISATIONS)
            .and_then(|v| v.parse().ok())
            .ok_or_else(missing)?;
        Ok((study, identity, r))
    };
    let (study_toml, identity, realisations) = footer(first)?;
    for path in &paths[1..] {
        let (_, other, r) = footer(path)?;
        if other != identity || r != realisations {
            return Err(OutputError::format(
                path,
                format!(
                    "belongs to a different study or R than {} (realisations {r} vs {realisations})",
                    first.display()
                ),
            )
            .into());
        }
    }
    let origin = format!("{} (footer)", first.display());
    let study = Study::from_toml(&study_toml, &origin)?;
    let model = model::prepare(&study)?;
    let layout = model.layout().clone();
    let infos = model.infos();
    let refs: Vec<&Path> = paths.iter().map(PathBuf::as_path).collect();
    let summary = summarise_files(&layout, &infos, realisations, &refs)?;
    let _lock = DirLock::acquire(out_dir)?;
    set::ensure_complete(out_dir)?;
    remove_temporaries(out_dir)?;
    let meta = FileMetadata {
        study_toml: study.to_toml(),
        seed: study.seed,
        realisations,
        identity,
        extra: Vec::new(),
    };
    let mut pending = write_summary(out_dir, &layout, &infos, &summary, &meta)?;
    pending.extend(write_extra_tables(&*model, out_dir, &meta)?);
    if figures {
        let figures = draw_figures(out_dir, &pending)?;
        pending.extend(figures);
    }
    // The summary's set keeps the realisation files it summarised.
    let files = set::commit(out_dir, pending, &|path| {
        path != files::REALISATIONS && !path.starts_with("shard=")
    })?;
    remove_temporaries(out_dir)?;
    Ok(RunReport {
        layout,
        infos,
        summary,
        files,
        reused: 0,
        computed: 0,
    })
}

/// Summarise the realisation rows stored in `paths` (any split of one study's rows).
pub fn summarise_files(
    layout: &Layout,
    infos: &[ConditionInfo],
    realisations: u64,
    paths: &[&Path],
) -> Result<Vec<SummaryRow>, RunError> {
    let mut summarizer = Summarizer::new(layout, infos, realisations, Z_95);
    let columns = RealisationBatches::columns(layout);
    let columns: Vec<&str> = columns.iter().map(String::as_str).collect();
    for pass in 0..2 {
        for path in paths {
            let summary_error = |source| RunError::Summary {
                path: path.to_path_buf(),
                source,
            };
            for batch in output::open_projected_reader(path, output::READ_ROWS, Some(&columns))? {
                let batch = batch.map_err(|e| OutputError::arrow(path, e))?;
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
