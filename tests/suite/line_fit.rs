//! The line fit of thesis §3.2–3.3.
//!
//! Closed form for t = 0, 0.5, …, 10 (n = 21): Σt = 105, Σt² = 717.5, det(XᵀX) = 21·717.5
//! − 105² = 4042.5, so [(XᵀX)⁻¹]₂₂ = 21/4042.5 and the OLS slope has SD
//! σ_true·√(21/4042.5) for i.i.d. noise of SD σ_true = 18/√12 = 5.196, whatever its shape.
//! The bound assumes σ = 7.5, so EmpSE/bound = 5.196/7.5 = 0.6928.

use super::common::*;

#[test]
fn slope_spread_matches_the_closed_form_and_the_wrong_sigma_shows() {
    let s = run_summary(&study("line_fit.toml", 20_000));
    let sigma_true = 18.0 / 12f64.sqrt();
    let closed = sigma_true * (21.0 / 4042.5f64).sqrt();
    let noise = str_col(&s, "noise");
    let param = str_col(&s, "parameter");
    let emp_se = f64_col(&s, "emp_se");
    let emp_se_mcse = f64_col(&s, "emp_se_mcse");
    let ratio = f64_col(&s, "emp_over_assumed_sigma");
    let ratio_mcse = f64_col(&s, "emp_over_assumed_sigma_mcse");
    let coverage = f64_col(&s, "coverage_true_sigma");
    let mut seen = 0;
    for i in (0..s.num_rows()).filter(|&i| param[i] == "slope") {
        seen += 1;
        assert!(
            (emp_se[i] - closed).abs() <= 4.0 * emp_se_mcse[i],
            "{}: EmpSE {} vs closed form {closed} ± {}",
            noise[i],
            emp_se[i],
            emp_se_mcse[i]
        );
        assert!(
            (ratio[i] - sigma_true / 7.5).abs() <= 4.0 * ratio_mcse[i],
            "{}: EmpSE/bound {} ± {} vs {}",
            noise[i],
            ratio[i],
            ratio_mcse[i],
            sigma_true / 7.5
        );
        // With the true σ the interval covers at about the nominal rate; MCSE at p = 0.95,
        // n = 20000 is 0.0015, and the slope averages 21 draws so it is nearly normal even
        // for uniform noise: within 4 MCSE of 0.95.
        assert!(
            (coverage[i] - 0.95).abs() <= 4.0 * (0.95f64 * 0.05 / 20_000.0).sqrt(),
            "{}",
            coverage[i]
        );
    }
    assert_eq!(seen, 2, "uniform and gaussian conditions");
}
