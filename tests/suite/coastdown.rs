//! The coast-down drive mode (docs/model.md#coastdown): its runs laid end to end in one
//! cycle, the return runs' flipped wind, the `runs` axis as the first k runs, and the
//! independence of the runs (differences and AR(1) speed noise within a run only). With no
//! propulsion force an estimator of all three parameters is singular, so these tests check
//! the cycle and the tables, not the estimates.

use std::path::Path;

use arrow::array::RecordBatch;
use chassis_mc::model::vehicle::VehicleModel;
use chassis_mc::study::Study;

use super::common::*;

/// `studies/coastdown.toml` with `runs` and `extra` lines appended to `[drive]` (before
/// `[noise]`), and `tail` appended to the file.
fn coastdown_text(runs: &str, extra: &str, tail: &str) -> String {
    let text = set_key(&study_text("coastdown.toml"), "runs", runs);
    let text = text.replacen("\n[noise]", &format!("{extra}\n\n[noise]"), 1);
    format!("{text}\n{tail}\n")
}

fn load(text: &str, realisations: u64) -> Study {
    Study::from_toml(text, "coastdown")
        .unwrap()
        .with_overrides(Some(realisations), None)
        .unwrap()
}

fn tables(dir: &Path) -> [RecordBatch; 3] {
    ["realisations", "summary", "cycles"]
        .map(|name| read_table(&dir.join(format!("{name}.parquet"))))
}

/// The rows of cycles.parquet's column `name` in run `k`.
fn of_run(cycles: &RecordBatch, name: &str, k: i32) -> Vec<f64> {
    let run = i32_col(cycles, "run");
    f64_col(cycles, name)
        .into_iter()
        .zip(run)
        .filter(|(_, r)| *r == k)
        .map(|(v, _)| v)
        .collect()
}

#[test]
fn the_example_coast_down_is_eight_runs_end_to_end_on_one_clock() {
    let (dir, _) = run(&study("coastdown.toml", 4), None);
    let [realisations, summary, cycles] = tables(dir.path());
    let run = i32_col(&cycles, "run");
    let (t, x, v) = (
        f64_col(&cycles, "t"),
        f64_col(&cycles, "x"),
        f64_col(&cycles, "v"),
    );
    // Runs 0 … 7 in order, each one contiguous block.
    assert_eq!(run[0], 0);
    assert!(run.windows(2).all(|w| w[1] == w[0] || w[1] == w[0] + 1));
    assert_eq!(*run.last().unwrap(), 7);
    // One clock at the sample step: run k + 1's first sample one step after run k's last.
    for (i, ti) in t.iter().enumerate() {
        assert_eq!(*ti, i as f64 * 0.1, "sample {i}");
    }
    for k in 0..8 {
        let rows: Vec<usize> = (0..run.len()).filter(|&i| run[i] == k).collect();
        let (first, last) = (rows[0], rows[rows.len() - 1]);
        assert_eq!(v[first], 33.3, "run {k}");
        assert!(
            v[last] >= 8.3 && v[last] < 8.3 + 0.02,
            "run {k}: {}",
            v[last]
        );
        // Even runs forwards, odd runs backwards along the route.
        let forwards = k % 2 == 0;
        assert_eq!(x[last] > x[first], forwards, "run {k}");
    }
    // Coasting: no propulsion force.
    assert!(f64_col(&cycles, "f_prop").iter().all(|&f| f == 0.0));
    // Every table carries the runs axis; the duration is the whole cycle's.
    for table in [&realisations, &summary] {
        assert!(f64_col(table, "runs").iter().all(|&k| k == 8.0));
    }
    assert!(
        f64_col(&summary, "duration")
            .iter()
            .all(|&d| d == *t.last().unwrap())
    );
}

#[test]
fn a_return_run_sees_a_steady_headwind_as_a_tailwind() {
    // Run 1 of an alternating coast-down in a 3 m/s headwind (along the route) drives
    // backwards: its wind is a 3 m/s tailwind, so it is run 0 of a one-way coast-down in a
    // −3 m/s wind, sample for sample (the same RK4 steps; time does not enter the truth
    // without a mass drift, and the road is flat).
    let cycle = |directions: &str, wind: &str| {
        let text = coastdown_text(
            "[2]",
            &format!("directions = \"{directions}\""),
            &format!("[truth]\nwind_speed = [{wind}]"),
        );
        let (dir, _) = run(&load(&text, 2), None);
        read_table(&dir.path().join("cycles.parquet"))
    };
    let alternate = cycle("alternate", "3.0");
    let opposite = cycle("one_way", "-3.0");
    for column in ["v", "accel", "grade", "f_prop"] {
        assert_eq!(
            of_run(&alternate, column, 1),
            of_run(&opposite, column, 0),
            "{column}"
        );
    }
    // It covers the same distance, backwards (to rounding: other starting points).
    let (xa, xo) = (of_run(&alternate, "x", 1), of_run(&opposite, "x", 0));
    let back = xa[0] - xa[xa.len() - 1];
    let ahead = xo[xo.len() - 1] - xo[0];
    assert!((back - ahead).abs() < 1e-9 * ahead, "{back} vs {ahead}");
    // And the wind matters: against the headwind run 0 is shorter than the return.
    assert!(of_run(&alternate, "v", 0).len() < xa.len());
    // One way in the headwind, run 1 is run 0 again.
    let headwind = cycle("one_way", "3.0");
    assert_eq!(of_run(&headwind, "v", 1), of_run(&headwind, "v", 0));
}

/// A coast-down with `runs` over a gently rolling road (cos², 2 m high, period 300 m:
/// grades within ±0.7 %), run 0 starting 1 km in.
fn rolling_text(runs: &str, acceleration: &str) -> String {
    let text = coastdown_text(runs, "start_distance = 1000.0", "");
    let text = text.replace(
        "\n[noise]",
        "\n[terrain]\nprofile = \"cos2\"\nheight = 2.0\nperiod = 300.0\nlength = 50000\n\
         scales = [1.0]\nscale_applies_to = \"grade\"\n\n[noise]",
    );
    // One estimator, with the acceleration source(s) given.
    let text = set_key(&text, "estimators", "[\"ols\"]");
    assert!(text.contains("\n[estimation]\n"));
    text.replacen(
        "\n[estimation]\n",
        &format!("\n[estimation]\nacceleration = {acceleration}\n"),
        1,
    )
}

#[test]
fn a_condition_with_k_runs_uses_the_rows_of_the_first_k_runs() {
    let study = load(&rolling_text("[2, 4, 8]", "\"model\""), 6);
    let (dir, _) = run(&study, None);
    let [realisations, summary, cycles] = tables(dir.path());
    let run_of = i32_col(&cycles, "run");
    let (t, grade) = (f64_col(&cycles, "t"), f64_col(&cycles, "grade"));
    let runs = f64_col(&summary, "runs");
    let conditions = i32_col(&summary, "condition");
    let (duration, ms_cycle) = (
        f64_col(&summary, "duration"),
        f64_col(&summary, "terrain_ms_cycle"),
    );
    for (row, &k) in runs.iter().enumerate() {
        assert_eq!(k, [2.0, 4.0, 8.0][conditions[row] as usize]);
        let mine: Vec<usize> = (0..t.len()).filter(|&i| f64::from(run_of[i]) < k).collect();
        // The duration is the time of the last sample of run k − 1 (t₀ = 0).
        assert_eq!(duration[row], t[*mine.last().unwrap()], "runs {k}");
        // ς over the condition's rows: those of the first k runs. The engine sums exactly,
        // this test in order: n ≈ 10⁴ positive terms, relative error ≤ n·ε ≈ 2e-12.
        let expected = mine.iter().map(|&i| grade[i] * grade[i]).sum::<f64>() / mine.len() as f64;
        assert!(
            (ms_cycle[row] - expected).abs() <= 1e-11 * expected,
            "runs {k}: {} vs {expected}",
            ms_cycle[row]
        );
    }
    // The rows are a prefix of the 8-run cycle's, and the first 2 runs of the 8-run cycle
    // are the 2-run cycle: the 2-run condition (condition 0) realises bit for bit as the
    // one condition of a study of 2 runs.
    let (alone, _) = run(&load(&rolling_text("[2]", "\"model\""), 6), None);
    let alone = read_table(&alone.path().join("realisations.parquet"));
    let keep: Vec<u32> = (0..realisations.num_rows() as u32)
        .filter(|&i| i32_col(&realisations, "condition")[i as usize] == 0)
        .collect();
    let first =
        arrow::compute::take_record_batch(&realisations, &arrow::array::UInt32Array::from(keep))
            .unwrap();
    assert_eq!(first.num_rows(), alone.num_rows());
    assert_eq!(first.columns(), alone.columns());
    assert!(f64_col(&alone, "runs").iter().all(|&k| k == 2.0));
}

#[test]
fn a_differentiated_acceleration_never_differences_across_runs() {
    // cycles.parquet's block of the differentiated acceleration leaves out exactly each
    // run's first and last sample (no central difference reaches into another run); the
    // model acceleration's block uses every sample.
    let study = load(&rolling_text("[4]", "[\"model\", \"differentiated\"]"), 2);
    let (dir, _) = run(&study, None);
    let cycles = read_table(&dir.path().join("cycles.parquet"));
    let (run_of, used) = (i32_col(&cycles, "run"), bool_col(&cycles, "used"));
    let acceleration = str_col(&cycles, "acceleration");
    for source in ["model", "differentiated"] {
        let rows: Vec<usize> = (0..cycles.num_rows())
            .filter(|&i| acceleration[i] == source)
            .collect();
        for (j, &i) in rows.iter().enumerate() {
            let edge = j == 0
                || j + 1 == rows.len()
                || run_of[rows[j - 1]] != run_of[i]
                || run_of[rows[j + 1]] != run_of[i];
            let expected = !(source == "differentiated" && edge);
            assert_eq!(
                used[i], expected,
                "{source}, sample {j} (run {})",
                run_of[i]
            );
        }
        // Four runs: 8 edges left out of the differentiated block.
        let left_out = rows.iter().filter(|&&i| !used[i]).count();
        assert_eq!(left_out, if source == "model" { 0 } else { 8 });
    }
}

#[test]
fn ar1_speed_noise_is_independent_across_runs() {
    // AR(1) speed noise with τ = 1000 s, far longer than a run (125.6 s): within a run the
    // noise is nearly one draw, and were it carried across the run boundary (one step,
    // 0.1 s, between runs) the two runs would share it. It restarts at each run's first
    // sample, so Var(Σ Ṽ²) = 4σ² Σ_ij V_i V_j ρ_ij + 2σ⁴ Σ_ij ρ_ij² with ρ_ij =
    // exp(−|t_i − t_j|/τ) within a run and 0 across (Gaussian e: Cov(e_i², e_j²) = 2ρ²σ⁴).
    let sd = 0.5;
    let tau = 1000.0;
    let text = coastdown_text("[2]", "", "").replace(
        "velocity_sd = [0.05]",
        &format!("velocity_sd = [{sd}]\nvelocity_correlation_time = [{tau}]"),
    );
    let study = load(&text, 1);
    let model = VehicleModel::new(&study).unwrap();
    let cycle = model.cycles().remove(0);
    let (t, v, run_of) = (&cycle.t_s, &cycle.v_m_s, &cycle.run);
    let n = t.len();
    let predicted = |across: bool| {
        let mut total = 0.0;
        for i in 0..n {
            for j in 0..n {
                if run_of[i] != run_of[j] && !across {
                    continue;
                }
                let rho = (-(t[i] - t[j]).abs() / tau).exp();
                total += 4.0 * sd * sd * v[i] * v[j] * rho + 2.0 * sd.powi(4) * rho * rho;
            }
        }
        total
    };
    let (independent, carried) = (predicted(false), predicted(true));
    let r = 400;
    let s_w: Vec<f64> = (0..r).map(|k| model.moments(2018, 0, k).s_w).collect();
    let mean = s_w.iter().sum::<f64>() / r as f64;
    let d2: Vec<f64> = s_w.iter().map(|s| (s - mean).powi(2)).collect();
    let var = d2.iter().sum::<f64>() / (r - 1) as f64;
    // The sample variance's standard error, from the data's fourth moment:
    // √((m₄ − S⁴)/R).
    let m4 = d2.iter().map(|d| d * d).sum::<f64>() / r as f64;
    let se = ((m4 - var * var) / r as f64).sqrt();
    println!(
        "Var(Σ Ṽ²) = {var:.1} ± {se:.1}; independent runs {independent:.1}, carried {carried:.1}"
    );
    assert!(
        (var - independent).abs() <= 4.0 * se,
        "{var} ± {se} vs {independent}"
    );
    // The test can tell: noise carried across the boundary is far outside.
    assert!(
        (carried - var).abs() > 8.0 * se,
        "{carried} vs {var} ± {se}"
    );
}

#[test]
fn bad_coast_down_keys_exit_2_naming_file_key_and_line() {
    let tmp = tempfile::tempdir().unwrap();
    let base = study_text("coastdown.toml");
    let line_of =
        |text: &str, needle: &str| text.lines().position(|l| l.starts_with(needle)).unwrap() + 1;
    let durations = base.replace("runs = [8]", "runs = [8]\ndurations = [60.0]");
    let cases = [
        (
            set_key(&base, "runs", "[4, 7]"),
            "drive.runs[1]",
            line_of(&base, "runs ="),
            "positive even number of runs",
        ),
        (
            set_key(&base, "speed_low", "40.0"),
            "drive.speed_low",
            line_of(&base, "speed_low ="),
            "must be below drive.speed_high",
        ),
        (
            // Fewer than 3 samples per run: the simulation names the key to change.
            set_key(&base, "time_step", "300.0"),
            "drive.time_step",
            line_of(&base, "time_step ="),
            "make drive.time_step smaller",
        ),
        (
            durations.clone(),
            "drive.durations",
            line_of(&durations, "durations ="),
            "drive.runs is the axis",
        ),
    ];
    for (i, (text, key, line, reason)) in cases.iter().enumerate() {
        let file = tmp.path().join(format!("case{i}.toml"));
        std::fs::write(&file, text).unwrap();
        let out = tmp.path().join(format!("out{i}"));
        let (code, stdout, stderr) = cli(
            &[
                "run".as_ref(),
                file.as_os_str(),
                "--out".as_ref(),
                out.as_os_str(),
                "--quiet".as_ref(),
            ],
            tmp.path(),
        );
        let message = stderr.trim();
        assert_eq!(code, 2, "{key}: {message}");
        assert!(stdout.is_empty(), "{key}: {stdout}");
        assert_eq!(message.lines().count(), 1, "{key}: {message}");
        assert!(
            message.contains(&file.display().to_string()),
            "{key}: {message}"
        );
        assert!(message.contains(&format!("`{key}`")), "{key}: {message}");
        assert!(
            message.contains(&format!("line {line}")),
            "{key}: {message}"
        );
        assert!(message.contains(reason), "{key}: {message}");
        assert!(!out.exists(), "{key}: nothing is written");
    }
}

/// Gusts (`truth.wind_gust_sd`) are drawn per run: with a correlation time of 10⁶ s a gust
/// is constant over a run, so each run's estimate moves with its own gust, and OLS's
/// Cd/M and Cr from k one-way runs average k independent shifts: their variance over 4 runs
/// is about half that over 2 (0.5; the runs' unequal lengths move it a little). A series
/// carried from run to run would give ≈ 1 (the same gust in every run). Noise-free sensors,
/// R = 1000 each: a variance's relative SE is √(2/R) = 4.5 %, the ratio's ≈ 6.3 %, so the
/// band [0.3, 0.75] is > 3.9 of it from 1 and > 3 from 0.5 (measured at R = 400: 0.44 and
/// 0.59).
#[test]
fn gusts_are_drawn_independently_per_run() {
    let text = set_key(&study_text("coastdown.toml"), "velocity_sd", "[0.0]");
    let text = set_key(&text, "runs", "[2, 4]");
    let text = set_key(&text, "estimators", "[\"ols\"]");
    let text = text.replace(
        "# directions = \"alternate\"",
        "directions = \"one_way\"\n#",
    );
    let text = format!("{text}\n[truth]\nwind_gust_sd = [1.0]\nwind_gust_time = 1000000.0\n");
    let summary = run_summary(&load(&text, 1000));
    let runs = f64_col(&summary, "runs");
    let parameter = str_col(&summary, "parameter");
    let emp_se = f64_col(&summary, "emp_se");
    for p in ["drag_over_mass", "rolling_resistance"] {
        let se = |k: f64| {
            (0..summary.num_rows())
                .find(|&i| runs[i] == k && parameter[i] == p)
                .map(|i| emp_se[i])
                .unwrap()
        };
        let ratio = (se(4.0) / se(2.0)).powi(2);
        eprintln!("{p}: Var(4 runs) / Var(2 runs) = {ratio:.3}");
        assert!((0.3..=0.75).contains(&ratio), "{p}: {ratio}");
    }
}

/// A coast-down with every per-realisation draw it has (speed noise, gusts re-integrating
/// every run, a runs axis) gives the same tables with one thread and with two.
#[test]
fn a_gusty_coast_down_is_the_same_on_one_thread_and_two() {
    let text = set_key(&study_text("coastdown.toml"), "runs", "[4, 8]");
    let text = format!("{text}\n[truth]\nwind_gust_sd = [0.5]\nwind_speed = [2.0]\n");
    let study = load(&text, 24);
    let (one, _) = run(&study, Some(1));
    let (two, _) = run(&study, Some(2));
    assert_same_tables(one.path(), two.path());
}
