//! Reading the engine's Parquet files: one open handle per file ([`OpenedFile`]), its footer.

use std::fs::{self, File};
use std::path::{Path, PathBuf};

use parquet::arrow::arrow_reader::{ParquetRecordBatchReader, ParquetRecordBatchReaderBuilder};

use super::{OutputError, keys, set};

/// Open a Parquet file for batch-wise reading.
pub fn open_reader(
    path: &Path,
    batch_rows: usize,
) -> Result<ParquetRecordBatchReader, OutputError> {
    open_projected_reader(path, batch_rows, None)
}

/// Open a Parquet file for batch-wise reading of the named top-level columns only (all
/// columns when `None`).
pub fn open_projected_reader(
    path: &Path,
    batch_rows: usize,
    columns: Option<&[&str]>,
) -> Result<ParquetRecordBatchReader, OutputError> {
    OpenedFile::open(path)?.reader(batch_rows, columns)
}

/// A file opened once, read through that one handle: its footer and every pass over its
/// rows come from the same bytes, even if a run renames another file over its path
/// meanwhile (the open file outlives the rename). [`set::open_checked`] opens one and
/// checks it against the directory's manifest.
///
/// Readers made from it share the handle's file position; the Parquet reader seeks before
/// every read, so several may be used in turn on one thread.
#[derive(Debug)]
pub struct OpenedFile {
    path: PathBuf,
    file: File,
}

impl OpenedFile {
    /// Open `path` for reading.
    pub fn open(path: &Path) -> Result<Self, OutputError> {
        let file = File::open(path).map_err(|e| OutputError::io(path, e))?;
        Ok(OpenedFile {
            path: path.to_path_buf(),
            file,
        })
    }

    /// The path it was opened at.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// A duplicate of its handle (the same open file, sharing its position).
    pub(crate) fn handle(&self) -> Result<File, OutputError> {
        self.file
            .try_clone()
            .map_err(|e| OutputError::io(&self.path, e))
    }

    /// Its length and checksum, read through the handle.
    pub fn checksum(&self) -> Result<set::Checksum, OutputError> {
        use std::io::Seek;
        let mut file = self.handle()?;
        file.rewind().map_err(|e| OutputError::io(&self.path, e))?;
        set::checksum_of(&mut file, &self.path)
    }

    /// Whether `path` still names this file (on Unix: the same device and inode).
    pub fn is_at(&self, path: &Path) -> bool {
        #[cfg(unix)]
        {
            use std::os::unix::fs::MetadataExt;
            match (self.file.metadata(), fs::metadata(path)) {
                (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
                _ => false,
            }
        }
        #[cfg(not(unix))]
        {
            let _ = path;
            true
        }
    }

    /// A batch-wise reader of the named top-level columns (all when `None`).
    pub fn reader(
        &self,
        batch_rows: usize,
        columns: Option<&[&str]>,
    ) -> Result<ParquetRecordBatchReader, OutputError> {
        let path = &self.path;
        let builder = ParquetRecordBatchReaderBuilder::try_new(self.handle()?)
            .map_err(|e| OutputError::parquet(path, e))?;
        let builder = match columns {
            Some(names) => {
                let schema = builder.parquet_schema();
                let leaves: Vec<usize> = (0..schema.num_columns())
                    .filter(|&i| names.contains(&schema.column(i).name()))
                    .collect();
                let mask = parquet::arrow::ProjectionMask::leaves(schema, leaves);
                builder.with_projection(mask)
            }
            None => builder,
        };
        builder
            .with_batch_size(batch_rows)
            .build()
            .map_err(|e| OutputError::parquet(path, e))
    }

    /// Its footer key-value metadata.
    pub fn footer(&self) -> Result<Footer, OutputError> {
        let builder = ParquetRecordBatchReaderBuilder::try_new(self.handle()?)
            .map_err(|e| OutputError::parquet(&self.path, e))?;
        let kv = builder
            .metadata()
            .file_metadata()
            .key_value_metadata()
            .cloned()
            .unwrap_or_default();
        Ok(Footer(
            kv.into_iter()
                .map(|k| (k.key, k.value.unwrap_or_default()))
                .collect(),
        ))
    }
}

/// The footer key-value metadata of a Parquet file.
#[derive(Debug, Clone, Default)]
pub struct Footer(Vec<(String, String)>);

impl Footer {
    /// The footer a file written with `meta` would have, holding `table`.
    pub fn of(meta: &super::FileMetadata, table: &str) -> Footer {
        Footer(
            meta.key_values(table)
                .into_iter()
                .map(|kv| (kv.key, kv.value.unwrap_or_default()))
                .collect(),
        )
    }

    /// The value of `key`, if the footer has it.
    pub fn get(&self, key: &str) -> Option<&str> {
        self.0
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }
}

/// The directory a footer's study names its data files relative to: the one recorded with
/// it, or (for files written before it was recorded) the directory of `path`.
pub fn footer_dir(footer: &Footer, path: &Path) -> PathBuf {
    match footer.get(keys::STUDY_DIR) {
        Some(dir) if !dir.is_empty() => PathBuf::from(dir),
        _ => path.parent().map(Path::to_path_buf).unwrap_or_default(),
    }
}

/// The footer key-value metadata of a Parquet file.
pub fn read_metadata(path: &Path) -> Result<Footer, OutputError> {
    OpenedFile::open(path)?.footer()
}
