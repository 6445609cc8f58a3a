//! Every run writes the figures unless `--no-figures`; each SVG parses
//! as XML, carries its axis labels, and holds a data marker for every condition plotted.
//!
//! Markers: every estimate (EmpSE, bias, EmpSE/bound, coverage) of a condition × estimator
//! (× bound) is one filled circle, and each marker series adds one filled circle to the
//! legend; error bars draw unfilled circles, which are not counted. The expected counts come
//! from summary.parquet.

use std::path::Path;
use std::process::Command;

use super::common::*;

fn svg(path: &Path) -> (usize, Vec<String>) {
    let text = std::fs::read_to_string(path).unwrap();
    let doc =
        roxmltree::Document::parse(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let filled = doc
        .descendants()
        .filter(|n| n.has_tag_name("circle") && n.attribute("fill").is_some_and(|f| f != "none"))
        .count();
    let texts = doc
        .descendants()
        .filter(|n| n.has_tag_name("text"))
        .filter_map(|n| n.text().map(|t| t.trim().to_string()))
        .collect();
    (filled, texts)
}

fn run_cli(args: &[&str]) {
    let out = Command::new(bin()).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn every_run_draws_parsable_figures_with_a_marker_per_condition() {
    let dir = tempfile::tempdir().unwrap();
    let study_file = dir.path().join("study.toml");
    let text = set_key(
        &study_text("bias_compensation.toml"),
        "scales",
        "[1.0, 1.5, 2.0]",
    );
    let text = set_key(&text, "velocity_sd", "[0.5, 1.0]");
    std::fs::write(&study_file, text).unwrap();
    let out = dir.path().join("out");
    let out_s = out.to_str().unwrap();
    run_cli(&[
        "run",
        study_file.to_str().unwrap(),
        "--out",
        out_s,
        "--realisations",
        "40",
        "--quiet",
    ]);

    let s = read_table(&out.join("summary.parquet"));
    let param = str_col(&s, "parameter");
    let est = str_col(&s, "estimator");
    let groups = 2; // velocity_sd levels; scale is the x axis
    let estimators = 2;
    for (p, symbol, unit) in [
        ("inv_mass", "1/M", "[1/kg]"),
        ("drag_over_mass", "Cd/M", "[1/kg]"),
        ("rolling_resistance", "Cr", "[-]"),
    ] {
        let rows: Vec<usize> = (0..s.num_rows()).filter(|&i| param[i] == p).collect();
        assert_eq!(rows.len(), 3 * 2 * estimators); // conditions × estimators
        let with = |col: &str| {
            let v = f64_col(&s, col);
            rows.iter().filter(|&&i| v[i].is_finite()).count()
        };
        let series_with = |col: &str| {
            let v = f64_col(&s, col);
            let mut keys: Vec<(String, u64)> = Vec::new();
            let sd = f64_col(&s, "velocity_sd");
            for &i in &rows {
                if v[i].is_finite() && !keys.contains(&(est[i].clone(), sd[i].to_bits())) {
                    keys.push((est[i].clone(), sd[i].to_bits()));
                }
            }
            keys.len()
        };
        let x_label = "terrain variability ς = mean θ² over the terrain table [rad²]";
        let checks: Vec<(String, usize, String)> = {
            let mut c = vec![
                (
                    format!("se_{p}.svg"),
                    rows.len() + groups * estimators,
                    format!("standard error of {symbol} {unit}"),
                ),
                (
                    // the plain bias and, where it applies, the control-variate bias
                    format!("bias_{p}.svg"),
                    rows.len() + groups * estimators + with("bias_cv") + series_with("bias_cv"),
                    format!("bias of {symbol} [% of the truth]"),
                ),
            ];
            let bounds = [
                "thesis_bound",
                "crlb_output",
                "eiv_sandwich",
                "eiv_crlb_linearized",
            ];
            let ratio: usize = bounds
                .iter()
                .map(|b| with(&format!("emp_over_{b}")) + series_with(&format!("emp_over_{b}")))
                .sum();
            let coverage: usize = bounds
                .iter()
                .map(|b| with(&format!("coverage_{b}")) + series_with(&format!("coverage_{b}")))
                .sum();
            c.push((format!("ratio_{p}.svg"), ratio, "EmpSE / bound [-]".into()));
            c.push((format!("coverage_{p}.svg"), coverage, "coverage [-]".into()));
            c
        };
        for (file, markers, y_label) in checks {
            let (filled, texts) = svg(&out.join("figures").join(&file));
            assert_eq!(filled, markers, "{file}: filled circles");
            assert!(
                texts.iter().any(|t| t == x_label),
                "{file}: x label missing"
            );
            assert!(
                texts.iter().any(|t| t == &y_label),
                "{file}: y label `{y_label}` missing in {texts:?}"
            );
        }
    }
    // The cycles: one line per distinct scale in each panel, labelled.
    let (_, texts) = svg(&out.join("figures/cycles.svg"));
    for label in [
        "time t [s]",
        "speed V [m/s]",
        "grade θ [rad]",
        "terrain scale 1",
        "terrain scale 1.5",
        "terrain scale 2",
    ] {
        assert!(
            texts.iter().any(|t| t == label),
            "cycles.svg: `{label}` missing"
        );
    }
    // Every sample is used (no min_speed, no braking): nothing is drawn as left out.
    assert!(!texts.iter().any(|t| t == "left out of the regression"));

    // `figures DIR` redraws the same files from the Parquet outputs.
    let before = std::fs::read(out.join("figures/se_inv_mass.svg")).unwrap();
    std::fs::remove_dir_all(out.join("figures")).unwrap();
    run_cli(&["figures", out_s]);
    assert_eq!(
        std::fs::read(out.join("figures/se_inv_mass.svg")).unwrap(),
        before
    );

    // --no-figures draws none.
    let bare = dir.path().join("bare");
    run_cli(&[
        "run",
        study_file.to_str().unwrap(),
        "--out",
        bare.to_str().unwrap(),
        "--realisations",
        "5",
        "--quiet",
        "--no-figures",
    ]);
    assert!(!bare.join("figures").exists());
    assert!(bare.join("summary.parquet").exists());
}

#[test]
fn a_terrain_by_sensor_study_draws_its_tradeoff_iso_lines() {
    // Scales 1 and 2 × σ_v 0.5, 1, 2 (R = 20): per parameter and estimator, a figure of
    // equal relative RMSE in the (scale, σ_v) plane, whose lines are labelled by level.
    let text = set_key(
        &study_text("terrain_vs_sensor.toml"),
        "scales",
        "[1.0, 2.0]",
    );
    let text = set_key(&text, "velocity_sd", "[0.5, 1.0, 2.0]");
    let study = chassis_mc::study::Study::from_toml(&text, "tradeoff")
        .unwrap()
        .with_overrides(Some(20), None)
        .unwrap();
    let (dir, _) = run(&study, None);
    let mut drawn = 0;
    for p in PARAMS {
        for e in ["ols", "bcls", "wbcls"] {
            let path = dir.path().join(format!("figures/tradeoff_{p}_{e}.svg"));
            let (_, texts) = svg(&path);
            assert!(
                texts.iter().any(|t| t.contains("terrain scale")),
                "{texts:?}"
            );
            assert!(texts.iter().any(|t| t.contains("RMSE =")), "{texts:?}");
            drawn += 1;
        }
    }
    assert_eq!(drawn, 9);
    // And per parameter one picture of OLS beside the best other estimator.
    for p in PARAMS {
        let (points, texts) = svg(&dir.path().join(format!("figures/tradeoff_{p}.svg")));
        assert!(texts.iter().any(|t| t.contains("ols (lines)")), "{texts:?}");
        assert!(
            points > 0,
            "{p}: the best estimator's iso-lines are drawn as points"
        );
    }
}
