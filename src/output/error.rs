//! What can go wrong writing or reading the engine's files, and whether it is the user's input.

use std::path::{Path, PathBuf};

use thiserror::Error;

use super::set;

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
    /// A file the engine would replace is not one it wrote (a user's own file at the path
    /// given): it is never overwritten without being told to.
    #[error("{path}: {reason}; nothing was changed")]
    NotEngines {
        /// The file.
        path: PathBuf,
        /// Why it is not the engine's, and how to replace it anyway.
        reason: String,
    },
    /// The output directory cannot be made or written (a read-only filesystem, no
    /// permission, a place no directory can be made).
    #[error("{dir}: cannot be used as the output directory: {source}")]
    Unwritable {
        /// The directory.
        dir: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
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
    /// A bookkeeping file of the engine's in the output directory (its manifest, its
    /// journal) does not hold what the engine writes there: the directory cannot be used
    /// as it is.
    #[error(
        "{path}: {reason}; this output directory cannot be used as it is (move the file away \
         if it is yours, or choose another --out)"
    )]
    Unusable {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// A shard run into a directory that holds shards of another run: it would mix two
    /// runs in one set.
    #[error(
        "{dir}: shard {shard} of this run would join {} of another run: they differ in {}; \
         run it into another --out, or move the other shards away (nothing was changed)",
        other.display(),
        differences.join("; ")
    )]
    ShardOfAnotherRun {
        /// The output directory.
        dir: PathBuf,
        /// This run's shard, "K/N".
        shard: String,
        /// The other run's realisation file.
        other: PathBuf,
        /// What differs, each with both values (this run's first).
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
                | OutputError::Unusable { .. }
                | OutputError::ShardOfAnotherRun { .. }
                | OutputError::NotEngines { .. }
                | OutputError::Unwritable { .. }
                | OutputError::Incomplete { .. }
        ) || self.io_kind().is_some_and(|kind| {
            use std::io::ErrorKind::*;
            // The directory given cannot be written, or a path in it is of the wrong kind.
            matches!(
                kind,
                PermissionDenied | ReadOnlyFilesystem | NotADirectory | IsADirectory
            )
        })
    }

    /// The kind of the operating system's error, for a failed filesystem operation.
    pub fn io_kind(&self) -> Option<std::io::ErrorKind> {
        match self {
            OutputError::Io { source, .. } => Some(source.kind()),
            _ => None,
        }
    }

    pub(crate) fn unusable(path: &Path, reason: impl Into<String>) -> Self {
        OutputError::Unusable {
            path: path.to_path_buf(),
            reason: reason.into(),
        }
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
