//! The output directory can be trusted: a user's files survive, a run's files replace the
//! previous run's as one set whatever instant the process is killed at, damaged parts and
//! files are detected and redone, memory does not grow with R, and one directory has one
//! writer. Each regression test is named after the guarantee it pins; the defect it pins is
//! in its doc comment.
//!
//! Every realisation is a pure function of (seed, condition, realisation) and summaries use
//! exact sums, so an interrupted, resumed or repaired run is compared with an uninterrupted
//! one byte for byte, not within a tolerance.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use chassis_mc::output::set::JOURNAL;
use chassis_mc::run::STAGING;

use super::common::*;

/// Every visible file under `dir` (hidden names, the engine's bookkeeping, are skipped),
/// by relative path.
fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<String, Vec<u8>>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for entry in entries {
            let entry = entry.unwrap();
            if entry.file_name().to_string_lossy().starts_with('.') {
                continue;
            }
            let path = entry.path();
            if path.is_dir() {
                walk(root, &path, out);
            } else {
                let rel = path
                    .strip_prefix(root)
                    .unwrap()
                    .to_string_lossy()
                    .into_owned();
                out.insert(rel, std::fs::read(&path).unwrap());
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

/// Names of the files in a snapshot, for assertion messages.
fn names(s: &BTreeMap<String, Vec<u8>>) -> Vec<&str> {
    s.keys().map(String::as_str).collect()
}

/// Copy a directory tree (hidden files included).
fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.path().is_dir() {
            copy_dir(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), target).unwrap();
        }
    }
}

/// `chassis-mc run studies/<study> --out DIR --quiet` with extra arguments.
fn run_cmd(study: &str, out: &Path, extra: &[&str]) -> Command {
    let mut cmd = Command::new(bin());
    cmd.arg("run")
        .arg(study_path(study))
        .arg("--out")
        .arg(out)
        .arg("--quiet")
        .args(extra)
        .stdin(Stdio::null());
    cmd
}

fn output_of(mut cmd: Command) -> Output {
    cmd.output().unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn succeeds(cmd: Command) -> Output {
    let o = output_of(cmd);
    assert!(o.status.success(), "failed: {}", stderr(&o));
    o
}

/// The same run with `CHASSIS_MC_FAILPOINT` set: it must die at that point.
fn crash_at(mut cmd: Command, point: &str) {
    cmd.env("CHASSIS_MC_FAILPOINT", point);
    let o = output_of(cmd);
    assert!(
        !o.status.success(),
        "the run did not reach the failpoint {point}: {}",
        stderr(&o)
    );
}

/// XOR two adjacent bytes at `offset` (from the end when negative).
fn flip(path: &Path, offset: i64) {
    let mut bytes = std::fs::read(path).unwrap();
    let at = if offset < 0 {
        (bytes.len() as i64 + offset) as usize
    } else {
        offset as usize
    };
    bytes[at] ^= 0x5a;
    bytes[at + 1] ^= 0xa5;
    std::fs::write(path, bytes).unwrap();
}

fn parts(dir: &Path) -> Vec<PathBuf> {
    let mut found: Vec<PathBuf> = std::fs::read_dir(dir.join(STAGING))
        .map(|d| {
            d.map(|e| e.unwrap().path())
                .filter(|p| {
                    let name = p.file_name().unwrap().to_string_lossy().into_owned();
                    name.starts_with("part-") && name.ends_with(".parquet")
                })
                .collect()
        })
        .unwrap_or_default();
    found.sort();
    found
}

const TABLES: [&str; 3] = ["realisations.parquet", "summary.parquet", "cycles.parquet"];

fn assert_same_tables(dir: &Path, reference: &Path) {
    for name in TABLES {
        assert!(
            std::fs::read(dir.join(name)).unwrap() == std::fs::read(reference.join(name)).unwrap(),
            "{name} differs from an uninterrupted run"
        );
    }
}

/// `run`, `figures`, `summarize` and a run without figures replace only the engine's own
/// figures: a user's file in DIR/figures/ stays, and is all that is left there once a run
/// draws none.
///
/// Regression: a run replaced DIR/figures/ as a whole, deleting the user's files in it.
#[test]
fn the_users_files_in_figures_survive_run_figures_and_summarize() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("d");
    let mine = out.join("figures").join("paper.pdf");
    std::fs::create_dir_all(mine.parent().unwrap()).unwrap();
    std::fs::write(&mine, b"mine").unwrap();
    succeeds(run_cmd("thesis.toml", &out, &["--realisations", "20"]));
    assert!(out.join("figures/se_inv_mass.svg").exists());
    let mut redraw = Command::new(bin());
    redraw.arg("figures").arg(&out);
    succeeds(redraw);
    let mut summarize = Command::new(bin());
    summarize.arg("summarize").arg(&out).arg("--quiet");
    succeeds(summarize);
    // A run without figures removes the run's figures, and only those.
    succeeds(run_cmd(
        "thesis.toml",
        &out,
        &["--realisations", "20", "--no-figures"],
    ));
    assert_eq!(std::fs::read(&mine).unwrap(), b"mine");
    let left: Vec<_> = std::fs::read_dir(out.join("figures"))
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(
        left,
        ["paper.pdf"],
        "only the user's file is left in figures/"
    );
}

/// A run killed after the first rename of its commit leaves a set that `figures` and
/// `summarize` refuse as incomplete, and the next run completes the replacement and ends as
/// a clean run into a fresh directory.
///
/// Regression: the output files were not replaced as one set, so such a directory held
/// files of two runs that were read as one.
#[test]
fn a_half_replaced_set_is_reported_incomplete_and_completed_by_the_next_run() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("d");
    succeeds(run_cmd("thesis.toml", &out, &["--realisations", "30"]));
    let args = ["--realisations", "30", "--seed", "2"];
    crash_at(run_cmd("thesis.toml", &out, &args), "commit-rename:1");
    assert!(out.join(JOURNAL).exists());
    for command in ["figures", "summarize"] {
        let o = output_of({
            let mut c = Command::new(bin());
            c.arg(command).arg(&out);
            c
        });
        assert!(!o.status.success(), "{command} read a mixed set");
        assert!(stderr(&o).contains("incomplete"), "{}", stderr(&o));
    }
    // `run` completes the interrupted replacement, then runs.
    let o = succeeds(run_cmd("thesis.toml", &out, &args));
    assert!(
        stderr(&o).contains("completed the replacement"),
        "{}",
        stderr(&o)
    );
    let reference = dir.path().join("reference");
    succeeds(run_cmd("thesis.toml", &reference, &args));
    assert_eq!(snapshot(&out), snapshot(&reference));
}

/// A resumed run whose completed parts include one with a flipped byte says so on stderr,
/// recomputes that part, and ends with the tables of an uninterrupted run.
///
/// Regression: a corrupted part was reused as it was.
#[test]
fn a_damaged_part_is_reported_and_recomputed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("d");
    let args = ["--realisations", "300", "--no-figures"];
    crash_at(run_cmd("thesis.toml", &out, &args), "part-committed:3");
    let found = parts(&out);
    assert_eq!(found.len(), 3, "three parts were complete");
    flip(&found[1], 200);
    let o = succeeds(run_cmd("thesis.toml", &out, &args));
    assert!(stderr(&o).contains("damaged"), "{}", stderr(&o));
    let reference = dir.path().join("reference");
    succeeds(run_cmd("thesis.toml", &reference, &args));
    assert_same_tables(&out, &reference);
}

#[test]
fn flipped_bytes_in_parts_and_in_the_finished_file_are_detected_and_redone() {
    let dir = tempfile::tempdir().unwrap();
    let small = ["--realisations", "200", "--no-figures"];
    let large = ["--realisations", "400", "--no-figures"];
    let reference = dir.path().join("reference");
    succeeds(run_cmd("thesis.toml", &reference, &large));

    // Parts: bytes flipped near the start, in the middle of the data, and in the footer.
    let interrupted = dir.path().join("interrupted");
    crash_at(
        run_cmd("thesis.toml", &interrupted, &large),
        "part-committed:4",
    );
    let found = parts(&interrupted);
    assert_eq!(found.len(), 4);
    let len = |p: &Path| std::fs::metadata(p).unwrap().len() as i64;
    flip(&found[0], 8);
    flip(&found[1], len(&found[1]) / 2);
    flip(&found[2], -40);
    let o = succeeds(run_cmd("thesis.toml", &interrupted, &large));
    assert_eq!(
        stderr(&o).matches("damaged").count(),
        3,
        "each damaged part is reported: {}",
        stderr(&o)
    );
    assert_same_tables(&interrupted, &reference);

    // A finished realisation file, flipped at several offsets, then extended from 200 to
    // 400 realisations: never reused, and the result is that of a clean run.
    let finished = dir.path().join("finished");
    succeeds(run_cmd("thesis.toml", &finished, &small));
    let file_len = len(&finished.join("realisations.parquet"));
    for offset in [4, file_len / 3, 2 * file_len / 3, -30] {
        let copy = dir.path().join(format!("finished-{offset}"));
        copy_dir(&finished, &copy);
        flip(&copy.join("realisations.parquet"), offset);
        let o = succeeds(run_cmd("thesis.toml", &copy, &large));
        assert!(
            stderr(&o).contains("not reused") || stderr(&o).contains("unreadable"),
            "offset {offset}: {}",
            stderr(&o)
        );
        assert_same_tables(&copy, &reference);
    }
}

/// Peak resident memory of a running process [bytes] (Linux: VmHWM).
fn peak_rss(pid: u32) -> Option<u64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

fn kill(mut child: Child) {
    child.kill().unwrap(); // SIGKILL, to this child's pid only
    child.wait().unwrap();
}

/// A run of R = 10^9 realisations per condition peaks under 200 MB of resident memory
/// while it computes: its memory is its chunk buffers and row groups, whatever R.
///
/// Regression: the plan of work was built up front: 10^9 realisations × 11 conditions meant
/// 10^7 chunk entries (hundreds of MB) before the first realisation, and 10^12 aborted out of
/// memory.
#[test]
#[cfg(target_os = "linux")]
fn a_run_of_a_billion_realisations_peaks_under_200_mb() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("d");
    let child = run_cmd(
        "thesis.toml",
        &out,
        &["--realisations", "1000000000", "--no-figures"],
    )
    .stdout(Stdio::null())
    .stderr(Stdio::null())
    .spawn()
    .unwrap();
    let pid = child.id();
    let started = Instant::now();
    let mut peak = 0;
    // Run until the first part is complete (the engine is computing, past any planning),
    // and at least five seconds.
    while started.elapsed() < Duration::from_secs(5) || parts(&out).is_empty() {
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "no part completed"
        );
        if let Some(rss) = peak_rss(pid) {
            peak = rss;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    if let Some(rss) = peak_rss(pid) {
        peak = rss;
    }
    kill(child);
    println!("peak RSS with R = 10^9: {:.1} MB", peak as f64 / 1e6);
    assert!(
        peak < 200 << 20,
        "peak RSS {:.0} MB with R = 10^9",
        peak as f64 / 1e6
    );
}

/// In an output directory without a manifest (written by an older engine, or the manifest
/// lost), redrawing the figures does not record its realisation file as trusted: a later
/// extension does not reuse its damaged rows and ends as a clean run.
///
/// Regression: `figures` vouched for such a file, and the extension reused damaged rows.
#[test]
fn a_damaged_file_in_a_directory_without_manifest_is_not_reused_after_figures() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("d");
    succeeds(run_cmd("thesis.toml", &out, &["--realisations", "100"]));
    std::fs::remove_file(out.join(chassis_mc::output::set::MANIFEST)).unwrap();
    let len = std::fs::metadata(out.join("realisations.parquet"))
        .unwrap()
        .len() as i64;
    flip(&out.join("realisations.parquet"), len / 2);
    let mut figures = Command::new(bin());
    figures.arg("figures").arg(&out);
    succeeds(figures);
    let o = succeeds(run_cmd("thesis.toml", &out, &["--realisations", "300"]));
    assert!(stderr(&o).contains("not reused"), "{}", stderr(&o));
    let reference = dir.path().join("reference");
    succeeds(run_cmd(
        "thesis.toml",
        &reference,
        &["--realisations", "300"],
    ));
    assert_same_tables(&out, &reference);
}

/// A line-fit run into the directory of a vehicle run leaves exactly the files of a
/// line-fit run into a fresh directory, byte for byte.
///
/// Regression: files of the previous run that the new model does not write (cycles.parquet)
/// survived a model change.
#[test]
fn a_model_change_leaves_exactly_the_new_runs_files() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("d");
    succeeds(run_cmd("thesis.toml", &out, &["--realisations", "20"]));
    assert!(out.join("cycles.parquet").exists());
    succeeds(run_cmd("line_fit.toml", &out, &["--realisations", "20"]));
    let reference = dir.path().join("reference");
    succeeds(run_cmd(
        "line_fit.toml",
        &reference,
        &["--realisations", "20"],
    ));
    assert_eq!(
        names(&snapshot(&out)),
        names(&snapshot(&reference)),
        "the directory holds exactly the line-fit run's files"
    );
    assert_eq!(snapshot(&out), snapshot(&reference));
}

/// While a run holds a directory, `figures`, `summarize` and a second run exit 2 with one
/// message naming the holder's pid; once the holder dies, the next run takes its lock over.
///
/// Regression: two concurrent runs into one directory raced.
#[test]
fn a_second_writer_is_refused_naming_the_holder_whose_lock_is_taken_over_once_dead() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("d");
    let holder = run_cmd(
        "thesis.toml",
        &out,
        &[
            "--realisations",
            "1000000000",
            "--no-figures",
            "--threads",
            "1",
        ],
    )
    .stdout(Stdio::null())
    .stderr(Stdio::null())
    .spawn()
    .unwrap();
    let pid = holder.id();
    let lock = out.join(chassis_mc::output::lock::LOCK);
    let started = Instant::now();
    while std::fs::read_to_string(&lock).map_or(true, |t| t.trim() != pid.to_string()) {
        assert!(started.elapsed() < Duration::from_secs(60), "no lock taken");
        std::thread::sleep(Duration::from_millis(20));
    }
    // A fresh directory: nothing but parts written yet. Every command names the writer.
    for command in ["figures", "summarize"] {
        let mut c = Command::new(bin());
        c.arg(command).arg(&out);
        let o = output_of(c);
        assert_eq!(o.status.code(), Some(2), "{command}: {}", stderr(&o));
        assert!(
            stderr(&o).contains(&format!("pid {pid}")),
            "{command}: {}",
            stderr(&o)
        );
    }
    let second = output_of(run_cmd("thesis.toml", &out, &["--realisations", "20"]));
    assert_eq!(second.status.code(), Some(2), "{}", stderr(&second));
    assert!(
        stderr(&second).contains(&format!("pid {pid}")),
        "{}",
        stderr(&second)
    );
    assert_eq!(stderr(&second).lines().count(), 1, "one message");
    // The holder dies without releasing anything: its lock is taken over.
    kill(holder);
    let third = succeeds(run_cmd("thesis.toml", &out, &["--realisations", "20"]));
    assert!(
        stderr(&third).contains(&format!("taking over the lock last held by process {pid}")),
        "{}",
        stderr(&third)
    );
    assert!(out.join("summary.parquet").exists());
}

/// Where a run can be stopped deterministically: after the first and seventh staged part,
/// while drawing figures, before and after the journal is written, after the first, a
/// middle and the last (the manifest's) of the 17 renames of the commit, and after it.
const FAILPOINTS: [&str; 10] = [
    "part-committed:1",
    "part-committed:7",
    "figure-drawn:1",
    "figure-drawn:3",
    "before-journal",
    "journal-written",
    "commit-rename:1",
    "commit-rename:9",
    "commit-rename:17",
    "committed",
];

#[test]
fn sigkill_at_any_instant_leaves_the_old_set_the_new_set_or_one_detected_as_incomplete() {
    let dir = tempfile::tempdir().unwrap();
    let old = dir.path().join("old");
    let mine = Path::new("figures").join("paper.pdf");
    std::fs::create_dir_all(old.join("figures")).unwrap();
    std::fs::write(old.join(&mine), b"mine").unwrap();
    let r = ["--realisations", "300"];
    succeeds(run_cmd("thesis.toml", &old, &r));
    let old_set = snapshot(&old);
    let new_args = ["--realisations", "300", "--seed", "2"];
    let new = dir.path().join("new");
    copy_dir(&old, &new);
    let started = Instant::now();
    succeeds(run_cmd("thesis.toml", &new, &new_args));
    let duration = started.elapsed();
    let new_set = snapshot(&new);
    assert_ne!(old_set, new_set);

    let mut seen = BTreeMap::<&str, usize>::new();
    let mut check = |d: &Path, how: &str| {
        let state = snapshot(d);
        let kind = if d.join(JOURNAL).exists() {
            let mut figures = Command::new(bin());
            figures.arg("figures").arg(d);
            let o = output_of(figures);
            assert!(
                !o.status.success() && stderr(&o).contains("incomplete"),
                "{how}: a journal, but `figures` did not report the set incomplete: {}",
                stderr(&o)
            );
            "incomplete"
        } else if state == old_set {
            "old"
        } else if state == new_set {
            "new"
        } else {
            panic!(
                "{how}: neither the old nor the new set, and not marked incomplete: {:?}",
                names(&state)
            );
        };
        *seen.entry(kind).or_default() += 1;
        // The rerun repairs and ends exactly as an uninterrupted run.
        succeeds(run_cmd("thesis.toml", d, &new_args));
        assert!(snapshot(d) == new_set, "{how}: the rerun differs");
        for entry in std::fs::read_dir(d).unwrap() {
            let name = entry.unwrap().file_name().to_string_lossy().into_owned();
            assert!(
                !name.starts_with('.')
                    || name == ".chassis-mc-lock"
                    || name == ".chassis-mc-manifest",
                "{how}: {name} left after the rerun"
            );
        }
    };

    for (k, point) in FAILPOINTS.iter().enumerate() {
        let d = dir.path().join(format!("failpoint-{k}"));
        copy_dir(&old, &d);
        crash_at(run_cmd("thesis.toml", &d, &new_args), point);
        check(&d, point);
    }
    // SIGKILL at instants spread over the whole run (planning, computing, summary, figures,
    // commit): the failpoints above pin the commit's instants, these cover the rest.
    for k in 0..12u32 {
        let d = dir.path().join(format!("timed-{k}"));
        copy_dir(&old, &d);
        let child = run_cmd("thesis.toml", &d, &new_args)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(duration * k / 11);
        kill(child);
        check(&d, &format!("SIGKILL after {:?}", duration * k / 11));
    }
    println!("states after an interruption: {seen:?}");
    for kind in ["old", "new", "incomplete"] {
        assert!(
            seen.contains_key(kind),
            "no interruption left the {kind} set: {seen:?}"
        );
    }
}
