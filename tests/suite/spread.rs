//! The control variates of the spread (docs/model.md#spread-control-variates): the exact
//! covariances of the controls against a Monte Carlo of the kernel's own sums, and the
//! control-variate EmpSE against an independent large run and over repeated experiments.

use super::common::*;
use chassis_mc::model;
use chassis_mc::study::Study;
use rayon::prelude::*;

/// The thesis vehicle and terrain on a 60 s drive (6000 rows), OLS, R = 1, with `noise`
/// as the `[noise]` table's body and `acceleration` the estimation's source.
fn short_study(noise: &str, acceleration: &str) -> Study {
    let text = set_key(&study_text("bias_compensation.toml"), "scales", "[1.5]");
    let text = set_key(&text, "duration", "60.0");
    // `noise` lists output_sd where it is on.
    let text: String = text
        .lines()
        .filter(|l| !l.starts_with("output_sd"))
        .map(|l| format!("{l}\n"))
        .collect();
    let noise = if noise.contains("output_sd") {
        noise.to_string()
    } else {
        format!("{noise}\noutput_sd = [0.0]")
    };
    let text = set_key(&text, "velocity_sd", &noise);
    let text = set_key(
        &text,
        "estimators",
        &format!("[\"ols\"]\nacceleration = \"{acceleration}\""),
    );
    Study::from_toml(&text, "covariances").unwrap()
}

/// Every exact covariance Cov(cⱼ, cₖ) of a condition's controls against the mean of
/// cⱼcₖ over R = 100 000 realisations of the kernel (E\[c\] = 0 exactly, so E\[cⱼcₖ\] is
/// the covariance): within 4 standard errors of that mean (each entry fails by chance with
/// probability 6.3e-5; ≈ 2e-2 over the ≈ 300 entries checked in all), and at least one
/// entry of each condition more than 30 of its standard errors from 0 (so the check has
/// power). Returns the exact covariances, the Monte Carlo means and their SEs.
fn check_covariances(study: &Study, c: usize, what: &str) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    const R: u64 = 100_000;
    let model = model::prepare(study).unwrap();
    let layout = model.layout();
    let info = model.condition_info(c);
    let exact = info
        .control_covariance
        .clone()
        .unwrap_or_else(|| panic!("{what}: covariances derived"));
    let active: Vec<usize> = (0..layout.controls.len())
        .filter(|&j| info.controls[j])
        .collect();
    let q = active.len();
    assert_eq!(exact.len(), q * (q + 1) / 2);
    let stride = layout.realisation_stride();
    let seed = study.seed();
    let (sum, sum_sq) = (0..R)
        .into_par_iter()
        .fold(
            || {
                (
                    vec![0.0; exact.len()],
                    vec![0.0; exact.len()],
                    vec![0.0; stride],
                )
            },
            |(mut s, mut s2, mut slots), r| {
                model.realise(seed, c, r, &mut slots);
                let cv: Vec<f64> = active
                    .iter()
                    .map(|&j| slots[layout.control_at(j)])
                    .collect();
                let mut k = 0;
                for a in 0..q {
                    for b in a..q {
                        let x = cv[a] * cv[b];
                        s[k] += x;
                        s2[k] += x * x;
                        k += 1;
                    }
                }
                (s, s2, slots)
            },
        )
        .map(|(s, s2, _)| (s, s2))
        .reduce(
            || (vec![0.0; exact.len()], vec![0.0; exact.len()]),
            |(a, b), (c, d)| {
                (
                    a.iter().zip(&c).map(|(x, y)| x + y).collect(),
                    b.iter().zip(&d).map(|(x, y)| x + y).collect(),
                )
            },
        );
    let n = R as f64;
    let mean: Vec<f64> = sum.iter().map(|s| s / n).collect();
    let se: Vec<f64> = sum_sq
        .iter()
        .zip(&mean)
        .map(|(s2, m)| ((s2 / n - m * m) * n / (n - 1.0) / n).sqrt())
        .collect();
    let mut strongest: f64 = 0.0;
    let mut k = 0;
    for a in 0..q {
        for b in a..q {
            let name = |j: usize| layout.controls[active[j]].name;
            eprintln!(
                "{what}: Cov({}, {}) exact {:.6e}, Monte Carlo {:.6e} ± {:.2e}",
                name(a),
                name(b),
                exact[k],
                mean[k],
                se[k]
            );
            assert!(
                (mean[k] - exact[k]).abs() <= 4.0 * se[k],
                "{what}: Cov({}, {}) exact {:e}, Monte Carlo {:e} ± {:e} ({:.1} SE)",
                name(a),
                name(b),
                exact[k],
                mean[k],
                se[k],
                (mean[k] - exact[k]) / se[k]
            );
            strongest = strongest.max(exact[k].abs() / se[k]);
            k += 1;
        }
    }
    assert!(
        strongest > 30.0,
        "{what}: the largest covariance is {strongest} SE"
    );
    (exact, mean, se)
}

#[test]
fn covariances_of_white_speed_noise_match_the_kernel() {
    check_covariances(&short_study("[1.0]", "model"), 0, "white speed noise");
}

/// AR(1) speed noise (τ = 2 s, 200 rows): the covariances gather the rows' shared noise.
/// Beside the check, at least one entry differs from the white-noise condition's by more
/// than 30 SE (so the cross-row terms are exercised, not negligible).
#[test]
fn covariances_of_correlated_speed_noise_match_the_kernel() {
    let study = short_study("[1.0]\nvelocity_correlation_time = [0.0, 2.0]", "model");
    let (white, _, _) = check_covariances(&study, 0, "white, the reference");
    let (ar1, _, se) = check_covariances(&study, 1, "AR(1) speed noise, τ = 2 s");
    let largest = (0..ar1.len())
        .map(|k| (ar1[k] - white[k]).abs() / se[k])
        .fold(0.0, f64::max);
    assert!(largest > 30.0, "the AR(1) terms reach {largest} SE");
}

/// White speed noise through a differentiated acceleration (σ_v = 0.05 m/s, so ỹ carries
/// σ_v√2/Δt ≈ 3.5 m/s² of it): the neighbours that share a draw.
#[test]
fn covariances_of_a_differentiated_acceleration_match_the_kernel() {
    check_covariances(
        &short_study("[0.05]", "differentiated"),
        0,
        "differentiated acceleration",
    );
}

#[test]
fn covariances_of_grade_force_and_output_noise_match_the_kernel() {
    check_covariances(
        &short_study("[0.0]\ngrade_sd = [0.02]", "model"),
        0,
        "grade noise",
    );
    check_covariances(
        &short_study("[0.0]\nforce_sd = [20.0]", "model"),
        0,
        "force noise",
    );
    check_covariances(
        &short_study("[0.0]\noutput_sd = [0.3]", "model"),
        0,
        "output noise",
    );
}

/// Every channel at once, with the model's and with a differentiated acceleration: the
/// products of independent channels and the grade noise shared by x̃₃ and ỹ.
#[test]
fn covariances_of_every_channel_together_match_the_kernel() {
    let noise = "[0.3]\ngrade_sd = [0.01]\nforce_sd = [10.0]\noutput_sd = [0.2]";
    check_covariances(&short_study(noise, "model"), 0, "every channel");
    let noise = "[0.02]\ngrade_sd = [0.01]\nforce_sd = [10.0]\noutput_sd = [0.2]";
    check_covariances(
        &short_study(noise, "differentiated"),
        0,
        "every channel, differentiated",
    );
}
