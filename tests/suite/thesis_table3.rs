//! The thesis's Table 3 (its §6.2: one realisation per scale, σ_v = 1 m/s) against the Monte
//! Carlo distribution of the thesis study.
//!
//! First, closeness: Table 3 lies within 1 % (1/M, Cd/M) and 5 % (Cr) of the Monte Carlo
//! means at R = 500, at all 11 scales. A single realisation scatters about the Monte Carlo
//! mean by its EmpSE, which at R = 2000 is ≈ 0.25 % of 1/M, 0.07 % of Cd/M and 1.7 % of Cr;
//! the Monte Carlo means themselves carry MCSE = EmpSE/√500.
//!
//! Second, whether Table 3 is one draw of this model's distribution: it is for 1/M and Cr,
//! and it is not for Cd/M, whose thesis values lie several EmpSE below the Monte Carlo mean
//! at every scale.

use super::common::*;
use statrs::distribution::{ChiSquared, ContinuousCDF};

/// Table 3 of the thesis: scale, 1/M, Cd/M, Cr (as printed).
const TABLE3: [(f64, f64, f64, f64); 11] = [
    (1.0, 0.00055479, 0.000182927, 0.018010557),
    (1.1, 0.000557093, 0.000183416, 0.01823568),
    (1.2, 0.000555393, 0.00018401, 0.017581247),
    (1.3, 0.000555327, 0.000184525, 0.01731914),
    (1.4, 0.00055618, 0.000184976, 0.017232048),
    (1.5, 0.000557523, 0.000185593, 0.017242714),
    (1.6, 0.000553248, 0.000185952, 0.016142849),
    (1.7, 0.000557133, 0.000186381, 0.016797372),
    (1.8, 0.000555928, 0.000187029, 0.016186674),
    (1.9, 0.000555913, 0.000187111, 0.016150069),
    (2.0, 0.000553493, 0.000187759, 0.015312255),
];

#[test]
fn table3_lies_within_tolerance_of_the_monte_carlo_means() {
    let s = run_summary(&study("thesis.toml", 500));
    let scale = f64_col(&s, "scale");
    let mean = f64_col(&s, "mean");
    let param = str_col(&s, "parameter");
    for (a, inv_m, cd_m, cr) in TABLE3 {
        for (name, thesis, tol) in [
            ("inv_mass", inv_m, 0.01),
            ("drag_over_mass", cd_m, 0.01),
            ("rolling_resistance", cr, 0.05),
        ] {
            let i = (0..s.num_rows())
                .find(|&i| (scale[i] - a).abs() < 1e-9 && param[i] == name)
                .unwrap();
            let rel = (thesis - mean[i]) / mean[i];
            assert!(
                rel.abs() <= tol,
                "scale {a}, {name}: thesis {thesis} vs Monte Carlo mean {} ({:+.2} %)",
                mean[i],
                100.0 * rel
            );
        }
    }
}

/// z = (thesis − MC mean) / √(EmpSE² + MCSE²) per scale and parameter, at R = 1000.
///
/// Under the hypothesis that Table 3's row at each scale is one draw of this model's
/// distribution, thesis − MC mean has variance EmpSE² (the draw) + MCSE² (the Monte Carlo
/// mean, EmpSE²/R), so z ~ N(0, 1); EmpSE itself is estimated to 1/√(2(R − 1)) ≈ 2 %. The
/// thesis drew its 11 scales from independent noise (one realisation each), and the Monte
/// Carlo conditions are independent too, so for each parameter Σ z² over the scales is
/// χ²(11); the test rejects when it exceeds the 1 − 1e-4 quantile (≈ 37.4), a false-alarm
/// rate of 1e-4 per parameter. Table 3 is printed to 6 significant digits: rounding moves
/// Cd/M by at most 5e-10, 0.4 % of its EmpSE (≈ 1.3e-7), and the others by less.
///
/// Measured (seed 2018): Σ z² = 16.0 for 1/M (p = 0.14) and 11.1 for Cr (p = 0.44), while
/// for Cd/M every z is negative (−1.5 to −6.4) and Σ z² = 165 (p ≈ 1e-29): the thesis's
/// Cd/M bias is ≈ 1.05× this model's, a difference between its simulation and ours, not
/// chance. Run with `--nocapture` to see the table.
#[test]
fn table3_is_a_draw_for_inverse_mass_and_cr_but_not_for_cd_m() {
    const R: u64 = 1000;
    const FALSE_ALARM: f64 = 1e-4;
    let s = run_summary(&study("thesis.toml", R));
    let scale = f64_col(&s, "scale");
    let param = str_col(&s, "parameter");
    let (truth, mean, mcse, emp_se) = (
        f64_col(&s, "truth"),
        f64_col(&s, "mean"),
        f64_col(&s, "mean_mcse"),
        f64_col(&s, "emp_se"),
    );
    let chi2 = ChiSquared::new(TABLE3.len() as f64).unwrap();
    let limit = chi2.inverse_cdf(1.0 - FALSE_ALARM);

    let mut z = [[0.0; 3]; TABLE3.len()];
    let mut bias_ratio = [0.0; TABLE3.len()];
    println!("z = (thesis − MC mean) / √(EmpSE² + MCSE²), R = {R}");
    println!("scale     1/M    Cd/M      Cr   thesis/MC Cd/M bias");
    for (k, (a, inv_m, cd_m, cr)) in TABLE3.into_iter().enumerate() {
        for (j, thesis) in [inv_m, cd_m, cr].into_iter().enumerate() {
            let i = (0..s.num_rows())
                .find(|&i| (scale[i] - a).abs() < 1e-9 && param[i] == PARAMS[j])
                .unwrap();
            z[k][j] = (thesis - mean[i]) / emp_se[i].hypot(mcse[i]);
            if j == 1 {
                bias_ratio[k] = (thesis - truth[i]) / (mean[i] - truth[i]);
            }
        }
        println!(
            "{a:5.1} {:+7.2} {:+7.2} {:+7.2}   {:.3}",
            z[k][0], z[k][1], z[k][2], bias_ratio[k]
        );
    }
    let sum_z2 = [0, 1, 2].map(|j| z.iter().map(|row| row[j] * row[j]).sum::<f64>());
    println!(
        "Σz²   {:7.1} {:7.1} {:7.1}   (χ²(11) 1 − {FALSE_ALARM:e} quantile {limit:.1})",
        sum_z2[0], sum_z2[1], sum_z2[2]
    );
    println!(
        "p     {:7.2} {:7.0e} {:7.2}",
        chi2.sf(sum_z2[0]),
        chi2.sf(sum_z2[1]),
        chi2.sf(sum_z2[2])
    );

    for j in [0, 2] {
        assert!(
            sum_z2[j] < limit,
            "{}: Σz² = {:.1} ≥ {limit:.1}, Table 3 is not a draw of this model",
            PARAMS[j],
            sum_z2[j]
        );
    }
    assert!(
        z.iter().all(|row| row[1] < 0.0),
        "Cd/M: the thesis lies below the Monte Carlo mean at every scale"
    );
    assert!(
        sum_z2[1] > limit,
        "Cd/M: Σz² = {:.1} ≤ {limit:.1}, consistent with one draw after all",
        sum_z2[1]
    );
}
