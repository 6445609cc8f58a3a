//! Acceptance 4 (issue 2): the thesis's Table 3 (its §6.2: one realisation per scale, σ_v =
//! 1 m/s) lies within 1 % (1/M, Cd/M) and 5 % (Cr) of the Monte Carlo means of the thesis
//! study at R = 500, at all 11 scales.
//!
//! Why these tolerances can hold: a single realisation scatters about the Monte Carlo mean by
//! its EmpSE, which at R = 2000 is ≈ 0.25 % of 1/M, 0.07 % of Cd/M and 1.7 % of Cr; the
//! Monte Carlo means themselves carry MCSE = EmpSE/√500. The tolerances are the issue's.

use super::common::*;

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
