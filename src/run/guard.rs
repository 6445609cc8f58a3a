//! The checks a run makes on its output directory before it writes: the directory's lock,
//! and refusing shards that an unsharded run would replace or that belong to another run.

use std::fs;
use std::path::Path;

use super::shard::Shard;
use super::summarize;
use crate::montecarlo::Observer;
use crate::output::lock::DirLock;
use crate::output::{self, FileMetadata, OutputError, files, set};

/// Fail if `dir` holds shards (`shard=K/` with a realisation file or a manifest): an
/// unsharded run would replace the set they belong to, and the engine never deletes them.
pub(super) fn refuse_shards(dir: &Path) -> Result<(), OutputError> {
    let mut shards = Vec::new();
    for entry in fs::read_dir(dir).map_err(|e| OutputError::io(dir, e))? {
        let entry = entry.map_err(|e| OutputError::io(dir, e))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        let path = entry.path();
        let file = path.join(files::REALISATIONS);
        if !name.starts_with("shard=") || !(file.is_file() || path.join(set::MANIFEST).is_file()) {
            continue;
        }
        let footer = output::read_metadata(&file).unwrap_or_default();
        shards.push(
            match (
                footer.get(output::keys::SEED),
                footer.get(output::keys::REALISATIONS),
            ) {
                (Some(seed), Some(r)) => format!("{name} (seed {seed}, {r} realisations)"),
                _ => name,
            },
        );
    }
    shards.sort();
    match shards.is_empty() {
        true => Ok(()),
        false => Err(OutputError::ShardsPresent {
            dir: dir.to_path_buf(),
            shards,
        }),
    }
}

/// Fail if `out_dir` holds another shard (`shard=J/`, J ≠ this one's) of a different run
/// than `meta` describes as shard `shard`: another study, seed, R, engine or split. The
/// shard would join a set it does not belong to (and its summary could not be made).
pub(super) fn refuse_other_runs_shards(
    out_dir: &Path,
    shard: Shard,
    meta: &FileMetadata,
) -> Result<(), OutputError> {
    let entries = match fs::read_dir(out_dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(OutputError::io(out_dir, e)),
    };
    let mut names: Vec<String> = entries
        .filter_map(Result::ok)
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("shard=") && *n != shard.dir_name())
        .collect();
    names.sort();
    let mine = output::Footer::of(
        &meta.with(output::keys::SHARD, shard.to_string()),
        "realisations",
    );
    for name in names {
        let file = out_dir.join(&name).join(files::REALISATIONS);
        if !file.is_file() {
            continue;
        }
        let theirs = output::read_metadata(&file)?;
        let mut differences = Vec::new();
        let split = |f: &output::Footer| {
            f.get(output::keys::SHARD)
                .and_then(|s| s.split_once('/'))
                .map(|(_, n)| n.to_string())
        };
        if split(&theirs) != split(&mine) {
            differences.push(format!(
                "the number of shards {} here, {} there",
                shard.count,
                split(&theirs).unwrap_or_else(|| "none".into())
            ));
        }
        if theirs.get(output::keys::IDENTITY) != mine.get(output::keys::IDENTITY)
            || theirs.get(output::keys::REALISATIONS) != mine.get(output::keys::REALISATIONS)
        {
            differences.extend(summarize::differences(&mine, &theirs));
        }
        if !differences.is_empty() {
            return Err(OutputError::ShardOfAnotherRun {
                dir: out_dir.to_path_buf(),
                shard: shard.to_string(),
                other: file,
                differences,
            });
        }
    }
    Ok(())
}

/// Lock `dir` for this process (creating it), telling `observer` when the lock of a killed
/// process is taken over.
pub(super) fn lock(dir: &Path, observer: &dyn Observer) -> Result<DirLock, OutputError> {
    let lock = DirLock::acquire(dir)?;
    if let Some(pid) = lock.taken_over_from {
        observer.notice(&format!(
            "{}: taking over the lock last held by process {pid}, which no longer holds it (it \
             was killed, or its run was interrupted)",
            dir.display()
        ));
    }
    Ok(lock)
}
