//! Every Monte Carlo standard error formula against a direct
//! repeated-experiment estimate.
//!
//! K = 1000 independent "studies", each of n = 200 realisations of known distributions,
//! are summarised exactly as the engine summarises a condition. For each measure the
//! standard deviation of its K values (the true Monte Carlo error) must match the root
//! mean square of its K reported MCSEs. The SD of K values has relative standard error
//! ≈ 1/√(2(K − 1)) = 2.2 % (normal-like statistics); we allow 10 %, ≈ 4.5 of those, so a
//! formula that is off by a factor (e.g. √2 = 41 %, or a missing n − 1) cannot pass.

use chassis_mc::stats::measures::{self, BoundSums, Estimate, EstimateSums, Z_95};
use chassis_mc::stats::summary::Measure;
use chassis_mc::{estimate::channels::Channel, noise::NormalStream};

const K: usize = 1000;
const N: usize = 200;
const TRUTH: f64 = 1.0;
const SIGMA: f64 = 2.0;
/// Degrees of freedom of the per-realisation variance estimates b_i² = σ² χ²_ν/ν.
const NU: usize = 10;

fn normals(study: u64, what: u64, n: usize) -> Vec<f64> {
    let mut s = NormalStream::for_realisation(4242, study, Channel::Output.stream(), what);
    let mut v = vec![0.0; n];
    s.fill(&mut v);
    v
}

fn estimate_sums(theta: &[f64]) -> EstimateSums {
    let n = theta.len() as f64;
    let sum_d: f64 = theta.iter().map(|t| t - TRUTH).sum();
    let mean = sum_d / n;
    let mse = theta.iter().map(|t| (t - TRUTH).powi(2)).sum::<f64>() / n;
    EstimateSums {
        n,
        sum_d,
        sum_centred_sq: theta.iter().map(|t| (t - TRUTH - mean).powi(2)).sum(),
        sum_d_sq: mse * n,
        sum_sq_dev_sq: theta
            .iter()
            .map(|t| ((t - TRUTH).powi(2) - mse).powi(2))
            .sum(),
    }
}

fn bound_sums(b: &[f64]) -> BoundSums {
    let n = b.len() as f64;
    let mean_sq = b.iter().map(|x| x * x).sum::<f64>() / n;
    BoundSums {
        n,
        sum_b_sq: mean_sq * n,
        sum_b_sq_dev_sq: b.iter().map(|x| (x * x - mean_sq).powi(2)).sum(),
    }
}

/// (SD of the values, RMS of the MCSEs) over the K studies.
fn compare(estimates: &[Estimate]) -> (f64, f64) {
    let k = estimates.len() as f64;
    let mean = estimates.iter().map(|e| e.value).sum::<f64>() / k;
    let sd = (estimates
        .iter()
        .map(|e| (e.value - mean).powi(2))
        .sum::<f64>()
        / (k - 1.0))
        .sqrt();
    let rms = (estimates.iter().map(|e| e.mcse * e.mcse).sum::<f64>() / k).sqrt();
    (sd, rms)
}

#[test]
fn each_mcse_matches_the_spread_over_repeated_experiments() {
    let names = [
        "mean",
        "bias",
        "emp_se",
        "mse",
        "rmse",
        "model_se",
        "emp_over_model",
        "model_se_rel_error",
        "coverage",
        "rel_precision",
    ];
    let mut results: Vec<Vec<Estimate>> = vec![Vec::with_capacity(K); names.len()];
    let rho = 0.8; // correlation of the two estimators of the relative-precision check
    for k in 0..K as u64 {
        let z = normals(k, 0, N);
        let w = normals(k, 1, N);
        let chi = normals(k, 2, N * NU);
        let theta: Vec<f64> = z.iter().map(|z| TRUTH + SIGMA * z).collect();
        // A second estimator, correlated with the first and 1.5× as spread.
        let theta_b: Vec<f64> = z
            .iter()
            .zip(&w)
            .map(|(z, w)| TRUTH + 1.5 * SIGMA * (rho * z + (1.0 - rho * rho).sqrt() * w))
            .collect();
        // Per-realisation model SEs b_i = σ √(χ²_ν/ν), independent of θ̂_i.
        let b: Vec<f64> = chi
            .chunks(NU)
            .map(|c| SIGMA * (c.iter().map(|x| x * x).sum::<f64>() / NU as f64).sqrt())
            .collect();
        let s = estimate_sums(&theta);
        let sb = estimate_sums(&theta_b);
        let bs = bound_sums(&b);
        let mean_a = s.sum_d / s.n;
        let mean_b = sb.sum_d / sb.n;
        let cross: f64 = theta
            .iter()
            .zip(&theta_b)
            .map(|(a, b)| (a - TRUTH - mean_a) * (b - TRUTH - mean_b))
            .sum();
        let covered = theta
            .iter()
            .filter(|t| (*t - TRUTH).abs() <= Z_95 * SIGMA)
            .count() as f64;
        let all = [
            measures::mean(TRUTH, &s),
            measures::bias(&s),
            measures::emp_se(&s),
            measures::mse(&s),
            measures::rmse(&s),
            measures::model_se(&bs),
            measures::emp_over_model(&s, &bs),
            measures::model_se_relative_error(&s, &bs),
            measures::coverage(covered, N as f64),
            measures::relative_precision(&s, &sb, cross),
        ];
        for (r, e) in results.iter_mut().zip(all) {
            r.push(e);
        }
    }
    for (name, estimates) in names.iter().zip(&results) {
        let (sd, rms_mcse) = compare(estimates);
        let ratio = rms_mcse / sd;
        eprintln!(
            "{name:>20}: SD over {K} studies {sd:.5e}, RMS MCSE {rms_mcse:.5e}, ratio {ratio:.3}"
        );
        assert!(
            (ratio - 1.0).abs() < 0.10,
            "{name}: MCSE formula gives {rms_mcse:e}, repeated experiments {sd:e} (ratio {ratio})"
        );
    }
}

#[test]
fn the_two_pass_summarizer_agrees_with_direct_formulas() {
    use chassis_mc::model::{BoundInfo, ConditionInfo, Layout, ParameterInfo};
    use chassis_mc::stats::summary::{Record, Summarizer};

    let layout = Layout {
        figure_x: None,
        context: vec![],
        axes: vec![],
        condition_metrics: vec![],
        parameters: vec![ParameterInfo {
            name: "p",
            unit: "",
            description: "",
        }],
        estimators: vec!["ols"],
        extras: vec![],
        bounds: vec![BoundInfo {
            name: "b",
            description: "",
            not_valid: None,
        }],
        controls: vec![],
    };
    let infos = vec![ConditionInfo {
        axes: vec![],
        metrics: vec![],
        truth: vec![TRUTH],
        bias_model: vec![vec![f64::NAN]],
        model_errors: vec![],
        applies: vec![vec![true]],
        controls: vec![],
        control_covariance: None,
    }];
    // A biased estimator (mean 1.3) with SE 2, and a variable bound.
    let z = normals(7, 0, N);
    let chi = normals(7, 2, N * NU);
    let theta: Vec<f64> = z.iter().map(|z| TRUTH + 0.3 + SIGMA * z).collect();
    let b: Vec<f64> = chi
        .chunks(NU)
        .map(|c| SIGMA * (c.iter().map(|x| x * x).sum::<f64>() / NU as f64).sqrt())
        .collect();
    let mut s = Summarizer::new(&layout, &infos, N as u64, Z_95);
    // Rows in a scrambled order: the exact sums make the order irrelevant.
    let order: Vec<usize> = (0..N).map(|i| (i * 37) % N).collect();
    let record = |i: usize| Record {
        condition: 0,
        realisation: i as u64,
        estimator: 0,
        ok: true,
        theta: std::slice::from_ref(&theta[i]),
        bounds: std::slice::from_ref(&b[i]),
        controls: &[],
        filter: [f64::NAN; 4],
        campaign: f64::NAN,
    };
    for &i in &order {
        s.first_pass(&record(i)).unwrap();
    }
    s.end_first_pass().unwrap();
    for &i in &order {
        s.second_pass(&record(i)).unwrap();
    }
    let row = &s.finish()[0];

    let direct = estimate_sums(&theta);
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs().max(1e-300);
    assert!(close(
        row[Measure::Mean].value,
        measures::mean(TRUTH, &direct).value
    ));
    assert!(close(
        row[Measure::EmpSe].value,
        measures::emp_se(&direct).value
    ));
    assert!(close(row[Measure::Mse].mcse, measures::mse(&direct).mcse));
    let bound = row.bounds[0].unwrap();
    assert!(close(
        bound.se.mcse,
        measures::model_se(&bound_sums(&b)).mcse
    ));
    let mean = TRUTH + direct.sum_d / direct.n;
    let covered = (0..N)
        .filter(|&i| (theta[i] - TRUTH).abs() <= Z_95 * b[i])
        .count();
    let be_covered = (0..N)
        .filter(|&i| (theta[i] - mean).abs() <= Z_95 * b[i])
        .count();
    assert_eq!(bound.coverage.value, covered as f64 / N as f64);
    assert_eq!(bound.be_coverage.value, be_covered as f64 / N as f64);
    assert!(
        be_covered > covered,
        "bias-elimination must matter for a biased estimator"
    );
}
