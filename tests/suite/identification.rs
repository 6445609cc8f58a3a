//! Why a cycle identifies (docs/model.md#identification): the summary's VIFs, correlations
//! and condition number against an independent computation from cycles.parquet.

use super::common::*;

/// The inverse's diagonal of the symmetric 3×3 `j` by cofactors.
fn inverse_diagonal(j: &[[f64; 3]; 3]) -> [f64; 3] {
    let minor = |a: usize, b: usize| j[a][a] * j[b][b] - j[a][b] * j[b][a];
    let det = j[0][0] * (j[1][1] * j[2][2] - j[1][2] * j[2][1])
        - j[0][1] * (j[1][0] * j[2][2] - j[1][2] * j[2][0])
        + j[0][2] * (j[1][0] * j[2][1] - j[1][1] * j[2][0]);
    [minor(1, 2) / det, minor(0, 2) / det, minor(0, 1) / det]
}

/// The eigenvalues of the symmetric 3×3 `s`, smallest first, by the trigonometric solution
/// of its characteristic cubic.
fn eigenvalues(s: &[[f64; 3]; 3]) -> [f64; 3] {
    let q = (s[0][0] + s[1][1] + s[2][2]) / 3.0;
    let p1 = s[0][1].powi(2) + s[0][2].powi(2) + s[1][2].powi(2);
    let p2 = (0..3).map(|i| (s[i][i] - q).powi(2)).sum::<f64>() + 2.0 * p1;
    let p = (p2 / 6.0).sqrt();
    let b: Vec<Vec<f64>> = (0..3)
        .map(|i| {
            (0..3)
                .map(|k| (s[i][k] - if i == k { q } else { 0.0 }) / p)
                .collect()
        })
        .collect();
    let det_b = b[0][0] * (b[1][1] * b[2][2] - b[1][2] * b[2][1])
        - b[0][1] * (b[1][0] * b[2][2] - b[1][2] * b[2][0])
        + b[0][2] * (b[1][0] * b[2][1] - b[1][1] * b[2][0]);
    let phi = (det_b / 2.0).clamp(-1.0, 1.0).acos() / 3.0;
    let high = q + 2.0 * p * phi.cos();
    let low = q + 2.0 * p * (phi + 2.0 * std::f64::consts::PI / 3.0).cos();
    [low, 3.0 * q - high - low, high]
}

#[test]
fn the_vifs_and_condition_number_are_those_of_the_cycles_rows() {
    // The thesis study at scales 1 and 2 (any R: the metrics are of the noise-free rows).
    // J = XᵀX of the used rows of cycles.parquet, X = [F, −kV², −g cos θ], summed plainly
    // here (the engine's sums are exactly rounded); the VIFs from the cofactor inverse, the
    // condition number from the closed-form eigenvalues. Tolerance 1e-9 relative: the sums
    // differ by ~1e-16 relative, the condition number ~1e3 amplifies that to ~1e-13, and
    // the trigonometric eigenvalue formula loses a few digits more on the smallest (a
    // difference of terms ~q; ~1e-12 at λ_min/q ~ 1e-3).
    let text = set_key(&study_text("thesis.toml"), "scales", "[1.0, 2.0]");
    let study = chassis_mc::study::Study::from_toml(&text, "identification")
        .unwrap()
        .with_overrides(Some(2), None)
        .unwrap();
    let (dir, _) = run(&study, None);
    let cycles = read_table(&dir.path().join("cycles.parquet"));
    let summary = read_table(&dir.path().join("summary.parquet"));
    let (scale, used) = (f64_col(&cycles, "scale"), bool_col(&cycles, "used"));
    let (f, v, grade) = (
        f64_col(&cycles, "f_prop"),
        f64_col(&cycles, "v"),
        f64_col(&cycles, "grade"),
    );
    let (k, g) = (0.5 * 1.2 * 5.5, 9.81);
    let rows_scale = f64_col(&summary, "scale");
    for s in [1.0, 2.0] {
        let mut j = [[0.0; 3]; 3];
        for i in (0..f.len()).filter(|&i| scale[i] == s && used[i]) {
            let x = [f[i], -k * v[i] * v[i], -g * grade[i].cos()];
            for a in 0..3 {
                for b in 0..3 {
                    j[a][b] += x[a] * x[b];
                }
            }
        }
        let inv = inverse_diagonal(&j);
        let vif: Vec<f64> = (0..3).map(|a| j[a][a] * inv[a]).collect();
        let scaled: [[f64; 3]; 3] =
            std::array::from_fn(|a| std::array::from_fn(|b| j[a][b] / (j[a][a] * j[b][b]).sqrt()));
        let eig = eigenvalues(&scaled);
        let expected = [
            ("vif_inv_mass", vif[0]),
            ("vif_drag_over_mass", vif[1]),
            ("vif_rolling_resistance", vif[2]),
            ("corr_inv_mass_drag_over_mass", scaled[0][1]),
            ("corr_inv_mass_rolling_resistance", scaled[0][2]),
            ("corr_drag_over_mass_rolling_resistance", scaled[1][2]),
            ("condition_number", eig[2] / eig[0]),
        ];
        let row = rows_scale.iter().position(|&x| x == s).unwrap();
        for (name, value) in expected {
            let engine = f64_col(&summary, name)[row];
            assert!(
                (engine / value - 1.0).abs() < 1e-9,
                "scale {s}: {name} {engine} against {value}"
            );
        }
        eprintln!(
            "scale {s}: VIF {vif:?}, condition number {}",
            eig[2] / eig[0]
        );
    }
}
