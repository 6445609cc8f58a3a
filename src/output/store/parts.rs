//! The staged parts of a run: their names (which record each part's checksum), committing a
//! complete one, checking the staging directory, and finding the parts a run can reuse.

use std::fs;
use std::ops::Range;
use std::path::{Path, PathBuf};

use super::Source;
use crate::output::{OutputError, PendingFile, is_temporary, keys, read_metadata, set};

/// Realisations per staged part (bounds the work lost when a run is killed).
pub const PART_REALISATIONS: u64 = 8192;

/// The footer value identifying a part: "condition start end".
pub fn part_value(condition: usize, range: &Range<u64>) -> String {
    format!("{condition} {} {}", range.start, range.end)
}

fn parse_part(value: &str) -> Option<(usize, Range<u64>)> {
    let mut it = value.split_whitespace().map(str::parse::<u64>);
    let (c, s, e) = (it.next()?.ok()?, it.next()?.ok()?, it.next()?.ok()?);
    (s < e).then_some((c as usize, s..e))
}

/// File name of the part of `condition` starting at realisation `start`, whose bytes have
/// the XXH64 checksum `hash`: the name records the checksum in the same rename that makes
/// the part complete.
pub fn part_name(condition: usize, start: u64, hash: u64) -> String {
    format!("part-c{condition:06}-r{start:015}-h{hash:016x}.parquet")
}

/// Whether `name` is a part's name: [`part_name`]'s, or one without the checksum (as an
/// engine that did not record it named its parts).
fn is_part_name(name: &str) -> bool {
    let Some(rest) = name
        .strip_prefix("part-c")
        .and_then(|r| r.strip_suffix(".parquet"))
    else {
        return false;
    };
    let digits = |s: &str, n: usize| s.len() == n && s.bytes().all(|b| b.is_ascii_digit());
    let mut fields = rest.split('-');
    match (fields.next(), fields.next(), fields.next(), fields.next()) {
        (Some(c), Some(r), hash, None) => {
            digits(c, 6)
                && r.strip_prefix('r').is_some_and(|r| digits(r, 15))
                && hash.is_none_or(|h| {
                    h.len() == 17
                        && h.starts_with('h')
                        && h[1..].bytes().all(|b| b.is_ascii_hexdigit())
                })
        }
        _ => false,
    }
}

/// The checksum a part's name records.
fn named_checksum(name: &str) -> Option<u64> {
    let hex = name.strip_prefix("part-")?.strip_suffix(".parquet")?;
    let (_, hex) = hex.rsplit_once("-h")?;
    (hex.len() == 16).then(|| u64::from_str_radix(hex, 16).ok())?
}

/// Commit a complete part (still under its temporary name) under the name that records
/// its checksum.
pub fn commit_part(
    file: PendingFile,
    condition: usize,
    start: u64,
) -> Result<PathBuf, OutputError> {
    let hash = file.checksum()?.hash;
    file.renamed(&part_name(condition, start, hash)).commit()
}

/// Fail with [`OutputError::Unsafe`], changing nothing, unless `staging` (the engine's
/// staging directory) is absent or a real directory holding only what the engine writes
/// there: parts ([`part_name`]) and files under temporary names. A symbolic link there could
/// lead anywhere, and a file of another name is not the engine's to delete.
pub fn ensure_staging(staging: &Path) -> Result<(), OutputError> {
    let unsafe_because = |reason: String| OutputError::Unsafe {
        file: staging.to_path_buf(),
        line: None,
        reason,
    };
    let meta = match fs::symlink_metadata(staging) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(OutputError::io(staging, e)),
    };
    if !meta.is_dir() {
        return Err(unsafe_because(format!(
            "is a {}, not the staging directory chassis-mc makes for its parts; nothing was \
             changed: move it away",
            crate::tabular::file_kind(&meta.file_type())
        )));
    }
    let mut foreign = Vec::new();
    for entry in fs::read_dir(staging).map_err(|e| OutputError::io(staging, e))? {
        let entry = entry.map_err(|e| OutputError::io(staging, e))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        let kind = entry.file_type().map_err(|e| OutputError::io(staging, e))?;
        let engines = kind.is_file() && (is_temporary(&name) || is_part_name(&name));
        if !engines {
            foreign.push(name);
        }
    }
    foreign.sort();
    match foreign.is_empty() {
        true => Ok(()),
        false => Err(unsafe_because(format!(
            "holds {}, which chassis-mc did not write (its staging directory holds only its \
             parts); nothing was changed: move them away",
            foreign.join(", ")
        ))),
    }
}

/// The staged parts in `staging` that belong to the study `identity`. Temporary files,
/// parts whose bytes do not match the checksum in their name (torn or corrupted), files
/// whose footer does not parse and parts of another study are deleted; `notice` is told
/// of each part that has to be redone because it was damaged.
pub fn scan_parts(
    staging: &Path,
    identity: &str,
    notice: &dyn Fn(&str),
) -> Result<Vec<Source>, OutputError> {
    let mut parts = Vec::new();
    let entries = match fs::read_dir(staging) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(parts),
        Err(e) => return Err(OutputError::io(staging, e)),
    };
    let mut paths: Vec<PathBuf> = entries
        .map(|e| e.map(|e| e.path()).map_err(|e| OutputError::io(staging, e)))
        .collect::<Result<_, _>>()?;
    paths.sort();
    for path in paths {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let keep = if is_temporary(&name) {
            false
        } else if named_checksum(&name) != Some(set::checksum(&path)?.hash) {
            notice(&format!(
                "{}: damaged (its bytes do not match the checksum in its name); its \
                 realisations are computed again",
                path.display()
            ));
            false
        } else {
            match read_metadata(&path) {
                Ok(footer) => match (
                    footer.get(keys::IDENTITY),
                    footer.get(keys::PART).and_then(parse_part),
                ) {
                    (Some(id), Some((c, range))) if id == identity => {
                        parts.push(Source {
                            path: path.clone(),
                            covers: vec![(c, range)],
                        });
                        true
                    }
                    _ => false, // another study's part
                },
                Err(_) => false, // no readable footer
            }
        };
        if !keep {
            fs::remove_file(&path).map_err(|e| OutputError::io(&path, e))?;
        }
    }
    Ok(parts)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parts_are_told_by_their_names() {
        assert!(is_part_name(&part_name(12, 8192, 0xdead_beef)));
        assert!(is_part_name("part-c000010-r000000000000000.parquet"));
        for other in [
            "notes.txt",
            "part-c10-r0.parquet",
            "part-c000010-r000000000000000-hxyz.parquet",
            "part-c000010-r000000000000000-h0000000000000000-x.parquet",
        ] {
            assert!(!is_part_name(other), "{other}");
        }
    }
}
