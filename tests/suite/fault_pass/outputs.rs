//! The output directory and the files the engine writes: its own bookkeeping never followed
//! or deleted when it is not its own, a shard of another run refused, a measured log never
//! overwritten, an unusable directory exit status 2, no litter.

use std::path::Path;
use std::process::{Command, Stdio};

use super::super::common::*;
use super::*;

/// A symbolic link at `DIR/.chassis-mc-parts` was followed and every regular file
/// in its target deleted as a "damaged part"; a directory of that name holding a user's
/// file, a user's `.chassis-mc-lock` (truncated) and links at the lock, manifest and journal
/// are the engine's bookkeeping only when they are what it writes. Each is refused and
/// nothing outside or inside is changed.
#[test]
fn a_symlinked_or_foreign_staging_directory_lock_or_journal_is_refused_and_nothing_deleted() {
    let tmp = tempfile::tempdir().unwrap();
    let study = short_study(tmp.path(), "s.toml", 60.0, "[1.0]", "");
    let victim = tmp.path().join("v");
    std::fs::create_dir(&victim).unwrap();
    std::fs::write(victim.join("notes.txt"), "keep").unwrap();
    std::fs::write(
        victim.join("part-c000000-r000000000000000-h0000000000000000.parquet"),
        "keep",
    )
    .unwrap();

    let victim_files = tree(&victim);
    let linked = tmp.path().join("o");
    std::fs::create_dir(&linked).unwrap();
    std::os::unix::fs::symlink("../v", linked.join(".chassis-mc-parts")).unwrap();
    refused(
        run_into(&study, &linked, &["--realisations", "5"]),
        &[".chassis-mc-parts", "symbolic link"],
    );
    assert_eq!(tree(&victim), victim_files, "files behind the link changed");

    let foreign = tmp.path().join("p");
    std::fs::create_dir_all(foreign.join(".chassis-mc-parts")).unwrap();
    std::fs::write(foreign.join(".chassis-mc-parts/notes.txt"), "keep").unwrap();
    let before = tree(&foreign);
    refused(
        run_into(&study, &foreign, &["--realisations", "5"]),
        &["notes.txt", "did not write"],
    );
    assert_eq!(tree(&foreign), before);

    let lock = tmp.path().join("q");
    std::fs::create_dir(&lock).unwrap();
    std::fs::write(lock.join(".chassis-mc-lock"), "my notes\n").unwrap();
    refused(
        run_into(&study, &lock, &["--realisations", "5"]),
        &[".chassis-mc-lock", "not a chassis-mc lock"],
    );
    assert_eq!(
        std::fs::read_to_string(lock.join(".chassis-mc-lock")).unwrap(),
        "my notes\n"
    );

    for name in [
        ".chassis-mc-lock",
        ".chassis-mc-manifest",
        ".chassis-mc-journal",
    ] {
        let d = tmp.path().join(format!("link{name}"));
        std::fs::create_dir(&d).unwrap();
        std::os::unix::fs::symlink("../v/notes.txt", d.join(name)).unwrap();
        refused(
            run_into(&study, &d, &["--realisations", "5"]),
            &[name, "symbolic link"],
        );
        assert_eq!(tree(&victim), victim_files, "{name}");
    }
}

/// `--shard 1/3 --seed 99` into a directory holding shards 0–2 of seed 5 (and
/// their summary) replaced shard 1 with exit 0, leaving a mixed set. Now it is refused,
/// naming what differs, and the directory is as it was; the same shard of the same run is
/// still run (its realisations kept).
#[test]
fn a_shard_of_another_run_does_not_replace_a_shard() {
    let tmp = tempfile::tempdir().unwrap();
    let study = short_study(tmp.path(), "s.toml", 60.0, "[1.0]", "");
    let d = tmp.path().join("d");
    for k in 0..3 {
        succeeds(run_into(
            &study,
            &d,
            &[
                "--realisations",
                "12",
                "--seed",
                "5",
                "--shard",
                &format!("{k}/3"),
            ],
        ));
    }
    succeeds(chassis(&[
        "summarize".as_ref(),
        d.as_os_str(),
        "--quiet".as_ref(),
    ]));
    let before = tree(&d);
    refused(
        run_into(
            &study,
            &d,
            &["--realisations", "12", "--seed", "99", "--shard", "1/3"],
        ),
        &["shard 1/3", "shard=0", "seed 99 here, 5 there"],
    );
    refused(
        run_into(
            &study,
            &d,
            &["--realisations", "12", "--seed", "5", "--shard", "1/4"],
        ),
        &["number of shards 4 here, 3 there"],
    );
    refused(
        run_into(
            &study,
            &d,
            &["--realisations", "15", "--seed", "5", "--shard", "1/3"],
        ),
        &["realisations per condition 15 here, 12 there"],
    );
    assert_eq!(tree(&d), before, "the directory changed");
    succeeds(run_into(
        &study,
        &d,
        &["--realisations", "12", "--seed", "5", "--shard", "1/3"],
    ));
    assert_eq!(tree(&d), before, "rerunning the same shard changed it");
}

/// `simulate-log --out FILE` overwrote an
/// existing file, a real measured log. It now replaces only a log it wrote itself (its
/// header) unless given `--force`; a directory is a bad argument.
#[test]
fn simulate_log_never_overwrites_a_file_it_did_not_write() {
    let tmp = tempfile::tempdir().unwrap();
    let study = study_path("fit_log.toml");
    let real = tmp.path().join("measured.csv");
    std::fs::write(&real, "t,v\n0,1\n").unwrap();
    let simulate = |out: &Path, extra: &[&str]| {
        let mut c = chassis(&[
            "simulate-log".as_ref(),
            study.as_os_str(),
            "--out".as_ref(),
            out.as_os_str(),
        ]);
        c.args(extra);
        c
    };
    refused(simulate(&real, &[]), &["measured.csv", "--force"]);
    assert_eq!(std::fs::read_to_string(&real).unwrap(), "t,v\n0,1\n");
    let own = tmp.path().join("simulated.csv");
    succeeds(simulate(&own, &[]));
    let first = std::fs::read(&own).unwrap();
    succeeds(simulate(&own, &["--realisation", "1"]));
    assert_ne!(
        std::fs::read(&own).unwrap(),
        first,
        "its own log is replaced"
    );
    succeeds(simulate(&real, &["--force"]));
    assert!(
        std::fs::read_to_string(&real)
            .unwrap()
            .starts_with("time_s,")
    );
    refused(simulate(tmp.path(), &[]), &["is a directory"]);
    let names: Vec<String> = std::fs::read_dir(tmp.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        names.iter().all(|n| !n.contains(".tmp-")),
        "litter: {names:?}"
    );
}

/// Exit 1 where the README promises 2 for an output directory that cannot be
/// used as it is: a garbage manifest or journal, `summarize` on a directory with a journal,
/// a directory that cannot be made or written, a directory inside the engine's staging
/// directory.
#[test]
fn an_unusable_output_directory_is_exit_status_2() {
    let tmp = tempfile::tempdir().unwrap();
    let study = short_study(tmp.path(), "s.toml", 60.0, "[1.0]", "");
    for (name, text, says) in [
        (
            ".chassis-mc-manifest",
            "garbage\n",
            "not a chassis-mc manifest",
        ),
        (
            ".chassis-mc-journal",
            "garbage\n",
            "not a chassis-mc journal",
        ),
    ] {
        let d = tmp.path().join(format!("bad{name}"));
        std::fs::create_dir(&d).unwrap();
        std::fs::write(d.join(name), text).unwrap();
        refused(
            run_into(&study, &d, &["--realisations", "4"]),
            &[name, says],
        );
    }
    let d = tmp.path().join("journal");
    succeeds(run_into(&study, &d, &["--realisations", "4"]));
    std::fs::write(d.join(".chassis-mc-journal"), "chassis-mc journal 1\n").unwrap();
    refused(
        chassis(&["summarize".as_ref(), d.as_os_str()]),
        &["incomplete"],
    );
    // A directory that cannot be made or written: none can be made under /proc.
    let nowhere = Path::new("/proc/chassis-mc-no-such-place/out");
    refused(
        run_into(&study, nowhere, &["--realisations", "4"]),
        &[
            "/proc/chassis-mc-no-such-place/out",
            "cannot be used as the output directory",
        ],
    );
    let inside = tmp.path().join("x/.chassis-mc-parts/mine");
    refused(
        run_into(&study, &inside, &["--realisations", "4"]),
        &[".chassis-mc-parts", "choose a directory outside it"],
    );
}

/// A refused run left `.chassis-mc-lock` in the user's directory (and a failed
/// `fit` its temporary figure). A lock goes with its holder, and a refused command leaves
/// the directory as it found it.
#[test]
fn a_refused_or_finished_command_leaves_no_lock_or_temporary_file() {
    let tmp = tempfile::tempdir().unwrap();
    let study = short_study(tmp.path(), "s.toml", 60.0, "[1.0]", "");
    let d = tmp.path().join("mine");
    std::fs::create_dir(&d).unwrap();
    std::fs::write(d.join("report.html"), "my own page").unwrap();
    let before = tree(&d);
    refused(
        run_into(&study, &d, &["--realisations", "4"]),
        &["report.html"],
    );
    assert_eq!(tree(&d), before, "a refused run left something");
    let fresh = tmp.path().join("fresh");
    succeeds(run_into(
        &study,
        &fresh,
        &["--realisations", "4", "--no-figures"],
    ));
    let names: Vec<String> = std::fs::read_dir(&fresh)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        !names
            .iter()
            .any(|n| n == ".chassis-mc-lock" || n.contains(".tmp-")),
        "{names:?}"
    );
    // A fit whose files cannot all be written (a file-size limit stands in for a full
    // disk) leaves no temporary file: `ulimit -f 20` is 10 KB in dash's 512-byte blocks,
    // 20 KB in bash's, below the fit's figure (about 21 KB) and report (25 KB) either way.
    let out = tmp.path().join("fit");
    std::fs::create_dir(&out).unwrap();
    let fit = root().join("studies/fit_example.toml");
    let o = Command::new("sh")
        .arg("-c")
        .arg("trap '' XFSZ; ulimit -f 20; exec \"$0\" fit \"$1\" --out \"$2\"")
        .arg(bin())
        .arg(&fit)
        .arg(&out)
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert!(
        !o.status.success(),
        "the fit did not fail under the limit: {}",
        stderr(&o)
    );
    let left: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(left.is_empty(), "left behind: {left:?} ({})", stderr(&o));
}
