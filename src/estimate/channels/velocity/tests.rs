use super::*;
use crate::estimate::regression::ar1_coefficients;
use crate::noise::NormalStream;

/// The covariance of a row's w with the derivative noise of its differentiated ỹ,
/// against a Monte Carlo of the AR(1) recursion the kernel runs, on steps of 0.1 s and
/// 1 s around the row (τ = 0.5 s: φ = 0.82 before, 0.14 after), 400 000 draws: within
/// 4.5 standard errors, and the term is > 20 of them (so an error of sign or index would
/// show).
#[test]
fn neighbour_covariance_is_the_ar1_expectation() {
    let t = [0.0, 0.1, 1.1];
    let ar1 = ar1_coefficients(&t, &[0; 3], 0.5);
    let (v, sd, inv_dt) = (12.0, 0.8, 1.0 / (t[2] - t[0]));
    let expected = neighbour_covariance(v, sd, &ar1, 1, inv_dt);
    let n = 400_000;
    let mut z = vec![0.0; 3 * n];
    NormalStream::for_realisation(3, 0, crate::noise::Stream::ForceCalibration, 0).fill(&mut z);
    let values: Vec<f64> = z
        .chunks_exact(3)
        .map(|z| {
            let mut e = [z[0], 0.0, 0.0];
            for j in 1..3 {
                e[j] = ar1[j][0] * e[j - 1] + ar1[j][1] * z[j];
            }
            (v + sd * e[1]).powi(2) * sd * (e[2] - e[0]) * inv_dt
        })
        .collect();
    let mean = values.iter().sum::<f64>() / n as f64;
    let se = (values.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n as f64 - 1.0) / n as f64)
        .sqrt();
    assert!(
        (mean - expected).abs() <= 4.5 * se,
        "{mean} vs {expected} (SE {se})"
    );
    assert!(expected.abs() > 20.0 * se, "{expected} vs SE {se}");
}
