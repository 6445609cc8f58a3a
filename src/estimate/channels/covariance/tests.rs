use super::*;

#[test]
fn hermite_coefficients_rebuild_the_polynomial() {
    // Σ h_k He_k(z) = (μ + σz)ⁿ at a few z (He by its recursion), to 1e-12 relative.
    for n in 0..=8u8 {
        let h = hermite_coefficients(1.7, 0.6, n);
        for z in [-2.0f64, -0.3, 0.0, 0.8, 2.5] {
            let mut he = [0.0; 9];
            he[0] = 1.0;
            he[1] = z;
            for k in 2..9 {
                he[k] = z * he[k - 1] - (k - 1) as f64 * he[k - 2];
            }
            let value: f64 = h.iter().zip(he).map(|(a, b)| a * b).sum();
            let expected = (1.7 + 0.6 * z).powi(n as i32);
            assert!(
                (value - expected).abs() <= 1e-12 * expected.abs().max(1.0),
                "n = {n}, z = {z}: {value} vs {expected}"
            );
        }
    }
    // E[(μ + σz)⁴] = μ⁴ + 6μ²σ² + 3σ⁴.
    let (mu, sd) = (2.0f64, 0.5f64);
    let e4 = mu.powi(4) + 6.0 * mu * mu * sd * sd + 3.0 * sd.powi(4);
    assert!((gaussian_moment(mu, sd, 4) - e4).abs() <= 1e-13 * e4);
}
