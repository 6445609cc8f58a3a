//! Routes and drive cycles from data: a `file` terrain (elevation or grade by distance), the
//! `speed_trace` drive mode (inverse dynamics on the trace's own, uneven samples), the row
//! selection and the durations axis (docs/model.md#speed-trace, #terrain).
//!
//! Without noise y = Xθ holds exactly in real arithmetic on every such cycle (the force of
//! a trace comes from the same acceleration the output uses), so OLS recovers θ to rounding.

use std::fmt::Write as _;
use std::path::Path;
use std::process::{Command, Stdio};

use chassis_mc::study::Study;

use super::common::*;

const TRUTH: [f64; 3] = [1.0 / 1800.0, 0.35 / 1800.0, 0.0125];

/// The thesis study with its `[terrain]` table replaced by `terrain` and its `[drive]` table
/// by `drive` (each without the header), noise off.
fn thesis_with(drive: Option<&str>, terrain: Option<&str>) -> String {
    let text = set_key(&study_text("thesis.toml"), "velocity_sd", "[0.0]");
    let mut out = String::new();
    let mut skipping = false;
    for line in text.lines() {
        if line.starts_with('[') {
            skipping = false;
            let replace = match line {
                "[drive]" => drive,
                "[terrain]" => terrain,
                _ => None,
            };
            if let Some(body) = replace {
                writeln!(out, "{line}\n{body}").unwrap();
                skipping = true;
                continue;
            }
        }
        if !skipping {
            writeln!(out, "{line}").unwrap();
        }
    }
    out
}

/// θ̂ of every realisation of `study` recovers the truth to 1e-9 relative.
fn assert_recovers_theta(study: &Study, what: &str) {
    let (dir, _) = run(study, None);
    let table = read_table(&dir.path().join("realisations.parquet"));
    for (p, name) in PARAMS.iter().enumerate() {
        for v in f64_col(&table, &format!("theta_{name}")) {
            let rel = ((v - TRUTH[p]) / TRUTH[p]).abs();
            // Rounding in the sums and the 3×3 solve, as on the thesis's road.
            assert!(rel <= 1e-9, "{what}: {name}: {v} vs {} ({rel:e})", TRUTH[p]);
        }
    }
}

fn load(text: &str, r: u64) -> Study {
    Study::from_toml(text, "routes test")
        .unwrap_or_else(|e| panic!("{e}"))
        .with_overrides(Some(r), None)
        .unwrap()
}

/// A road of three superposed hills, elevation [m] at distance `x` [m].
fn hills(x: f64) -> f64 {
    4.0 * (x / 150.0 + 0.3).cos().powi(2)
        + 12.0 * (x / 700.0 + 1.1).cos().powi(2)
        + 30.0 * (x / 2000.0).cos().powi(2)
}

#[test]
fn ols_recovers_theta_without_noise_on_file_routes_of_elevation_and_of_grade() {
    let tmp = tempfile::tempdir().unwrap();
    // Every 7 m over 30 km, so that the linear interpolation to the 1 m grid matters.
    let (mut elevation, mut grade) = (
        String::from("# a test road\ndistance_m,elevation_m\n"),
        String::from("distance_m,grade_pct\n"),
    );
    for i in 0..=(30_000 / 7) {
        let x = 7.0 * i as f64;
        writeln!(elevation, "{x},{}", hills(x)).unwrap();
        let slope = (hills(x + 0.5) - hills(x - 0.5)) * 100.0;
        writeln!(grade, "{x},{slope}").unwrap();
    }
    let (e_path, g_path) = (tmp.path().join("road.csv"), tmp.path().join("grade.csv"));
    std::fs::write(&e_path, elevation).unwrap();
    std::fs::write(&g_path, grade).unwrap();
    for (what, columns) in [
        (
            "elevation",
            "elevation_column = \"elevation_m\"".to_string(),
        ),
        (
            "grade",
            "grade_column = \"grade_pct\"\ngrade_unit = \"percent\"".to_string(),
        ),
    ] {
        let path = if what == "elevation" {
            &e_path
        } else {
            &g_path
        };
        let terrain = format!(
            "profile = \"file\"\nfile = \"{}\"\ndistance_column = \"distance_m\"\n{columns}\nscales = [1.0, 2.0]\nscale_applies_to = \"grade\"",
            path.display()
        );
        assert_recovers_theta(&load(&thesis_with(None, Some(&terrain)), 2), what);
    }
}

/// A drive log with three stops, hard braking and uneven steps (0.8 to 1.3 s): speed
/// [km/h] and grade [%] by time.
fn drive_log() -> String {
    let mut out = String::from("time_s,speed_kmh,grade_pct\n");
    let (mut t, mut i) = (0.0f64, 0u32);
    while t < 900.0 {
        // Cycles of 300 s: 10 s standing, 60 s pulling away, cruising, braking hard to a
        // stop at the end.
        let phase = t % 300.0;
        let v = if phase < 10.0 {
            0.0
        } else if phase < 70.0 {
            let u = (phase - 10.0) / 60.0;
            70.0 * (1.0 - (std::f64::consts::PI * u).cos()) / 2.0
        } else if phase < 270.0 {
            70.0 + 15.0 * ((phase - 70.0) / 40.0).sin()
        } else {
            let u = (phase - 270.0) / 30.0;
            70.0 * (1.0 + (std::f64::consts::PI * u).cos()) / 2.0
        };
        let grade = 2.0 * (t / 90.0).sin() + 0.7 * (t / 23.0).cos();
        writeln!(out, "{t},{v},{grade}").unwrap();
        t += [1.0, 0.8, 1.3, 1.1, 0.9][(i % 5) as usize];
        i += 1;
    }
    out
}

fn trace_drive(path: &Path, extra: &str) -> String {
    format!(
        "mode = \"speed_trace\"\ntrace = \"{}\"\ntime_column = \"time_s\"\nspeed_column = \"speed_kmh\"\nspeed_unit = \"km/h\"\ngrade_column = \"grade_pct\"\ngrade_unit = \"percent\"\n{extra}",
        path.display()
    )
}

#[test]
fn ols_recovers_theta_without_noise_on_a_speed_trace_with_stops_and_braking() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("log.csv");
    std::fs::write(&path, drive_log()).unwrap();
    // The trace brings its grade: [terrain] only gives the scales.
    let study = load(
        &thesis_with(Some(&trace_drive(&path, "")), Some("scales = [1.0, 2.0]")),
        2,
    );
    assert_recovers_theta(&study, "speed trace");

    // The row selection and the durations axis, and what cycles.parquet records.
    let study = load(
        &thesis_with(
            Some(&trace_drive(
                &path,
                "min_speed = 0.5\nexclude_braking = true\ndurations = [300.0, 600.0]",
            )),
            Some(""),
        ),
        2,
    );
    let (dir, report) = run(&study, None);
    assert_eq!(report.infos.len(), 2, "one scale × two durations");
    let cycles = read_table(&dir.path().join("cycles.parquet"));
    let used = cycles
        .column_by_name("used")
        .unwrap()
        .as_any()
        .downcast_ref::<arrow::array::BooleanArray>()
        .unwrap();
    let (t, v, f) = (
        f64_col(&cycles, "t"),
        f64_col(&cycles, "v"),
        f64_col(&cycles, "f_prop"),
    );
    // The cycle once, `used` for the whole of it; a duration's samples are those within it.
    assert_eq!(cycles.num_rows(), t.len());
    assert!(
        t.windows(2).all(|w| w[0] < w[1]),
        "one block, in time order"
    );
    let mut counted = [0usize; 2];
    for i in 0..cycles.num_rows() {
        assert_eq!(used.value(i), v[i] >= 0.5 && f[i] >= 0.0, "row {i}");
        for (c, d) in [300.0, 600.0].into_iter().enumerate() {
            counted[c] += usize::from(used.value(i) && t[i] - t[0] <= d);
        }
    }
    // Stops and braking really were left out, and the longer duration keeps more rows.
    assert!(v.iter().any(|&v| v < 0.5) && f.iter().any(|&f| f < 0.0));
    assert!(counted[0] > 100 && counted[1] > counted[0], "{counted:?}");
    let summary = read_table(&dir.path().join("summary.parquet"));
    let durations = f64_col(&summary, "duration");
    assert!(durations.contains(&300.0) && durations.contains(&600.0));
}

#[test]
fn a_file_terrain_equal_to_the_cos2_table_reproduces_the_cos2_study_bit_for_bit() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("cos2.csv");
    // The elevation of the cos2 profile at every grid point, written in the shortest form
    // that reads back to the same double: linear interpolation at the grid points returns
    // these values exactly, so the rises, the grades and every number downstream agree.
    let mut text = String::from("x,y\n");
    for i in 0..=50_000 {
        let x = i as f64;
        let c = (x / 300.0).cos();
        writeln!(text, "{x},{}", 25.0 * c * c).unwrap();
    }
    std::fs::write(&path, text).unwrap();
    let thesis = study("thesis.toml", 40);
    let terrain = format!(
        "profile = \"file\"\nfile = \"{}\"\ndistance_column = \"x\"\nelevation_column = \"y\"\nscales = [1.0, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6, 1.7, 1.8, 1.9, 2.0]\nscale_applies_to = \"grade\"",
        path.display()
    );
    let text = thesis_with(None, Some(&terrain));
    let text = set_key(&text, "velocity_sd", "[1.0]");
    let file = load(&text, 40);
    let (a, _) = run(&thesis, None);
    let (b, _) = run(&file, None);
    assert_same_tables(a.path(), b.path());
}

#[test]
fn a_speed_trace_of_the_torque_cycle_gives_the_torque_study_within_mcse() {
    // The torque-driven thesis cycle at scale 1, written as a trace of its own t, v and
    // grade: the same cycle, the force now from inverse dynamics with central-difference
    // accelerations. At σ_v = 1 the OLS means and EmpSEs agree within 4 combined MCSEs.
    let r = 400;
    let torque_text = set_key(&study_text("thesis.toml"), "scales", "[1.0]");
    let torque = load(&torque_text, r);
    let (a, _) = run(&torque, None);
    let cycles = read_table(&a.path().join("cycles.parquet"));
    let mut trace = String::from("t,v,grade\n");
    let (t, v, g) = (
        f64_col(&cycles, "t"),
        f64_col(&cycles, "v"),
        f64_col(&cycles, "grade"),
    );
    for i in 0..t.len() {
        writeln!(trace, "{},{},{}", t[i], v[i], g[i]).unwrap();
    }
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("thesis_cycle.csv");
    std::fs::write(&path, trace).unwrap();
    let drive = format!(
        "mode = \"speed_trace\"\ntrace = \"{}\"\ntime_column = \"t\"\nspeed_column = \"v\"\nspeed_unit = \"m/s\"\ngrade_column = \"grade\"\ngrade_unit = \"rad\"",
        path.display()
    );
    let text = set_key(&thesis_with(Some(&drive), Some("")), "velocity_sd", "[1.0]");
    let (b, _) = run(&load(&text, r), None);
    let (sa, sb) = (
        read_table(&a.path().join("summary.parquet")),
        read_table(&b.path().join("summary.parquet")),
    );
    for (measure, mcse) in [("mean", "mean_mcse"), ("emp_se", "emp_se_mcse")] {
        let (x, y) = (f64_col(&sa, measure), f64_col(&sb, measure));
        let (mx, my) = (f64_col(&sa, mcse), f64_col(&sb, mcse));
        for p in 0..x.len() {
            let z = (x[p] - y[p]) / (mx[p].powi(2) + my[p].powi(2)).sqrt();
            assert!(
                z.abs() < 4.0,
                "{measure} of parameter {p}: {} vs {} (z = {z:.2})",
                x[p],
                y[p]
            );
        }
    }
}

#[test]
fn a_malformed_trace_is_exit_2_naming_file_column_and_line_and_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let good = drive_log();
    let mut lines: Vec<String> = good.lines().map(str::to_string).collect();
    let bad_line = |n: usize, cell: &str| {
        let mut l = lines.clone();
        let mut cells: Vec<&str> = l[n - 1].split(',').collect();
        cells[1] = cell;
        l[n - 1] = cells.join(",");
        l.join("\n") + "\n"
    };
    let not_increasing = {
        let mut l = lines.clone();
        let previous = l[4].split(',').next().unwrap().to_string();
        let rest: Vec<&str> = l[5].split(',').skip(1).collect();
        l[5] = format!("{previous},{}", rest.join(","));
        l.join("\n") + "\n"
    };
    let cases: Vec<(&str, String, &str, &[&str])> = vec![
        (
            "missing column",
            good.replace("speed_kmh", "speed"),
            "",
            &["column \"speed_kmh\"", "no such column"],
        ),
        (
            "text in a number cell",
            bad_line(7, "fast"),
            "",
            &["column \"speed_kmh\"", "line 7", "\"fast\" is not a number"],
        ),
        (
            "NaN",
            bad_line(9, "NaN"),
            "",
            &["column \"speed_kmh\"", "line 9", "not a finite number"],
        ),
        (
            "time not increasing",
            not_increasing,
            "",
            &["column \"time_s\"", "line 6", "strictly increasing"],
        ),
        (
            "fewer than 3 rows",
            lines[..3].join("\n") + "\n",
            "",
            &["2 data rows; at least 3"],
        ),
        (
            "a wrong unit name",
            good.clone(),
            "kph",
            &[
                "drive.speed_unit",
                "must be one of [\"m/s\", \"km/h\", \"mph\"]",
                "\"kph\"",
            ],
        ),
    ];
    lines.clear();
    for (name, data, unit, expected) in cases {
        let data_path = tmp.path().join(format!("{}.csv", name.replace(' ', "_")));
        std::fs::write(&data_path, data).unwrap();
        let mut drive = trace_drive(&data_path, "");
        if !unit.is_empty() {
            drive = drive.replace("speed_unit = \"km/h\"", &format!("speed_unit = \"{unit}\""));
        }
        let study = tmp.path().join(format!("{}.toml", name.replace(' ', "_")));
        std::fs::write(&study, thesis_with(Some(&drive), Some(""))).unwrap();
        let out = tmp.path().join(format!("out-{}", name.replace(' ', "_")));
        let (code, stdout, stderr) = cli(
            &[
                "run".as_ref(),
                study.as_os_str(),
                "--out".as_ref(),
                out.as_os_str(),
                "--quiet".as_ref(),
            ],
            tmp.path(),
        );
        assert_eq!(code, 2, "{name}: exit {code}: {stderr}");
        assert!(stdout.is_empty(), "{name}: {stdout}");
        assert_eq!(stderr.trim().lines().count(), 1, "{name}: {stderr}");
        let named = if unit.is_empty() {
            data_path.display().to_string()
        } else {
            study.display().to_string()
        };
        assert!(stderr.contains(&named), "{name}: names {named}: {stderr}");
        for e in expected {
            assert!(stderr.contains(e), "{name}: `{e}` in {stderr}");
        }
        assert!(!out.exists(), "{name}: wrote {}", out.display());
    }
}

#[test]
fn the_shipped_route_and_heavy_duty_studies_run_from_any_directory() {
    // The route study names its trace relative to the study file; run, figures and
    // summarize (which reload the study from the output's footer) must all find it from
    // another working directory.
    let tmp = tempfile::tempdir().unwrap();
    for name in ["route_trace.toml", "heavy_duty.toml"] {
        let out = tmp.path().join(name.trim_end_matches(".toml"));
        let output = Command::new(bin())
            .arg("run")
            .arg(study_path(name))
            .arg("--out")
            .arg(&out)
            .args(["--realisations", "20", "--quiet"])
            .current_dir(tmp.path())
            .stdin(Stdio::null())
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(output.status.success(), "{name}: {stderr}");
        assert!(out.join("figures/cycles.svg").is_file(), "{name}");
        let output = Command::new(bin())
            .arg("summarize")
            .arg(&out)
            .arg("--quiet")
            .current_dir(tmp.path())
            .stdin(Stdio::null())
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(output.status.success(), "{name} summarize: {stderr}");
    }
}

#[test]
fn a_study_run_by_its_bare_file_name_finds_its_trace() {
    // From inside studies/: the study's directory is the working directory, recorded as
    // such, so the figures (which reload the study from the output footer) find the trace.
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let output = Command::new(bin())
        .args(["run", "route_trace.toml", "--out"])
        .arg(&out)
        .args(["--realisations", "10", "--quiet"])
        .current_dir(root().join("studies"))
        .stdin(Stdio::null())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(out.join("figures/cycles.svg").is_file());
}

#[test]
fn a_differentiated_acceleration_on_an_uneven_trace() {
    // A speed trace's own acceleration is the central difference of its speed, so without
    // noise the differentiated output (the same difference, first and last sample left
    // out) is the trace's and OLS recovers θ as before. With AR(1) speed noise on these
    // uneven steps (0.8–1.3 s) BCLS's compensation does not hold (the noise is more
    // correlated with one neighbour than the other): an error naming the combination.
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("log.csv");
    std::fs::write(&path, drive_log()).unwrap();
    let text = thesis_with(Some(&trace_drive(&path, "min_speed = 0.5")), Some(""));
    let text = format!("{text}acceleration = \"differentiated\"\n");
    assert_recovers_theta(&load(&text, 2), "differentiated speed trace");

    let text = set_key(&text, "velocity_sd", "[0.3]");
    let text = set_key(&text, "estimators", "[\"ols\", \"bcls\"]");
    let text = text.replace("[noise]", "[noise]\nvelocity_correlation_time = [2.0]");
    let err = chassis_mc::model::vehicle::VehicleModel::new(&load(&text, 2))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("estimation.acceleration")
            && err.contains("\"bcls\"")
            && err.contains("evenly"),
        "{err}"
    );
    // White noise keeps BCLS unbiased on any steps: no error.
    let white = text.replace(
        "velocity_correlation_time = [2.0]",
        "velocity_correlation_time = [0.0]",
    );
    assert!(chassis_mc::model::vehicle::VehicleModel::new(&load(&white, 2)).is_ok());
}
