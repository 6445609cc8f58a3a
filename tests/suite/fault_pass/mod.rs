//! What a new user's fault pass found: each test reproduces one case that misbehaved
//! (deleted files outside the output directory, replaced a shard, overwrote a measured log,
//! ran a meaningless truth with exit 0, called an unbiased estimator biased, hung on a
//! FIFO, blamed the wrong key, exited 1 for an unusable directory, accepted duplicate
//! conditions, left litter, hid the results under `--quiet`) and pins the fix. A refusal is
//! exit status 2 with one message naming the file, key or column and the reason, with
//! nothing changed on disk.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use super::common::*;

mod inputs;
mod outputs;

/// `chassis-mc ARGS…` (stdin closed).
pub(super) fn chassis<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Command {
    let mut cmd = Command::new(bin());
    cmd.args(args).stdin(Stdio::null());
    cmd
}

pub(super) fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

pub(super) fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The command exits 2 with one error message containing every one of `needles`.
pub(super) fn refused(mut cmd: Command, needles: &[&str]) -> Output {
    let o = cmd.output().unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(
        err.lines().filter(|l| l.starts_with("error")).count(),
        1,
        "one error: {err}"
    );
    for needle in needles {
        assert!(err.contains(needle), "no \"{needle}\" in: {err}");
    }
    o
}

pub(super) fn succeeds(mut cmd: Command) -> Output {
    let o = cmd.output().unwrap();
    assert!(o.status.success(), "failed: {}", stderr(&o));
    o
}

/// The thesis study shortened to `duration` s at scale 1, OLS, with `noise` as its
/// `[noise]` lines and `extra` appended, written to `dir/name`.
pub(super) fn short_study(
    dir: &Path,
    name: &str,
    duration: f64,
    noise: &str,
    extra: &str,
) -> PathBuf {
    let text = set_key(
        &study_text("thesis.toml"),
        "duration",
        &format!("{duration:.1}"),
    );
    let text = set_key(&text, "scales", "[1.0]");
    let text = set_key(&text, "velocity_sd", noise);
    let path = dir.join(name);
    std::fs::write(&path, format!("{text}\n{extra}\n")).unwrap();
    path
}

/// The lines of the shipped route log (`studies/data/route_trace.csv`: comment lines, the
/// header `time_s,speed_kmh,grade_pct`, the rows).
pub(super) fn trace_lines() -> Vec<String> {
    std::fs::read_to_string(root().join("studies/data/route_trace.csv"))
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect()
}

/// `run STUDY --out OUT --quiet` with extra arguments.
pub(super) fn run_into(study: &Path, out: &Path, extra: &[&str]) -> Command {
    let mut cmd = chassis(&[
        "run".as_ref(),
        study.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
    ]);
    cmd.arg("--quiet").args(extra);
    cmd
}

/// Every file under `dir` (following no link) with its bytes, for before/after comparisons.
pub(super) fn tree(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in entries {
            let e = e.unwrap();
            let t = e.file_type().unwrap();
            if t.is_dir() {
                stack.push(e.path());
            } else if t.is_file() {
                out.push((e.path(), std::fs::read(e.path()).unwrap()));
            } else {
                out.push((e.path(), Vec::new()));
            }
        }
    }
    out.sort();
    out
}
