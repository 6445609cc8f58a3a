//! What a new user's fault pass found: each test reproduces one case that misbehaved
//! (deleted files outside the output directory, replaced a shard, overwrote a measured log,
//! ran a meaningless truth with exit 0, called an unbiased estimator biased, hung on a
//! FIFO, blamed the wrong key, exited 1 for an unusable directory, accepted duplicate
//! conditions, left litter, hid the results under `--quiet`) and pins the fix. A refusal is
//! exit status 2 with one message naming the file, key or column and the reason, with
//! nothing changed on disk.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use super::common::*;

/// `chassis-mc ARGS…` (stdin closed).
fn chassis<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Command {
    let mut cmd = Command::new(bin());
    cmd.args(args).stdin(Stdio::null());
    cmd
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The command exits 2 with one error message containing every one of `needles`.
fn refused(mut cmd: Command, needles: &[&str]) -> Output {
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

fn succeeds(mut cmd: Command) -> Output {
    let o = cmd.output().unwrap();
    assert!(o.status.success(), "failed: {}", stderr(&o));
    o
}

/// The thesis study shortened to `duration` s at scale 1, OLS, with `noise` as its
/// `[noise]` lines and `extra` appended, written to `dir/name`.
fn short_study(dir: &Path, name: &str, duration: f64, noise: &str, extra: &str) -> PathBuf {
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
fn trace_lines() -> Vec<String> {
    std::fs::read_to_string(root().join("studies/data/route_trace.csv"))
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect()
}

/// `run STUDY --out OUT --quiet` with extra arguments.
fn run_into(study: &Path, out: &Path, extra: &[&str]) -> Command {
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
fn tree(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
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

/// Item 1: a symbolic link at `DIR/.chassis-mc-parts` was followed and every regular file
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

/// Item 2: `--shard 1/3 --seed 99` into a directory holding shards 0–2 of seed 5 (and
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

/// Item 3 (and 15's `simulate-log --out DIR`): `simulate-log --out FILE` overwrote an
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

/// Items 4 and 13: `[truth]` values far outside physics ran with exit 0 (1e300, the car
/// never moving, "ok") or failed naming another key (the terrain's length, the grade). Each
/// entry has a physical range, and a mass drift that empties the vehicle names
/// `truth.mass_rate`.
#[test]
fn truth_values_outside_physics_are_refused_naming_their_key() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    for (line, key, says) in [
        (
            "rotating_mass_factor = [1e300]",
            "truth.rotating_mass_factor[0]",
            "got 1e300",
        ),
        (
            "force_scale = [1e300]",
            "truth.force_scale[0]",
            "[-0.5, 0.5]",
        ),
        (
            "force_scale_sd = [0.9]",
            "truth.force_scale_sd[0]",
            "[0, 0.5]",
        ),
        (
            "air_density_ratio = [1e12]",
            "truth.air_density_ratio[0]",
            "[0.5, 2]",
        ),
        ("wind_speed = [1e6]", "truth.wind_speed[0]", "50 m/s"),
        (
            "wind_gust_sd = [100.0]",
            "truth.wind_gust_sd[0]",
            "[0, 20] m/s",
        ),
        (
            "rolling_speed_coefficient = [5.0]",
            "truth.rolling_speed_coefficient[0]",
            "0.1",
        ),
        ("mass_rate = -100", "truth.mass_rate", "10 kg/s"),
    ] {
        let study = short_study(
            tmp.path(),
            "t.toml",
            60.0,
            "[1.0]",
            &format!("[truth]\n{line}"),
        );
        let o = refused(run_into(&study, &out, &[]), &[key, says]);
        assert!(stderr(&o).len() < 400, "{line}: {}", stderr(&o));
        assert!(!out.exists(), "{line}: the output directory was made");
    }
    // Within its range, a drift that empties the car before the drive ends: 1800 kg at
    // −9 kg/s is gone at 200 s of a 600 s drive.
    let study = short_study(
        tmp.path(),
        "t.toml",
        600.0,
        "[1.0]",
        "[truth]\nmass_rate = -9.0",
    );
    refused(
        run_into(&study, &out, &[]),
        &["truth.mass_rate", "mass drifts from 1800.0 kg"],
    );
}

/// Item 5: at R = 20 over a large grid the report called OLS under output noise — exactly
/// unbiased — "biased beyond 4 MCSE" in a few of its thousands of estimates (Student's t
/// at 19 degrees of freedom exceeds 4 with probability 7.6e-4 per estimate, not the normal
/// 6.3e-5). The warning now tests each bias with Student's t at n − 1 and Holm's rule at a
/// 5 % family-wise error rate: an unbiased estimator is called biased with probability at
/// most 5 % over the whole grid, and here (a fixed seed) it says "no evidence of bias";
/// a calibration error of 5 % in the force, a real bias of 5 % in 1/M, is still named.
#[test]
fn report_html_calls_an_unbiased_estimator_unbiased_and_a_biased_one_biased() {
    let tmp = tempfile::tempdir().unwrap();
    // 11 scales × 200 output-noise levels = 2200 conditions × 3 parameters: under the old
    // rule E[false alarms] = 6600 × 7.6e-4 = 5.0.
    let levels: Vec<String> = (1..=200)
        .map(|i| format!("{:.2}", 0.05 * i as f64))
        .collect();
    let text = set_key(&study_text("output_noise.toml"), "duration", "60.0");
    let text = set_key(&text, "output_sd", &format!("[{}]", levels.join(", ")));
    let study = tmp.path().join("grid.toml");
    std::fs::write(&study, text).unwrap();
    let out = tmp.path().join("unbiased");
    succeeds(run_into(
        &study,
        &out,
        &["--realisations", "20", "--no-figures"],
    ));
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(
        html.contains("ols: no evidence of bias in any of its 6600 estimates"),
        "report lacks the verdict"
    );
    assert!(
        !html.contains("is biased"),
        "an unbiased estimator called biased"
    );

    let biased = short_study(
        tmp.path(),
        "b.toml",
        60.0,
        "[0.0]",
        "[truth]\nforce_scale = [0.05]",
    );
    let text = std::fs::read_to_string(&biased)
        .unwrap()
        .replace("output_sd = [0.0]", "output_sd = [0.1]");
    std::fs::write(&biased, text).unwrap();
    let out = tmp.path().join("biased");
    succeeds(run_into(
        &biased,
        &out,
        &["--realisations", "20", "--no-figures"],
    ));
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("ols is biased in"), "a 5 % bias not named");
    assert!(html.contains("Holm"), "the rule is not stated");
}

/// Item 12: a trace that is `/dev/zero` grew memory without bound, a FIFO hung, and a
/// 50 MB bad cell was echoed whole into the error. Only regular files are read, and a
/// message quotes at most a short piece of a cell.
#[test]
fn a_device_a_fifo_or_a_huge_cell_is_refused_quickly_with_a_short_message() {
    let tmp = tempfile::tempdir().unwrap();
    let trace_study = |trace: &Path| {
        let text = study_text("route_trace.toml").replace(
            "trace = \"data/route_trace.csv\"",
            &format!("trace = \"{}\"", trace.display()),
        );
        let path = tmp.path().join("trace.toml");
        std::fs::write(&path, text).unwrap();
        path
    };
    let fifo = tmp.path().join("fifo.csv");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    let zero = tmp.path().join("zero.csv");
    std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
    let big = tmp.path().join("big.csv");
    // The route's log with its first data row's time a 50 MB cell.
    let mut lines = trace_lines();
    let header = lines.iter().position(|l| !l.starts_with('#')).unwrap();
    let row = &mut lines[header + 1];
    let comma = row.find(',').unwrap();
    row.replace_range(..comma, &"x".repeat(50 << 20));
    std::fs::write(&big, lines.join("\n")).unwrap();
    for (trace, says) in [(zero, "device"), (fifo, "FIFO"), (big, "bytes)")] {
        let study = trace_study(&trace);
        let mut child = chassis(&["check".as_ref(), study.as_os_str()])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let started = Instant::now();
        // A hang or an unbounded read fails here (by the child's pid) instead of stalling
        // the suite: the refusal takes well under a second; 60 s allows a loaded machine.
        while child.try_wait().unwrap().is_none() {
            if started.elapsed() > Duration::from_secs(60) {
                child.kill().unwrap();
                panic!("{}: still running after 60 s", trace.display());
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let o = child.wait_with_output().unwrap();
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{}: {err}", trace.display());
        assert!(err.contains(says), "{}: {err}", trace.display());
        assert!(
            err.len() < 1000,
            "{}: a message of {} bytes",
            trace.display(),
            err.len()
        );
    }
}

/// Item 15: exit 1 where the README promises 2 for an output directory that cannot be
/// used as it is: a garbage manifest or journal, `summarize` on a directory with a journal,
/// a directory inside the engine's staging directory.
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
    let inside = tmp.path().join("x/.chassis-mc-parts/mine");
    refused(
        run_into(&study, &inside, &["--realisations", "4"]),
        &[".chassis-mc-parts", "choose a directory outside it"],
    );
}

/// Item 16: duplicate axis values made duplicate conditions silently, and a CSV with two
/// columns of one name read one of them.
#[test]
fn duplicate_axis_values_and_ambiguous_columns_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    for (noise, extra, key) in [
        ("[1.0, 1.0]", "", "noise.velocity_sd[1]"),
        (
            "[1.0]",
            "[truth]\nwind_speed = [1.0, 1.0]",
            "truth.wind_speed[1]",
        ),
    ] {
        let study = short_study(tmp.path(), "d.toml", 60.0, noise, extra);
        refused(run_into(&study, &out, &[]), &[key, "listed twice"]);
    }
    let text = set_key(&study_text("thesis.toml"), "scales", "[1.0, 1.5, 1.0]");
    let study = tmp.path().join("scales.toml");
    std::fs::write(&study, text).unwrap();
    refused(
        run_into(&study, &out, &[]),
        &["terrain.scales[2]", "listed twice"],
    );
    let text = set_key(
        &study_text("thesis.toml"),
        "duration",
        "120.0\ndurations = [60.0, 60.0]",
    );
    let study = tmp.path().join("durations.toml");
    std::fs::write(&study, text).unwrap();
    refused(
        run_into(&study, &out, &[]),
        &["drive.durations[1]", "listed twice"],
    );

    let mut lines = trace_lines();
    let header = lines.iter().position(|l| !l.starts_with('#')).unwrap();
    lines[header] = lines[header].replacen("grade_pct", "speed_kmh", 1);
    let doubled = lines.join("\n");
    let trace = tmp.path().join("doubled.csv");
    std::fs::write(&trace, doubled).unwrap();
    let text = study_text("route_trace.toml").replace(
        "trace = \"data/route_trace.csv\"",
        &format!("trace = \"{}\"", trace.display()),
    );
    let study = tmp.path().join("trace.toml");
    std::fs::write(&study, text).unwrap();
    refused(
        chassis(&["check".as_ref(), study.as_os_str()]),
        &["speed_kmh", "two columns have this name"],
    );
    assert!(!out.exists());
}

/// Item 17: a refused run left `.chassis-mc-lock` in the user's directory (and a failed
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

/// Item 18: `--quiet` hid the results table and the files written (the README says it
/// hides the progress only), and `--seed -1` got clap's advice to write `-- -1`.
#[test]
fn quiet_hides_progress_only_and_negative_numbers_get_a_range() {
    let tmp = tempfile::tempdir().unwrap();
    let study = short_study(tmp.path(), "s.toml", 60.0, "[1.0]", "");
    let out = tmp.path().join("out");
    let o = succeeds(run_into(
        &study,
        &out,
        &["--realisations", "4", "--no-figures"],
    ));
    assert!(
        stdout(&o).contains("EmpSE") && stdout(&o).contains("summary.parquet"),
        "{}",
        stdout(&o)
    );
    assert!(!stderr(&o).contains("progress"), "{}", stderr(&o));
    for (flag, value, says) in [
        ("--seed", "-1", "--seed"),
        ("--realisations", "-1", "--realisations"),
        ("--threads", "-2", "--threads"),
        ("--threads", "0", "--threads"),
        ("--seed", "18446744073709551616", "--seed"),
    ] {
        let o = run_into(&study, &out, &[flag, value]).output().unwrap();
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{flag} {value}: {err}");
        assert!(
            err.contains(says) && err.contains("whole number"),
            "{flag} {value}: {err}"
        );
        assert!(!err.contains("-- -1"), "{flag} {value}: {err}");
    }
}

/// Item 20: a coast-down on a flat road (no `[terrain]`) printed `scale 1.0000` and a
/// `ς_grid` column of NaN: neither means anything without a terrain.
#[test]
fn a_flat_road_prints_no_terrain_scale_or_metric() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let study = study_path("coastdown.toml");
    let o = succeeds(run_into(
        &study,
        &out,
        &["--realisations", "8", "--no-figures"],
    ));
    let table = stdout(&o);
    assert!(!table.contains("NaN"), "{table}");
    assert!(!table.contains("ς_grid"), "{table}");
    assert!(!table.contains(" scale = "), "{table}");
    for header in table.lines().filter(|l| l.starts_with("cond")) {
        assert!(!header.contains(" scale "), "{header}");
    }
}
