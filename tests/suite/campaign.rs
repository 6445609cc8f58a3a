//! A coast-down campaign's pass probability (docs/model.md#campaign): the kernel's verdict is
//! the criterion on the realisation's measured speeds, the summary's pass_probability the
//! share of verdicts that pass, `design` finds the fewest runs that pass with a chosen
//! probability, and a bad `[campaign]` is named.

use chassis_mc::design::{DesignKey, DesignMeasure, DesignRequest, DesignTarget, design};
use chassis_mc::estimate::channels::{Channel, Signal};
use chassis_mc::model::Model;
use chassis_mc::model::vehicle::VehicleModel;
use chassis_mc::study::Study;

use super::common::*;

/// `studies/coastdown_campaign.toml` with `edits` (key, value) applied, R = `realisations`.
fn campaign_study(edits: &[(&str, &str)], realisations: u64) -> Result<Study, String> {
    let mut text = study_text("coastdown_campaign.toml");
    for (key, value) in edits {
        text = set_key(&text, key, value);
    }
    Study::from_toml(&text, "campaign.toml")
        .and_then(|s| s.with_overrides(Some(realisations), None))
        .map_err(|e| e.to_string())
}

#[test]
fn the_verdict_is_the_criterion_on_the_measured_speeds() {
    // No model errors and an accelerometer: every sample of the first n runs is a row, and
    // the row's measured speed is V + σ_v z with z the speed channel's draws
    // (`VehicleModel::standard_draws`, the kernel's own stream). The realisation table's
    // verdict must be the criterion on those speeds.
    let mut text = study_text("coastdown_campaign.toml");
    text = text[..text.find("[truth]").unwrap()].to_string()
        + &text[text.find("[campaign]").unwrap()..];
    text = set_key(&text, "acceleration", "\"model\"");
    text = set_key(&text, "runs", "[4, 6]");
    let study = Study::from_toml(&text, "campaign.toml")
        .unwrap()
        .with_overrides(Some(40), None)
        .unwrap();
    let (dir, _) = run(&study, Some(2));
    let table = read_table(&dir.path().join("realisations.parquet"));
    let (conditions, realisations) = (i32_col(&table, "condition"), i64_col(&table, "realisation"));
    let (pass, precision) = (
        f64_col(&table, "campaign_pass"),
        f64_col(&table, "campaign_precision"),
    );
    let model = VehicleModel::new(&study).unwrap();
    let campaign = study.vehicle().unwrap().campaign.clone().unwrap();
    let sd = model.noise_levels(0)[Channel::of(Signal::Speed)];
    let cycles = model.cycles();
    let mut passed = [0u32; 2];
    for c in 0..model.condition_count() {
        let runs = [4, 6][c];
        let cycle = &cycles[c];
        let rows = cycle.run.iter().filter(|&&r| (r as usize) < runs).count();
        for r in 0..40u64 {
            let mut z = vec![0.0; rows];
            model.standard_draws(study.seed(), c, Channel::of(Signal::Speed), r, &mut z);
            let verdict = campaign.judge(
                &cycle.t_s[..rows],
                &cycle.run[..rows],
                |k| cycle.v_m_s[k] + sd * z[k],
                runs,
            );
            let i = (0..table.num_rows())
                .find(|&i| conditions[i] as usize == c && realisations[i] as u64 == r)
                .unwrap();
            assert_eq!(
                pass[i],
                f64::from(u8::from(verdict.passes)),
                "condition {c}, realisation {r}"
            );
            // √(Ṽ²) against Ṽ: one rounding apart in each crossing's speeds.
            assert!(
                ((precision[i] - verdict.precision) / verdict.precision).abs() < 1e-9,
                "condition {c}, realisation {r}: {} against {}",
                precision[i],
                verdict.precision
            );
            passed[c] += u32::from(verdict.passes);
        }
    }
    // Some pass and some fail, or the comparison says little.
    assert!(
        passed.iter().sum::<u32>() > 0 && passed.iter().sum::<u32>() < 80,
        "{passed:?}"
    );
    // pass_probability is the share that passes, its MCSE the binomial one.
    let summary = read_table(&dir.path().join("summary.parquet"));
    let (p, mcse, cond) = (
        f64_col(&summary, "pass_probability"),
        f64_col(&summary, "pass_probability_mcse"),
        i32_col(&summary, "condition"),
    );
    for i in 0..summary.num_rows() {
        let share = f64::from(passed[cond[i] as usize]) / 40.0;
        assert_eq!(p[i], share);
        assert!((mcse[i] - (share * (1.0 - share) / 40.0).sqrt()).abs() < 1e-15);
    }
}

#[test]
fn a_fixed_run_count_passes_from_its_count_on() {
    let study = campaign_study(&[("runs", "[14, 16]"), ("criterion", "\"run_count\"")], 3);
    // speeds and half_width belong to a criterion that reads times.
    let err = study.unwrap_err();
    assert!(
        err.contains("campaign.speeds") || err.contains("campaign.half_width"),
        "{err}"
    );
    let mut text = study_text("coastdown_campaign.toml");
    let at = text.find("[campaign]").unwrap();
    text = text[..at].to_string() + "[campaign]\ncriterion = \"run_count\"\n";
    text = set_key(&text, "runs", "[14, 16]");
    text = set_key(&text, "wind_speed", "[0.3]");
    text = set_key(&text, "wind_gust_sd", "[0.35]");
    let study = Study::from_toml(&text, "campaign.toml")
        .unwrap()
        .with_overrides(Some(3), None)
        .unwrap();
    let (dir, _) = run(&study, None);
    let summary = read_table(&dir.path().join("summary.parquet"));
    let (runs, p) = (
        f64_col(&summary, "runs"),
        f64_col(&summary, "pass_probability"),
    );
    for (n, p) in runs.iter().zip(&p) {
        assert_eq!(*p, if *n >= 16.0 { 1.0 } else { 0.0 }, "{n} runs");
    }
}

#[test]
fn design_finds_the_fewest_runs_that_pass_with_the_chosen_probability() {
    let study = Study::load(&study_path("coastdown_campaign_design.toml"))
        .unwrap()
        .with_overrides(Some(100), None)
        .unwrap();
    let out = tempfile::tempdir().unwrap();
    let request = DesignRequest {
        key: DesignKey::Runs,
        from: 4.0,
        to: 24.0,
        target: DesignTarget::parse("pass_probability>=0.9").unwrap(),
        estimator: None,
        out: out.path().to_path_buf(),
    };
    assert_eq!(request.target.measure, DesignMeasure::PassProbability);
    let result = design(&study, &request).unwrap();
    let answer = result.answer.expect("some number of runs in 4..24 passes");
    let (p, _) = answer.simulated.unwrap();
    assert!(p >= 0.9, "the answer holds: {p}");
    // The next fewer runs were simulated and fail (the search's bracket).
    let fewer = result.neighbour.expect("4 runs fail in this gusty case");
    assert_eq!(fewer, answer.value - 2.0);
    let below = result.points.iter().find(|q| q.value == fewer).unwrap();
    assert!(below.simulated.unwrap().0 < 0.9);
}

#[test]
fn a_bad_campaign_is_named() {
    let cases: [(&[(&str, &str)], &str); 3] = [
        (&[("criterion", "\"eu_1970\"")], "campaign.criterion"),
        (&[("half_width", "-1.0")], "campaign.half_width"),
        (&[("speeds", "[40.0]")], "campaign.speeds[0]"),
    ];
    for (edits, key) in cases {
        let err = campaign_study(edits, 2)
            .and_then(|s| VehicleModel::new(&s).map(|_| ()).map_err(|e| e.to_string()));
        let err = err.unwrap_err();
        assert!(err.contains(&format!("`{key}`")), "{edits:?}: {err}");
    }
    // A fixed run count is half each way: not with every run driven forwards.
    let mut text = study_text("coastdown_campaign.toml");
    text = text[..text.find("[campaign]").unwrap()].to_string()
        + "[campaign]\ncriterion = \"run_count\"\n";
    text = text.replace(
        "time_step = 0.1             # s (10 Hz)",
        "time_step = 0.1\ndirections = \"one_way\"",
    );
    let err = Study::from_toml(&text, "one_way.toml").unwrap_err();
    assert_eq!(err.key.as_deref(), Some("campaign.criterion"), "{err}");
    // A campaign judges a coast-down's runs.
    let text = study_text("thesis.toml") + "\n[campaign]\ncriterion = \"run_count\"\n";
    let err = Study::from_toml(&text, "thesis_campaign.toml").unwrap_err();
    assert_eq!(err.key.as_deref(), Some("campaign"), "{err}");
}
