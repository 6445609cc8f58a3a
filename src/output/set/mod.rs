//! The output set of a directory: which files the engine wrote, and how a new set replaces
//! the old one as a unit.
//!
//! A run's output — the Parquet files and the figures — is one set: a reader must never see
//! the realisations of one run next to the summary or figures of another. Three hidden
//! files in the output directory make that true:
//!
//! - the **manifest** ([`MANIFEST`]) lists every file of the current set with its length
//!   and an XXH64 checksum of its bytes. Only files it lists are ever replaced or deleted
//!   by the engine; a user's own files in the directory (also under `figures/`) are left
//!   alone, and one at a path the new set writes stops the commit ([`ensure_owned`]). The
//!   checksum is verified before a file is reused (e.g. when extending R) and, through the
//!   reader's own open handle, before a file is read ([`open_checked`]). Every path it
//!   names is a plain relative name inside the directory, or the directory is refused.
//! - the **journal** ([`JOURNAL`]) makes the replacement atomic. Every new file is first
//!   written completely under a temporary name and synced; then the journal — the list of
//!   renames and deletions that turn the old set into the new one, the new manifest last —
//!   is written and renamed into place, and only then are the operations carried out. A
//!   process killed at any instant leaves either the complete old set (no journal yet),
//!   the complete new set (journal removed), or a journal: [`ensure_complete`] then reports
//!   the set as incomplete to every reader, and [`recover`] (which `run` calls first)
//!   carries the journal out to the end, which is idempotent.
//! - the **lock** ([`super::lock`]) keeps two processes from writing one directory.

use std::collections::BTreeSet;
use std::fs::{self, File};
use std::io::Write;
use std::path::{Path, PathBuf};

use super::{OutputError, PendingFile, failpoint, temporary_name};

mod checked;
mod confine;
mod owned;

pub(crate) use checked::checksum_of;
pub use checked::{checksum, open_checked, verify_file};
use confine::{check_steps, confined};
use owned::engine_table;
pub use owned::{ensure_owned, foreign_files};

/// File name of the manifest inside an output directory.
pub const MANIFEST: &str = ".chassis-mc-manifest";

/// File name of the journal inside an output directory (present only while a set is being
/// replaced, or after a process was killed doing so).
pub const JOURNAL: &str = ".chassis-mc-journal";

const MANIFEST_HEADER: &str = "chassis-mc manifest 1";
const JOURNAL_HEADER: &str = "chassis-mc journal 1";

/// Files an engine without a manifest (before checksums were recorded) wrote at the top of
/// an output directory: the set they form is replaced as a whole.
const LEGACY_SET: [&str; 3] = ["realisations.parquet", "summary.parquet", "cycles.parquet"];

/// Length and XXH64 checksum (seed 0) of a file's bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Checksum {
    /// Length in bytes.
    pub len: u64,
    /// XXH64 of the bytes.
    pub hash: u64,
}

impl std::fmt::Display for Checksum {
    /// The hash in hex (as the manifest records it); `{:#}` adds the length.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match f.alternate() {
            true => write!(f, "{} bytes, xxh64 {:016x}", self.len, self.hash),
            false => write!(f, "{:016x}", self.hash),
        }
    }
}

/// One file of an output set.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Entry {
    /// Path relative to the output directory, `/`-separated (e.g. `figures/cycles.svg`).
    pub path: String,
    /// Its length and checksum when it was committed.
    pub checksum: Checksum,
}

/// The files of an output directory's current set.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Manifest {
    /// The files, sorted by path.
    pub entries: Vec<Entry>,
}

impl Manifest {
    /// The manifest of `dir`, or `None` if it has none (a directory no engine run has
    /// committed into, or one written by an engine without manifests).
    pub fn read(dir: &Path) -> Result<Option<Manifest>, OutputError> {
        let path = dir.join(MANIFEST);
        super::lock::ensure_plain_file(&path)?;
        let text = match fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(OutputError::io(&path, e)),
        };
        Manifest::parse(&text, &path).map(Some)
    }

    fn parse(text: &str, path: &Path) -> Result<Manifest, OutputError> {
        let mut lines = text.lines();
        if lines.next() != Some(MANIFEST_HEADER) {
            return Err(OutputError::unusable(path, "not a chassis-mc manifest"));
        }
        let mut entries = Vec::new();
        for (i, line) in lines.enumerate() {
            let bad = || OutputError::unusable(path, format!("line {}: malformed entry", i + 2));
            let mut fields = line.splitn(3, '\t');
            let (Some(hash), Some(len), Some(file)) = (fields.next(), fields.next(), fields.next())
            else {
                return Err(bad());
            };
            confined(file).map_err(|reason| OutputError::Unsafe {
                file: path.to_path_buf(),
                line: Some(i + 2),
                reason,
            })?;
            entries.push(Entry {
                path: file.to_string(),
                checksum: Checksum {
                    len: len.parse().map_err(|_| bad())?,
                    hash: u64::from_str_radix(hash, 16).map_err(|_| bad())?,
                },
            });
        }
        Ok(Manifest { entries })
    }

    fn render(&self) -> String {
        let mut text = format!("{MANIFEST_HEADER}\n");
        for e in &self.entries {
            text += &format!("{}\t{}\t{}\n", e.checksum, e.checksum.len, e.path);
        }
        text
    }

    /// The entry of `path` (relative to the directory), if the set holds it.
    pub fn get(&self, path: &str) -> Option<&Entry> {
        self.entries.iter().find(|e| e.path == path)
    }
}

/// Fail if a replacement of `dir`'s output set was interrupted (a journal is present):
/// what is there may mix two runs.
pub fn ensure_complete(dir: &Path) -> Result<(), OutputError> {
    super::lock::ensure_plain_file(&dir.join(JOURNAL))?;
    if dir.join(JOURNAL).exists() {
        return Err(OutputError::Incomplete {
            dir: dir.to_path_buf(),
        });
    }
    Ok(())
}

/// One step of a journal.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Op {
    /// Move a complete temporary file (relative path) to its final relative path.
    Rename(String, String),
    /// Delete a file of the old set that the new set does not have.
    Delete(String),
}

/// Replace the output set of `dir` by `files` (each complete under its temporary name).
///
/// `replaced(path)` says which entries of the old set the new files take the place of:
/// those are deleted unless a new file has the same path; the others stay in the set
/// (e.g. `summarize` keeps a run's realisation file, `figures` everything but the
/// figures). Returns the final paths of `files`.
pub fn commit(
    dir: &Path,
    files: Vec<PendingFile>,
    replaced: &dyn Fn(&str) -> bool,
) -> Result<Vec<PathBuf>, OutputError> {
    // Without a manifest, the old files are replaced or deleted as before, but the new
    // manifest vouches for none of them: their bytes were never recorded.
    let (old, vouched) = match Manifest::read(dir)? {
        Some(m) => (m, true),
        None => (legacy_set(dir)?, false),
    };
    let relative = |path: &Path| -> Result<String, OutputError> {
        let rel = path
            .strip_prefix(dir)
            .map_err(|_| OutputError::format(path, "is not inside the output directory"))?;
        Ok(rel
            .components()
            .map(|c| c.as_os_str().to_string_lossy())
            .collect::<Vec<_>>()
            .join("/"))
    };
    let mut ops = Vec::new();
    let mut entries = Vec::new();
    let mut finals = Vec::new();
    for file in &files {
        let path = relative(file.final_path())?;
        entries.push(Entry {
            path: path.clone(),
            checksum: file.checksum()?,
        });
        ops.push(Op::Rename(relative(file.tmp_path())?, path));
        finals.push(file.final_path().to_path_buf());
    }
    let new_paths: BTreeSet<String> = entries.iter().map(|e| e.path.clone()).collect();
    // A user's file at a path of the new set is never overwritten (README "Output files").
    ensure_owned(dir, &new_paths.iter().cloned().collect::<Vec<_>>())?;
    for e in &old.entries {
        if new_paths.contains(&e.path) {
            continue;
        }
        if replaced(&e.path) {
            ops.push(Op::Delete(e.path.clone()));
        } else if vouched {
            entries.push(e.clone());
        }
    }
    entries.sort_by(|a, b| a.path.cmp(&b.path));
    let manifest = Manifest { entries };
    let manifest_tmp = temporary_name(MANIFEST);
    write_synced(&dir.join(&manifest_tmp), manifest.render().as_bytes())?;
    ops.push(Op::Rename(manifest_tmp, MANIFEST.to_string()));

    // Nothing is written if a step would reach outside `dir` (a manifest entry or a new
    // file under a directory that is a symbolic link).
    check_steps(dir, &ops, None)?;
    let mut journal = format!("{JOURNAL_HEADER}\n");
    for op in &ops {
        journal += &match op {
            Op::Rename(from, to) => format!("rename\t{from}\t{to}\n"),
            Op::Delete(path) => format!("delete\t{path}\n"),
        };
    }
    let journal_tmp = dir.join(temporary_name(JOURNAL));
    write_synced(&journal_tmp, journal.as_bytes())?;
    failpoint("before-journal");
    fs::rename(&journal_tmp, dir.join(JOURNAL)).map_err(|e| OutputError::io(dir, e))?;
    sync_dir(dir)?;
    // From here on the journal finishes the job even if this process dies.
    for file in files {
        file.disarm();
    }
    failpoint("journal-written");
    apply(dir, &ops)?;
    Ok(finals)
}

/// Carry out an interrupted replacement of `dir`'s output set, if there is one. Returns
/// whether there was.
pub fn recover(dir: &Path) -> Result<bool, OutputError> {
    let path = dir.join(JOURNAL);
    super::lock::ensure_plain_file(&path)?;
    let text = match fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(false),
        Err(e) => return Err(OutputError::io(&path, e)),
    };
    let mut lines = text.lines();
    if lines.next() != Some(JOURNAL_HEADER) {
        return Err(OutputError::unusable(&path, "not a chassis-mc journal"));
    }
    let mut ops = Vec::new();
    for (i, line) in lines.enumerate() {
        let fields: Vec<&str> = line.split('\t').collect();
        let op = match fields.as_slice() {
            ["rename", from, to] => Op::Rename(from.to_string(), to.to_string()),
            ["delete", file] => Op::Delete(file.to_string()),
            _ => {
                return Err(OutputError::unusable(
                    &path,
                    format!("line {}: malformed step", i + 2),
                ));
            }
        };
        ops.push(op);
    }
    apply(dir, &ops)?;
    Ok(true)
}

impl Op {
    /// The paths (relative to the output directory) the step names.
    fn paths(&self) -> Vec<&str> {
        match self {
            Op::Rename(from, to) => vec![from, to],
            Op::Delete(path) => vec![path],
        }
    }
}

/// Carry out `ops` (each step idempotent), then remove the journal. Every step is checked
/// first: none is carried out if one would reach outside `dir`.
fn apply(dir: &Path, ops: &[Op]) -> Result<(), OutputError> {
    let journal = dir.join(JOURNAL);
    check_steps(dir, ops, Some(&journal))?;
    let mut touched = BTreeSet::new();
    for op in ops {
        match op {
            Op::Rename(from, to) => {
                let (from, to) = (dir.join(from), dir.join(to));
                if let Some(parent) = to.parent() {
                    fs::create_dir_all(parent).map_err(|e| OutputError::io(parent, e))?;
                    touched.insert(parent.to_path_buf());
                }
                match fs::rename(&from, &to) {
                    Ok(()) => {}
                    // Done before the process that wrote the journal died (or the temporary
                    // file was deleted by hand: the next run replaces the set anyway).
                    Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                    Err(e) => return Err(OutputError::io(&from, e)),
                }
                failpoint("commit-rename");
            }
            Op::Delete(file) => {
                let path = dir.join(file);
                match fs::remove_file(&path) {
                    Ok(()) => {}
                    Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                    Err(e) => return Err(OutputError::io(&path, e)),
                }
                if let Some(parent) = path.parent() {
                    touched.insert(parent.to_path_buf());
                }
            }
        }
    }
    for d in &touched {
        sync_dir(d)?;
    }
    fs::remove_file(&journal).map_err(|e| OutputError::io(&journal, e))?;
    sync_dir(dir)?;
    // A directory of figures emptied by the deletions goes too (a user's file keeps it).
    for d in touched {
        if d != dir && d.starts_with(dir) {
            let _ = fs::remove_dir(&d);
        }
    }
    Ok(())
}

/// The set of a directory written before manifests existed: its top-level tables (those
/// whose footer shows chassis-mc wrote them).
fn legacy_set(dir: &Path) -> Result<Manifest, OutputError> {
    let mut entries = Vec::new();
    for name in LEGACY_SET {
        if engine_table(&dir.join(name)) {
            entries.push(Entry {
                path: name.to_string(),
                checksum: checksum(&dir.join(name))?,
            });
        }
    }
    Ok(Manifest { entries })
}

fn write_synced(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    let mut file = File::create(path).map_err(|e| OutputError::io(path, e))?;
    file.write_all(bytes)
        .and_then(|()| file.sync_all())
        .map_err(|e| OutputError::io(path, e))
}

/// Make renames and deletions in `dir` durable.
fn sync_dir(dir: &Path) -> Result<(), OutputError> {
    File::open(dir)
        .and_then(|d| d.sync_all())
        .map_err(|e| OutputError::io(dir, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_manifest_reads_back_what_was_written() {
        let m = Manifest {
            entries: vec![
                Entry {
                    path: "figures/se_inv_mass.svg".into(),
                    checksum: Checksum { len: 12, hash: 7 },
                },
                Entry {
                    path: "summary.parquet".into(),
                    checksum: Checksum {
                        len: 0,
                        hash: u64::MAX,
                    },
                },
            ],
        };
        assert_eq!(Manifest::parse(&m.render(), Path::new("m")).unwrap(), m);
    }

    #[test]
    fn a_parquet_file_s_checksum_recorded_while_writing_equals_the_one_read_back() {
        use std::sync::Arc;

        use arrow::array::{Float64Array, RecordBatch};
        use arrow::datatypes::{DataType, Field, Schema};

        let dir = tempfile::tempdir().unwrap();
        let schema = Arc::new(Schema::new(vec![Field::new("x", DataType::Float64, false)]));
        let meta = crate::output::FileMetadata {
            study_toml: "name = \"t\"".into(),
            study_dir: String::new(),
            seed: 1,
            realisations: 1,
            identity: "t".into(),
            extra: Vec::new(),
        };
        let mut sink =
            crate::output::ParquetSink::create(dir.path(), "t.parquet", schema.clone(), &meta, "t")
                .unwrap();
        for k in 0..3 {
            let values = Float64Array::from_iter_values((0..70_000).map(|i| (i * k) as f64));
            sink.write(&RecordBatch::try_new(schema.clone(), vec![Arc::new(values)]).unwrap())
                .unwrap();
        }
        let pending = sink.finish().unwrap();
        let recorded = pending.checksum().unwrap();
        assert_eq!(recorded, checksum(pending.tmp_path()).unwrap());
        assert!(recorded.len > 0);
    }

    #[test]
    fn only_plain_relative_paths_are_confined() {
        for ok in [
            "report.html",
            "figures/se_inv_mass.svg",
            ".summary.parquet.tmp-12",
            "a..b",
        ] {
            assert!(confined(ok).is_ok(), "{ok}");
        }
        for bad in [
            "",
            "/etc/passwd",
            "../x",
            "figures/../../x",
            "./x",
            "a//b",
            "a/",
            "a\\b",
        ] {
            assert!(confined(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn the_checksum_is_xxh64_of_the_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f");
        fs::write(&path, b"").unwrap();
        // XXH64 of the empty input with seed 0 (the reference value of the xxHash spec).
        assert_eq!(checksum(&path).unwrap().hash, 0xef46_db37_51d8_e999);
    }
}
