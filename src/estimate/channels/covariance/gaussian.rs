//! Moments of a Gaussian's powers: E\[(μ + σz)ⁿ\] and the Hermite coefficients of (μ + σz)ⁿ,
//! from which the channels' joint moments and their covariances across rows are built.

/// n! for small n.
pub(super) fn factorial(n: u8) -> f64 {
    (1..=n as u32).map(f64::from).product()
}

/// E\[(μ + σz)ⁿ\] for z ~ N(0, 1), by mₖ = μ mₖ₋₁ + (k − 1)σ² mₖ₋₂.
pub fn gaussian_moment(mu: f64, sd: f64, n: u8) -> f64 {
    let s2 = sd * sd;
    let (mut before, mut m) = (0.0, 1.0);
    for k in 1..=n {
        (before, m) = (m, mu * m + f64::from(k - 1) * s2 * before);
    }
    m
}

/// The Hermite coefficients h_k = E\[(μ + σz)ⁿ He_k(z)\] / k!, k = 0..=8, of (μ + σz)ⁿ
/// (n ≤ 8): (μ + σz)ⁿ = Σ_k h_k He_k(z), so for z, z' standard normal with correlation ρ,
/// Cov(f(z), g(z')) = Σ_{k≥1} k! f_k g_k ρᵏ (Mehler).
pub fn hermite_coefficients(mu: f64, sd: f64, n: u8) -> [f64; 9] {
    assert!(n <= 8, "powers up to 8");
    let mut h = [0.0; 9];
    // (μ + σz)ⁿ = Σ_m C(n, m) μ^(n−m) σ^m z^m, z^m = Σ_k m! / (k! j! 2^j) He_k, m − k = 2j.
    for m in 0..=n {
        let c = factorial(n) / (factorial(m) * factorial(n - m))
            * mu.powi((n - m) as i32)
            * sd.powi(m as i32);
        let mut k = m as i32;
        while k >= 0 {
            let j = (m as i32 - k) / 2;
            h[k as usize] +=
                c * factorial(m) / (factorial(k as u8) * factorial(j as u8) * 2f64.powi(j));
            k -= 2;
        }
    }
    h
}
