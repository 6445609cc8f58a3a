//! The Monte Carlo executor: runs realisations of a [`Model`] on rayon and hands them, in
//! index order, to a sink.
//!
//! Each realisation is a pure function of (seed, condition, realisation) — its random
//! streams are keyed by those integers (by the condition's draw group instead, when
//! conditions share draws) — so the slots computed here are bit-identical whatever the
//! thread count. Work is done in chunks of realisations: the chunk is computed in parallel,
//! a few realisations per task side by side (and every condition of a draw group from one
//! draw), into one flat buffer (no allocation per realisation), then passed to the sink on
//! the calling thread. Memory is bounded by the chunk size, not by R.

use std::collections::BTreeMap;
use std::ops::Range;

use rayon::prelude::*;

use crate::model::{Model, SINGLE_BATCH};

/// Realisations computed per chunk (one Arrow batch per chunk).
pub const DEFAULT_CHUNK: u64 = 1024;

/// Realisations of a draw group computed together by one task (at most), so that each block
/// of every condition's data is read once for all of them (from cache) rather than once each.
const GROUP_BATCH: usize = 32;

/// A contiguous range of realisations of one condition, or of several conditions of one
/// draw group ([`Model::draw_group`]) computed together from one draw per realisation.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Work {
    /// Condition indices, in the order their chunks reach the sink.
    pub conditions: Vec<usize>,
    /// Realisation indices.
    pub realisations: Range<u64>,
}

/// A computed chunk: realisations `first..first + len` of `condition`.
#[derive(Debug)]
pub struct Chunk<'a> {
    /// Condition index.
    pub condition: usize,
    /// Index of the first realisation in the chunk.
    pub first: u64,
    /// The realisations of the [`Work`] item the chunk belongs to.
    pub item: Range<u64>,
    /// The slots of every realisation, `Layout::realisation_stride` each.
    pub slots: &'a [f64],
}

/// Watches a run; every method has a no-op default (e.g. a progress bar implements it).
pub trait Observer: Sync {
    /// The run needs `total` realisations (all conditions), `done` of which exist already
    /// (kept from an interrupted or smaller run).
    fn planned(&self, _total: u64, _done: u64) {}

    /// `count` more realisations are done.
    fn realisations_done(&self, _count: u64) {}

    /// Something the user should know that is not an error (e.g. a corrupted part that is
    /// being recomputed). A command-line observer prints it on stderr.
    fn notice(&self, _message: &str) {}

    /// Whether the caller asks the run to stop (e.g. Ctrl-C in Python). A run asks after
    /// each chunk it has written and stops with `RunError::Interrupted`; its
    /// completed parts stay, so running it again resumes. The executor itself never asks.
    fn stop_requested(&self) -> bool {
        false
    }
}

/// An observer that does nothing.
#[derive(Debug, Default, Clone, Copy)]
pub struct Silent;

impl Observer for Silent {}

/// Run every item of `work` in order, chunk by chunk, and pass each chunk to `sink`: per
/// chunk of realisations, one [`Chunk`] for each of the item's conditions, in its order.
///
/// `work` is consumed lazily, one chunk ahead of the sink, so the plan of a run never
/// occupies memory in proportion to its realisations.
/// Parallelism comes from the ambient rayon pool (use `ThreadPool::install` to choose it).
/// While a chunk is computed, the previous one is handed to the sink on another task, so
/// writing overlaps computing; the sink still sees every chunk, in order.
pub fn execute<M, E>(
    model: &M,
    seed: u64,
    work: impl Iterator<Item = Work>,
    chunk: u64,
    observer: &dyn Observer,
    mut sink: impl FnMut(Chunk<'_>) -> Result<(), E> + Send,
) -> Result<(), E>
where
    M: Model + ?Sized,
    E: Send,
{
    let stride = model.layout().realisation_stride();
    let chunk = chunk.max(1);
    // (first realisation, count, the item) of every chunk, in order
    let plan = work.flat_map(|item| {
        let realisations = item.realisations.clone();
        (realisations.start..realisations.end)
            .step_by(usize::try_from(chunk).unwrap_or(usize::MAX))
            .map(move |first| (first, chunk.min(realisations.end - first), item.clone()))
    });
    // The chunk's slots, realisation-major: realisation i of the item's k-th condition at
    // (i · conditions + k) · stride.
    let compute = |first: u64, len: u64, conditions: &[usize], buffer: &mut Vec<f64>| {
        let width = conditions.len() * stride;
        buffer.clear();
        buffer.resize(len as usize * width, f64::NAN);
        // At most the batch size, and at least four tasks per thread so none waits (batching
        // never changes a realisation's bits).
        let most = if conditions.len() == 1 {
            SINGLE_BATCH
        } else {
            GROUP_BATCH
        };
        let batch = (len as usize / (4 * rayon::current_num_threads())).clamp(1, most);
        buffer
            .par_chunks_mut(width * batch)
            .enumerate()
            .for_each(|(i, slots)| {
                let from = first + (i * batch) as u64;
                model.realise_group(seed, conditions, from, slots.len() / width, slots)
            });
        observer.realisations_done(len * conditions.len() as u64);
    };
    // One condition's realisations out of a chunk computed for several.
    let mut gathered: Vec<f64> = Vec::new();
    let mut hand_over = |first: u64, item: &Work, slots: &[f64]| -> Result<(), E> {
        let [condition] = item.conditions[..] else {
            let width = item.conditions.len() * stride;
            for (k, &condition) in item.conditions.iter().enumerate() {
                gathered.clear();
                for row in slots.chunks_exact(width) {
                    gathered.extend_from_slice(&row[k * stride..(k + 1) * stride]);
                }
                sink(Chunk {
                    condition,
                    first,
                    item: item.realisations.clone(),
                    slots: &gathered,
                })?;
            }
            return Ok(());
        };
        sink(Chunk {
            condition,
            first,
            item: item.realisations.clone(),
            slots,
        })
    };
    let mut current: Vec<f64> = Vec::new();
    let mut previous: Vec<f64> = Vec::new();
    // the computed chunk waiting in `previous`: (first, item)
    let mut done: Option<(u64, Work)> = None;
    for (first, len, item) in plan {
        let waiting = done.take();
        let (_, written) = rayon::join(
            || compute(first, len, &item.conditions, &mut current),
            || {
                waiting
                    .as_ref()
                    .map_or(Ok(()), |(first, item)| hand_over(*first, item, &previous))
            },
        );
        written?;
        std::mem::swap(&mut current, &mut previous);
        done = Some((first, item));
    }
    if let Some((first, item)) = done {
        hand_over(first, &item, &previous)?;
    }
    Ok(())
}

/// Realisations `realisations` of each of `conditions` (distinct), computed by [`execute`]
/// (the conditions of a draw group together, as a run computes them) and held in memory:
/// for callers that need every slot at once and write no file (the in-memory summary of
/// `design` and `check`, the bootstrap of `fit`). Condition-major: realisation
/// `realisations.start + i` of `conditions[k]` at `(k · R + i) · stride`, R the range's
/// length; bit for bit the slots a run writes.
pub fn in_memory<M>(
    model: &M,
    seed: u64,
    conditions: &[usize],
    realisations: Range<u64>,
    observer: &dyn Observer,
) -> Vec<f64>
where
    M: Model + ?Sized,
{
    held(model, seed, conditions, realisations, observer, false)
        .expect("a run that is never stopped completes")
}

/// [`in_memory`] that stops after the chunk in progress when the observer asks
/// ([`Observer::stop_requested`]): `None` then.
pub fn in_memory_until_stopped<M>(
    model: &M,
    seed: u64,
    conditions: &[usize],
    realisations: Range<u64>,
    observer: &dyn Observer,
) -> Option<Vec<f64>>
where
    M: Model + ?Sized,
{
    held(model, seed, conditions, realisations, observer, true)
}

/// Asked to stop.
struct Stopped;

fn held<M>(
    model: &M,
    seed: u64,
    conditions: &[usize],
    realisations: Range<u64>,
    observer: &dyn Observer,
    stoppable: bool,
) -> Option<Vec<f64>>
where
    M: Model + ?Sized,
{
    let stride = model.layout().realisation_stride();
    let r = usize::try_from(realisations.end - realisations.start).expect("fits in memory");
    let mut slots = vec![f64::NAN; conditions.len() * r * stride];
    let mut groups: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    let mut position: BTreeMap<usize, usize> = BTreeMap::new();
    for (k, &c) in conditions.iter().enumerate() {
        groups.entry(model.draw_group(c)).or_default().push(c);
        let earlier = position.insert(c, k);
        debug_assert!(earlier.is_none(), "condition {c} listed twice");
    }
    let work = groups.into_values().map(|conditions| Work {
        conditions,
        realisations: realisations.clone(),
    });
    let start = realisations.start;
    let stored = execute(model, seed, work, DEFAULT_CHUNK, observer, |chunk| {
        let at = (position[&chunk.condition] * r + (chunk.first - start) as usize) * stride;
        slots[at..at + chunk.slots.len()].copy_from_slice(chunk.slots);
        match stoppable && observer.stop_requested() {
            true => Err(Stopped),
            false => Ok(()),
        }
    });
    stored.ok().map(|()| slots)
}
