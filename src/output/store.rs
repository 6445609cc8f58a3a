//! Durable realisation storage: staged parts, resuming and extending, and assembling sources
//! into one sorted file.
//!
//! A run computes its realisations into *parts* in a staging directory: Parquet files of at
//! most [`PART_REALISATIONS`] realisations of one condition, each written under a temporary
//! name and renamed when complete to a name that records the checksum of its bytes. If the
//! run is killed, completed parts survive; a torn or corrupted part (a temporary file, or
//! one whose bytes do not match its checksum) is deleted and redone. A finished realisation
//! file is reused only if its bytes match the checksum of the directory's manifest
//! ([`super::set`]).
//! The final file is assembled in (condition, realisation) order: rows that already exist —
//! in parts, or in the realisation file of an earlier run of the same study — are copied,
//! computed rows are written as they arrive (or, when the conditions of a draw group are
//! computed together and their rows arrive interleaved, copied from their parts once all
//! are committed). Re-running with a larger R therefore computes only the new
//! realisations, and any interrupted run ends identical to an uninterrupted one: each
//! realisation is a pure function of (seed, condition, realisation).

use std::ops::Range;
use std::path::{Path, PathBuf};

use arrow::array::{Array, Int32Array, Int64Array, RecordBatch};
use parquet::arrow::arrow_reader::ParquetRecordBatchReader;

use super::{OutputError, ParquetSink, PendingFile, READ_ROWS, keys, read_metadata, set};

mod parts;

pub use parts::{
    PART_REALISATIONS, commit_part, ensure_staging, part_name, part_value, scan_parts,
};

/// A file holding realisation rows, sorted by (condition, realisation).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Source {
    /// The file.
    pub path: PathBuf,
    /// Per condition, the realisation ranges it holds.
    pub covers: Vec<(usize, Range<u64>)>,
}

/// Where the rows of one stretch of the output come from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Segment {
    /// Condition index.
    pub condition: usize,
    /// Realisations.
    pub range: Range<u64>,
    /// Index into the sources, or `None` when the rows must be computed.
    pub source: Option<usize>,
}

/// The realisation file of an earlier run at `path`, if it exists, belongs to the study
/// `identity` and its bytes match the checksum recorded when it was committed, with the
/// realisation ranges it holds. `notice` is told why a file of the study is not reused.
pub fn existing_file(
    path: &Path,
    identity: &str,
    notice: &dyn Fn(&str),
) -> Result<Option<Source>, OutputError> {
    if !path.exists() {
        return Ok(None);
    }
    let Ok(footer) = read_metadata(path) else {
        notice(&format!(
            "{}: unreadable; its realisations are computed again",
            path.display()
        ));
        return Ok(None);
    };
    if footer.get(keys::IDENTITY) != Some(identity) {
        return Ok(None);
    }
    let (dir, name) = (
        path.parent().unwrap_or(Path::new(".")),
        path.file_name()
            .map(|n| n.to_string_lossy())
            .unwrap_or_default(),
    );
    if let Some(why) = set::verify_file(dir, &name)? {
        notice(&format!(
            "{}: not reused because {why}; its realisations are computed again",
            path.display()
        ));
        return Ok(None);
    }
    Ok(Some(Source {
        path: path.to_path_buf(),
        covers: covered_ranges(path)?,
    }))
}

/// Contiguous realisation ranges per condition of a sorted realisation file (reads only
/// the two index columns).
fn covered_ranges(path: &Path) -> Result<Vec<(usize, Range<u64>)>, OutputError> {
    let mut out: Vec<(usize, Range<u64>)> = Vec::new();
    let mut reader = index_reader(path)?;
    for batch in &mut reader {
        let batch = batch.map_err(|e| OutputError::arrow(path, e))?;
        let (cond, real) = index_columns(&batch, path)?;
        for i in 0..batch.num_rows() {
            let (c, r) = (cond.value(i) as usize, real.value(i) as u64);
            match out.last_mut() {
                Some((lc, range)) if *lc == c && range.end == r + 1 => {}
                Some((lc, range)) if *lc == c && range.end == r => range.end = r + 1,
                _ => out.push((c, r..r + 1)),
            }
        }
    }
    Ok(out)
}

fn index_reader(path: &Path) -> Result<ParquetRecordBatchReader, OutputError> {
    super::open_projected_reader(path, READ_ROWS, Some(&["condition", "realisation"]))
}

fn index_columns<'a>(
    batch: &'a RecordBatch,
    path: &Path,
) -> Result<(&'a Int32Array, &'a Int64Array), OutputError> {
    let cond = batch
        .column_by_name("condition")
        .and_then(|c| c.as_any().downcast_ref::<Int32Array>())
        .ok_or_else(|| OutputError::format(path, "no int32 column `condition`"))?;
    let real = batch
        .column_by_name("realisation")
        .and_then(|c| c.as_any().downcast_ref::<Int64Array>())
        .ok_or_else(|| OutputError::format(path, "no int64 column `realisation`"))?;
    Ok((cond, real))
}

/// Assign every needed realisation to a source, or to computation.
///
/// `needed[c]` is the range condition c must have. Where sources overlap, the one reaching
/// furthest is used, so each realisation comes from exactly one place.
pub fn plan(needed: &[Range<u64>], sources: &[Source]) -> Vec<Segment> {
    let mut segments = Vec::new();
    for (c, need) in needed.iter().enumerate() {
        let mut at = need.start;
        while at < need.end {
            let best = sources
                .iter()
                .enumerate()
                .flat_map(|(i, s)| s.covers.iter().map(move |(sc, r)| (i, *sc, r)))
                .filter(|(_, sc, r)| *sc == c && r.start <= at && at < r.end)
                .max_by_key(|(i, _, r)| (r.end, std::cmp::Reverse(*i)));
            match best {
                Some((i, _, r)) => {
                    let end = r.end.min(need.end);
                    segments.push(Segment {
                        condition: c,
                        range: at..end,
                        source: Some(i),
                    });
                    at = end;
                }
                None => {
                    let next = sources
                        .iter()
                        .flat_map(|s| s.covers.iter())
                        .filter(|(sc, r)| *sc == c && r.start > at)
                        .map(|(_, r)| r.start)
                        .min()
                        .unwrap_or(need.end)
                        .min(need.end);
                    segments.push(Segment {
                        condition: c,
                        range: at..next,
                        source: None,
                    });
                    at = next;
                }
            }
        }
    }
    segments
}

/// Reads a sorted realisation file forward, handing out the rows of requested ranges.
struct Cursor {
    path: PathBuf,
    reader: ParquetRecordBatchReader,
    batch: Option<RecordBatch>,
    row: usize,
}

impl Cursor {
    fn open(path: &Path) -> Result<Self, OutputError> {
        Ok(Cursor {
            path: path.to_path_buf(),
            reader: super::open_reader(path, READ_ROWS)?,
            batch: None,
            row: 0,
        })
    }

    /// Key (condition, realisation) of the current row, loading batches as needed; `None`
    /// at the end of the file.
    fn key(&mut self) -> Result<Option<(usize, u64)>, OutputError> {
        loop {
            if let Some(batch) = &self.batch
                && self.row < batch.num_rows()
            {
                let (cond, real) = index_columns(batch, &self.path)?;
                return Ok(Some((
                    cond.value(self.row) as usize,
                    real.value(self.row) as u64,
                )));
            }
            match self.reader.next() {
                Some(batch) => {
                    self.batch = Some(batch.map_err(|e| OutputError::arrow(&self.path, e))?);
                    self.row = 0;
                }
                None => return Ok(None),
            }
        }
    }

    /// Pass the rows of `condition` with realisations in `range` to `sink`, skipping rows
    /// before them. Rows of one realisation are adjacent, so whole realisations move.
    fn copy(
        &mut self,
        condition: usize,
        range: &Range<u64>,
        sink: &mut dyn FnMut(&RecordBatch) -> Result<(), OutputError>,
    ) -> Result<u64, OutputError> {
        let start = (condition, range.start);
        let end = (condition, range.end);
        let mut rows = 0;
        while let Some(key) = self.key()? {
            if key >= end {
                break;
            }
            let batch = self.batch.clone().expect("a batch is loaded");
            let (cond, real) = index_columns(&batch, &self.path)?;
            let key_at = |i: usize| (cond.value(i) as usize, real.value(i) as u64);
            // the run of rows from here that fall in one class (before / inside the range)
            let inside = key >= start;
            let mut stop = self.row;
            while stop < batch.num_rows() && {
                let k = key_at(stop);
                k < end && (k >= start) == inside
            } {
                stop += 1;
            }
            if inside {
                sink(&batch.slice(self.row, stop - self.row))?;
                rows += (stop - self.row) as u64;
            }
            self.row = stop;
        }
        Ok(rows)
    }
}

/// Rows per batch the assembler hands the Parquet writer: every batch but the last has
/// exactly this many rows, and it divides [`super::ROW_GROUP_ROWS`], so row groups and
/// pages fall at the same rows whatever sizes the copied and computed pieces had.
pub const WRITE_ROWS: usize = 8192;

/// Writes the realisation file in plan order: the rows of segments with a source are
/// copied from it, computed rows are written as they arrive (in plan order too). The rows
/// reach the writer in batches of exactly [`WRITE_ROWS`] (re-cut from whatever arrived), so
/// the file's bytes — its row groups of [`super::ROW_GROUP_ROWS`] rows across conditions,
/// and their pages — do not depend on which rows were copied and which computed. Row groups
/// span conditions: the footer's metadata grows with the rows, not with the conditions.
pub struct Assembler<'a> {
    sources: &'a [Source],
    segments: &'a [Segment],
    cursors: Vec<Option<Cursor>>,
    /// Per source, the index of the last segment it serves: its reader (and the row group
    /// it buffers) is dropped after it, so memory stays bounded however many parts there are.
    last_use: Vec<usize>,
    /// The first segment not yet written or passed.
    next: usize,
    /// Rows received and not yet written (fewer than [`WRITE_ROWS`]).
    pending: Vec<RecordBatch>,
    pending_rows: usize,
    out: ParquetSink,
}

/// Hand `batch` to `out` through `pending`, in batches of exactly [`WRITE_ROWS`].
fn rechunked(
    out: &mut ParquetSink,
    pending: &mut Vec<RecordBatch>,
    pending_rows: &mut usize,
    batch: &RecordBatch,
) -> Result<(), OutputError> {
    let mut rest = batch.clone();
    while *pending_rows + rest.num_rows() >= WRITE_ROWS {
        let take = WRITE_ROWS - *pending_rows;
        pending.push(rest.slice(0, take));
        rest = rest.slice(take, rest.num_rows() - take);
        write_pending(out, pending)?;
        *pending_rows = 0;
    }
    if rest.num_rows() > 0 {
        *pending_rows += rest.num_rows();
        pending.push(rest);
    }
    Ok(())
}

/// Write the batches of `pending` to `out` as one batch, and empty it.
fn write_pending(out: &mut ParquetSink, pending: &mut Vec<RecordBatch>) -> Result<(), OutputError> {
    let Some(first) = pending.first() else {
        return Ok(());
    };
    let batch = arrow::compute::concat_batches(&first.schema(), pending.iter())
        .map_err(|e| OutputError::arrow(out.path(), e))?;
    pending.clear();
    out.write(&batch)
}

impl<'a> Assembler<'a> {
    /// Assemble `segments` (from [`plan`] over `sources`) into `out`.
    pub fn new(sources: &'a [Source], segments: &'a [Segment], out: ParquetSink) -> Self {
        let mut last_use = vec![0; sources.len()];
        for (k, seg) in segments.iter().enumerate() {
            if let Some(i) = seg.source {
                last_use[i] = k;
            }
        }
        Assembler {
            sources,
            segments,
            cursors: sources.iter().map(|_| None).collect(),
            last_use,
            next: 0,
            pending: Vec::new(),
            pending_rows: 0,
            out,
        }
    }

    /// Write computed rows of `condition`, the first of them of realisation `first`, after
    /// copying every sourced segment that precedes them.
    pub fn computed(
        &mut self,
        condition: usize,
        first: u64,
        batch: &RecordBatch,
    ) -> Result<(), OutputError> {
        self.copy_before((condition, first))?;
        rechunked(
            &mut self.out,
            &mut self.pending,
            &mut self.pending_rows,
            batch,
        )
    }

    /// Copy the remaining sourced segments, write the last rows and the footer.
    pub fn finish(mut self) -> Result<PendingFile, OutputError> {
        self.copy_before((usize::MAX, u64::MAX))?;
        write_pending(&mut self.out, &mut self.pending)?;
        self.out.finish()
    }

    /// Copy the sourced segments that start before `key` (condition, realisation), and
    /// pass over the computed ones.
    fn copy_before(&mut self, key: (usize, u64)) -> Result<(), OutputError> {
        while let Some(seg) = self.segments.get(self.next)
            && (seg.condition, seg.range.start) < key
        {
            let k = self.next;
            self.next += 1;
            let Some(i) = seg.source else { continue };
            let cursor = match &mut self.cursors[i] {
                Some(cursor) => cursor,
                slot => slot.insert(Cursor::open(&self.sources[i].path)?),
            };
            let (out, pending, pending_rows) =
                (&mut self.out, &mut self.pending, &mut self.pending_rows);
            cursor.copy(seg.condition, &seg.range, &mut |batch| {
                rechunked(out, pending, pending_rows, batch)
            })?;
            if self.last_use[i] == k {
                self.cursors[i] = None;
            }
        }
        Ok(())
    }
}
