//! One writer per output directory.
//!
//! Two runs into one directory would replace each other's files halfway. A process that
//! writes a directory first takes an exclusive advisory lock (`flock`) on its
//! [`LOCK`] file and records its pid there; a second process is refused with that pid. The
//! operating system releases the lock when its holder exits, however it exits, so a lock
//! left by a killed process is simply taken over. The file itself stays (removing it would
//! race with a process that has just opened it).

use std::fs::{self, File, OpenOptions, TryLockError};
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};

use super::OutputError;

/// File name of the lock inside an output directory.
pub const LOCK: &str = ".chassis-mc-lock";

/// An exclusive lock on an output directory, released when dropped.
#[derive(Debug)]
pub struct DirLock {
    file: File,
    /// The pid of a previous holder that exited without releasing it cleanly, if any.
    pub taken_over_from: Option<u32>,
    path: PathBuf,
}

impl DirLock {
    /// Create `dir` if needed and lock it; [`OutputError::Locked`] names the pid of the
    /// process holding it.
    pub fn acquire(dir: &Path) -> Result<DirLock, OutputError> {
        fs::create_dir_all(dir).map_err(|e| OutputError::io(dir, e))?;
        let path = dir.join(LOCK);
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .map_err(|e| OutputError::io(&path, e))?;
        let mut previous = String::new();
        match file.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                let _ = file.read_to_string(&mut previous);
                return Err(OutputError::Locked {
                    dir: dir.to_path_buf(),
                    pid: previous.trim().parse().ok(),
                });
            }
            Err(TryLockError::Error(e)) => return Err(OutputError::io(&path, e)),
        }
        let _ = file.read_to_string(&mut previous);
        let taken_over_from = previous
            .trim()
            .parse::<u32>()
            .ok()
            .filter(|&pid| pid != std::process::id());
        file.set_len(0)
            .and_then(|()| file.rewind())
            .and_then(|()| writeln!(file, "{}", std::process::id()))
            .and_then(|()| file.flush())
            .map_err(|e| OutputError::io(&path, e))?;
        Ok(DirLock {
            file,
            taken_over_from,
            path,
        })
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for DirLock {
    fn drop(&mut self) {
        // Leave no stale pid behind a clean exit (the lock itself goes with the file handle).
        let _ = self.file.set_len(0);
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
        let again = DirLock::acquire(dir.path()).unwrap();
        assert_eq!(again.taken_over_from, None);
    }
}
