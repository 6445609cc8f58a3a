//! A run held in memory: the realisation and summary tables a run writes, as Arrow record
//! batches, with no file created (the Python package's `run` without `out`); and the
//! in-memory summary of callers that evaluate a study many times (`design`, `check`).
//!
//! Bit for bit the tables of a run into a directory: the same slots ([`montecarlo::in_memory`]
//! is the executor a run uses), the same rows built from them, and the summary by the same
//! two passes over the same records in the same order.

use std::path::PathBuf;

use arrow::datatypes::SchemaRef;
use arrow::record_batch::RecordBatch;

use super::realise::identity;
use super::{RunError, SUMMARY_GROUP_ROWS, files, thread_pool};
use crate::estimate::campaign::CAMPAIGN_PASS;
use crate::model::{self, ConditionInfo, Layout, Model, Status};
use crate::montecarlo::{self, Chunk, Observer};
use crate::output::{self, FileMetadata, OutputError};
use crate::stats::measures::Z_95;
use crate::stats::summary::filter::INPUTS;
use crate::stats::summary::{ConditionSummarizer, Record, SummaryError, SummaryRow};
use crate::study::Study;

/// One table of a run held in memory: what its file would be called, its schema (with the
/// key-value metadata the file's footer carries) and its rows.
#[derive(Debug, Clone)]
pub struct TableInMemory {
    /// The file a run into a directory writes it to, e.g. `summary.parquet`.
    pub file: &'static str,
    /// Its columns, and as metadata the footer's keys (`chassis_mc.identity`, the study).
    pub schema: SchemaRef,
    /// Its rows.
    pub batches: Vec<RecordBatch>,
}

/// What a run held in memory produced.
#[derive(Debug)]
pub struct RunInMemory {
    /// realisations.parquet's table: one row per realisation × estimator.
    pub realisations: TableInMemory,
    /// summary.parquet's table: one row per condition × estimator × parameter.
    pub summary: TableInMemory,
    /// The summary rows the table holds.
    pub rows: Vec<SummaryRow>,
    /// Realisations computed (every condition's, summed).
    pub computed: u64,
}

/// Slots an in-memory computation holds at once: 2^28 (2 GiB).
pub const MAX_SLOTS: usize = 1 << 28;

/// Conditions an in-memory summary computes at once.
const IN_MEMORY_BLOCK: usize = 256;

/// Run `study` on `threads` workers (`None`: every core) with every table held in memory
/// and no file created. The observer sees the progress, and a stop it asks for ends the run
/// with [`RunError::Stopped`] (nothing is kept).
pub fn run_in_memory(
    study: &Study,
    threads: Option<usize>,
    observer: &dyn Observer,
) -> Result<RunInMemory, RunError> {
    thread_pool(threads)?.install(|| {
        let model = model::prepare(study)?;
        let layout = model.layout().clone();
        let infos = model.infos();
        let meta = FileMetadata::of_study(study, identity(study, &*model, &infos));
        let r = study.realisations();
        let total = r * infos.len() as u64;
        observer.planned(total, 0);
        let block = block_size(study, &layout, "split the run into shards")?;
        let schema =
            output::footer_schema(output::realisation_schema(&layout), &meta, "realisations");
        let mut batches = Vec::new();
        let mut rows = Vec::new();
        let all: Vec<usize> = (0..infos.len()).collect();
        let stride = layout.realisation_stride();
        for conditions in all.chunks(block) {
            let slots = montecarlo::in_memory_until_stopped(
                &*model,
                study.seed(),
                conditions,
                0..r,
                observer,
            )
            .ok_or(RunError::Stopped)?;
            let per = r as usize * stride;
            for (k, &c) in conditions.iter().enumerate() {
                // in the realisation file's row groups: ROW_GROUP_ROWS rows at most
                let step = (output::ROW_GROUP_ROWS / layout.estimators.len()).max(1) * stride;
                for (j, slots) in slots[k * per..(k + 1) * per].chunks(step).enumerate() {
                    let chunk = Chunk {
                        condition: c,
                        first: (j * step / stride) as u64,
                        item: 0..r,
                        slots,
                    };
                    let batch = output::realisations_batch(&layout, &schema, &infos[c], &chunk)
                        .map_err(|e| OutputError::arrow(&PathBuf::from(files::REALISATIONS), e))?;
                    batches.push(batch);
                }
            }
            summarise_block(&layout, &infos, conditions, r, &slots, &mut rows)?;
        }
        drop(model);
        let summary_schema =
            output::footer_schema(output::summary_schema(&layout), &meta, "summary");
        let summary = rows
            .chunks(SUMMARY_GROUP_ROWS)
            .map(|group| {
                output::summary_batch(&layout, &infos, group)
                    .and_then(|b| b.with_schema(summary_schema.clone()))
                    .map_err(|e| OutputError::arrow(&PathBuf::from(files::SUMMARY), e).into())
            })
            .collect::<Result<Vec<_>, RunError>>()?;
        Ok(RunInMemory {
            realisations: TableInMemory {
                file: files::REALISATIONS,
                schema,
                batches,
            },
            summary: TableInMemory {
                file: files::SUMMARY,
                schema: summary_schema,
                batches: summary,
            },
            rows,
            computed: total,
        })
    })
}

/// The model's extra tables of `study` (the vehicle's cycles.parquet) held in memory, as a
/// run writes them; none for a model without them.
pub fn extra_tables_in_memory(
    study: &Study,
    threads: Option<usize>,
) -> Result<Vec<TableInMemory>, RunError> {
    thread_pool(threads)?.install(|| {
        let model = model::prepare(study)?;
        let infos = model.infos();
        let meta = FileMetadata::of_study(study, identity(study, &*model, &infos));
        let mut tables = Vec::new();
        for (t, table) in model.extra_tables().iter().enumerate() {
            let schema = output::footer_schema(table.schema.clone(), &meta, table.table);
            let batches = (0..)
                .map_while(|i| model.extra_batch(t, i))
                .map(|b| {
                    b.and_then(|b| b.with_schema(schema.clone()))
                        .map_err(|e| OutputError::arrow(&PathBuf::from(table.file), e).into())
                })
                .collect::<Result<Vec<_>, RunError>>()?;
            tables.push(TableInMemory {
                file: table.file,
                schema,
                batches,
            });
        }
        Ok(tables)
    })
}

/// Conditions held at once so that their slots stay within [`MAX_SLOTS`], or the study's
/// error when one condition's do not fit (`instead` says what to do).
fn block_size(study: &Study, layout: &Layout, instead: &str) -> Result<usize, RunError> {
    let r = study.realisations();
    let per = usize::try_from(r)
        .ok()
        .and_then(|r| r.checked_mul(layout.realisation_stride()))
        .filter(|&n| n <= MAX_SLOTS)
        .ok_or_else(|| {
            RunError::Study(study.error_at(
                "realisations",
                format!(
                    "{r} realisations of one condition ({} numbers each) are more than the \
                     {MAX_SLOTS} numbers held in memory at once; {instead}",
                    layout.realisation_stride()
                ),
            ))
        })?;
    Ok((MAX_SLOTS / per).clamp(1, IN_MEMORY_BLOCK))
}

/// The summary of `model`'s realisations 0..R of every condition (R = the study's), computed
/// in memory and written nowhere: for callers that evaluate a study many times (`design`).
pub fn summarise_in_memory(study: &Study, model: &dyn Model) -> Result<Vec<SummaryRow>, RunError> {
    let layout = model.layout();
    let infos = model.infos();
    let block = block_size(study, layout, "use fewer")?;
    let mut out = Vec::new();
    // A block of conditions at a time: the slots held do not grow with the grid (each
    // realisation is a pure function of its seed, condition and index, so the blocks give
    // what one call over every condition gives).
    let all: Vec<usize> = (0..infos.len()).collect();
    for conditions in all.chunks(block) {
        let r = study.realisations();
        let slots =
            montecarlo::in_memory(model, study.seed(), conditions, 0..r, &montecarlo::Silent);
        summarise_block(layout, &infos, conditions, r, &slots, &mut out)?;
    }
    Ok(out)
}

/// Append to `out` the summary rows of `block`'s conditions from their `slots` (condition
/// major, realisations 0..r each, as [`montecarlo::in_memory`] holds them).
fn summarise_block(
    layout: &Layout,
    infos: &[ConditionInfo],
    block: &[usize],
    r: u64,
    slots: &[f64],
    out: &mut Vec<SummaryRow>,
) -> Result<(), RunError> {
    let inconsistent = |source: SummaryError| RunError::Summary {
        path: PathBuf::from("(in memory)"),
        source,
    };
    let stride = layout.realisation_stride();
    let p = layout.parameters.len();
    let bounds = layout.bounds.len() * p;
    // The filters' columns among the extras (None: the layout has none).
    let filter_extras = INPUTS.map(|name| layout.extras.iter().position(|x| x.name == name));
    let campaign_extra = layout.extras.iter().position(|x| x.name == CAMPAIGN_PASS);
    let records = |i: usize| {
        let s = &slots[i * stride..(i + 1) * stride];
        (0..layout.estimators.len()).map(move |e| Record {
            condition: block[i / r as usize],
            realisation: (i % r as usize) as u64,
            estimator: e,
            ok: s[layout.status_at(e)] == Status::Ok as u8 as f64,
            theta: &s[layout.theta_at(e, 0)..layout.theta_at(e, 0) + p],
            bounds: &s[layout.bound_at(e, 0, 0)..layout.bound_at(e, 0, 0) + bounds],
            controls: &s[layout.control_at(0)..layout.control_at(0) + layout.controls.len()],
            filter: filter_extras.map(|x| x.map_or(f64::NAN, |x| s[layout.extra_at(e, x)])),
            campaign: campaign_extra.map_or(f64::NAN, |x| s[layout.extra_at(e, x)]),
        })
    };
    for (k, &c) in block.iter().enumerate() {
        let mut summarizer = ConditionSummarizer::new(layout, c, &infos[c], r, Z_95);
        let rows = k * r as usize..(k + 1) * r as usize;
        for rec in rows.clone().flat_map(records) {
            summarizer.first_pass(&rec).map_err(inconsistent)?;
        }
        summarizer.end_first_pass().map_err(inconsistent)?;
        for rec in rows.flat_map(records) {
            summarizer.second_pass(&rec).map_err(inconsistent)?;
        }
        out.extend(summarizer.finish());
    }
    Ok(())
}
