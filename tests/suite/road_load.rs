//! The `road_load` estimator: the coast-down analysis A + B·V + C·V² (docs/model.md#road-load).

use super::common::*;
use chassis_mc::study::Study;

/// The thesis drive with the mass known, on a flat road (terrain height 0), `estimators`
/// and speed noise `velocity_sd`, R = `realisations`.
fn flat_thesis(estimators: &str, velocity_sd: &str, realisations: u64) -> Study {
    let text = set_key(&study_text("bias_compensation.toml"), "scales", "[1.0]");
    let text = set_key(&text, "height", "0.0");
    let text = set_key(&text, "velocity_sd", velocity_sd);
    let text = set_key(&text, "estimators", estimators);
    let text = text.replace("[estimation]\n", "[estimation]\nknown_mass = true\n");
    Study::from_toml(&text, "flat_thesis")
        .unwrap()
        .with_overrides(Some(realisations), None)
        .unwrap()
}

/// Noise-free on a flat road the road load is exactly k Cd V² + Cr M g: `road_load`
/// recovers Cd/M and Cr to 1e-9 relative and B = 0 to 1e-9 of A (rounding in the sums of
/// 60 001 rows and the 3×3 solve of [1, V, V²], whose equilibrated condition is ≈ 1e5 here);
/// the columns road_load_a/b/c hold A = Cr M g, B, C = k Cd; other estimators' rows hold
/// null there.
#[test]
fn road_load_recovers_drag_and_rolling_resistance_on_a_flat_road() {
    let study = flat_thesis("[\"ols\", \"road_load\"]", "[0.0]", 2);
    let (dir, _) = run(&study, None);
    let table = read_table(&dir.path().join("realisations.parquet"));
    let estimator = str_col(&table, "estimator");
    let (a, b, c) = (
        f64_col(&table, "road_load_a"),
        f64_col(&table, "road_load_b"),
        f64_col(&table, "road_load_c"),
    );
    let cd_m = f64_col(&table, "theta_drag_over_mass");
    let cr = f64_col(&table, "theta_rolling_resistance");
    let (m, g, k) = (1800.0, 9.81, 0.5 * 1.2 * 5.5);
    let rel = |x: f64, t: f64| ((x - t) / t).abs();
    for i in 0..table.num_rows() {
        if estimator[i] != "road_load" {
            assert!(a[i].is_nan() && b[i].is_nan() && c[i].is_nan());
            continue;
        }
        assert!(rel(cd_m[i], 0.35 / m) <= 1e-9, "Cd/M {}", cd_m[i]);
        assert!(rel(cr[i], 0.0125) <= 1e-9, "Cr {}", cr[i]);
        assert!(rel(a[i], 0.0125 * m * g) <= 1e-9, "A {}", a[i]);
        assert!(rel(c[i], 0.35 * k) <= 1e-9, "C {}", c[i]);
        assert!(b[i].abs() <= 1e-9 * a[i], "B {} of A {}", b[i], a[i]);
    }
}

/// `road_load` without the mass known, and `effective_mass_factor` without `road_load`, are
/// refused naming the key.
#[test]
fn road_load_needs_the_mass_known_and_its_key_needs_road_load() {
    let text = set_key(
        &study_text("thesis.toml"),
        "estimators",
        "[\"ols\", \"road_load\"]",
    );
    let err = Study::from_toml(&text, "no_mass").unwrap_err();
    assert_eq!(
        err.key.as_deref(),
        Some("estimation.estimators[1]"),
        "{err}"
    );
    assert!(err.reason.contains("known_mass"), "{err}");
    let text = study_text("thesis.toml").replace(
        "[estimation]\n",
        "[estimation]\nknown_mass = true\neffective_mass_factor = 0.03\n",
    );
    let err = Study::from_toml(&text, "no_road_load").unwrap_err();
    assert_eq!(
        err.key.as_deref(),
        Some("estimation.effective_mass_factor"),
        "{err}"
    );
    assert!(err.line.is_some(), "{err}");
}

/// `estimation.effective_mass_factor` δ̂: on a flat calm coast-down the analysis's road-load
/// force is −M(1 + δ̂)a while the truth's is −M(1 + δ)a, so A, B, C (and Cd, Cr) scale by
/// exactly (1 + δ̂)/(1 + δ): δ̂ = δ = 0.03 recovers them (to 1e-9, rounding), δ̂ = 0.03 with
/// δ = 0 overstates both by 3 %, and δ = 0.03 unknown to the analysis understates them by
/// 1 − 1/1.03. Noise-free, `bias_model`.
#[test]
fn the_effective_mass_factor_scales_the_road_load_as_derived() {
    for (truth_delta, assumed, factor) in [
        (0.03, 0.03, 1.0),
        (0.0, 0.03, 1.03),
        (0.03, 0.0, 1.0 / 1.03),
    ] {
        let text = set_key(&study_text("coastdown.toml"), "velocity_sd", "[0.0]");
        let text = set_key(&text, "estimators", "[\"road_load\"]");
        let text = text.replacen(
            "\n[estimation]\n",
            &format!("\n[estimation]\neffective_mass_factor = {assumed}\n"),
            1,
        );
        let text = format!("{text}\n[truth]\nrotating_mass_factor = [{truth_delta}]\n");
        let study = Study::from_toml(&text, "delta")
            .unwrap()
            .with_overrides(Some(2), None)
            .unwrap();
        let summary = run_summary(&study);
        let (truth, bias) = (f64_col(&summary, "truth"), f64_col(&summary, "bias_model"));
        for p in 0..2 {
            let got = (truth[p] + bias[p]) / truth[p];
            assert!(
                (got - factor).abs() <= 1e-9,
                "δ = {truth_delta}, δ̂ = {assumed}, parameter {p}: {got} vs {factor}"
            );
        }
    }
}
