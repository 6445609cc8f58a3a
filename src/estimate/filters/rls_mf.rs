//! Recursive least squares with a forgetting factor per parameter (Vahidi, Stefanopoulou
//! & Peng 2005) for 1/M and β = Cr cos φ + sin φ from the measured speed and force
//! (docs/model.md#rls-mf).
//!
//! With m samples either side, at each sample k from m to n − 1 − m:
//!
//! ```text
//! y_k = (z_{k+m} − z_{k−m}) / (t_{k+m} − t_{k−m})      V̂_k = mean of z_{k−m} … z_{k+m}
//! u_k = F_k − c V̂_k²                                    y_k = θ₁ u_k − g β_k
//! ε_k = y_k − (θ̂₁ u_k − g β̂)                            (the a-priori error)
//! L₁ = P₁ u_k / (λ₁ + u_k² P₁),     θ̂₁ += L₁ ε_k,   P₁ = (1 − L₁ u_k) P₁ / λ₁
//! L₂ = −g P₂ / (λ₂ + g² P₂),        β̂  += L₂ ε_k,   P₂ = (1 + g L₂) P₂ / λ₂
//! ```
//!
//! started at θ̂₁ = 1/M₀, β̂ = Cr, P₁ = Var(1/M)/σ_y², P₂ = σ_φ0²/σ_y², with σ_y² =
//! 2σ_v²/(t_{k+m} − t_{k−m})² the variance of y's noise at the first sample. Its own SD of
//! 1/M is √(P₁ σ_y²) at the last sample (the covariance of a least-squares fit with white
//! output noise: y's noise is correlated over 2m samples, so it is nominal, not calibrated).

use super::FilterModel;
use super::ekf::Prior;

/// The forgetting factors and the difference's half-window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RlsMfSettings {
    /// λ₁, of 1/M.
    pub forgetting_mass: f64,
    /// λ₂, of β.
    pub forgetting_grade: f64,
    /// m, the samples either side of the central difference (≥ 1).
    pub half_window: usize,
}

/// What the recursion gives after its last sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RlsMfRun {
    /// θ̂₁ \[1/kg\].
    pub inv_mass: f64,
    /// β̂ \[-\].
    pub beta: f64,
    /// √(P₁ σ_y²) \[1/kg\].
    pub inv_mass_sd: f64,
}

/// The half-window m = `window_s`/Δt of samples `step_s` = Δt apart (the nearest whole
/// number, at least one): the difference spans 2m samples.
pub fn half_window(window_s: f64, step_s: f64) -> usize {
    ((window_s / step_s).round() as usize).max(1)
}

/// The recursion over measured speeds `z` and forces `force` at times `t` (`None` when
/// there are fewer than 2m + 1 samples); `watch` sees the estimate of 1/M at each sample k
/// up to n − 1 − m (the prior's before the first difference, at k = m).
pub fn run(
    model: &FilterModel,
    prior: &Prior,
    settings: &RlsMfSettings,
    t: &[f64],
    z: &[f64],
    force: &[f64],
    mut watch: impl FnMut(usize, f64),
) -> Option<RlsMfRun> {
    let n = t.len();
    let m = settings.half_window;
    if n < 2 * m + 1 {
        return None;
    }
    let (l1, l2) = (settings.forgetting_mass, settings.forgetting_grade);
    let g = model.g;
    let y_var = |k: usize| 2.0 * model.speed_noise_var / (t[k + m] - t[k - m]).powi(2);
    // With noise-free speeds the output has no noise to scale the priors by: the priors'
    // variances are then taken as they are.
    let scale = match y_var(m) {
        v if v > 0.0 => v,
        _ => 1.0,
    };
    let mut theta = prior.inv_mass();
    let mut beta = model.rolling;
    let mut p1 = prior.inv_mass_var() / scale;
    let mut p2 = prior.grade_sd_rad * prior.grade_sd_rad / scale;
    let mut window: f64 = z[..2 * m + 1].iter().sum();
    let count = (2 * m + 1) as f64;
    // Before the first difference the estimate is the prior's.
    for k in 0..m {
        watch(k, theta);
    }
    for k in m..n - m {
        if k > m {
            window += z[k + m] - z[k - m - 1];
        }
        let v = window / count;
        let y = (z[k + m] - z[k - m]) / (t[k + m] - t[k - m]);
        let u = force[k] - model.drag * v * v;
        let error = y - (theta * u - g * beta);
        let gain1 = p1 * u / (l1 + u * u * p1);
        theta += gain1 * error;
        p1 = (1.0 - gain1 * u) * p1 / l1;
        let gain2 = -g * p2 / (l2 + g * g * p2);
        beta += gain2 * error;
        p2 = (1.0 + g * gain2) * p2 / l2;
        watch(k, theta);
    }
    Some(RlsMfRun {
        inv_mass: theta,
        beta,
        inv_mass_sd: (p1 * y_var(n - 1 - m)).sqrt(),
    })
}
