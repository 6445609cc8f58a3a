//! Every path a manifest or journal names stays inside the output directory.

use std::fs;
use std::path::Path;

use super::Op;
use crate::output::OutputError;

/// Why `path`, read from a manifest or a journal, is not a plain relative path inside the
/// output directory: an absolute path, an empty, `.` or `..` component, or a backslash (a
/// separator elsewhere) would let the file name a place outside it.
pub(super) fn confined(path: &str) -> Result<(), String> {
    let plain = !path.is_empty()
        && !path.contains('\\')
        && path
            .split('/')
            .all(|c| !c.is_empty() && c != "." && c != "..")
        && Path::new(path)
            .components()
            .all(|c| matches!(c, std::path::Component::Normal(_)));
    match plain {
        true => Ok(()),
        false => Err(format!(
            "`{path}` is not a plain relative path inside the output directory (absolute \
             paths and `..` are refused)"
        )),
    }
}

/// Why `dir/path` may lie outside `dir` although `path` is [`confined`]: a directory on
/// the way is a symbolic link. (The file itself may be a link: renaming over it or deleting
/// it replaces the link, not what it points to.)
pub(super) fn link_escape(dir: &Path, path: &str) -> Option<String> {
    let mut at = dir.to_path_buf();
    let components: Vec<&str> = path.split('/').collect();
    for c in &components[..components.len().saturating_sub(1)] {
        at.push(c);
        if fs::symlink_metadata(&at).is_ok_and(|m| m.file_type().is_symlink()) {
            return Some(format!(
                "`{path}` passes through the symbolic link {}, which may lead outside the \
                 output directory",
                at.display()
            ));
        }
    }
    None
}

/// Check every step of `ops` before any is carried out: each must stay inside `dir`. An
/// error names the `journal` and the step's line in it, else the file the step names.
pub(super) fn check_steps(
    dir: &Path,
    ops: &[Op],
    journal: Option<&Path>,
) -> Result<(), OutputError> {
    for (i, op) in ops.iter().enumerate() {
        for path in op.paths() {
            if let Some(reason) = confined(path).err().or_else(|| link_escape(dir, path)) {
                return Err(OutputError::Unsafe {
                    file: journal.map_or_else(|| dir.join(path), Path::to_path_buf),
                    line: journal.map(|_| i + 2),
                    reason,
                });
            }
        }
    }
    Ok(())
}
