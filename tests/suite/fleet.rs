//! A fleet from a table (docs/model.md#fleet): one condition per vehicle, each vehicle's truth
//! the conversion of its row's road load, its id in every table; a bad row is named before
//! anything runs; the same bits whatever the thread count.

use chassis_mc::study::Study;

use super::common::*;

/// The shipped fleet study, its realisation count `r`, runs [4], written into `dir` beside a
/// copy of its table whose text is `table` (the shipped one when `None`).
fn fleet_in(dir: &std::path::Path, table: Option<String>, r: u64) -> Result<Study, String> {
    let data = dir.join("data");
    std::fs::create_dir_all(&data).unwrap();
    let shipped = std::fs::read_to_string(root().join("studies/data/epa_2022_fleet.csv")).unwrap();
    std::fs::write(data.join("epa_2022_fleet.csv"), table.unwrap_or(shipped)).unwrap();
    let text = set_key(&study_text("fleet.toml"), "runs", "[4]");
    let path = dir.join("fleet.toml");
    std::fs::write(&path, text).unwrap();
    Study::load(&path)
        .and_then(|s| s.with_overrides(Some(r), None))
        .map_err(|e| e.to_string())
}

#[test]
fn each_vehicle_is_its_rows_road_load_and_its_id_is_in_every_table() {
    let dir = tempfile::tempdir().unwrap();
    let study = fleet_in(dir.path(), None, 4).unwrap();
    let fleet = study.fleet().unwrap();
    // The FTP rows, one per test vehicle: the twelve vehicles, not the three HWY repeats.
    assert_eq!(fleet.vehicles.len(), 12);
    let (out, report) = run(&study, None);
    assert_eq!(report.infos.len(), 12);
    let summary = read_table(&out.path().join("summary.parquet"));
    let (ids, parameters, truth) = (
        str_col(&summary, "vehicle"),
        str_col(&summary, "parameter"),
        f64_col(&summary, "truth"),
    );
    // The conversion (docs/model.md#road-load-vehicle) from the table's own cells, read here
    // independently: M = ETW·lb, Cd/M = 2C/(ρ A_f M), Cr = A/(M g), in SI.
    let (lbf, mph, lb) = (4.4482216152605, 0.44704, 0.45359237);
    let table = std::fs::read_to_string(root().join("studies/data/epa_2022_fleet.csv")).unwrap();
    let mut checked = 0;
    for line in table.lines().filter(|l| !l.starts_with('#')).skip(1) {
        let cells: Vec<&str> = line.split(',').collect();
        if cells[4] != "FTP" {
            continue;
        }
        let number = |i: usize| cells[i].parse::<f64>().unwrap();
        let (m, a, c) = (
            number(5) * lb,
            number(6) * lbf,
            number(8) * lbf / (mph * mph),
        );
        let expected = [
            ("drag_over_mass", 2.0 * c / (1.2 * 2.5) / m),
            ("rolling_resistance", a / (m * 9.81)),
        ];
        // And B in the truth's speed-dependent rolling resistance: B/A [s/m].
        let b = number(7) * lbf / mph;
        let speeds = f64_col(&summary, "rolling_speed_coefficient");
        for i in (0..summary.num_rows()).filter(|&i| ids[i] == cells[2]) {
            assert!(
                ((speeds[i] - b / a) / (b / a)).abs() < 1e-12,
                "{}: B/A",
                cells[2]
            );
        }
        for (parameter, value) in expected {
            let rows: Vec<usize> = (0..summary.num_rows())
                .filter(|&i| ids[i] == cells[2] && parameters[i] == parameter)
                .collect();
            assert!(!rows.is_empty(), "{} has rows", cells[2]);
            for i in rows {
                assert!(
                    ((truth[i] - value) / value).abs() < 1e-12,
                    "{} {parameter}: {} against {value}",
                    cells[2],
                    truth[i]
                );
                checked += 1;
            }
        }
    }
    assert_eq!(
        checked,
        12 * 2 * 2,
        "12 vehicles × 2 parameters × 2 estimators"
    );
    // The id is a column of the realisations too.
    let realisations = read_table(&out.path().join("realisations.parquet"));
    assert!(
        str_col(&realisations, "vehicle")
            .iter()
            .any(|v| v == "CAMRY")
    );
}

#[test]
fn a_fleet_is_the_same_bits_on_one_thread_and_two() {
    let dir = tempfile::tempdir().unwrap();
    let study = fleet_in(dir.path(), None, 3).unwrap();
    let (one, _) = run(&study, Some(1));
    let (two, _) = run(&study, Some(2));
    for file in ["realisations.parquet", "summary.parquet"] {
        let (x, y) = (
            read_table(&one.path().join(file)),
            read_table(&two.path().join(file)),
        );
        assert_eq!(x.columns(), y.columns(), "{file}");
    }
}

#[test]
fn a_bad_row_is_named_by_file_line_column_and_reason() {
    let shipped = std::fs::read_to_string(root().join("studies/data/epa_2022_fleet.csv")).unwrap();
    let line_of = |needle: &str| shipped.lines().position(|l| l.contains(needle)).unwrap() + 1;
    // A cell that is not a number, and a weight that is not positive.
    let cases = [
        (
            "37.800",
            "3x.800",
            line_of("CIVIC 4DR,EM4A1C,FTP"),
            "Target Coef A (lbf)",
            "not a finite number",
        ),
        (
            "3000,25.880",
            "-3000,25.880",
            line_of("Elantra"),
            "Equivalent Test Weight (lbs.)",
            "must be > 0",
        ),
    ];
    for (from, to, line, column, why) in cases {
        let dir = tempfile::tempdir().unwrap();
        let err = fleet_in(dir.path(), Some(shipped.replacen(from, to, 1)), 2).unwrap_err();
        for part in [
            "epa_2022_fleet.csv",
            &format!("line {line}"),
            &format!("\"{column}\""),
            why,
        ] {
            assert!(err.contains(part), "{to}: no {part:?} in {err}");
        }
        // At the command line: exit 2, and nothing written.
        let out = dir.path().join("out");
        let args = ["run", "fleet.toml", "--out", out.to_str().unwrap()].map(std::ffi::OsStr::new);
        let (code, _, stderr) = cli(&args, dir.path());
        assert_eq!(code, 2, "{stderr}");
        assert!(stderr.contains(&format!("line {line}")), "{stderr}");
        assert!(!out.exists());
    }
    // Without the filter the HWY repeats name a vehicle twice.
    let dir = tempfile::tempdir().unwrap();
    let study = fleet_in(dir.path(), None, 2).unwrap();
    let text = study_text("fleet.toml").replace("filter = ['\"Test Category\" == \"FTP\"']", "");
    let text = text.replace("distinct = [\"Test Vehicle ID\"]", "");
    std::fs::write(dir.path().join("fleet.toml"), text).unwrap();
    drop(study);
    let err = Study::load(&dir.path().join("fleet.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("names a vehicle already read") && err.contains("fleet.filter"),
        "{err}"
    );
}

#[test]
fn summarize_refuses_a_table_whose_vehicles_changed_since_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let study = fleet_in(dir.path(), None, 2).unwrap();
    let out = dir.path().join("out");
    let args = [
        "run",
        "fleet.toml",
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]
    .map(std::ffi::OsStr::new);
    assert_eq!(cli(&args, dir.path()).0, 0);
    drop(study);
    // The Camry's C doubled after the run: its truth would no longer be the run's.
    let table = dir.path().join("data/epa_2022_fleet.csv");
    let text = std::fs::read_to_string(&table).unwrap();
    std::fs::write(&table, text.replacen("0.015068", "0.030136", 1)).unwrap();
    let args = ["summarize", out.to_str().unwrap()].map(std::ffi::OsStr::new);
    let (code, _, stderr) = cli(&args, dir.path());
    assert_eq!(code, 2, "{stderr}");
    assert!(
        stderr.contains("fleet.file") && stderr.contains("no longer holds"),
        "{stderr}"
    );
}
