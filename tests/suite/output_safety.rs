//! What the engine reads and touches in an output directory is what it may: readers see one
//! consistent, undamaged set; the engine's bookkeeping cannot lead it outside the directory;
//! a user's files and a user's shards are never replaced silently; bad arguments say what
//! is wrong. Each test is named after the guarantee it pins and reproduces the case that
//! broke it.
//!
//! Every realisation is a pure function of (seed, condition, realisation) and summaries use
//! exact sums, so outputs are compared byte for byte, not within a tolerance.

use std::path::Path;
use std::process::{Command, Output, Stdio};

use chassis_mc::output::set::{JOURNAL, MANIFEST};

use super::common::*;

/// `chassis-mc ARGS…` (stdin closed).
fn chassis(args: &[&std::ffi::OsStr]) -> Command {
    let mut cmd = Command::new(bin());
    cmd.args(args).stdin(Stdio::null());
    cmd
}

/// `chassis-mc run studies/thesis.toml --out DIR --quiet` with extra arguments.
fn run_cmd(out: &Path, extra: &[&str]) -> Command {
    let study = study_path("thesis.toml");
    let mut cmd = chassis(&["run".as_ref(), study.as_os_str(), "--out".as_ref()]);
    cmd.arg(out).arg("--quiet").args(extra);
    cmd
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn succeeds(mut cmd: Command) -> Output {
    let o = cmd.output().unwrap();
    assert!(o.status.success(), "failed: {}", stderr(&o));
    o
}

/// The command exits 2 with one message containing every one of `needles`.
fn refused(mut cmd: Command, needles: &[&str]) -> Output {
    let o = cmd.output().unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    // (a notice such as "resuming: …" may precede it)
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

fn read(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn journal_and_manifest_paths_never_reach_outside_the_directory() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("d");
    let r = ["--realisations", "5", "--no-figures"];
    succeeds(run_cmd(&out, &r));
    let victim = tmp.path().join("victim.txt");
    let report = read(&out.join("report.html"));
    let manifest = std::fs::read_to_string(out.join(MANIFEST)).unwrap();

    // A journal deleting an absolute path, and one renaming a file of the set onto a path
    // with `..`: the run refuses the directory and does neither.
    let journals = [
        format!("chassis-mc journal 1\ndelete\t{}\n", victim.display()),
        "chassis-mc journal 1\nrename\treport.html\t../victim.txt\n".to_string(),
    ];
    for journal in &journals {
        std::fs::write(&victim, b"victim").unwrap();
        std::fs::write(out.join(JOURNAL), journal).unwrap();
        let path = out.join(JOURNAL).display().to_string();
        refused(
            run_cmd(&out, &r),
            &[&path, "line 2", "refusing this directory"],
        );
        assert_eq!(read(&victim), b"victim", "{journal}");
        assert_eq!(read(&out.join("report.html")), report, "{journal}");
    }
    std::fs::remove_file(out.join(JOURNAL)).unwrap();

    // A manifest entry naming `../victim2.txt`: a run would delete it as a file of the old
    // set; every command refuses the directory instead.
    let victim2 = tmp.path().join("victim2.txt");
    std::fs::write(&victim2, b"victim").unwrap();
    let lines = manifest.lines().count();
    std::fs::write(
        out.join(MANIFEST),
        format!("{manifest}0123456789abcdef\t6\t../victim2.txt\n"),
    )
    .unwrap();
    let line = format!("line {}", lines + 1);
    refused(run_cmd(&out, &r), &["../victim2.txt", &line]);
    refused(
        chassis(&["summarize".as_ref(), out.as_os_str()]),
        &["../victim2.txt"],
    );
    refused(
        chassis(&["figures".as_ref(), out.as_os_str()]),
        &["../victim2.txt"],
    );
    assert_eq!(read(&victim2), b"victim");

    // A plain entry under a directory that is a symbolic link to elsewhere: deleting it
    // would delete the file the link leads to.
    let elsewhere = tmp.path().join("elsewhere");
    std::fs::create_dir(&elsewhere).unwrap();
    std::fs::write(elsewhere.join("x.svg"), b"victim").unwrap();
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(&elsewhere, out.join("figures")).unwrap();
        std::fs::write(
            out.join(MANIFEST),
            format!("{manifest}0123456789abcdef\t6\tfigures/x.svg\n"),
        )
        .unwrap();
        refused(run_cmd(&out, &r), &["symbolic link", "figures/x.svg"]);
        assert_eq!(read(&elsewhere.join("x.svg")), b"victim");
        assert!(!out.join(JOURNAL).exists(), "refused before the journal");
    }
}
