//! Terrain profiles other than the thesis's cos² hill: `sines`, a sum of cos² hills with
//! phases. One component with zero phase is the cos² profile itself (x/P + 0 = x/P exactly),
//! so it must reproduce the thesis study bit for bit; several components give a road on
//! which, without noise, OLS still recovers θ to rounding (y = Xθ holds exactly in real
//! arithmetic: docs/model.md#regression).

use chassis_mc::study::Study;

use super::common::*;

/// The thesis study with its `[terrain]` profile keys replaced by `profile_lines`.
fn with_profile(profile_lines: &str) -> String {
    let text = study_text("thesis.toml");
    let mut out = Vec::new();
    for line in text.lines() {
        let key = line.split('=').next().unwrap_or("").trim();
        match key {
            "profile" => out.push(profile_lines.to_string()),
            "height" | "period" => {}
            _ => out.push(line.to_string()),
        }
    }
    out.join("\n") + "\n"
}

#[test]
fn one_sines_component_reproduces_the_cos2_study_bit_for_bit() {
    let cos2 = study("thesis.toml", 40);
    let sines = Study::from_toml(
        &with_profile(
            "profile = \"sines\"\ncomponents = [{ height = 25.0, period = 300.0, phase = 0.0 }]",
        ),
        "one-component sines",
    )
    .unwrap()
    .with_overrides(Some(40), None)
    .unwrap();
    let (a, _) = run(&cos2, None);
    let (b, _) = run(&sines, None);
    assert_same_tables(a.path(), b.path());
}

#[test]
fn ols_recovers_theta_without_noise_on_a_sines_route() {
    // Three hills of 4, 12 and 30 m over 150 to 2000 m: grades up to ≈ 0.1 rad.
    let text = with_profile(
        "profile = \"sines\"\ncomponents = [\n  { height = 4.0, period = 150.0, phase = 0.3 },\n  { height = 12.0, period = 700.0, phase = 1.1 },\n  { height = 30.0, period = 2000.0, phase = 0.0 },\n]",
    );
    let text = set_key(&text, "velocity_sd", "[0.0]");
    let text = set_key(&text, "scales", "[1.0, 2.0]");
    let study = Study::from_toml(&text, "noise-free sines")
        .unwrap()
        .with_overrides(Some(2), None)
        .unwrap();
    let (dir, report) = run(&study, None);
    let thesis_study = super::common::study("thesis.toml", 1);
    let table = read_table(&dir.path().join("realisations.parquet"));
    let truth = [1.0 / 1800.0, 0.35 / 1800.0, 0.0125];
    for (p, name) in PARAMS.iter().enumerate() {
        for v in f64_col(&table, &format!("theta_{name}")) {
            let rel = ((v - truth[p]) / truth[p]).abs();
            // Rounding in the sums and the 3×3 solve, as on the thesis's road.
            assert!(rel <= 1e-9, "{name}: {v} vs {} ({rel:e})", truth[p]);
        }
    }
    // A different road from the thesis's: its terrain metric differs.
    let thesis = chassis_mc::model::prepare(&thesis_study).unwrap().infos();
    assert_ne!(report.infos[0].metrics[0], thesis[0].metrics[0]);
}

#[test]
fn a_bad_sines_key_is_a_study_error_naming_it() {
    for (lines, key, reason) in [
        (
            "profile = \"sines\"\ncomponents = [{ height = 25.0, period = -3.0, phase = 0.0 }]",
            "terrain.components[0].period",
            "must be > 0",
        ),
        (
            "profile = \"sines\"\ncomponents = [{ height = 25.0, period = 300.0 }]",
            "terrain.components[0].phase",
            "required key is missing",
        ),
        (
            "profile = \"sines\"\ncomponents = [{ height = 25.0, period = 300.0, phase = 0.0, tilt = 1.0 }]",
            "terrain.components[0].tilt",
            "unknown field",
        ),
        (
            "profile = \"sines\"\ncomponents = []",
            "terrain.components",
            "non-empty",
        ),
        (
            "profile = \"cos2\"\nheight = 25.0\nperiod = 300.0\ncomponents = []",
            "terrain.components",
            "unknown field",
        ),
        ("profile = \"steps\"", "terrain.profile", "unknown profile"),
    ] {
        let text = with_profile(lines);
        let err = Study::from_toml(&text, "bad.toml").unwrap_err();
        println!("{err}");
        assert_eq!(err.key.as_deref(), Some(key), "{lines}: {err}");
        assert!(err.reason.contains(reason), "{lines}: {err}");
        // The line of the profile's keys (each case writes them on the lines after
        // `profile =`): the error points at the table the user must fix.
        let first = text
            .lines()
            .position(|l| l.starts_with("profile ="))
            .unwrap()
            + 1;
        let last = first + lines.lines().count() - 1;
        let line = err
            .line
            .unwrap_or_else(|| panic!("{lines}: no line: {err}"));
        assert!(
            (first..=last).contains(&line),
            "{lines}: line {line} not in {first}..={last}: {err}"
        );
    }
}
