//! What a study costs as its grid of conditions grows: cycles.parquet holds each distinct
//! cycle once (every condition's samples derived from it exactly), and the cycles figure
//! does not grow with the number of conditions.

use arrow::array::{Array, BooleanArray};
use chassis_mc::model::Model;
use chassis_mc::model::vehicle::VehicleModel;

use super::common::*;

/// Samples of the thesis cycle: 600 s at 0.01 s, both ends included.
const THESIS_SAMPLES: usize = 60_001;

/// The thesis study with `scales`, `durations`, `velocity_sd` and the acceleration sources
/// `acceleration`, standstill below 3 m/s left out.
fn grid_text(scales: &str, durations: &str, velocity_sd: &str, acceleration: &str) -> String {
    let text = set_key(&study_text("thesis.toml"), "scales", scales);
    let text = set_key(&text, "velocity_sd", velocity_sd);
    let text = text.replace(
        "[drive]",
        &format!("[drive]\nmin_speed = 3.0\nexclude_braking = true\ndurations = {durations}"),
    );
    text.replace(
        "[estimation]",
        &format!("[estimation]\nacceleration = {acceleration}"),
    )
}

fn used_col(batch: &arrow::array::RecordBatch) -> Vec<bool> {
    let a = batch
        .column_by_name("used")
        .unwrap()
        .as_any()
        .downcast_ref::<BooleanArray>()
        .unwrap();
    (0..a.len()).map(|i| a.value(i)).collect()
}

#[test]
fn cycles_parquet_holds_each_distinct_cycle_once_and_every_condition_recovers_its_samples() {
    // 2 scales × 3 durations × 2 speed-noise levels × 2 acceleration sources: 24 conditions,
    // and 4 distinct (scale, source) cycles.
    let text = grid_text(
        "[1.0, 2.0]",
        "[60.0, 300.0, 600.0]",
        "[0.5, 1.0]",
        "[\"model\", \"differentiated\"]",
    );
    let study = chassis_mc::study::Study::from_toml(&text, "grid")
        .unwrap()
        .with_overrides(Some(2), None)
        .unwrap();
    let (dir, report) = run(&study, None);
    assert_eq!(report.infos.len(), 24);
    let cycles = read_table(&dir.path().join("cycles.parquet"));
    assert_eq!(
        cycles.num_rows(),
        4 * THESIS_SAMPLES,
        "each distinct cycle once"
    );
    let (scale, source) = (f64_col(&cycles, "scale"), str_col(&cycles, "acceleration"));
    let (t, v, f, grade) = (
        f64_col(&cycles, "t"),
        f64_col(&cycles, "v"),
        f64_col(&cycles, "f_prop"),
        f64_col(&cycles, "grade"),
    );
    let used = used_col(&cycles);
    // Blocks in order: scale-major, the sources in study order; both sources of a scale
    // have the same cycle, and `used` is the row selection over the whole cycle (a
    // differentiated acceleration also leaves out the first and last sample).
    for (b, (s, a)) in [
        (1.0, "model"),
        (1.0, "differentiated"),
        (2.0, "model"),
        (2.0, "differentiated"),
    ]
    .into_iter()
    .enumerate()
    {
        let rows = b * THESIS_SAMPLES..(b + 1) * THESIS_SAMPLES;
        let first = rows.start;
        for (i, row) in rows.enumerate() {
            assert_eq!((scale[row], source[row].as_str()), (s, a), "row {row}");
            let twin = (b / 2) * 2 * THESIS_SAMPLES + i;
            assert_eq!(
                [t[row], v[row], grade[row]],
                [t[twin], v[twin], grade[twin]]
            );
            let edge = a == "differentiated" && (i == 0 || i == THESIS_SAMPLES - 1);
            assert_eq!(
                used[row],
                v[row] >= 3.0 && f[row] >= 0.0 && !edge,
                "row {row}"
            );
        }
        assert_eq!(t[first], 0.0, "a simulated cycle starts at t = 0");
    }
    // Each condition's samples, joined on (scale, acceleration) and cut at its duration
    // (t − t₀ ≤ duration, t₀ = 0 here),
    // are the rows its regression has: their number is what a realisation sums over, and
    // their mean θ² is the summary's terrain_ms_cycle to the bit (both exact sums) for the
    // model's acceleration (the metric ignores the differentiated edges, which lie outside
    // every duration but the whole cycle's).
    let model = VehicleModel::new(&study).unwrap();
    let summary = read_table(&dir.path().join("summary.parquet"));
    let (s_condition, s_ms) = (
        i32_col(&summary, "condition"),
        f64_col(&summary, "terrain_ms_cycle"),
    );
    let layout = model.layout();
    let axis = |name: &str| layout.axes.iter().position(|a| a.name == name).unwrap();
    for (c, info) in report.infos.iter().enumerate() {
        let (s, d) = (
            info.axes[axis("scale")].number(),
            info.axes[axis("duration")].number(),
        );
        let a = info.axes[axis("acceleration")].to_string();
        let rows: Vec<usize> = (0..cycles.num_rows())
            .filter(|&i| scale[i] == s && source[i] == a && used[i] && t[i] <= d)
            .collect();
        let n = model.moments(study.seed(), c, 0).n;
        assert_eq!(
            rows.len() as f64,
            n,
            "condition {c} (scale {s}, {a}, {d} s)"
        );
        if a == "model" {
            let grades: Vec<f64> = rows.iter().map(|&i| grade[i]).collect();
            let row = s_condition.iter().position(|&k| k == c as i32).unwrap();
            assert_eq!(
                chassis_mc::terrain::mean_square(&grades).to_bits(),
                s_ms[row].to_bits(),
                "condition {c}"
            );
        }
    }
}

#[test]
fn the_cycles_table_and_figure_do_not_grow_with_the_conditions() {
    // 14 scales, more than the figure draws: one condition each, then 3 durations × 3
    // noise levels each (126 conditions). cycles.parquet holds the same rows, and
    // cycles.svg is the same file byte for byte: 12 of the scales (the first and the last
    // among them), each at most MAX_CYCLE_POINTS bins.
    let scales = "[1.0, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6, 1.7, 1.8, 1.9, 2.0, 2.1, 2.2, 2.3]";
    let small = grid_text(scales, "[600.0]", "[1.0]", "\"model\"");
    let large = grid_text(
        scales,
        "[60.0, 300.0, 600.0]",
        "[0.2, 0.5, 1.0]",
        "\"model\"",
    );
    let outputs: Vec<(tempfile::TempDir, usize)> = [small, large]
        .iter()
        .map(|text| {
            let study = chassis_mc::study::Study::from_toml(text, "grid")
                .unwrap()
                .with_overrides(Some(2), None)
                .unwrap();
            let (dir, report) = run(&study, None);
            (dir, report.infos.len())
        })
        .collect();
    assert_eq!((outputs[0].1, outputs[1].1), (14, 126));
    let [a, b] = [&outputs[0].0, &outputs[1].0].map(|d| d.path().to_path_buf());
    let cycles = read_table(&a.join("cycles.parquet"));
    assert_eq!(cycles.num_rows(), 14 * THESIS_SAMPLES);
    assert_eq!(
        cycles.columns(),
        read_table(&b.join("cycles.parquet")).columns()
    );
    let figure = std::fs::read_to_string(a.join("figures/cycles.svg")).unwrap();
    assert_eq!(
        figure,
        std::fs::read_to_string(b.join("figures/cycles.svg")).unwrap()
    );
    // The SVG writes each text on a line of its own.
    let texts: Vec<&str> = figure.lines().map(str::trim).collect();
    let scales_drawn = texts
        .iter()
        .filter(|t| t.starts_with("terrain scale "))
        .count();
    assert_eq!(scales_drawn, 12, "legend entries");
    for label in [
        "terrain scale 1",
        "terrain scale 2.3",
        "left out of the regression",
    ] {
        assert!(texts.contains(&label), "cycles.svg lacks {label}");
    }
}

#[test]
fn a_shorter_durations_regression_shares_the_longer_ones_rows_bit_for_bit() {
    // The 60 s conditions of a study that also has 300 s and 600 s (their regressions the
    // first rows of the 600 s ones, sharing its columns) against a study with 60 s alone
    // (built on their own): the same realisations to the bit, for both acceleration sources
    // and a grade bias. The 60 s conditions come first in both (duration is the outer axis).
    let tables: Vec<arrow::array::RecordBatch> = ["[60.0, 300.0, 600.0]", "[60.0]"]
        .iter()
        .map(|durations| {
            let text = grid_text(
                "[1.5]",
                durations,
                "[0.5, 1.0]",
                "[\"model\", \"differentiated\"]",
            );
            let text = text.replace("[noise]", "[noise]\ngrade_bias = [0.0, 0.001]");
            let study = chassis_mc::study::Study::from_toml(&text, "durations")
                .unwrap()
                .with_overrides(Some(3), None)
                .unwrap();
            let (dir, _) = run(&study, None);
            read_table(&dir.path().join("realisations.parquet"))
        })
        .collect();
    let first = |table: &arrow::array::RecordBatch| {
        let conditions = i32_col(table, "condition");
        let rows = conditions.iter().filter(|&&c| c < 8).count();
        assert!(
            conditions[..rows].iter().all(|&c| c < 8),
            "rows in condition order"
        );
        table.slice(0, rows)
    };
    let (a, b) = (first(&tables[0]), first(&tables[1]));
    assert_eq!(b.num_rows(), tables[1].num_rows(), "8 conditions of 60 s");
    assert_eq!(a.num_rows(), 8 * 3);
    assert_eq!(a.columns(), b.columns());
}

/// Every file under `dir` (the lock and manifest, which hold no results, left out), by
/// its path inside `dir`, with its size.
fn written_files(dir: &std::path::Path) -> std::collections::BTreeMap<String, f64> {
    let mut out = std::collections::BTreeMap::new();
    let mut pending = vec![dir.to_path_buf()];
    while let Some(d) = pending.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                pending.push(path);
            } else if !path.file_name().unwrap().to_string_lossy().starts_with('.') {
                let name = path
                    .strip_prefix(dir)
                    .unwrap()
                    .to_string_lossy()
                    .into_owned();
                out.insert(name, std::fs::metadata(&path).unwrap().len() as f64);
            }
        }
    }
    out
}

#[test]
fn check_estimates_every_file_a_run_writes_within_a_stated_factor() {
    // 2 scales × 2 durations × 2 noise levels, OLS and BCLS. `check` writes the summary,
    // cycles, figures and report as a run does, from a summary of 8 realisations per
    // condition, and models realisations.parquet from sample files (bytes fixed, per row
    // group, per realisation). Its files have the run's rows, row groups and figure
    // elements; only the values differ, and a zstd-compressed double's size depends on its
    // value only through its sign, exponent and leading bits. So within 1.25× either way
    // (measured: 0.90–1.00 on this study, the 1100-condition grid and the thesis study at
    // R = 2000 and 100 000). Which trade-off figures exist depends on the results (their
    // iso-lines), so the list of files is compared at R = 8, where check's summary is the
    // run's own; the Parquet files also at R = 300.
    const FACTOR: f64 = 1.25;
    let text = grid_text("[1.0, 2.0]", "[300.0, 600.0]", "[0.5, 1.0]", "\"model\"");
    let text = set_key(&text, "estimators", "[\"ols\", \"bcls\"]");
    for r in [8, 300] {
        let study = chassis_mc::study::Study::from_toml(&text, "grid")
            .unwrap()
            .with_overrides(Some(r), None)
            .unwrap();
        let estimated = chassis_mc::check::check(&study, None).unwrap();
        let (dir, _) = run(&study, None);
        let written = written_files(dir.path());
        let names: std::collections::BTreeSet<&String> =
            estimated.files.iter().map(|f| &f.name).collect();
        assert_eq!(names.len(), estimated.files.len(), "each file once");
        if r == 8 {
            assert_eq!(
                names,
                written.keys().collect(),
                "check names every file a run writes"
            );
        }
        for f in &estimated.files {
            if r != 8 && !f.name.ends_with(".parquet") {
                continue;
            }
            let ratio = f.bytes / written[&f.name];
            println!("R = {r}, {}: ratio {ratio:.3}", f.name);
            assert!(
                (1.0 / FACTOR..=FACTOR).contains(&ratio),
                "R = {r}, {}: estimated {} B, written {} B",
                f.name,
                f.bytes,
                written[&f.name]
            );
        }
    }
}

#[test]
fn check_does_not_count_more_threads_than_cores() {
    // 1000 threads on this machine's cores run no faster than as many threads as cores:
    // the estimate divides the realisations' single-thread time by the cores at most.
    let study = chassis_mc::study::Study::from_toml(&study_text("thesis.toml"), "thesis")
        .unwrap()
        .with_overrides(Some(100_000), None)
        .unwrap();
    let many = chassis_mc::check::check(&study, Some(1000)).unwrap();
    assert_eq!(many.threads, 1000);
    let mut as_many_as_cores = many.clone();
    as_many_as_cores.threads = many.cores;
    assert_eq!(
        many.estimated_run_time(),
        as_many_as_cores.estimated_run_time()
    );
    // 1.1 million realisations of ≥ 0.05 ms each (the kernel's 60 001 draws alone take
    // longer: README, Performance) cannot take less than 55 s of single-thread work.
    let floor = 1.1e6 * 0.05e-3 / many.cores as f64;
    assert!(
        many.estimated_run_time().as_secs_f64() > floor,
        "{:?}",
        many.estimated_run_time()
    );
}
