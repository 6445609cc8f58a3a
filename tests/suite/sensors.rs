//! Sensor models of the measurements (docs/model.md#sensors).

use nalgebra::{Matrix3, Vector3};

use super::common::*;

#[test]
fn a_grade_offset_biases_ols_as_the_first_order_prediction() {
    // A constant offset b on the measured grade, all noise off: y = a + g sin(θ + b) and
    // x₃ = −g cos(θ + b). To first order δy = g cos θ · b and δx₃ = g sin θ · b, so OLS
    // moves by (XᵀX)⁻¹Xᵀ(δy − δx₃ θ₃) = (XᵀX)⁻¹Xᵀ g b (cos θ − θ₃ sin θ), computed here
    // from cycles.parquet, independently of the engine's regression code.
    //
    // The offset is almost a rolling-resistance term (cos θ ≈ 1): Cr moves by ≈ −b, and its
    // first-order prediction holds to O(b) relative, far inside 2 %. 1/M and Cd/M move by
    // only ~1e-5 of their values, and there the neglected second-order terms (g b² sin θ / 2
    // and the like, not aligned with x₃) are O(b) of the first-order shift: about 10–20 % at
    // b = 0.002 rad, ten times less at 0.0002 rad. So: Cr within 2 % at both offsets, 1/M
    // and Cd/M within 2.5 % at 0.0002, and their deviation growing in proportion to b
    // (8–13× for a 10× larger offset), which is what a second-order term does and a wrong
    // first-order term would not.
    let offsets = [0.0, 0.0002, 0.002];
    let text = set_key(&study_text("thesis.toml"), "velocity_sd", "[0.0]");
    let text = set_key(&text, "scales", "[1.0, 2.0]");
    let text = text.replace("[noise]", "[noise]\ngrade_bias = [0.0, 0.0002, 0.002]");
    let study = chassis_mc::study::Study::from_toml(&text, "grade bias")
        .unwrap()
        .with_overrides(Some(2), None)
        .unwrap();
    let (dir, report) = run(&study, None);
    assert_eq!(report.infos.len(), 6, "2 scales × 3 offsets");
    let truth = [1.0 / 1800.0, 0.35 / 1800.0, 0.0125];
    let (g, k) = (9.81, 0.5 * 1.2 * 5.5);
    let cycles = read_table(&dir.path().join("cycles.parquet"));
    let (cond, v, grade, f) = (
        i32_col(&cycles, "condition"),
        f64_col(&cycles, "v"),
        f64_col(&cycles, "grade"),
        f64_col(&cycles, "f_prop"),
    );
    let summary = read_table(&dir.path().join("summary.parquet"));
    let (s_cond, s_param, s_bias, s_offset) = (
        i32_col(&summary, "condition"),
        str_col(&summary, "parameter"),
        f64_col(&summary, "bias"),
        f64_col(&summary, "grade_bias"),
    );
    // deviation[scale][offset][parameter]: (engine − prediction) / prediction.
    let mut deviation = [[[0.0f64; 3]; 3]; 2];
    for c in 0..6 {
        let (scale, o) = (c / 3, c % 3);
        let b = offsets[o];
        let mut xtx = Matrix3::zeros();
        let mut xtd = Vector3::zeros();
        for i in (0..cond.len()).filter(|&i| cond[i] == c as i32) {
            let x = Vector3::new(f[i], -k * v[i] * v[i], -g * grade[i].cos());
            xtx += x * x.transpose();
            xtd += x * (g * b * (grade[i].cos() - truth[2] * grade[i].sin()));
        }
        let predicted = xtx.try_inverse().unwrap() * xtd;
        for (p, name) in PARAMS.iter().enumerate() {
            let row = (0..s_cond.len())
                .find(|&r| s_cond[r] == c as i32 && s_param[r] == *name)
                .unwrap();
            assert_eq!(s_offset[row], b);
            if b == 0.0 {
                // No offset: OLS recovers θ to rounding.
                assert!(
                    s_bias[row].abs() <= 1e-9 * truth[p],
                    "{name}: {}",
                    s_bias[row]
                );
                continue;
            }
            deviation[scale][o][p] = (s_bias[row] - predicted[p]) / predicted[p];
        }
    }
    for (scale, d) in deviation.iter().enumerate() {
        let (small, large) = (d[1], d[2]);
        assert!(small[2].abs() < 0.02 && large[2].abs() < 0.02, "Cr: {d:?}");
        for p in 0..2 {
            assert!(small[p].abs() < 0.025, "scale {scale} {}: {d:?}", PARAMS[p]);
            let growth = large[p] / small[p];
            assert!(
                (8.0..13.0).contains(&growth),
                "scale {scale} {}: {d:?}",
                PARAMS[p]
            );
        }
    }
}
