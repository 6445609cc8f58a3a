//! Under output noise OLS is unbiased and efficient, so for every
//! parameter and scale |EmpSE/CRLB − 1| and |bias| are each within 4 MCSE.
//!
//! 33 comparisons at once: a 4-MCSE band has two-sided normal tail probability 6.3e-5 per
//! comparison, ≈ 2e-3 for all 33. The seed is the study's, fixed once and never tuned.

use super::common::*;

#[test]
fn crlb_is_tight_and_ols_unbiased_under_output_noise() {
    let s = run_summary(&study("output_noise.toml", 400));
    assert_eq!(s.num_rows(), 33);
    let ratio = f64_col(&s, "emp_over_crlb_output");
    let ratio_mcse = f64_col(&s, "emp_over_crlb_output_mcse");
    let bias = f64_col(&s, "bias");
    let bias_mcse = f64_col(&s, "bias_mcse");
    let params = str_col(&s, "parameter");
    let scales = f64_col(&s, "scale");
    for i in 0..s.num_rows() {
        let what = format!("{} at scale {}", params[i], scales[i]);
        assert!(
            (ratio[i] - 1.0).abs() <= 4.0 * ratio_mcse[i],
            "{what}: EmpSE/CRLB = {} ± {}",
            ratio[i],
            ratio_mcse[i]
        );
        assert!(
            bias[i].abs() <= 4.0 * bias_mcse[i],
            "{what}: bias = {} ± {}",
            bias[i],
            bias_mcse[i]
        );
    }
    // Coverage of θ̂ ± 1.96·CRLB within 4 MCSE of 0.95 (MCSE at the
    // nominal p: √(0.95·0.05/400) = 0.0109), and the χ² variance-ratio test's p-values are
    // not systematically small: none below 1e-4 (P(any of 33 < 1e-4) = 0.0033 under H₀).
    let coverage = f64_col(&s, "coverage_crlb_output");
    let nominal_mcse = (0.95f64 * 0.05 / 400.0).sqrt();
    for (i, c) in coverage.iter().enumerate() {
        assert!(
            (c - 0.95).abs() <= 4.0 * nominal_mcse,
            "{} at scale {}: coverage {c}",
            params[i],
            scales[i]
        );
    }
    for (i, p) in f64_col(&s, "crlb_output_chi2_p").iter().enumerate() {
        assert!(
            *p >= 1e-4,
            "{} at scale {}: χ² p = {p}",
            params[i],
            scales[i]
        );
    }
    // The thesis bound needs speed noise; under output noise it is not reported.
    assert!(f64_col(&s, "thesis_bound_se").iter().all(|v| v.is_nan()));
}
