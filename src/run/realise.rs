//! Computing the realisations a run needs (reusing what earlier runs left) and assembling
//! them, in order, into the realisation file.

use std::collections::{BTreeMap, HashMap};
use std::ops::Range;
use std::path::Path;

use super::{RunError, RunOptions, STAGING, files};
use crate::model::{ConditionInfo, Model};
use crate::montecarlo::{self, Observer, Work};
use crate::output::{self, FileMetadata, Kept, OutputError, ParquetSink, PendingFile, keys, store};
use crate::study::Study;

/// What makes realisations of two runs interchangeable: the study without its realisation
/// count and the engine version ([`Study::identity`]), plus a check of this build's
/// numbers — a hash of every condition's metrics and of realisation 0 of condition 0 — so
/// that a rebuilt engine whose arithmetic changed never reuses an older run's parts.
pub(super) fn identity(study: &Study, model: &dyn Model, infos: &[ConditionInfo]) -> String {
    let mut canary = vec![0.0; model.layout().realisation_stride()];
    model.realise(study.seed(), 0, 0, &mut canary);
    let metrics = infos.iter().flat_map(|i| i.metrics.iter().copied());
    let mut fnv = crate::numeric::hash::Fnv1a::default();
    for v in canary.into_iter().chain(metrics) {
        fnv.eat(&v.to_bits().to_le_bytes());
    }
    let hash = fnv.finish();
    format!("{}# numbers {hash:016x}\n", study.identity())
}

/// Make every needed realisation exist and assemble them, in order, into the realisation
/// file (still under its temporary name). Returns it with the counts reused and computed,
/// and with [`RunOptions::keep_realisations`] its rows as written.
pub(super) fn realise(
    study: &Study,
    model: &dyn Model,
    infos: &[ConditionInfo],
    options: &RunOptions,
    observer: &dyn Observer,
    dir: &Path,
    meta: &FileMetadata,
) -> Result<(PendingFile, u64, u64, Option<Kept>), RunError> {
    let staging = dir.join(STAGING);
    let layout = model.layout();
    let schema = output::realisation_schema(layout);
    let range = options
        .shard
        .map_or(0..study.realisations(), |s| s.range(study.realisations()));
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
    if computed < total {
        observer.notice(&format!(
            "resuming: {} of {total} realisations kept from an earlier run; computing {computed}",
            total - computed
        ));
    }

    // 2. Compute what is missing into staged parts, each renamed into place when complete
    //    (so a killed run resumes). The missing ranges of the conditions of one draw group
    //    are computed together (one draw per realisation serves the group). Without such
    //    groups the final file is assembled as the rows arrive, which keeps the executor's
    //    compute/write pipeline full; with them the rows of a group's conditions arrive
    //    interleaved, and the file is assembled from the parts afterwards. The parts are
    //    planned lazily, so the plan's memory does not grow with R.
    let mut groups: Vec<(usize, Range<u64>, Vec<usize>)> = Vec::new();
    let mut group_of: HashMap<(usize, u64, u64), usize> = HashMap::new();
    for seg in segments.iter().filter(|s| s.source.is_none()) {
        let key = (
            model.draw_group(seg.condition),
            seg.range.start,
            seg.range.end,
        );
        match group_of.get(&key) {
            Some(&i) => groups[i].2.push(seg.condition),
            None => {
                group_of.insert(key, groups.len());
                groups.push((key.0, seg.range.clone(), vec![seg.condition]));
            }
        }
    }
    let streaming = groups
        .iter()
        .all(|(_, _, conditions)| conditions.len() == 1);
    let mut pieces = groups.iter().flat_map(|(_, range, conditions)| {
        let step = usize::try_from(store::PART_REALISATIONS).unwrap_or(usize::MAX);
        (range.start..range.end)
            .step_by(step)
            .map(move |start| Work {
                conditions: conditions.clone(),
                realisations: start..(start + store::PART_REALISATIONS).min(range.end),
            })
    });
    let file_meta = match options.shard {
        Some(shard) => meta.with(keys::SHARD, shard.to_string()),
        None => meta.clone(),
    };
    let kept: Option<Kept> = options.keep_realisations.then(Kept::default);
    let create = || {
        ParquetSink::create(
            dir,
            files::REALISATIONS,
            schema.clone(),
            &file_meta,
            "realisations",
        )
        .map(|sink| match &kept {
            Some(kept) => sink.keeping(kept.clone()),
            None => sink,
        })
    };
    let mut assembler = match streaming {
        true => Some(store::Assembler::new(&sources, &segments, create()?)),
        false => None,
    };
    // the open part of each condition being computed, and the parts committed
    let mut parts: BTreeMap<usize, ParquetSink> = BTreeMap::new();
    let mut committed: Vec<store::Source> = Vec::new();
    montecarlo::execute(
        model,
        study.seed(),
        &mut pieces,
        options.chunk,
        observer,
        |chunk| {
            if chunk.first == chunk.item.start {
                let part_meta =
                    meta.with(keys::PART, store::part_value(chunk.condition, &chunk.item));
                let part = ParquetSink::create(
                    &staging,
                    &store::part_name(chunk.condition, chunk.item.start, 0),
                    schema.clone(),
                    &part_meta,
                    "realisations",
                )?;
                parts.insert(chunk.condition, part);
            }
            let batch =
                output::realisations_batch(layout, &schema, &infos[chunk.condition], &chunk)
                    .map_err(|e| OutputError::arrow(&staging, e))?;
            let part = parts.get_mut(&chunk.condition).expect("a part is open");
            part.write(&batch)?;
            if !streaming {
                // A group keeps one part per condition open: a row group per chunk bounds
                // what each of them buffers.
                part.flush()?;
            }
            if let Some(assembler) = assembler.as_mut() {
                assembler.computed(chunk.condition, chunk.first, &batch)?;
            }
            let rows = (chunk.slots.len() / layout.realisation_stride()) as u64;
            if chunk.first + rows == chunk.item.end {
                let done = parts.remove(&chunk.condition).expect("a part is open");
                let path = store::commit_part(done.finish()?, chunk.condition, chunk.item.start)?;
                committed.push(store::Source {
                    path,
                    covers: vec![(chunk.condition, chunk.item.clone())],
                });
                output::failpoint("part-committed");
            }
            if observer.stop_requested() {
                return Err(RunError::Interrupted {
                    parts: staging.clone(),
                });
            }
            Ok::<(), RunError>(())
        },
    )?;
    if let Some(assembler) = assembler {
        return Ok((assembler.finish()?, total - computed, computed, kept));
    }
    // 3. With draw groups: every needed row now exists in a part or the earlier file. (Were
    //    one missing, the summary's completeness check would name the condition.)
    sources.extend(committed);
    let segments = store::plan(&needed, &sources);
    debug_assert!(
        segments.iter().all(|s| s.source.is_some()),
        "every computed row is in a committed part"
    );
    let assembler = store::Assembler::new(&sources, &segments, create()?);
    Ok((assembler.finish()?, total - computed, computed, kept))
}
