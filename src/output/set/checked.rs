//! Checksums, and opening a file the manifest vouches for ([`open_checked`]).

use std::fs::File;
use std::hash::Hasher;
use std::io::Read;
use std::path::Path;

use twox_hash::XxHash64;

use super::{Checksum, JOURNAL, Manifest};
use crate::output::{self, OutputError};

/// The checksum of the file at `path` (read in 1 MiB blocks).
pub fn checksum(path: &Path) -> Result<Checksum, OutputError> {
    let mut file = File::open(path).map_err(|e| OutputError::io(path, e))?;
    checksum_of(&mut file, path)
}

/// The checksum of what is left to read of `file` (opened at `path`).
pub(crate) fn checksum_of(file: &mut File, path: &Path) -> Result<Checksum, OutputError> {
    let mut hasher = XxHash64::with_seed(0);
    let mut buffer = vec![0u8; 1 << 20];
    let mut len = 0u64;
    loop {
        let n = file
            .read(&mut buffer)
            .map_err(|e| OutputError::io(path, e))?;
        if n == 0 {
            break;
        }
        hasher.write(&buffer[..n]);
        len += n as u64;
    }
    Ok(Checksum {
        len,
        hash: hasher.finish(),
    })
}

/// Whether the file `name` in `dir` is the one the manifest recorded: `Ok(None)` if it is,
/// otherwise why it cannot be trusted.
pub fn verify_file(dir: &Path, name: &str) -> Result<Option<String>, OutputError> {
    let Some(manifest) = Manifest::read(dir)? else {
        return Ok(Some("no checksum was recorded for it".into()));
    };
    let Some(entry) = manifest.get(name) else {
        return Ok(Some("it is not part of the directory's output set".into()));
    };
    let found = checksum(&dir.join(name))?;
    Ok((found != entry.checksum).then(|| {
        format!(
            "its content does not match the checksum recorded when it was written \
             ({:#} recorded; {found:#} found)",
            entry.checksum
        )
    }))
}

/// How many times [`open_checked`] looks again when a commit may be replacing the file,
/// waiting 10, 20, 40 … ms in between (1.3 s in all; a commit's renames take milliseconds).
const CHECK_ATTEMPTS: u32 = 8;

/// Open the file at `path` and, if its directory's manifest lists it, check the bytes of
/// that open file against the checksum recorded there. What the caller reads through the
/// returned handle is then the file the manifest vouched for, whatever a run renames over
/// the path afterwards.
///
/// A commit may be under way (a journal in the directory) or may happen between the open
/// and the manifest's read: the check is repeated until the file, the manifest and the
/// absence of a journal agree, or fails with [`OutputError::Incomplete`] (a journal that
/// stays) or [`OutputError::Damaged`] (the bytes differ and nothing is changing). A file
/// the manifest does not list (or in a directory without one) is opened unchecked.
pub fn open_checked(path: &Path) -> Result<output::OpenedFile, OutputError> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut attempt = 0;
    loop {
        let last = attempt + 1 >= CHECK_ATTEMPTS;
        let again = |attempt: u32| {
            std::thread::sleep(std::time::Duration::from_millis(10 << attempt));
        };
        if dir.join(JOURNAL).exists() {
            if last {
                return Err(OutputError::Incomplete {
                    dir: dir.to_path_buf(),
                });
            }
            again(attempt);
            attempt += 1;
            continue;
        }
        let file = output::OpenedFile::open(path)?;
        output::pause("input-opened");
        let manifest = Manifest::read(dir)?;
        let Some(entry) = manifest.as_ref().and_then(|m| m.get(&name)) else {
            return Ok(file);
        };
        let found = file.checksum()?;
        if found == entry.checksum {
            return Ok(file);
        }
        // Did a commit replace the file or the manifest since the open?
        let changing =
            dir.join(JOURNAL).exists() || Manifest::read(dir)? != manifest || !file.is_at(path);
        if !changing || last {
            return Err(OutputError::Damaged {
                path: path.to_path_buf(),
                recorded: entry.checksum,
                found,
                remedy: "run the study (or its shard) that wrote it again".into(),
            });
        }
        again(attempt);
        attempt += 1;
    }
}
