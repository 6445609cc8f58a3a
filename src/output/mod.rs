//! Parquet output (the data contract is in the README's "Output files"): the realisation, summary and cycle tables, their schemas, and
//! files that appear only when complete.
//!
//! Every file is written under a temporary name in the destination directory and renamed
//! into place by [`PendingFile::commit`], so a reader never sees a half-written file and a
//! failed run leaves the previous results untouched. Compression is zstd, row groups are
//! bounded, and the footer carries the study as run, the engine version and the seed.

mod failpoints;
pub mod lock;
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
use parquet::arrow::arrow_reader::{ParquetRecordBatchReader, ParquetRecordBatchReaderBuilder};
use parquet::basic::{Compression, ZstdLevel};
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;
use thiserror::Error;

pub use failpoints::{FAILPOINTS, PAUSE_POINTS, failpoint, pause};
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

/// Failure while writing or reading output.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum OutputError {
    /// A filesystem operation failed.
    #[error("{path}: {source}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The Parquet/Arrow layer failed.
    #[error("{path}: {source}")]
    Parquet {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: parquet::errors::ParquetError,
    },
    /// Building or reading an Arrow batch failed.
    #[error("{path}: {source}")]
    Arrow {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: arrow::error::ArrowError,
    },
    /// A file does not hold what chassis-mc wrote.
    #[error("{path}: {reason}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// Another process is writing the output directory.
    #[error(
        "{dir}: another chassis-mc process{} is writing this directory; wait for it to \
         finish or choose another --out",
        pid.map(|p| format!(" (pid {p})")).unwrap_or_default()
    )]
    Locked {
        /// The directory.
        dir: PathBuf,
        /// The pid of the process holding the lock, if it could be read.
        pid: Option<u32>,
    },
    /// The directory's manifest or journal names a path outside the directory (absolute,
    /// with `..`, or through a symbolic link): the directory is refused, nothing is done.
    #[error(
        "{file}{}: {reason}; refusing this directory (chassis-mc writes only plain names \
         inside it)",
        line.map(|l| format!(": line {l}")).unwrap_or_default()
    )]
    Unsafe {
        /// The manifest or journal.
        file: PathBuf,
        /// The line naming the path.
        line: Option<usize>,
        /// What is wrong with the path.
        reason: String,
    },
    /// A file of an output set does not hold the bytes recorded for it when it was written.
    #[error(
        "{path}: damaged: its bytes do not match the checksum recorded when it was written \
         ({recorded:#} recorded; {found:#} found); {remedy}"
    )]
    Damaged {
        /// The file.
        path: PathBuf,
        /// Length and checksum in the manifest.
        recorded: set::Checksum,
        /// Length and checksum of the file.
        found: set::Checksum,
        /// How to make it whole again.
        remedy: String,
    },
    /// An unsharded run into a directory that holds shards (`shard=K/`): it would replace
    /// them, and they are a user's computation.
    #[error(
        "{dir}: holds the shards {} of a sharded run, which an unsharded run into it would \
         replace; combine them with `chassis-mc summarize {}`, move them away, or choose \
         another --out",
        shards.join(", "),
        dir.display()
    )]
    ShardsPresent {
        /// The directory.
        dir: PathBuf,
        /// Each shard directory, with its seed and realisations when its file says them.
        shards: Vec<String>,
    },
    /// Files the engine would write over are not its own (not in its manifest, not
    /// recognisably written by chassis-mc): a user's files are never overwritten.
    #[error(
        "{dir}: would overwrite {}, which chassis-mc did not write (they are not in its \
         manifest); move them away or choose another --out (nothing of yours was changed)",
        files.join(", ")
    )]
    NotOwned {
        /// The directory.
        dir: PathBuf,
        /// The files, relative to it.
        files: Vec<String>,
    },
    /// A file or directory given as an argument does not exist.
    #[error("{path}: no such file or directory")]
    Missing {
        /// The path given.
        path: PathBuf,
    },
    /// Realisation files summarised together belong to different runs.
    #[error(
        "{path}: cannot be summarised with {first}: they differ in {}; summarise the files of \
         one run (the same study, seed and R) together",
        differences.join("; ")
    )]
    Mismatch {
        /// The file that does not match.
        path: PathBuf,
        /// The first file, which the others are compared with.
        first: PathBuf,
        /// What differs, each with both values.
        differences: Vec<String>,
    },
    /// A run was interrupted while replacing the directory's output files, so they may
    /// come from two runs.
    #[error(
        "{dir}: incomplete output: a run was interrupted while replacing its files, so they \
         may mix two runs; run `chassis-mc run` into this directory again to complete it"
    )]
    Incomplete {
        /// The directory.
        dir: PathBuf,
    },
}

impl OutputError {
    /// Whether the error is the input's fault (exit status 2: a bad argument, a directory
    /// that cannot be used as it is) rather than a failure while running (1).
    pub fn is_bad_input(&self) -> bool {
        matches!(
            self,
            OutputError::Locked { .. }
                | OutputError::Unsafe { .. }
                | OutputError::Damaged { .. }
                | OutputError::ShardsPresent { .. }
                | OutputError::NotOwned { .. }
                | OutputError::Mismatch { .. }
                | OutputError::Missing { .. }
        )
    }

    pub(crate) fn io(path: &Path, source: std::io::Error) -> Self {
        OutputError::Io {
            path: path.to_path_buf(),
            source,
        }
    }

    pub(crate) fn parquet(path: &Path, source: parquet::errors::ParquetError) -> Self {
        OutputError::Parquet {
            path: path.to_path_buf(),
            source,
        }
    }

    pub(crate) fn arrow(path: &Path, source: arrow::error::ArrowError) -> Self {
        OutputError::Arrow {
            path: path.to_path_buf(),
            source,
        }
    }

    pub(crate) fn format(path: &Path, reason: impl Into<String>) -> Self {
        OutputError::Format {
            path: path.to_path_buf(),
            reason: reason.into(),
        }
    }
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

/// A Parquet file being written under a temporary name.
pub struct ParquetSink {
    writer: ArrowWriter<HashingWriter>,
    pending: PendingFile,
}

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
        Ok(ParquetSink { writer, pending })
    }

    /// Append a batch.
    pub fn write(&mut self, batch: &RecordBatch) -> Result<(), OutputError> {
        self.writer
            .write(batch)
            .map_err(|e| OutputError::parquet(&self.pending.tmp_path, e))
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

/// Shared pointer to a schema (re-exported for callers building batches).
pub type Schema = Arc<arrow::datatypes::Schema>;
