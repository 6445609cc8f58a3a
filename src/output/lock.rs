//! One writer per output directory.
//!
//! Two runs into one directory would replace each other's files halfway. A process that
//! writes a directory first takes an exclusive advisory lock (`flock`) on its
//! [`LOCK`] file and records its pid there; a second process is refused with that pid. The
//! operating system releases the lock when its holder exits, however it exits, so a lock
//! left by a killed process is simply taken over. A holder that ends cleanly removes the
//! file (and the directory, if it made it and left it empty): a process that opened the
//! file just before and then locks it finds that the path no longer names what it locked,
//! and starts again.
//!
//! The lock file is the engine's own: a symbolic link there, or a file that holds anything
//! but a pid (a user's file of that name), is refused and left as it is.

use std::fs::{self, File, OpenOptions, TryLockError};
use std::io::{Read, Seek, Write};
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

use super::OutputError;

/// File name of the lock inside an output directory.
pub const LOCK: &str = ".chassis-mc-lock";

/// An exclusive lock on an output directory, released when dropped.
#[derive(Debug)]
pub struct DirLock {
    file: Option<File>,
    /// The pid of a previous holder that exited without releasing it cleanly, if any.
    pub taken_over_from: Option<u32>,
    path: PathBuf,
    /// The directory, when this lock created it.
    created: Option<PathBuf>,
}

/// How many times [`DirLock::acquire`] starts again when the file it locked was removed
/// by its previous holder in the meantime (each time means another process made progress).
const ATTEMPTS: usize = 64;

impl DirLock {
    /// Create `dir` if needed and lock it; [`OutputError::Locked`] names the pid of the
    /// process holding it, [`OutputError::Unsafe`] a lock path that is not the engine's.
    pub fn acquire(dir: &Path) -> Result<DirLock, OutputError> {
        let unwritable = |source| OutputError::Unwritable {
            dir: dir.to_path_buf(),
            source,
        };
        let created = match dir.exists() {
            true => None,
            false => {
                fs::create_dir_all(dir).map_err(unwritable)?;
                Some(dir.to_path_buf())
            }
        };
        let path = dir.join(LOCK);
        for _ in 0..ATTEMPTS {
            if let Some(lock) = Self::try_once(dir, &path, &created).map_err(|e| match e {
                OutputError::Io { source, .. } => unwritable(source),
                e => e,
            })? {
                return Ok(lock);
            }
        }
        Err(OutputError::Locked {
            dir: dir.to_path_buf(),
            pid: None,
        })
    }

    /// One attempt: `Ok(None)` when the file locked was no longer the one at `path`.
    fn try_once(
        dir: &Path,
        path: &Path,
        created: &Option<PathBuf>,
    ) -> Result<Option<DirLock>, OutputError> {
        ensure_plain_file(path)?;
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(path)
            .map_err(|e| OutputError::io(path, e))?;
        let mut previous = String::new();
        let _ = file.read_to_string(&mut previous);
        let pid = |text: &str| text.trim().parse::<u32>().ok();
        match file.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                return Err(OutputError::Locked {
                    dir: dir.to_path_buf(),
                    pid: pid(&previous),
                });
            }
            Err(TryLockError::Error(e)) => return Err(OutputError::io(path, e)),
        }
        // The previous holder may have removed the file between our open and our lock.
        let same = match (file.metadata(), fs::symlink_metadata(path)) {
            (Ok(held), Ok(named)) => held.dev() == named.dev() && held.ino() == named.ino(),
            _ => false,
        };
        if !same {
            return Ok(None);
        }
        // Read again under the lock: what a holder wrote is complete now.
        previous.clear();
        let _ = file
            .rewind()
            .and_then(|()| file.read_to_string(&mut previous));
        if !previous.trim().is_empty() && pid(&previous).is_none() {
            return Err(OutputError::Unsafe {
                file: path.to_path_buf(),
                line: None,
                reason: "holds something other than a process id, so it is not a chassis-mc \
                         lock (a file of yours?); it was left as it is: move it away"
                    .into(),
            });
        }
        let taken_over_from = pid(&previous).filter(|&p| p != std::process::id());
        file.set_len(0)
            .and_then(|()| file.rewind())
            .and_then(|()| writeln!(file, "{}", std::process::id()))
            .and_then(|()| file.flush())
            .map_err(|e| OutputError::io(path, e))?;
        Ok(Some(DirLock {
            file: Some(file),
            taken_over_from,
            path: path.to_path_buf(),
            created: created.clone(),
        }))
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// Fail with [`OutputError::Unsafe`] if something other than a regular file (a symbolic
/// link, a directory, a FIFO) is at `path`, an engine's bookkeeping file: following or
/// replacing it could reach outside the output directory or hang.
pub fn ensure_plain_file(path: &Path) -> Result<(), OutputError> {
    match fs::symlink_metadata(path) {
        Ok(m) if !m.file_type().is_file() => Err(OutputError::Unsafe {
            file: path.to_path_buf(),
            line: None,
            reason: format!(
                "is a {}, not a file chassis-mc wrote; it was left as it is: move it away",
                crate::tabular::file_kind(&m.file_type())
            ),
        }),
        _ => Ok(()),
    }
}

impl Drop for DirLock {
    fn drop(&mut self) {
        // Remove the file while holding the lock, then release it with the handle: a
        // process waiting on the old file finds the path changed and starts again.
        let _ = fs::remove_file(&self.path);
        drop(self.file.take());
        if let Some(dir) = &self.created {
            let _ = fs::remove_dir(dir); // only if this run left it empty
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_lock_is_refused_with_the_holders_pid_and_free_after_release() {
        let dir = tempfile::tempdir().unwrap();
        let first = DirLock::acquire(dir.path()).unwrap();
        match DirLock::acquire(dir.path()) {
            Err(OutputError::Locked { pid, .. }) => assert_eq!(pid, Some(std::process::id())),
            other => panic!("expected Locked, got {other:?}"),
        }
        drop(first);
        assert!(
            !dir.path().join(LOCK).exists(),
            "a clean release leaves no file"
        );
        let again = DirLock::acquire(dir.path()).unwrap();
        assert_eq!(again.taken_over_from, None);
    }

    #[test]
    fn a_lock_of_a_killed_process_is_taken_over_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        fs::write(dir.path().join(LOCK), "4242\n").unwrap();
        let lock = DirLock::acquire(dir.path()).unwrap();
        assert_eq!(lock.taken_over_from, Some(4242));
    }

    #[test]
    fn a_users_file_or_a_link_at_the_lock_path_is_refused_and_kept() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(LOCK);
        fs::write(&path, "keep this\n").unwrap();
        assert!(matches!(
            DirLock::acquire(dir.path()),
            Err(OutputError::Unsafe { .. })
        ));
        assert_eq!(fs::read_to_string(&path).unwrap(), "keep this\n");
        fs::remove_file(&path).unwrap();
        let target = dir.path().join("elsewhere");
        fs::write(&target, "").unwrap();
        std::os::unix::fs::symlink(&target, &path).unwrap();
        assert!(matches!(
            DirLock::acquire(dir.path()),
            Err(OutputError::Unsafe { .. })
        ));
        assert!(
            fs::symlink_metadata(&path)
                .unwrap()
                .file_type()
                .is_symlink()
        );
    }

    #[test]
    fn a_directory_the_lock_created_goes_when_left_empty() {
        let dir = tempfile::tempdir().unwrap();
        let fresh = dir.path().join("fresh");
        drop(DirLock::acquire(&fresh).unwrap());
        assert!(!fresh.exists());
    }
}
