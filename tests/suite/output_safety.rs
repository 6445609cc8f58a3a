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

/// Wait until `path` exists (a paused process has reached its pause point).
fn wait_for(path: &Path, child: &mut std::process::Child) {
    let started = std::time::Instant::now();
    while !path.exists() {
        if let Some(status) = child.try_wait().unwrap() {
            panic!("exited ({status}) before reaching its pause point");
        }
        assert!(
            started.elapsed() < std::time::Duration::from_secs(120),
            "never paused"
        );
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
}

#[test]
fn summarize_reads_one_consistent_set_while_a_run_replaces_it() {
    // `summarize D --out E` holds no lock on D, so a run may replace D's realisation file
    // while the summary reads it. Paused at two instants — between its two passes, and
    // between opening its input and checking it against the manifest — while a run with
    // another seed replaces the file, the summary must be that of one run, byte for byte:
    // of the file it opened (which a rename over its path does not change), or of the new
    // one when the check saw the commit and opened again. Mixed, it would differ (its
    // EmpSE from one run's mean and the other's values).
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path().join("d");
    let seed = |s: &'static str| ["--realisations", "30", "--no-figures", "--seed", s];
    succeeds(run_cmd(&d, &seed("1")));
    let seed_1 = read(&d.join("summary.parquet"));
    // (point, the seed D holds when paused, the seed a run writes meanwhile)
    for (point, new_seed) in [("between-passes", "2"), ("input-opened", "1")] {
        let go = tmp.path().join(format!("go-{point}"));
        let out = tmp.path().join(format!("summary-{point}"));
        let mut summarize = chassis(&["summarize".as_ref(), d.as_os_str(), "--out".as_ref()]);
        let mut child = summarize
            .arg(&out)
            .args(["--no-figures", "--quiet"])
            .env("CHASSIS_MC_PAUSE", format!("{point}:{}", go.display()))
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        wait_for(&tmp.path().join(format!("go-{point}.paused")), &mut child);
        succeeds(run_cmd(&d, &seed(new_seed)));
        std::fs::write(&go, b"").unwrap();
        let o = child.wait_with_output().unwrap();
        assert!(o.status.success(), "{point}: {}", stderr(&o));
        // Paused between the passes, it finishes the seed-1 file it opened; paused before
        // its check, it sees the commit and reads the new seed-1 file.
        assert!(
            read(&out.join("summary.parquet")) == seed_1,
            "{point}: the summary is not that of the seed-1 run"
        );
    }
}

/// XOR one byte at `offset` (from the end when negative).
fn flip(path: &Path, offset: i64) {
    let mut bytes = read(path);
    let at = if offset < 0 {
        (bytes.len() as i64 + offset) as usize
    } else {
        offset as usize
    };
    bytes[at] ^= 0x01;
    std::fs::write(path, bytes).unwrap();
}

/// The figures of `dir` with their bytes.
fn figures_of(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut found: Vec<_> = std::fs::read_dir(dir.join("figures"))
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().to_string_lossy().into_owned(),
                read(&e.path()),
            )
        })
        .collect();
    found.sort();
    found
}

#[test]
fn figures_and_summarize_refuse_a_damaged_input_naming_it() {
    // One flipped byte of summary.parquet (offset 100 changed every figure; offset 3000
    // one MCSE; others raised raw Parquet errors) or cycles.parquet: `figures` names the
    // file as damaged, exits 2 and leaves the figures as they were. The same for a
    // realisation file given to `summarize`.
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path().join("d");
    succeeds(run_cmd(&d, &["--realisations", "20"]));
    let before = figures_of(&d);
    let figures = || chassis(&["figures".as_ref(), d.as_os_str()]);
    for (name, offsets) in [
        ("summary.parquet", &[100, 3000, -100, -10][..]),
        ("cycles.parquet", &[100, -10][..]),
    ] {
        let path = d.join(name);
        let len = read(&path).len() as i64;
        for &offset in offsets.iter().chain([len / 2].iter()) {
            flip(&path, offset);
            let shown = format!("{}: damaged", path.display());
            refused(figures(), &[&shown, "summarize"]);
            assert!(
                figures_of(&d) == before,
                "{name} at {offset}: figures changed"
            );
            flip(&path, offset); // restored
        }
    }
    succeeds(figures());
    assert!(figures_of(&d) == before);

    let realisations = d.join("realisations.parquet");
    flip(&realisations, 3000);
    let shown = format!("{}: damaged", realisations.display());
    refused(chassis(&["summarize".as_ref(), d.as_os_str()]), &[&shown]);
}

#[test]
fn an_unsharded_run_never_deletes_shards() {
    // Shards with seed 5, then an unsharded run with seed 6 into the same directory: it
    // deleted both shard files. Now it refuses, naming them and what differs, and they
    // stay byte for byte; `summarize` still combines them (and keeps them).
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path().join("d");
    for k in ["0/2", "1/2"] {
        let args = ["--realisations", "20", "--seed", "5", "--shard", k];
        succeeds(run_cmd(&d, &args));
    }
    let shard = |k: u32| d.join(format!("shard={k}/realisations.parquet"));
    let before = [read(&shard(0)), read(&shard(1))];
    for seed in ["6", "5"] {
        refused(
            run_cmd(&d, &["--realisations", "20", "--seed", seed]),
            &[
                "shard=0 (seed 5, 20 realisations)",
                "shard=1 (seed 5, 20 realisations)",
                "summarize",
            ],
        );
        assert!([read(&shard(0)), read(&shard(1))] == before, "seed {seed}");
    }
    assert!(!d.join("summary.parquet").exists(), "nothing written");
    succeeds(chassis(&[
        "summarize".as_ref(),
        d.as_os_str(),
        "--quiet".as_ref(),
    ]));
    assert!([read(&shard(0)), read(&shard(1))] == before);
}

#[test]
fn a_users_files_at_the_engines_paths_are_never_overwritten() {
    // A fresh --out holding a user's report.html, summary.parquet and figures/cycles.svg
    // (no manifest): each was overwritten. Now every command refuses (exit 2), naming the
    // files, and they stay as they were.
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path().join("d");
    std::fs::create_dir_all(d.join("figures")).unwrap();
    let mine = [
        ("report.html", &b"<html>my report</html>"[..]),
        ("summary.parquet", b"my table"),
        ("figures/cycles.svg", b"<svg>my figure</svg>"),
    ];
    for (name, bytes) in mine {
        std::fs::write(d.join(name), bytes).unwrap();
    }
    let intact = |present: &[&str]| {
        for (name, bytes) in mine {
            if present.contains(&name) {
                assert_eq!(read(&d.join(name)), bytes, "{name} changed");
            }
        }
    };
    let r = ["--realisations", "5"];
    // The tables, the report and the figures are checked before any work; nothing is
    // written.
    refused(
        run_cmd(&d, &r),
        &[
            "figures/cycles.svg, report.html, summary.parquet",
            "did not write",
        ],
    );
    intact(&["report.html", "summary.parquet", "figures/cycles.svg"]);
    assert!(!d.join("realisations.parquet").exists());
    // A figure alone stops the run before its work too (it used to stop only the commit,
    // losing the realisations computed).
    std::fs::remove_file(d.join("report.html")).unwrap();
    std::fs::remove_file(d.join("summary.parquet")).unwrap();
    refused(run_cmd(&d, &r), &["figures/cycles.svg", "did not write"]);
    intact(&["figures/cycles.svg"]);
    assert!(!d.join("summary.parquet").exists(), "nothing committed");
    assert!(!d.join("realisations.parquet").exists(), "no work done");
    // Without figures the run goes ahead beside the user's figure; redrawing the figures
    // into that directory (now with a manifest that does not list it) is refused too.
    succeeds(run_cmd(&d, &["--realisations", "5", "--no-figures"]));
    refused(
        chassis(&["figures".as_ref(), d.as_os_str()]),
        &["figures/cycles.svg"],
    );
    intact(&["figures/cycles.svg"]);
    // `summarize --out` into a fresh directory holding a user's report.
    let e = tmp.path().join("e");
    std::fs::create_dir(&e).unwrap();
    std::fs::write(e.join("report.html"), mine[0].1).unwrap();
    refused(
        chassis(&[
            "summarize".as_ref(),
            d.as_os_str(),
            "--out".as_ref(),
            e.as_os_str(),
            "--no-figures".as_ref(),
        ]),
        &["report.html"],
    );
    assert_eq!(read(&e.join("report.html")), mine[0].1);
}

#[test]
fn mixed_shards_are_refused_naming_what_differs() {
    // Shards of one study with different seeds were refused as "a different study or R
    // (realisations 30 vs 30)". The message names what differs, and only that; and the
    // shard of another run is refused when it is run, before it can join the directory.
    let tmp = tempfile::tempdir().unwrap();
    let heavier = tmp.path().join("heavier.toml");
    std::fs::write(
        &heavier,
        set_key(&study_text("thesis.toml"), "mass", "1900.0"),
    )
    .unwrap();
    let thesis = study_path("thesis.toml");
    // (case, shard 1's study, R, seed; what the message says; what it must not say)
    let cases = [
        ("seed", &thesis, "20", "6", "seed 6 here, 5 there", "study"),
        (
            "r",
            &thesis,
            "30",
            "5",
            "realisations per condition 30 here, 20 there",
            "seed",
        ),
        ("study", &heavier, "20", "5", "the study", "seed"),
    ];
    for (case, study, r, seed, says, not) in cases {
        let d = tmp.path().join(case);
        succeeds(run_cmd(
            &d,
            &["--realisations", "20", "--seed", "5", "--shard", "0/2"],
        ));
        let mut second = chassis(&["run".as_ref(), study.as_os_str(), "--out".as_ref()]);
        second.arg(&d).args([
            "--quiet",
            "--realisations",
            r,
            "--seed",
            seed,
            "--shard",
            "1/2",
        ]);
        let o = refused(second, &["shard 1/2", "shard=0/realisations.parquet", says]);
        let err = stderr(&o);
        let (_, reason) = err.split_once("they differ in").unwrap();
        let (reason, _) = reason.split_once("; run it").unwrap();
        assert!(!reason.contains(not), "{case}: {err}");
        assert!(
            !d.join("shard=1").exists(),
            "{case}: the refused shard left a directory"
        );
    }
}

#[test]
fn a_missing_path_is_a_bad_argument_for_summarize_and_figures() {
    // `summarize /nonexistent` exited 1 where `figures` exited 2.
    let tmp = tempfile::tempdir().unwrap();
    let missing = tmp.path().join("nonexistent");
    let shown = format!("{}: no such file or directory", missing.display());
    for command in ["summarize", "figures"] {
        refused(chassis(&[command.as_ref(), missing.as_os_str()]), &[&shown]);
    }
    // One good directory and one missing one.
    let d = tmp.path().join("d");
    succeeds(run_cmd(&d, &["--realisations", "5", "--no-figures"]));
    refused(
        chassis(&["summarize".as_ref(), d.as_os_str(), missing.as_os_str()]),
        &[&shown],
    );
    assert!(!missing.exists());
}
