//! The Monte Carlo executor: runs realisations of a [`Model`] on rayon and hands them, in
//! index order, to a sink.
//!
//! Each realisation is a pure function of (seed, condition, realisation) — its random
//! streams are keyed by those integers — so the slots computed here are bit-identical
//! whatever the thread count. Work is done in chunks of realisations: the chunk is computed
//! in parallel into one flat buffer (no allocation per realisation), then passed whole to
//! the sink on the calling thread. Memory is bounded by the chunk size, not by R.

use std::ops::Range;

use rayon::prelude::*;

use crate::model::Model;

/// Realisations computed per chunk (one Arrow batch per chunk).
pub const DEFAULT_CHUNK: u64 = 1024;

/// A contiguous range of realisations of one condition.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Work {
    /// Condition index.
    pub condition: usize,
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
}

/// An observer that does nothing.
#[derive(Debug, Default, Clone, Copy)]
pub struct Silent;

impl Observer for Silent {}

/// Run every item of `work` in order, chunk by chunk, and pass each chunk to `sink`.
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
    // (condition, first realisation, count, the item's realisations) of every chunk, in order
    let plan = work.flat_map(|item| {
        let Work {
            condition,
            realisations,
        } = item;
        (realisations.start..realisations.end)
            .step_by(usize::try_from(chunk).unwrap_or(usize::MAX))
            .map(move |first| {
                let len = chunk.min(realisations.end - first);
                (condition, first, len, realisations.clone())
            })
    });
    let compute = |(condition, first, len): (usize, u64, u64), buffer: &mut Vec<f64>| {
        buffer.clear();
        buffer.resize(len as usize * stride, f64::NAN);
        buffer
            .par_chunks_mut(stride)
            .enumerate()
            .for_each(|(i, slots)| model.realise(seed, condition, first + i as u64, slots));
        observer.realisations_done(len);
    };
    let mut current: Vec<f64> = Vec::new();
    let mut previous: Vec<f64> = Vec::new();
    // the computed chunk waiting in `previous`: (condition, first, item)
    let mut done: Option<(usize, u64, Range<u64>)> = None;
    for (condition, first, len, item) in plan {
        let waiting = done.take().map(|(condition, first, item)| Chunk {
            condition,
            first,
            item,
            slots: &previous,
        });
        let (_, written) = rayon::join(
            || compute((condition, first, len), &mut current),
            || waiting.map_or(Ok(()), &mut sink),
        );
        written?;
        std::mem::swap(&mut current, &mut previous);
        done = Some((condition, first, item));
    }
    if let Some((condition, first, item)) = done {
        sink(Chunk {
            condition,
            first,
            item,
            slots: &previous,
        })?;
    }
    Ok(())
}
