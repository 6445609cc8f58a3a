//! Every run writes the figures unless `--no-figures`; each SVG parses
//! as XML, carries its axis labels, and holds a data marker for every condition plotted.
//!
//! Markers: every estimate (EmpSE, bias, EmpSE/bound, coverage, and the control-variate
//! EmpSE, bias and EmpSE/bound) of a condition × estimator (× bound) is one filled circle, and each marker series adds one filled circle to the
//! legend; error bars draw unfilled circles, which are not counted. The expected counts come
//! from summary.parquet.

use chassis_mc::stats::summary::Measure;
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
        let sd = f64_col(&s, "velocity_sd");
        // The ratio figure draws each bound's EmpSE / bound plainly and by control variates:
        // 2 estimators × 3 bounds × 2 = 12 series per group, so of the 16 it holds it shows
        // one group, the last σ_v (src/figures/parameters.rs, `shown_rows`).
        let last_sd: Vec<usize> = rows.iter().copied().filter(|&i| sd[i] == 1.0).collect();
        let with_in = |rows: &[usize], col: &str| {
            let v = f64_col(&s, col);
            rows.iter().filter(|&&i| v[i].is_finite()).count()
        };
        let series_in = |rows: &[usize], col: &str| {
            let v = f64_col(&s, col);
            let mut keys: Vec<(String, u64)> = Vec::new();
            for &i in rows {
                if v[i].is_finite() && !keys.contains(&(est[i].clone(), sd[i].to_bits())) {
                    keys.push((est[i].clone(), sd[i].to_bits()));
                }
            }
            keys.len()
        };
        let with = |col: &str| with_in(&rows, col);
        let series_with = |col: &str| series_in(&rows, col);
        let x_label = "terrain variability ς = mean θ² over the terrain table [rad²]";
        let checks: Vec<(String, usize, String)> = {
            let mut c = vec![
                (
                    // EmpSE and, where they apply, EmpSE by control variates
                    format!("se_{p}.svg"),
                    rows.len() + groups * estimators + with("emp_se_cv") + series_with("emp_se_cv"),
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
                .flat_map(|b| [format!("emp_over_{b}"), format!("emp_over_{b}_cv")])
                .map(|col| with_in(&last_sd, &col) + series_in(&last_sd, &col))
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
            if file.starts_with("ratio_") {
                let note = texts.join(" ");
                assert!(
                    note.contains("Showing 1 of 2 groups: velocity_sd ∈ {1}"),
                    "{file}: {texts:?}"
                );
            }
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

/// The legend entries of an SVG figure that name the control variates.
fn control_variate_entries(path: &Path) -> Vec<String> {
    svg(path)
        .1
        .into_iter()
        .filter(|t| t.contains("control variates"))
        .collect()
}

/// Where the second moment's control variates apply (speed noise,
/// docs/model.md#spread-control-variates), the SE and EmpSE / bound figures draw the
/// control-variate EmpSE and EmpSE / bound beside the plain ones, one series per estimator
/// (× bound); where none apply (the line fit), neither figure names them.
#[test]
fn control_variate_spread_is_drawn_where_it_applies_and_only_there() {
    // One condition (scale 1, σ_v = 1 m/s), OLS and BCLS, R = 40: the spread's control
    // variates (the five speed controls, defined from q + 3 = 8 realisations on) apply to
    // every row.
    let study = speed_noise_study("[1.0]", "[1.0]", 40, None);
    let (dir, report) = run(&study, None);
    let bounds_reported = |p: usize| {
        (0..report.layout.bounds.len())
            .filter(|&b| {
                report.summary.iter().any(|r| {
                    r.parameter == p
                        && r.bounds[b]
                            .as_ref()
                            .is_some_and(|s| s.emp_over_cv.value.is_finite())
                })
            })
            .count()
    };
    for (pi, p) in PARAMS.iter().enumerate() {
        assert!(
            report
                .summary
                .iter()
                .filter(|r| r.parameter == pi)
                .all(|r| r[Measure::EmpSeCv].value.is_finite()),
            "{p}: emp_se_cv applies"
        );
        let se = control_variate_entries(&dir.path().join(format!("figures/se_{p}.svg")));
        assert_eq!(
            se,
            [
                "EmpSE (control variates) ± MCSE, ols",
                "EmpSE (control variates) ± MCSE, bcls"
            ],
            "se_{p}.svg"
        );
        let ratio = control_variate_entries(&dir.path().join(format!("figures/ratio_{p}.svg")));
        assert_eq!(ratio.len(), 2 * bounds_reported(pi), "{ratio:?}");
        assert!(
            ratio
                .iter()
                .any(|l| l == "eiv_sandwich, ols, control variates")
        );
        // The coverage figure has no control-variate estimate.
        let coverage = dir.path().join(format!("figures/coverage_{p}.svg"));
        assert!(control_variate_entries(&coverage).is_empty());
    }

    // The line fit has no controls: its summary has no control-variate spread, and its
    // figures none either.
    let (dir, report) = run(&super::common::study("line_fit.toml", 20), None);
    assert!(report.summary.iter().all(|r| {
        r[Measure::EmpSeCv].value.is_nan()
            && r.bounds
                .iter()
                .flatten()
                .all(|s| s.emp_over_cv.value.is_nan())
    }));
    let mut drawn = 0;
    for entry in std::fs::read_dir(dir.path().join("figures")).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if name.starts_with("se_") || name.starts_with("ratio_") {
            drawn += 1;
            assert!(control_variate_entries(&path).is_empty(), "{name}");
        }
    }
    assert_eq!(
        drawn, 4,
        "se and ratio figures of the intercept and the slope"
    );
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

/// Tick labels (position along the axis [px], text).
type Labels = Vec<(f64, String)>;

/// The tick labels of each axis of an SVG chart: the y axis's are right-aligned at one x,
/// the x axis's centred at one y (titles and axis descriptions stand alone at theirs).
fn tick_label_groups(svg: &str) -> Vec<Labels> {
    let doc = roxmltree::Document::parse(svg).unwrap();
    let mut groups: Vec<((String, String), Labels)> = Vec::new();
    for n in doc.descendants().filter(|n| n.has_tag_name("text")) {
        let (Some(x), Some(y)) = (n.attribute("x"), n.attribute("y")) else {
            continue;
        };
        let text = n.text().unwrap_or("").trim().to_string();
        let (key, at) = match n.attribute("text-anchor") {
            Some("end") => (("y axis".to_string(), x.to_string()), y),
            Some("middle") if n.attribute("transform").is_none() => {
                (("x axis".to_string(), y.to_string()), x)
            }
            _ => continue,
        };
        let at: f64 = at.parse().unwrap();
        match groups.iter_mut().find(|(k, _)| *k == key) {
            Some((_, g)) => g.push((at, text)),
            None => groups.push((key, vec![(at, text)])),
        }
    }
    groups
        .into_iter()
        .map(|(_, g)| g)
        .filter(|g| g.len() >= 2)
        .collect()
}

/// A tick label's value: plain ("0.05", "-3"), or m·10ⁿ / 10ⁿ in superscript digits.
fn label_value(label: &str) -> Option<f64> {
    let superscript = |s: &str| -> Option<i32> {
        let digits: String = s
            .chars()
            .map(|c| match c {
                '⁻' => Some('-'),
                c => "⁰¹²³⁴⁵⁶⁷⁸⁹"
                    .chars()
                    .position(|d| d == c)
                    .and_then(|d| char::from_digit(d as u32, 10)),
            })
            .collect::<Option<String>>()?;
        digits.parse().ok()
    };
    if let Some((m, p)) = label.split_once("·10") {
        return Some(m.parse::<f64>().ok()? * 10f64.powi(superscript(p)?));
    }
    if let Some(p) = label.strip_prefix("10")
        && !p.is_empty()
        && let Some(e) = superscript(p)
    {
        return Some(10f64.powi(e));
    }
    label.parse().ok()
}

#[test]
fn every_axis_of_the_thesis_figures_has_distinct_readable_tick_labels() {
    // The thesis study (OLS, σ_v = 1 m/s, 11 scales) at R = 4: on every axis of every
    // figure the tick labels are distinct numbers, none in e-notation ("1" for one, never
    // "1e0"), and a log axis spanning a decade or more labels only 1, 2 and 5 × 10ⁿ (no
    // label on every minor tick). cycles.svg's two panels share their column of y labels:
    // a column is split where its values turn back along the pixels (a repeated value is
    // no turn, so it still counts as a repeated label).
    let (dir, _) = run(&study("thesis.toml", 4), None);
    let mut axes = 0;
    let mut log_axes = 0;
    for entry in std::fs::read_dir(dir.path().join("figures")).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let svg = std::fs::read_to_string(&path).unwrap();
        let mut panels = Vec::new();
        for mut group in tick_label_groups(&svg) {
            group.sort_by(|a, b| a.0.total_cmp(&b.0));
            let value = |l: &str| label_value(l).unwrap_or_else(|| panic!("{name}: label `{l}`"));
            let mut panel = vec![group[0].clone()];
            for pair in group.windows(2) {
                let turned = panel.len() >= 2 && {
                    let (a, b) = (
                        value(&panel[panel.len() - 2].1),
                        value(&panel[panel.len() - 1].1),
                    );
                    (value(&pair[1].1) - b) * (b - a) < 0.0
                };
                if turned {
                    panels.push(std::mem::take(&mut panel));
                }
                panel.push(pair[1].clone());
            }
            panels.push(panel);
        }
        for group in panels {
            axes += 1;
            let labels: Vec<&String> = group.iter().map(|(_, l)| l).collect();
            let values: Vec<f64> = labels
                .iter()
                .map(|l| label_value(l).unwrap_or_else(|| panic!("{name}: label `{l}`")))
                .collect();
            for l in &labels {
                assert!(!l.contains('e'), "{name}: e-notation in {labels:?}");
            }
            let mut sorted = values.clone();
            sorted.sort_by(f64::total_cmp);
            sorted.dedup();
            assert_eq!(
                sorted.len(),
                values.len(),
                "{name}: repeated labels {labels:?}"
            );
            // A linear axis steps evenly in value along its pixels; a log axis does not.
            let steps: Vec<f64> = values.windows(2).map(|w| w[1] - w[0]).collect();
            let even = steps
                .iter()
                .all(|s| (s - steps[0]).abs() <= 1e-9 * steps[0].abs());
            if !even && sorted[0] > 0.0 && sorted[sorted.len() - 1] / sorted[0] >= 10.0 {
                log_axes += 1;
                for v in &values {
                    let mantissa = v / 10f64.powf(v.log10().floor());
                    assert!(
                        [1.0, 2.0, 5.0, 10.0]
                            .iter()
                            .any(|m| (mantissa - m).abs() < 1e-6),
                        "{name}: minor tick labelled in {labels:?}"
                    );
                }
            }
        }
    }
    // 12 figures of two axes each, and the cycles' two panels.
    assert_eq!(axes, 28, "axes with tick labels");
    assert!(log_axes >= 3, "{log_axes} log axes spanning a decade");
}

#[test]
fn equal_estimates_of_different_series_stay_distinguishable() {
    // Under speed noise OLS's Cd/M is biased far beyond every bound: its coverage is 0 for
    // each of the three bounds the thesis study reports, three series at the same values.
    // Their markers must not hide one another: no two filled markers of different colours
    // at one position.
    let (dir, report) = run(&study("thesis.toml", 4), None);
    let svg =
        std::fs::read_to_string(dir.path().join("figures/coverage_drag_over_mass.svg")).unwrap();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    let markers: Vec<(String, String, String)> = doc
        .descendants()
        .filter(|n| n.has_tag_name("circle") && n.attribute("fill").is_some_and(|f| f != "none"))
        .filter(|n| {
            n.attribute("cx")
                .and_then(|x| x.parse::<f64>().ok())
                .unwrap_or(0.0)
                < 930.0
        })
        .map(|n| {
            (
                n.attribute("cx").unwrap().to_string(),
                n.attribute("cy").unwrap().to_string(),
                n.attribute("fill").unwrap().to_string(),
            )
        })
        .collect();
    let conditions = report.infos.len();
    assert_eq!(
        markers.len(),
        3 * conditions,
        "three bounds × {conditions} conditions"
    );
    // The coincidence is real: every OLS coverage of Cd/M is 0 here.
    let at_zero = report
        .summary
        .iter()
        .filter(|r| r.parameter == 1)
        .flat_map(|r| r.bounds.iter().flatten())
        .filter(|b| b.coverage.value == 0.0)
        .count();
    assert_eq!(at_zero, 3 * conditions);
    for (i, a) in markers.iter().enumerate() {
        for b in &markers[i + 1..] {
            assert!(
                !(a.0 == b.0 && a.1 == b.1 && a.2 != b.2),
                "markers of two series at one position: {a:?} {b:?}"
            );
        }
    }
}
