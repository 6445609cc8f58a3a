//! Shards, resume and extension: sharded + summarize == unsharded, a run killed
//! with SIGKILL and re-run ends identical, growing R keeps the earlier realisations, and a
//! killed run's leftovers do not stop the next one.
//! Every realisation is a pure function of (seed, condition, realisation) and summaries use
//! exact sums, so all of these are byte-for-byte comparisons, not tolerances.

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use chassis_mc::montecarlo::Silent;
use chassis_mc::run::{RunOptions, RunReport, STAGING, run_study, summarize};
use chassis_mc::study::Study;

use super::common::*;

fn bytes(path: &std::path::Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn four_shards_and_summarize_equal_the_unsharded_run() {
    let study = study("thesis.toml", 203); // 203 does not divide by 4
    let (whole, _) = run(&study, None);
    let sharded = tempfile::tempdir().unwrap();
    // Shards in a scrambled order, as a cluster may finish them.
    run_shards(&study, sharded.path(), &[2, 0, 3, 1]);
    let report = summarize(&[sharded.path().to_path_buf()], sharded.path(), false).unwrap();
    assert_eq!(report.summary.len(), 33);
    for name in ["summary.parquet", "cycles.parquet"] {
        assert!(
            bytes(&whole.path().join(name)) == bytes(&sharded.path().join(name)),
            "{name} differs"
        );
    }
    // ...including the control-variate estimates, from the shards' stored controls.
    let summary = read_table(&sharded.path().join("summary.parquet"));
    assert!(
        f64_col(&summary, "bias_cv_mcse")
            .iter()
            .all(|m| m.is_finite() && *m > 0.0)
    );
    // The shards' rows are exactly the unsharded rows.
    let all = read_table(&whole.path().join("realisations.parquet"));
    let mut rows = 0;
    let mut parts = Vec::new();
    for k in 0..4 {
        let t = read_table(
            &sharded
                .path()
                .join(format!("shard={k}/realisations.parquet")),
        );
        rows += t.num_rows();
        parts.push(t);
    }
    assert_eq!(rows, all.num_rows());
    let r_all = i64_col(&all, "realisation");
    let c_all = i32_col(&all, "condition");
    let theta_all = f64_col(&all, "theta_drag_over_mass");
    for t in &parts {
        let (c, r, th) = (
            i32_col(t, "condition"),
            i64_col(t, "realisation"),
            f64_col(t, "theta_drag_over_mass"),
        );
        for i in 0..t.num_rows() {
            let j = (0..all.num_rows())
                .find(|&j| c_all[j] == c[i] && r_all[j] == r[i])
                .unwrap();
            assert_eq!(th[i].to_bits(), theta_all[j].to_bits());
        }
    }
    // A shard missing is an error, not a silently smaller summary.
    std::fs::remove_dir_all(sharded.path().join("shard=1")).unwrap();
    let err = summarize(&[sharded.path().to_path_buf()], sharded.path(), false).unwrap_err();
    assert!(err.to_string().contains("realisations"), "{err}");
}

#[test]
fn growing_r_computes_only_the_new_realisations() {
    let dir = tempfile::tempdir().unwrap();
    let options = RunOptions::new(dir.path());
    let first = run_study(&study("thesis.toml", 100), &options, &Silent).unwrap();
    assert_eq!((first.reused, first.computed), (0, 1100));
    let second = run_study(&study("thesis.toml", 250), &options, &Silent).unwrap();
    assert_eq!((second.reused, second.computed), (1100, 1650));
    let (direct, _) = run(&study("thesis.toml", 250), None);
    for name in ["realisations.parquet", "summary.parquet"] {
        assert!(
            bytes(&dir.path().join(name)) == bytes(&direct.path().join(name)),
            "{name} differs"
        );
    }
}

/// Asks the run to stop once `after` realisations are done (as the Python package does on
/// Ctrl-C).
struct StopAfter {
    after: u64,
    done: std::sync::atomic::AtomicU64,
}

impl chassis_mc::montecarlo::Observer for StopAfter {
    fn realisations_done(&self, count: u64) {
        self.done
            .fetch_add(count, std::sync::atomic::Ordering::Relaxed);
    }

    fn stop_requested(&self) -> bool {
        self.done.load(std::sync::atomic::Ordering::Relaxed) >= self.after
    }
}

/// Run `study` into `dir` on one thread, asked to stop once `after` realisations are done
/// (the run ends interrupted, without a summary), then run it again to the end there: the
/// second run's report.
fn stop_then_resume(study: &Study, dir: &std::path::Path, after: u64) -> RunReport {
    let mut options = RunOptions::new(dir);
    options.threads = Some(1);
    let stop = StopAfter {
        after,
        done: Default::default(),
    };
    let stopped = run_study(study, &options, &stop);
    assert!(
        matches!(stopped, Err(chassis_mc::run::RunError::Interrupted { .. })),
        "{}: {stopped:?}",
        study.name()
    );
    assert!(!dir.join("summary.parquet").exists());
    run_study(study, &options, &Silent).unwrap()
}

#[test]
fn a_run_asked_to_stop_keeps_its_parts_and_resumes_to_identical_output() {
    // 11 conditions × 2500 realisations, one part per condition (three chunks of 1024). The
    // stop is seen by the sink writing a chunk while the next one is computed, so asked
    // once two conditions are computed, the run has committed at least the first's part.
    let study = study("thesis.toml", 2500);
    let dir = tempfile::tempdir().unwrap();
    let resumed = stop_then_resume(&study, dir.path(), 2 * 2500);
    assert!(resumed.reused >= 2500, "kept {}", resumed.reused);
    assert!(resumed.reused < 11 * 2500);
    let (direct, _) = run(&study, None);
    for name in ["realisations.parquet", "summary.parquet", "cycles.parquet"] {
        assert!(
            bytes(&dir.path().join(name)) == bytes(&direct.path().join(name)),
            "{name} differs"
        );
    }
}

#[test]
fn a_run_killed_midway_resumes_to_identical_output() {
    let r = "3000";
    let (reference, _) = run(&study("thesis.toml", 3000), None);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let args = |cmd: &mut Command| {
        cmd.args([
            "run",
            "--quiet",
            "--threads",
            "1",
            "--realisations",
            r,
            "--out",
        ])
        .arg(&out)
        .arg(study_path("thesis.toml"));
    };
    let mut first = Command::new(bin());
    args(&mut first);
    let mut child = first
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Wait for two completed parts (conditions 0 and 1), then SIGKILL.
    let staging = out.join(STAGING);
    let completed = || {
        std::fs::read_dir(&staging).map_or(0, |d| {
            d.filter(|e| {
                let name = e.as_ref().unwrap().file_name();
                let name = name.to_string_lossy();
                name.starts_with("part-") && name.ends_with(".parquet")
            })
            .count()
        })
    };
    let started = Instant::now();
    while completed() < 2 && started.elapsed() < Duration::from_secs(120) {
        std::thread::sleep(Duration::from_millis(10));
    }
    child.kill().unwrap(); // SIGKILL on Unix
    child.wait().unwrap();
    let kept = completed();
    assert!(kept >= 2, "killed before two parts were complete");
    assert!(
        !out.join("realisations.parquet").exists(),
        "the run finished before the kill"
    );
    // A torn part, as a crash in the middle of a rename-less write would leave.
    std::fs::write(
        staging.join("part-c000010-r000000000000000.parquet"),
        b"PAR1 torn",
    )
    .unwrap();

    let mut again = Command::new(bin());
    args(&mut again);
    let output = again.output().unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("resuming:"), "{stderr}");
    for name in ["realisations.parquet", "summary.parquet", "cycles.parquet"] {
        assert!(
            bytes(&out.join(name)) == bytes(&reference.path().join(name)),
            "{name} differs from an uninterrupted run"
        );
    }
    assert!(!staging.exists(), "staging is removed after a complete run");
}

#[test]
fn leftovers_of_a_killed_run_are_cleared_not_fatal() {
    // A killed run can leave a temporary Parquet file and the figures' staging directory
    // (both named `.NAME.tmp-PID`); the next run into the same directory removes them.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join(".summary.parquet.tmp-4194304");
    let figures = dir.path().join(".figures.tmp-4194304");
    std::fs::write(&file, b"PAR1 torn").unwrap();
    std::fs::create_dir(&figures).unwrap();
    std::fs::write(figures.join("se_inv_mass.svg"), b"<svg").unwrap();
    run_study(
        &study("thesis.toml", 20),
        &RunOptions::new(dir.path()),
        &Silent,
    )
    .unwrap();
    assert!(!file.exists() && !figures.exists(), "leftovers are removed");
    assert!(dir.path().join("summary.parquet").exists());
}

/// Every sensor path of the kernel (README "Performance"), 40 realisations per condition
/// (the run on one thread computes them in batches of eight side by side, on two in
/// batches of five; the others' batches depend on the machine's core count): the thesis
/// drive (30 s at 0.01 s) with white and AR(1) speed noise, the model's and a
/// differentiated acceleration, with and without grade noise, and the same axes on the
/// truck's drive (the first 10 minutes of heavy_duty.toml's hour at 0.1 s: five-row WBCLS
/// segments); each with OLS alone, OLS and BCLS (realisations measured side by side where
/// they can be, the grade term's sums for BCLS), OLS, BCLS and WBCLS, and all four (the
/// rows scanned for WBCLS and RLS, each realisation measured on its own). Then the paths
/// whose realisations each have their own regression: the model errors drawn per
/// realisation (gusts, a random force calibration, the elevation map's error, each on and
/// off: each alone takes its own path, drawn_errors.rs checks them together) and the
/// filters without a grade sensor on a truth that follows their model. Each
/// with a name for the messages, its number of estimators and of conditions.
fn sensor_path_studies() -> Vec<(String, Study, usize, u64)> {
    let axes = "[noise]\nvelocity_correlation_time = [0.0, 1.0]\ngrade_sd = [0.0, 0.001]";
    let thesis = set_key(&study_text("bias_compensation.toml"), "duration", "30.0");
    let thesis = set_key(&set_key(&thesis, "scales", "[1.0]"), "velocity_sd", "[1.0]");
    let truck = set_key(&study_text("heavy_duty.toml"), "durations", "[600.0]");
    let truck = set_key(&truck, "velocity_sd", "[0.5]");
    let mut studies = Vec::new();
    for (name, text) in [("thesis", thesis), ("truck", truck)] {
        for estimators in [
            r#"["ols"]"#,
            r#"["ols", "bcls"]"#,
            r#"["ols", "bcls", "wbcls"]"#,
            r#"["ols", "bcls", "wbcls", "rls"]"#,
        ] {
            let estimation =
                format!("{estimators}\nacceleration = [\"model\", \"differentiated\"]");
            let text = set_key(
                &text.replacen("[noise]", axes, 1),
                "estimators",
                &estimation,
            );
            let study = Study::from_toml(&text, name)
                .unwrap()
                .with_overrides(Some(40), None)
                .unwrap();
            let count = estimators.matches(',').count() + 1;
            studies.push((format!("{name} {estimators}"), study, count, 8));
        }
    }
    let drawn = set_key(&study_text("thesis.toml"), "duration", "30.0");
    let drawn = set_key(&drawn, "scales", "[1.0]");
    let drawn = set_key(&drawn, "velocity_sd", "[0.3]\ngrade_map_sd = [0.0, 0.02]");
    let drawn = set_key(&drawn, "estimators", "[\"ols\", \"bcls\"]");
    let drawn =
        format!("{drawn}\n[truth]\nwind_gust_sd = [0.0, 1.5]\nforce_scale_sd = [0.0, 0.03]\n");
    let drawn = Study::from_toml(&drawn, "drawn")
        .unwrap()
        .with_overrides(Some(40), None)
        .unwrap();
    studies.push(("drawn model errors".into(), drawn, 2, 8));
    let (filters, _) = super::no_grade_sensor::filter_model_study(30.0, 40);
    let filters = set_key(&filters, "velocity_sd", "[0.1, 0.2]");
    let filters = Study::from_toml(&filters, study_path("no_grade.toml").to_str().unwrap())
        .unwrap()
        .with_overrides(Some(40), None)
        .unwrap();
    studies.push(("filters without a grade sensor".into(), filters, 2, 2));
    studies
}

/// `table`'s rows sorted by condition, realisation and estimator.
fn sorted(table: &arrow::array::RecordBatch) -> arrow::array::RecordBatch {
    let keys = ["condition", "realisation", "estimator"].map(|name| arrow::compute::SortColumn {
        values: table.column_by_name(name).unwrap().clone(),
        options: None,
    });
    let order = arrow::compute::lexsort_to_indices(&keys, None).unwrap();
    arrow::compute::take_record_batch(table, &order).unwrap()
}

#[test]
fn every_sensor_path_is_the_same_across_threads_shards_resume_and_extension() {
    for (name, study, estimators, conditions) in sensor_path_studies() {
        let files = ["realisations.parquet", "summary.parquet", "cycles.parquet"];
        let same = |a: &std::path::Path, b: &std::path::Path, how: &str| {
            for file in files {
                assert!(
                    bytes(&a.join(file)) == bytes(&b.join(file)),
                    "{name}, {how}: {file} differs"
                );
            }
        };
        let (one, _) = run(&study, Some(1));
        let (two, _) = run(&study, Some(2));
        same(one.path(), two.path(), "two threads against one");

        // Three shards in a scrambled order, then summarize.
        let sharded = tempfile::tempdir().unwrap();
        run_shards(&study, sharded.path(), &[2, 0, 1]);
        summarize(&[sharded.path().to_path_buf()], sharded.path(), false).unwrap();
        for file in ["summary.parquet", "cycles.parquet"] {
            assert!(
                bytes(&one.path().join(file)) == bytes(&sharded.path().join(file)),
                "{name}, three shards: {file} differs"
            );
        }
        let parts: Vec<_> = (0..3)
            .map(|k| {
                read_table(
                    &sharded
                        .path()
                        .join(format!("shard={k}/realisations.parquet")),
                )
            })
            .collect();
        let parts = arrow::compute::concat_batches(&parts[0].schema(), &parts).unwrap();
        let whole = read_table(&one.path().join("realisations.parquet"));
        assert_eq!(
            whole.num_rows() as u64,
            conditions * 40 * estimators as u64,
            "{name}: {conditions} conditions"
        );
        assert_eq!(
            sorted(&parts).columns(),
            sorted(&whole).columns(),
            "{name}, three shards: the realisations differ"
        );

        // Extended from R = 20 to 40 in the same directory.
        let grown = tempfile::tempdir().unwrap();
        let options = RunOptions::new(grown.path());
        let fewer = study.clone().with_overrides(Some(20), None).unwrap();
        run_study(&fewer, &options, &Silent).unwrap();
        let report = run_study(&study, &options, &Silent).unwrap();
        assert_eq!(
            report.reused,
            conditions * 20,
            "{name}: the first 20 of each kept"
        );
        same(one.path(), grown.path(), "extended from R = 20");

        // Asked to stop once three conditions are done (one part each): the parts written
        // before the stop is seen are kept (at least one), then the run resumes.
        let resumed = tempfile::tempdir().unwrap();
        let report = stop_then_resume(&study, resumed.path(), 3.min(conditions - 1) * 40);
        assert!(
            (40..conditions * 40).contains(&report.reused),
            "{name}: kept {}",
            report.reused
        );
        same(one.path(), resumed.path(), "stopped and resumed");
    }
}
