//! Summaries from realisation files: of a run, or of every shard of a sharded run.

use crate::estimate::campaign::CAMPAIGN_PASS;
use std::fs;
use std::path::{Path, PathBuf};

use super::rows::ConditionRows;
use super::{
    RunError, RunReport, draw_figures, files, remove_temporaries, write_extra_tables, write_report,
    write_summary,
};
use crate::model::{self, ConditionInfo, Layout, Model, Status};
use crate::montecarlo;
use crate::output::lock::DirLock;
use crate::output::{self, FileMetadata, OpenedFile, OutputError, keys, set};
use crate::stats::measures::Z_95;
use crate::stats::summary::filter::INPUTS;
use crate::stats::summary::{ConditionSummarizer, Record, SummaryError, SummaryRow};
use crate::study::{Study, StudyError};

/// The realisation files in `input` (the file itself, or in a directory its
/// `realisations.parquet` and every `shard=*/realisations.parquet`), each opened once and
/// checked through that handle against the checksum its directory's manifest records
/// ([`set::open_checked`]): a summary reads the footer and both passes from these handles,
/// so a run replacing a file meanwhile cannot mix two runs into it. A directory whose
/// output set is incomplete (an interrupted commit) or a file that does not match its
/// checksum is an error.
pub fn realisation_files(input: &Path) -> Result<Vec<OpenedFile>, OutputError> {
    if !input.exists() {
        return Err(OutputError::Missing {
            path: input.to_path_buf(),
        });
    }
    find_realisation_files(input)?
        .iter()
        .map(|path| set::open_checked(path))
        .collect()
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
    // A directory that exists is locked before it is read, so a run writing it is named.
    let early = match out_dir.is_dir() {
        true => Some(DirLock::acquire(out_dir)?),
        false => None,
    };
    let mut opened = Vec::new();
    for input in inputs {
        opened.extend(realisation_files(input)?);
    }
    let first = opened.first().ok_or_else(|| {
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
    // Each file's footer: the study, its identity and R (read once per file).
    let footer = |file: &OpenedFile| -> Result<(output::Footer, String, String, u64), RunError> {
        let path = file.path();
        let footer = file.footer()?;
        let get = |k: &str| footer.get(k).map(str::to_string);
        let missing = || {
            OutputError::format(
                path,
                "not a chassis-mc realisation file (footer metadata missing)",
            )
        };
        if let Some(table) = footer.get(keys::TABLE).filter(|&t| t != "realisations") {
            return Err(OutputError::format(
                path,
                format!("not a realisation file: its footer says it holds the {table} table"),
            )
            .into());
        }
        let study = get(keys::STUDY).ok_or_else(missing)?;
        let identity = get(keys::IDENTITY).ok_or_else(missing)?;
        let r = get(keys::REALISATIONS)
            .and_then(|v| v.parse().ok())
            .ok_or_else(missing)?;
        Ok((footer, study, identity, r))
    };
    let (first_footer, study_toml, identity, realisations) = footer(first)?;
    for file in &opened[1..] {
        let (this, _, other, r) = footer(file)?;
        if other != identity || r != realisations {
            return Err(OutputError::Mismatch {
                path: file.path().to_path_buf(),
                first: first.path().to_path_buf(),
                differences: differences(&this, &first_footer),
            }
            .into());
        }
    }
    let origin = format!("{} (footer)", first.path().display());
    let dir = output::footer_dir(&first_footer, first.path());
    let study = Study::from_toml_in(&study_toml, &origin, &dir)?;
    if let Some(fleet) = study.fleet() {
        // The fleet's table is read again: it must still hold the vehicles the
        // realisations were drawn for (their truths and ids come from it).
        let line = format!("# fleet {:016x}\n", fleet.fingerprint());
        if !identity.contains(&line) {
            return Err(RunError::Study(study.error_at(
                "fleet.file",
                format!(
                    "{} no longer holds the vehicles of this run (its rows or the filter changed \
                     since): the truths and ids would not be those the realisations were drawn \
                     for; restore the table, or run the study again",
                    fleet.file.display()
                ),
            )));
        }
    }
    let model = model::prepare(&study)?;
    // A user's file where the summary writes is refused before the passes over the rows
    // (again below, under the lock, for a directory that did not exist yet).
    let writes = super::written_beside(&*model, figures);
    if early.is_some() {
        set::ensure_complete(out_dir)?;
        set::ensure_owned(out_dir, &writes)?;
    }
    let layout = model.layout().clone();
    let infos = model.infos();
    let summary = summarise_files(&layout, &infos, realisations, &opened)?;
    let _lock = match early {
        Some(lock) => lock,
        None => DirLock::acquire(out_dir)?,
    };
    set::ensure_complete(out_dir)?;
    set::ensure_owned(out_dir, &writes)?;
    remove_temporaries(out_dir)?;
    let meta = FileMetadata {
        study_toml: study.to_toml(),
        study_dir: study.dir().display().to_string(),
        seed: study.seed(),
        realisations,
        identity,
        extra: Vec::new(),
    };
    let mut pending = write_summary(out_dir, &layout, &infos, &summary, &meta)?;
    pending.extend(write_extra_tables(&*model, out_dir, &meta)?);
    drop(model); // the figures and the report need only the layout and the conditions
    if figures {
        let figures = draw_figures(out_dir, &layout, &pending)?;
        pending.extend(figures);
    }
    let report = write_report(
        out_dir,
        "summarize",
        study.name(),
        &meta,
        (&layout, &infos, &summary),
        &pending,
    )?;
    pending.push(report);
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

/// What differs between the runs two realisation files' footers record, `this` against
/// `that`: the seed, the realisations per condition, the engine version, the study itself
/// (compared with seed and R set equal), or else the engine's arithmetic (same version,
/// another build).
pub(super) fn differences(this: &output::Footer, that: &output::Footer) -> Vec<String> {
    let mut found = Vec::new();
    for (key, what) in [
        (keys::SEED, "seed"),
        (keys::REALISATIONS, "realisations per condition"),
        (keys::VERSION, "engine version"),
    ] {
        let (a, b) = (this.get(key), that.get(key));
        if a != b {
            let show = |v: Option<&str>| v.unwrap_or("none").to_string();
            found.push(format!("{what} {} here, {} there", show(a), show(b)));
        }
    }
    // The studies, read back and compared without their seed and R.
    let normalised = |f: &output::Footer| {
        let text = f.get(keys::STUDY)?;
        let dir = PathBuf::from(f.get(keys::STUDY_DIR).unwrap_or_default());
        let study = Study::from_toml_in(text, "(footer)", &dir).ok()?;
        Some(study.with_overrides(Some(1), Some(0)).ok()?.to_toml())
    };
    let studies_differ = match (normalised(this), normalised(that)) {
        (Some(a), Some(b)) => a != b,
        // unreadable: compare the texts as written
        _ => this.get(keys::STUDY) != that.get(keys::STUDY) && found.is_empty(),
    };
    if studies_differ {
        found.push("the study (its vehicle, drive, terrain, noise or estimators)".into());
    }
    if found.is_empty() {
        found.push(
            "the engine's arithmetic (the same version, built differently: its check of \
             realisation 0 differs)"
                .into(),
        );
    }
    found
}

/// Summarise the realisation rows stored in `files` (any split of one study's rows, each
/// file sorted by condition as chassis-mc writes it).
///
/// Condition by condition: both passes over one condition's rows in every file, then its
/// summary rows, then the next; so the exact accumulators of one condition are held at a
/// time, and the memory does not grow with the number of conditions (nor with R).
pub fn summarise_files(
    layout: &Layout,
    infos: &[ConditionInfo],
    realisations: u64,
    files: &[OpenedFile],
) -> Result<Vec<SummaryRow>, RunError> {
    let mut first = Vec::with_capacity(files.len());
    let mut second = Vec::with_capacity(files.len());
    for file in files {
        let [a, b] = ConditionRows::open_pair(file, layout)?;
        first.push(a);
        second.push(b);
    }
    let mut out =
        Vec::with_capacity(infos.len() * layout.estimators.len() * layout.parameters.len());
    for (c, info) in infos.iter().enumerate() {
        let mut summarizer = ConditionSummarizer::new(layout, c, info, realisations, Z_95);
        for rows in &mut first {
            rows.each(c, &mut |r| summarizer.first_pass(r))?;
        }
        summarizer
            .end_first_pass()
            .map_err(|source| RunError::Summary {
                path: files
                    .first()
                    .map(|f| f.path().to_path_buf())
                    .unwrap_or_default(),
                source,
            })?;
        if c == 0 {
            output::pause("between-passes");
        }
        for rows in &mut second {
            rows.each(c, &mut |r| summarizer.second_pass(r))?;
        }
        out.extend(summarizer.finish());
    }
    first.into_iter().try_for_each(ConditionRows::finish)?;
    Ok(out)
}

/// The summary of `model`'s realisations 0..R of every condition (R = the study's), computed
/// in memory and written nowhere: for callers that evaluate a study many times (`design`).
pub fn summarise_in_memory(study: &Study, model: &dyn Model) -> Result<Vec<SummaryRow>, RunError> {
    let layout = model.layout();
    let infos = model.infos();
    let stride = layout.realisation_stride();
    let r = study.realisations();
    // Every slot of every realisation of a block of conditions is held at once: at most
    // 2^28 (2 GiB).
    let count = usize::try_from(r)
        .ok()
        .and_then(|r| r.checked_mul(infos.len().min(IN_MEMORY_BLOCK) * stride))
        .filter(|&n| n <= 1 << 28)
        .ok_or_else(|| {
            RunError::Study(study.error_at(
                "realisations",
                format!(
                    "{r} realisations of {} conditions do not fit in memory for an in-memory \
                     summary; use fewer",
                    infos.len()
                ),
            ))
        })?;
    let inconsistent = |source: SummaryError| RunError::Summary {
        path: PathBuf::from("(in memory)"),
        source,
    };
    debug_assert!(count <= 1 << 28);
    let p = layout.parameters.len();
    let bounds = layout.bounds.len() * p;
    let mut out = Vec::with_capacity(infos.len() * layout.estimators.len() * p);
    // A block of conditions at a time: the slots held do not grow with the grid (each
    // realisation is a pure function of its seed, condition and index, so the blocks give
    // what one call over every condition gives).
    let all: Vec<usize> = (0..infos.len()).collect();
    // The filters' columns among the extras (None: the layout has none).
    let filter_extras = INPUTS.map(|name| layout.extras.iter().position(|x| x.name == name));
    let campaign_extra = layout.extras.iter().position(|x| x.name == CAMPAIGN_PASS);
    for block in all.chunks(IN_MEMORY_BLOCK) {
        let slots = montecarlo::in_memory(model, study.seed(), block, 0..r, &montecarlo::Silent);
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
    }
    Ok(out)
}

/// Conditions an in-memory summary computes at once.
const IN_MEMORY_BLOCK: usize = 256;
