//! With all noise off, OLS recovers θ to ≤ 1e-9 relative error at
//! every scale of the thesis sweep. The thesis reports errors of order 1e-11 (its §6.2);
//! the noise-free regression satisfies y = Xθ exactly in real arithmetic, so what remains
//! is rounding in the sums and the 3×3 solve.

use super::common::*;
use chassis_mc::study::Study;

#[test]
fn ols_recovers_theta_without_noise_at_every_scale() {
    let text = set_key(&study_text("thesis.toml"), "velocity_sd", "[0.0]");
    let text = set_key(&text, "realisations", "2");
    let study = Study::from_toml(&text, "noise-free thesis").unwrap();
    let (dir, report) = run(&study, None);
    let table = read_table(&dir.path().join("realisations.parquet"));
    assert_eq!(table.num_rows(), 11 * 2);
    let truth = [1.0 / 1800.0, 0.35 / 1800.0, 0.0125];
    let mut worst: f64 = 0.0;
    for (p, name) in PARAMS.iter().enumerate() {
        for v in f64_col(&table, &format!("theta_{name}")) {
            let rel = ((v - truth[p]) / truth[p]).abs();
            worst = worst.max(rel);
            assert!(
                rel <= 1e-9,
                "{name}: {v} vs {} (relative error {rel:e})",
                truth[p]
            );
        }
    }
    assert!(str_col(&table, "status").iter().all(|s| s == "ok"));
    eprintln!("worst relative error without noise: {worst:e}");
    assert_eq!(report.infos.len(), 11);
}
