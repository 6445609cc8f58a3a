//! Which files at the engine's paths are the engine's to replace, and which a user's.

use std::fs::{self, File};
use std::io::Read;
use std::path::Path;

use super::{LEGACY_SET, Manifest};
use crate::output::{self, OutputError};

/// Whether the file at `path` is a Parquet table chassis-mc wrote (its footer names the
/// table, README "Output files").
pub(super) fn engine_table(path: &Path) -> bool {
    path.is_file()
        && output::read_metadata(path).is_ok_and(|f| f.get(output::keys::TABLE).is_some())
}

/// The provenance row of the report pages of engines before [`output::REPORT_MARK`].
const LEGACY_REPORT_MARK: &str = "<td>chassis-mc version</td>";

/// Whether the file at `path` is a report page chassis-mc wrote.
pub(super) fn engine_report(path: &Path) -> bool {
    let mut head = Vec::new();
    File::open(path)
        .and_then(|f| f.take(1 << 16).read_to_end(&mut head))
        .is_ok()
        && [output::REPORT_MARK, LEGACY_REPORT_MARK]
            .iter()
            .any(|mark| String::from_utf8_lossy(&head).contains(mark))
}

/// The files at `paths` (relative to `dir`, where a new set will be written) that are not
/// the engine's to replace: a file there is the engine's when the manifest lists it, when
/// its content shows chassis-mc wrote it (a Parquet table with chassis-mc's footer, a
/// report page with its provenance row), or, in a directory an engine before manifests
/// wrote (no manifest, chassis-mc tables at the top), when it is one of its figures. Any
/// other file there is a user's: it must not be overwritten.
pub fn foreign_files(dir: &Path, paths: &[String]) -> Result<Vec<String>, OutputError> {
    let manifest = Manifest::read(dir)?;
    let legacy = manifest.is_none() && LEGACY_SET.iter().any(|n| engine_table(&dir.join(n)));
    let mut foreign = Vec::new();
    for rel in paths {
        let path = dir.join(rel);
        let owned = manifest.as_ref().is_some_and(|m| m.get(rel).is_some())
            || fs::symlink_metadata(&path).is_err()
            || (rel.ends_with(".parquet") && engine_table(&path))
            || (path.file_name() == Some("report.html".as_ref()) && engine_report(&path))
            || (legacy && rel.starts_with("figures/"));
        if !owned {
            foreign.push(rel.clone());
        }
    }
    Ok(foreign)
}

/// Fail with [`OutputError::NotOwned`] if any of `paths` (relative to `dir`) is a
/// [foreign file](foreign_files).
pub fn ensure_owned(dir: &Path, paths: &[String]) -> Result<(), OutputError> {
    let mut files = foreign_files(dir, paths)?;
    files.sort();
    match files.is_empty() {
        true => Ok(()),
        false => Err(OutputError::NotOwned {
            dir: dir.to_path_buf(),
            files,
        }),
    }
}
