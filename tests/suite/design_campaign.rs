//! `design FILE` with a design file (docs/model.md#design-campaign): the cheapest combination
//! of priced choices and a duration at which BCLS meets every target.

use chassis_mc::design::campaign::{Campaign, campaign};
use chassis_mc::study::Study;

use super::common::*;

/// θ of the thesis vehicle: 1/M and Cd/M.
const INV_MASS: f64 = 1.0 / 1800.0;
const DRAG_OVER_MASS: f64 = 0.35 / 1800.0;

/// The campaign study with a speed sensor, an accelerometer or not, a route and a duration
/// set by editing its text (not by the design's own editing), and R realisations.
fn study_at(velocity_sd: f64, accelerometer: bool, scale: f64, duration: f64, r: u64) -> Study {
    let mut text = study_text("design_campaign_study.toml");
    text = set_key(&text, "velocity_sd", &format!("[{velocity_sd}]"));
    text = set_key(&text, "scales", &format!("[{scale}]"));
    text = set_key(&text, "duration", &format!("{duration:.1}"));
    if accelerometer {
        text = set_key(&text, "acceleration", "[\"model\"]");
        text = set_key(&text, "output_sd", "[0.05]");
    }
    Study::from_toml_in(&text, "campaign point", &root().join("studies"))
        .unwrap()
        .with_overrides(Some(r), None)
        .unwrap()
}

/// The relative EmpSE of 1/M and Cd/M of a one-condition summary, each with its MCSE.
fn measures(study: &Study) -> [(f64, f64); 2] {
    let summary = run_summary(study);
    let (parameter, emp_se, mcse) = (
        str_col(&summary, "parameter"),
        f64_col(&summary, "emp_se"),
        f64_col(&summary, "emp_se_mcse"),
    );
    [("inv_mass", INV_MASS), ("drag_over_mass", DRAG_OVER_MASS)].map(|(p, truth)| {
        let i = parameter.iter().position(|x| x == p).unwrap();
        (emp_se[i] / truth, mcse[i] / truth)
    })
}

#[test]
fn the_campaign_returns_the_cheapest_design_an_exhaustive_monte_carlo_confirms() {
    // Two speed sensors, an accelerometer or not, two routes: 8 combinations; durations
    // 60–900 s by 60 s at 1 € per s; targets 1 % on 1/M and 2 % on Cd/M; R = 100.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("campaign.toml");
    std::fs::write(
        &file,
        format!(
            r#"[design]
study = "{}"
targets = ["inv_mass:rel_emp_se<=0.01", "drag_over_mass:rel_emp_se<=0.02"]

[[design.choices]]
key = "noise.velocity_sd"
options = [1.0, 0.3]
costs = [0, 400]

[[design.choices]]
options = [
    {{ "estimation.acceleration" = "differentiated" }},
    {{ "estimation.acceleration" = "model", "noise.output_sd" = 0.05 }},
]
costs = [0, 1500]

[[design.choices]]
key = "terrain.scales"
options = [1.0, 2.0]
costs = [0, 300]

[design.amount]
key = "drive.duration"
from = 60.0
to = 900.0
step = 60.0
cost_rate = 1.0
"#,
            study_path("design_campaign_study.toml").display()
        ),
    )
    .unwrap();
    let mut c = Campaign::load(&file, dir.path().join("out")).unwrap();
    c.study = c.study.with_overrides(Some(100), None).unwrap();
    let result = campaign(&c).unwrap();
    let answer = &result.points[result.answer.expect("a design meets the targets")];
    let answer_amount = answer.amount.unwrap();
    // The confirmation meets each target (its Monte Carlo estimate at most the target).
    let confirmed = answer.simulated.as_ref().unwrap();
    for ((m, s), target) in confirmed.iter().zip([0.01, 0.02]) {
        assert!(*m <= target, "confirmation {m} ± {s} above {target}");
    }
    // Exhaustively: every combination by Monte Carlo at the answer's duration, the next
    // shorter one, and the longest at which it is cheaper than the answer. Each run is the
    // campaign's study edited here, with the study's seed: the answer's own combination at
    // its duration reproduces the confirmation exactly.
    let sensors = [(1.0, 0.0), (0.3, 400.0)];
    let accelerometers = [(false, 0.0), (true, 1500.0)];
    let routes = [(1.0, 0.0), (2.0, 300.0)];
    let mut cheaper_checked = 0;
    for &(sd, sd_cost) in &sensors {
        for &(acc, acc_cost) in &accelerometers {
            for &(scale, route_cost) in &routes {
                let fixed = sd_cost + acc_cost + route_cost;
                // The longest duration of the grid at which this combination is cheaper.
                let longest_cheaper =
                    (((answer.cost - fixed) / 60.0).ceil() * 60.0 - 60.0).min(900.0);
                let mut durations = vec![answer_amount, answer_amount - 60.0];
                if longest_cheaper >= 60.0 && !durations.contains(&longest_cheaper) {
                    durations.push(longest_cheaper);
                }
                for duration in durations.into_iter().filter(|d| *d >= 60.0) {
                    let cost = fixed + duration;
                    let m = measures(&study_at(sd, acc, scale, duration, 100));
                    let this = sd == [1.0, 0.3][answer.options[0]]
                        && acc == (answer.options[1] == 1)
                        && scale == [1.0, 2.0][answer.options[2]]
                        && duration == answer_amount;
                    if this {
                        assert_eq!(m.to_vec(), *confirmed, "the confirmation is reproduced");
                    } else if cost < answer.cost {
                        // A cheaper design does not meet both targets beyond its MCSE.
                        cheaper_checked += 1;
                        let clearly_meets = m
                            .iter()
                            .zip([0.01, 0.02])
                            .all(|((v, s), target)| v + 3.0 * s <= target);
                        assert!(
                            !clearly_meets,
                            "σ_v {sd}, accelerometer {acc}, scale {scale}, {duration} s (cost {cost} < {}): {m:?}",
                            answer.cost
                        );
                    }
                }
            }
        }
    }
    assert!(
        cheaper_checked >= 8,
        "{cheaper_checked} cheaper designs checked"
    );
    // The outputs: every point, the answer marked once, a Pareto front.
    let table = read_table(&dir.path().join("out/design.parquet"));
    assert_eq!(table.num_rows(), 8 * 15);
    let answers = bool_col(&table, "is_answer").iter().filter(|a| **a).count();
    assert_eq!(answers, 1);
    assert!(bool_col(&table, "pareto").iter().any(|p| *p));
}

#[test]
fn a_bad_design_file_is_exit_2_naming_file_key_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let study = study_path("design_campaign_study.toml");
    let good = format!(
        "[design]\nstudy = \"{}\"\ntargets = [\"inv_mass:rel_rmse<=0.01\"]\n\n\
         [[design.choices]]\nkey = \"noise.velocity_sd\"\noptions = [1.0, 0.3]\ncosts = [0, 400]\n",
        study.display()
    );
    let cases = [
        (
            "costs = [0, 400]",
            "costs = [0]",
            "design.choices[0].costs",
            8,
            "one per option",
        ),
        (
            "targets = [\"inv_mass:rel_rmse<=0.01\"]",
            "targets = [\"inv_mass:rel_rmse<0.01\"]",
            "design.targets[0]",
            3,
            "",
        ),
        (
            "[[design.choices]]",
            "[design.amount]\nkey = \"noise.velocity_sd\"\nfrom = 1\nto = 2\nstep = 1\ncost_rate = 1\n\n[[design.choices]]",
            "design.amount.key",
            6,
            "must be drive.duration",
        ),
    ];
    for (from, to, key, line, reason) in cases {
        let file = dir.path().join("bad.toml");
        std::fs::write(&file, good.replace(from, to)).unwrap();
        let out = dir.path().join("out");
        let (code, _, stderr) = cli(
            &[
                "design".as_ref(),
                file.as_os_str(),
                "--out".as_ref(),
                out.as_os_str(),
            ],
            dir.path(),
        );
        assert_eq!(code, 2, "{key}: {stderr}");
        assert!(stderr.contains("bad.toml"), "{key}: {stderr}");
        assert!(stderr.contains(&format!("`{key}`")), "{key}: {stderr}");
        assert!(stderr.contains(&format!("line {line}")), "{key}: {stderr}");
        assert!(stderr.contains(reason), "{key}: {stderr}");
        assert!(!out.exists(), "{key}: nothing is written");
    }
    // A study without --vary, and a design file with it, are refused with exit 2.
    let out = dir.path().join("out");
    let (code, _, stderr) = cli(
        &[
            "design".as_ref(),
            study.as_os_str(),
            "--out".as_ref(),
            out.as_os_str(),
        ],
        dir.path(),
    );
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("--vary"), "{stderr}");
    let file = dir.path().join("good.toml");
    std::fs::write(&file, &good).unwrap();
    let (code, _, stderr) = cli(
        &[
            "design".as_ref(),
            file.as_os_str(),
            "--vary".as_ref(),
            "drive.duration".as_ref(),
            "--out".as_ref(),
            out.as_os_str(),
        ],
        dir.path(),
    );
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("is a design file"), "{stderr}");
}
