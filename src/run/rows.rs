//! Reading realisation files condition by condition, so that a summary holds the
//! accumulators of one condition at a time, however many conditions the study has.
//!
//! chassis-mc writes a realisation file (and each shard's) sorted by (condition,
//! realisation). A [`ConditionRows`] reads one file forward and hands out the rows of one
//! condition at a time; the summary keeps two per file — one for each pass — the second a
//! condition behind the first, so every file is read twice in order, as a whole-file
//! summary would read it, and only one batch per reader is in memory.

use std::fs::File;
use std::path::Path;

use parquet::arrow::ProjectionMask;
use parquet::arrow::arrow_reader::{
    ArrowReaderMetadata, ArrowReaderOptions, ParquetRecordBatchReader,
    ParquetRecordBatchReaderBuilder,
};

use super::RunError;
use crate::model::Layout;
use crate::output::{OpenedFile, OutputError, RealisationBatches};
use crate::stats::summary::{Record, SummaryError};

/// Rows per batch read for the summary. Two readers per file are open at once; a batch of
/// the vehicle model's rows decodes to about 2 MB.
const BATCH_ROWS: usize = 8192;

/// A forward reader of one sorted realisation file, condition by condition.
pub(super) struct ConditionRows<'a> {
    path: &'a Path,
    layout: &'a Layout,
    reader: ParquetRecordBatchReader,
    batch: Option<RealisationBatches>,
    /// The next row of `batch` to hand out.
    at: usize,
    /// The condition of the last row decoded: a file's rows never go back to an earlier one.
    last: Option<usize>,
}

impl<'a> ConditionRows<'a> {
    /// Two readers of the open `file` (one per pass of the summary) sharing its footer,
    /// reading the columns the summary needs. Both read through the one handle (each read
    /// seeks first), so a file replaced at its path meanwhile is not seen.
    pub(super) fn open_pair(
        opened: &'a OpenedFile,
        layout: &'a Layout,
    ) -> Result<[Self; 2], RunError> {
        let path = opened.path();
        let file = opened.handle()?;
        let metadata = ArrowReaderMetadata::load(&file, ArrowReaderOptions::default())
            .map_err(|e| OutputError::parquet(path, e))?;
        let columns = RealisationBatches::columns(layout);
        let schema = metadata.metadata().file_metadata().schema_descr();
        let leaves: Vec<usize> = (0..schema.num_columns())
            .filter(|&i| columns.iter().any(|c| c == schema.column(i).name()))
            .collect();
        let mask = ProjectionMask::leaves(schema, leaves);
        let reader = |file: File| -> Result<Self, RunError> {
            let reader = ParquetRecordBatchReaderBuilder::new_with_metadata(file, metadata.clone())
                .with_projection(mask.clone())
                .with_batch_size(BATCH_ROWS)
                .build()
                .map_err(|e| OutputError::parquet(path, e))?;
            Ok(ConditionRows {
                path,
                layout,
                reader,
                batch: None,
                at: 0,
                last: None,
            })
        };
        let second = file.try_clone().map_err(|e| OutputError::io(path, e))?;
        Ok([reader(file)?, reader(second)?])
    }

    fn error(&self, source: SummaryError) -> RunError {
        RunError::Summary {
            path: self.path.to_path_buf(),
            source,
        }
    }

    /// The condition of the next row, decoding the next batch when needed; `None` at the
    /// end of the file.
    fn peek(&mut self) -> Result<Option<usize>, RunError> {
        loop {
            if let Some(batch) = &self.batch
                && self.at < batch.len()
            {
                return Ok(Some(batch.record(self.at).condition));
            }
            let Some(next) = self.reader.next() else {
                self.batch = None;
                return Ok(None);
            };
            let next = next.map_err(|e| OutputError::arrow(self.path, e))?;
            let rows = RealisationBatches::decode(self.layout, &next, self.path)?;
            for record in rows.records() {
                if let Some(after) = self.last
                    && record.condition < after
                {
                    return Err(self.error(SummaryError::Unsorted {
                        condition: record.condition,
                        after,
                    }));
                }
                self.last = Some(record.condition);
            }
            self.batch = Some(rows);
            self.at = 0;
        }
    }

    /// Hand every row of `condition` at the front of the file to `add`, stopping before the
    /// first row of a later condition.
    pub(super) fn each(
        &mut self,
        condition: usize,
        add: &mut dyn FnMut(&Record<'_>) -> Result<(), SummaryError>,
    ) -> Result<(), RunError> {
        while self.peek()? == Some(condition) {
            let batch = self.batch.as_ref().expect("peek loaded a batch");
            while self.at < batch.len() {
                let record = batch.record(self.at);
                if record.condition != condition {
                    break;
                }
                add(&record).map_err(|source| RunError::Summary {
                    path: self.path.to_path_buf(),
                    source,
                })?;
                self.at += 1;
            }
        }
        Ok(())
    }

    /// Check that no row is left once every condition of the study has been read: a row
    /// left refers to a condition the study does not have.
    pub(super) fn finish(mut self) -> Result<(), RunError> {
        match self.peek()? {
            None => Ok(()),
            Some(_) => {
                let record = self
                    .batch
                    .as_ref()
                    .expect("peek loaded a batch")
                    .record(self.at);
                Err(self.error(SummaryError::UnknownRow {
                    condition: record.condition,
                    estimator: record.estimator,
                }))
            }
        }
    }
}
