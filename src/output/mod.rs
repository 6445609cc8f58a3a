//! Parquet output (the data contract is in the README's "Output files"): the realisation, summary and cycle tables, their schemas, and
//! files that appear only when complete.
//!
//! Every file is written under a temporary name in the destination directory and renamed
//! into place by [`PendingFile::commit`], so a reader never sees a half-written file and a
//! failed run leaves the previous results untouched. Compression is zstd, row groups are
//! bounded, and the footer carries the study as run, the engine version and the seed.

mod error;
mod failpoints;
pub mod lock;
mod read;
pub mod set;
pub mod store;
mod summary_table;
mod tables;

use std::fs::{self, File};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use arrow::array::RecordBatch;
use arrow::datatypes::SchemaRef;
use parquet::arrow::ArrowWriter;
use parquet::basic::{Compression, ZstdLevel};
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;

pub use error::OutputError;
pub use failpoints::{FAILPOINTS, PAUSE_POINTS, failpoint, pause};
pub use read::{Footer, OpenedFile, footer_dir, open_projected_reader, open_reader, read_metadata};
pub use summary_table::{SummaryTable, read_summary, summary_batch, summary_schema};
pub use tables::{RealisationBatches, realisation_schema, realisations_batch};

/// File names inside an output directory.
pub mod files {
    /// One row per realisation × estimator.
    pub const REALISATIONS: &str = "realisations.parquet";
    /// One row per condition × estimator × parameter.
    pub const SUMMARY: &str = "summary.parquet";
    /// Noise-free drive cycles (the vehicle model's extra table).
    pub const CYCLES: &str = "cycles.parquet";
}

/// What every report page chassis-mc writes (`run`, `summarize`, `design`, `fit`) carries
/// in its head, so that a page of the engine's is told from a user's file of the same name.
pub const REPORT_MARK: &str = "<meta name=\"generator\" content=\"chassis-mc\"/>";

/// Rows per Parquet row group (bounds the writer's memory).
pub const ROW_GROUP_ROWS: usize = 65_536;

/// Rows per batch when reading a file back (bounds the reader's memory).
pub const READ_ROWS: usize = 65_536;

/// zstd level used for every file.
pub const ZSTD_LEVEL: i32 = 3;

/// The name `name` is written under until complete: `.name.tmp-<pid>`.
pub fn temporary_name(name: &str) -> String {
    format!(".{name}.tmp-{}", std::process::id())
}

/// True for names of files (or directories) still being written, by any process: see
/// [`temporary_name`].
pub fn is_temporary(name: &str) -> bool {
    name.starts_with('.') && name.contains(".tmp-")
}

/// Footer metadata keys.
pub mod keys {
    /// The study TOML as run (overrides applied); `chassis-mc` can reload it.
    pub const STUDY: &str = "chassis_mc.study";
    /// Engine version (`CARGO_PKG_VERSION`).
    pub const VERSION: &str = "chassis_mc.version";
    /// The master seed.
    pub const SEED: &str = "chassis_mc.seed";
    /// Realisations per condition.
    pub const REALISATIONS: &str = "chassis_mc.realisations";
    /// Which table the file holds: `realisations`, `summary` or `cycles`.
    pub const TABLE: &str = "chassis_mc.table";
    /// The study as run without its realisation count, plus the engine version: files
    /// with the same identity hold interchangeable realisations.
    pub const IDENTITY: &str = "chassis_mc.identity";
    /// On a staged part: "condition first_realisation end_realisation".
    pub const PART: &str = "chassis_mc.part";
    /// On a shard's realisation file: "K/N".
    pub const SHARD: &str = "chassis_mc.shard";
    /// The directory the study's data files (a speed trace, a terrain file) are named
    /// relative to, so that the study can be reloaded from the footer.
    pub const STUDY_DIR: &str = "chassis_mc.study_dir";
}

/// What goes into every file's footer.
#[derive(Debug, Clone)]
pub struct FileMetadata {
    /// The study TOML as run.
    pub study_toml: String,
    /// See [`keys::STUDY_DIR`].
    pub study_dir: String,
    /// The master seed.
    pub seed: u64,
    /// Realisations per condition.
    pub realisations: u64,
    /// See [`keys::IDENTITY`].
    pub identity: String,
    /// Further key-value pairs (e.g. [`keys::PART`], [`keys::SHARD`]).
    pub extra: Vec<(String, String)>,
}

impl FileMetadata {
    /// The metadata of files written for `study` (its text as run, directory, seed and R)
    /// with `identity`.
    pub fn of_study(study: &crate::study::Study, identity: String) -> Self {
        FileMetadata {
            study_toml: study.to_toml(),
            study_dir: study.dir().display().to_string(),
            seed: study.seed(),
            realisations: study.realisations(),
            identity,
            extra: Vec::new(),
        }
    }

    /// The same metadata with one more key-value pair.
    pub fn with(&self, key: &str, value: String) -> Self {
        let mut m = self.clone();
        m.extra.push((key.to_string(), value));
        m
    }

    fn key_values(&self, table: &str) -> Vec<KeyValue> {
        let mut kv = vec![
            KeyValue::new(keys::TABLE.into(), table.to_string()),
            KeyValue::new(keys::STUDY.into(), self.study_toml.clone()),
            KeyValue::new(keys::STUDY_DIR.into(), self.study_dir.clone()),
            KeyValue::new(keys::VERSION.into(), env!("CARGO_PKG_VERSION").to_string()),
            KeyValue::new(keys::SEED.into(), self.seed.to_string()),
            KeyValue::new(keys::REALISATIONS.into(), self.realisations.to_string()),
            KeyValue::new(keys::IDENTITY.into(), self.identity.clone()),
        ];
        kv.extend(
            self.extra
                .iter()
                .map(|(k, v)| KeyValue::new(k.clone(), v.clone())),
        );
        kv
    }
}

/// Writer settings shared by every table: zstd, bounded row groups, footer metadata.
///
/// Floating-point columns use BYTE_STREAM_SPLIT without dictionaries: measured series and
/// noisy estimates have few repeated values, and splitting their bytes lets zstd compress
/// the slowly varying exponents (the cycles table shrinks by about 40 %).
fn properties(
    meta: &FileMetadata,
    table: &str,
    schema: &arrow::datatypes::Schema,
) -> WriterProperties {
    let mut builder = WriterProperties::builder();
    for field in schema.fields() {
        if field.data_type() == &arrow::datatypes::DataType::Float64 {
            let column = parquet::schema::types::ColumnPath::from(field.name().as_str());
            builder = builder
                .set_column_dictionary_enabled(column.clone(), false)
                .set_column_encoding(column, parquet::basic::Encoding::BYTE_STREAM_SPLIT);
        }
    }
    builder
        .set_compression(Compression::ZSTD(
            ZstdLevel::try_new(ZSTD_LEVEL).expect("valid zstd level"),
        ))
        .set_max_row_group_row_count(Some(ROW_GROUP_ROWS))
        .set_created_by(format!("chassis-mc {}", env!("CARGO_PKG_VERSION")))
        .set_key_value_metadata(Some(meta.key_values(table)))
        .build()
}

/// `schema` with the key-value metadata a file of `table` written with `meta` carries in
/// its footer (the study as run, its identity, seed and R): a table held in memory keeps
/// the provenance its file would.
pub fn footer_schema(schema: SchemaRef, meta: &FileMetadata, table: &str) -> SchemaRef {
    let metadata: std::collections::HashMap<String, String> = meta
        .key_values(table)
        .into_iter()
        .filter_map(|kv| kv.value.map(|v| (kv.key, v)))
        .collect();
    std::sync::Arc::new(arrow::datatypes::Schema::new_with_metadata(
        schema.fields().clone(),
        metadata,
    ))
}

/// A Parquet file being written under a temporary name.
pub struct ParquetSink {
    writer: ArrowWriter<HashingWriter>,
    pending: PendingFile,
    kept: Option<Kept>,
}

/// Where a sink keeps a copy of every batch it writes ([`ParquetSink::keeping`]).
pub type Kept = std::sync::Arc<std::sync::Mutex<Vec<RecordBatch>>>;

/// A file that hashes the bytes written to it (XXH64, as [`set::checksum`] reads them
/// back), so a file's checksum costs no second read. The Parquet writer only appends.
struct HashingWriter {
    file: File,
    hasher: twox_hash::XxHash64,
    len: u64,
}

impl std::io::Write for HashingWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.file.write(buf)?;
        std::hash::Hasher::write(&mut self.hasher, &buf[..n]);
        self.len += n as u64;
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

impl ParquetSink {
    /// Start `dir/name` (written as `dir/.name.tmp-<pid>` until committed).
    pub fn create(
        dir: &Path,
        name: &str,
        schema: SchemaRef,
        meta: &FileMetadata,
        table: &str,
    ) -> Result<Self, OutputError> {
        let final_path = dir.join(name);
        let tmp_path = dir.join(temporary_name(name));
        let file = File::create(&tmp_path).map_err(|e| OutputError::io(&tmp_path, e))?;
        let pending = PendingFile::new(tmp_path, final_path);
        let props = properties(meta, table, &schema);
        let file = HashingWriter {
            file,
            hasher: twox_hash::XxHash64::with_seed(0),
            len: 0,
        };
        let writer = ArrowWriter::try_new(file, schema, Some(props))
            .map_err(|e| OutputError::parquet(&pending.tmp_path, e))?;
        Ok(ParquetSink {
            writer,
            pending,
            kept: None,
        })
    }

    /// The same sink keeping a copy of every batch it writes in `kept` (its columns shared,
    /// not copied): a caller that wants the table in memory as well as in the file, without
    /// reading it back.
    pub fn keeping(mut self, kept: Kept) -> Self {
        self.kept = Some(kept);
        self
    }

    /// Append a batch.
    pub fn write(&mut self, batch: &RecordBatch) -> Result<(), OutputError> {
        if let Some(kept) = &self.kept {
            kept.lock().expect("kept batches").push(batch.clone());
        }
        self.writer
            .write(batch)
            .map_err(|e| OutputError::parquet(&self.pending.tmp_path, e))
    }

    /// The file being written (its temporary name).
    pub fn path(&self) -> &Path {
        &self.pending.tmp_path
    }

    /// End the current row group here.
    pub fn flush(&mut self) -> Result<(), OutputError> {
        self.writer
            .flush()
            .map_err(|e| OutputError::parquet(&self.pending.tmp_path, e))
    }

    /// Write the footer and flush to disk; the file still has its temporary name.
    pub fn finish(self) -> Result<PendingFile, OutputError> {
        let ParquetSink {
            writer,
            mut pending,
            ..
        } = self;
        let written = writer
            .into_inner()
            .map_err(|e| OutputError::parquet(&pending.tmp_path, e))?;
        written
            .file
            .sync_all()
            .map_err(|e| OutputError::io(&pending.tmp_path, e))?;
        pending.checksum = Some(set::Checksum {
            len: written.len,
            hash: std::hash::Hasher::finish(&written.hasher),
        });
        Ok(pending)
    }
}

/// A complete file under its temporary name; removed on drop unless committed.
#[derive(Debug)]
pub struct PendingFile {
    tmp_path: PathBuf,
    final_path: PathBuf,
    committed: bool,
    /// The checksum of its bytes, when known from writing them.
    checksum: Option<set::Checksum>,
}

impl PendingFile {
    /// Where the file is now.
    pub fn tmp_path(&self) -> &Path {
        &self.tmp_path
    }

    /// Where it will be after [`commit`](Self::commit).
    pub fn final_path(&self) -> &Path {
        &self.final_path
    }

    /// Rename into place (atomic on one filesystem), replacing any previous file.
    pub fn commit(mut self) -> Result<PathBuf, OutputError> {
        fs::rename(&self.tmp_path, &self.final_path)
            .map_err(|e| OutputError::io(&self.final_path, e))?;
        self.committed = true;
        Ok(self.final_path.clone())
    }

    /// The same file, to be renamed to `name` in the same directory instead.
    pub fn renamed(mut self, name: &str) -> Self {
        self.final_path.set_file_name(name);
        self
    }

    /// A file whose move into place is now someone else's job (a written journal): it is
    /// no longer removed on drop.
    pub fn disarm(mut self) {
        self.committed = true;
    }

    /// A complete file at `tmp_path`, to be moved to `final_path`.
    pub fn new(tmp_path: PathBuf, final_path: PathBuf) -> Self {
        PendingFile {
            tmp_path,
            final_path,
            committed: false,
            checksum: None,
        }
    }

    /// The checksum of its bytes: recorded while writing, else read from the file.
    pub fn checksum(&self) -> Result<set::Checksum, OutputError> {
        match self.checksum {
            Some(c) => Ok(c),
            None => set::checksum(&self.tmp_path),
        }
    }
}

impl Drop for PendingFile {
    fn drop(&mut self) {
        if !self.committed {
            let _ = fs::remove_file(&self.tmp_path);
        }
    }
}

/// Write `bytes` as `dir/name` under its temporary name: the returned file is renamed into
/// place by a commit, and a failed write (a full disk) leaves nothing behind.
pub fn write_pending(dir: &Path, name: &str, bytes: &[u8]) -> Result<PendingFile, OutputError> {
    let pending = PendingFile::new(dir.join(temporary_name(name)), dir.join(name));
    fs::write(pending.tmp_path(), bytes).map_err(|e| OutputError::io(pending.tmp_path(), e))?;
    Ok(pending)
}

/// Shared pointer to a schema (re-exported for callers building batches).
pub type Schema = Arc<arrow::datatypes::Schema>;
