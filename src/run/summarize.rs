//! Summaries from realisation files: of a run, or of every shard of a sharded run.

use std::fs;
use std::path::{Path, PathBuf};

use super::rows::ConditionRows;
use super::{
    RunError, RunReport, draw_figures, files, remove_temporaries, write_extra_tables, write_report,
    write_summary,
};
use crate::model::{self, ConditionInfo, Layout};
use crate::output::lock::DirLock;
use crate::output::{self, FileMetadata, OpenedFile, OutputError, keys, set, store};
use crate::stats::measures::Z_95;
use crate::stats::summary::{ConditionSummarizer, SummaryRow};
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
    summarize_into(inputs, out_dir, figures, false)
}

/// [`summarize`] that also assembles the realisation rows of `inputs` into `out_dir`'s
/// realisations.parquet, in order: the files one run of the study writes, byte for byte,
/// from its shards (the Python package's `summarize`).
pub fn summarize_assembled(
    inputs: &[PathBuf],
    out_dir: &Path,
    figures: bool,
) -> Result<RunReport, RunError> {
    summarize_into(inputs, out_dir, figures, true)
}

fn summarize_into(
    inputs: &[PathBuf],
    out_dir: &Path,
    figures: bool,
    assemble: bool,
) -> Result<RunReport, RunError> {
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
    let mut writes = super::written_beside(&*model, figures);
    if assemble {
        writes.push(files::REALISATIONS.to_string());
    }
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
    if assemble {
        pending.push(assembled(&opened, &layout, infos.len(), out_dir, &meta)?);
    }
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
        realisations: None,
        metadata: meta,
    })
}

/// The realisation rows of `opened` (every realisation of each of `conditions` exactly
/// once, as the summary has checked) in order, in `out_dir`'s realisations.parquet under
/// its temporary name: the rows rechunked as a run writes them.
fn assembled(
    opened: &[OpenedFile],
    layout: &Layout,
    conditions: usize,
    out_dir: &Path,
    meta: &FileMetadata,
) -> Result<output::PendingFile, RunError> {
    let mut sources = Vec::new();
    for file in opened {
        sources.extend(store::existing_file(file.path(), &meta.identity, &|_| {})?);
    }
    let segments = store::plan(&vec![0..meta.realisations; conditions], &sources);
    if let Some(missing) = segments.iter().find(|s| s.source.is_none()) {
        return Err(OutputError::format(
            opened.first().map_or(out_dir, |f| f.path()),
            format!(
                "condition {}'s realisations {}..{} are in none of the files",
                missing.condition, missing.range.start, missing.range.end
            ),
        )
        .into());
    }
    let sink = output::ParquetSink::create(
        out_dir,
        files::REALISATIONS,
        output::realisation_schema(layout),
        meta,
        "realisations",
    )?;
    Ok(store::Assembler::new(&sources, &segments, sink).finish()?)
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
