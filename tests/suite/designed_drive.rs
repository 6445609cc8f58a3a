//! A designed drive (docs/model.md#designed-drive): `studies/designed_drive.toml` — the
//! thesis vehicle, 600 s, torque within 0–450 N·m, speed within 10–35 m/s, the thesis
//! terrain at scale 1, σ_v = 0.1 m/s, BCLS, criterion "d".

use chassis_mc::model::vehicle::designed_profile_criterion;
use chassis_mc::study::Study;

use super::common::*;

/// The parameter's row of a one-condition, one-estimator summary: (EmpSE, its MCSE).
fn emp_se(summary: &arrow::array::RecordBatch, parameter: &str) -> (f64, f64) {
    let i = str_col(summary, "parameter")
        .iter()
        .position(|p| p == parameter)
        .unwrap();
    (
        f64_col(summary, "emp_se")[i],
        f64_col(summary, "emp_se_mcse")[i],
    )
}

#[test]
fn the_designed_drive_holds_its_limits_beats_the_thesis_drive_and_every_square_wave() {
    let study = study("designed_drive.toml", 100);
    let (dir, _) = run(&study, None);
    let trace = read_table(&dir.path().join("designed_drive.parquet"));
    // Every sample within the limits (the governor's guarantee, exactly: no tolerance).
    let (v, torque) = (f64_col(&trace, "v"), f64_col(&trace, "torque"));
    assert_eq!(v.len(), 60_001);
    assert!(
        v.iter().all(|v| (10.0..=35.0).contains(v)),
        "speed outside 10–35 m/s"
    );
    assert!(
        torque.iter().all(|t| (0.0..=450.0).contains(t)),
        "torque outside 0–450 N·m"
    );

    // On its own criterion, at least as good as every square wave between the limits at
    // periods 10, 20, 30, 60 and 100 s, starting high or low (segments of 5 s: these are
    // profiles of the search's first stage, so this checks that the search keeps the best
    // it saw), and at each phase a whole segment into the wave (profiles the search need
    // not have tried); each is driven under the same governor.
    let design = read_table(&dir.path().join("drive_design.parquet"));
    let designed = f64_col(&design, "criterion_value")[0];
    assert_eq!(str_col(&design, "drive")[0], "designed");
    let mut waves = 0;
    for period in [10.0_f64, 20.0, 30.0, 60.0, 100.0] {
        for shift in (0..(period / 5.0) as usize).map(|s| s as f64 * 5.0) {
            let levels: Vec<f64> = (0..120)
                .map(|j| {
                    let high = (j as f64 * 5.0 + shift) % period < period / 2.0;
                    if high { 450.0 } else { 0.0 }
                })
                .collect();
            let square = designed_profile_criterion(&study, &levels).unwrap();
            waves += 1;
            assert!(
                designed <= square,
                "period {period} s, phase {shift} s: square wave {square} < designed {designed}"
            );
        }
    }
    assert_eq!(waves, 2 + 4 + 6 + 12 + 20);

    // Its Monte Carlo EmpSE of 1/M at most a quarter of the thesis drive's (the study's own
    // torque from rest, 600 s, the same sensor and estimator) and of Cr at most half, with
    // each EmpSE moved 3 MCSE towards failing.
    let thesis_text =
        ["scales", "velocity_sd", "estimators"]
            .iter()
            .zip(["[1.0]", "[0.1]", "[\"bcls\"]"]);
    let mut text = study_text("thesis.toml");
    for (key, value) in thesis_text {
        text = set_key(&text, key, value);
    }
    let thesis = Study::from_toml(&text, "thesis_bcls")
        .unwrap()
        .with_overrides(Some(100), None)
        .unwrap();
    let thesis = run_summary(&thesis);
    let ours = read_table(&dir.path().join("summary.parquet"));
    for (parameter, fraction) in [("inv_mass", 0.25), ("rolling_resistance", 0.5)] {
        let (d, d_mcse) = emp_se(&ours, parameter);
        let (t, t_mcse) = emp_se(&thesis, parameter);
        assert!(
            d + 3.0 * d_mcse <= fraction * (t - 3.0 * t_mcse),
            "{parameter}: designed EmpSE {d:.3e} ± {d_mcse:.1e}, thesis drive {t:.3e} ± {t_mcse:.1e}"
        );
    }

    // `run` replays the trace (mode `replay` on designed_drive.parquet): the same rows, so
    // the same estimates to the bit under the same seed.
    let replay_text = {
        let text = study_text("designed_drive.toml");
        let start = text.find("[drive]").unwrap();
        let end = text.find("[noise]").unwrap();
        format!(
            "{}[drive]\nmode = \"replay\"\nfile = \"{}\"\n\n[terrain]\nscales = [1.0]\n\n{}",
            &text[..start],
            dir.path().join("designed_drive.parquet").display(),
            &text[end..]
        )
    };
    let replayed = Study::from_toml(&replay_text, "replayed")
        .unwrap()
        .with_overrides(Some(100), None)
        .unwrap();
    let replayed = run_summary(&replayed);
    for column in ["mean", "emp_se"] {
        assert_eq!(
            f64_col(&replayed, column),
            f64_col(&ours, column),
            "{column}"
        );
    }
}

#[test]
fn the_design_is_the_same_whatever_the_thread_count() {
    // A minute of the designed drive, 12 segments: the search evaluates its profiles in
    // parallel and must choose the same one on one thread as on two.
    let mut text = study_text("designed_drive.toml");
    text = set_key(&text, "duration", "60.0");
    text = set_key(&text, "segments", "12");
    text = set_key(&text, "polish_iterations", "20");
    let study = Study::from_toml(&text, "short_design")
        .unwrap()
        .with_overrides(Some(10), None)
        .unwrap();
    let (one, _) = run(&study, Some(1));
    let (two, _) = run(&study, Some(2));
    for (file, columns) in [
        ("designed_drive.parquet", &["t", "v", "torque"][..]),
        (
            "drive_design.parquet",
            &["criterion_value", "governed_fraction"][..],
        ),
    ] {
        let (a, b) = (
            read_table(&one.path().join(file)),
            read_table(&two.path().join(file)),
        );
        for c in columns {
            assert_eq!(f64_col(&a, c), f64_col(&b, c), "{file}: {c}");
        }
    }
}
