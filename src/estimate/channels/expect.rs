//! Each channel's expectations of the measured columns at a noise-free row, which the
//! control variates centre the sums with (docs/model.md#control-variates), and the place
//! for the covariances the spread control variates will need.

use super::{Channel, NoiseLevels, velocity};
use crate::estimate::regression::Regression;
use crate::estimate::sums::{Column, Sum};

/// A noise-free row as the expectations of its measured columns read it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrueRow {
    /// Propulsion force F \[N\].
    pub f: f64,
    /// Speed V \[m/s\].
    pub v: f64,
    /// The acceleration in the output \[m/s²\] (without the grade term).
    pub accel: f64,
    /// sin of the grade.
    pub sin_grade: f64,
    /// cos of the grade.
    pub cos_grade: f64,
    /// Gravity g \[m/s²\].
    pub g: f64,
}

/// The expectations at one row of the measured columns and of the products of two
/// columns that the same channel moves (docs/model.md#control-variates): noise-free from
/// [`ColumnMoments::noise_free`], then moved by each channel that is on
/// ([`Channel::expect`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColumnMoments {
    /// E\[x̃₁\], E\[w\], E\[x̃₃\], E\[ỹ\], indexed by [`Column`].
    pub mean: [f64; 4],
    /// E\[x̃₁²\].
    pub ff: f64,
    /// E\[w²\].
    pub ww: f64,
    /// E\[x̃₃²\].
    pub cc: f64,
    /// E\[x̃₃ỹ\] (both carry the grade noise).
    pub cy: f64,
    /// Cov(w, ỹ), through a differentiated acceleration with correlated speed noise (0
    /// otherwise; set by [`Channel::expect_shared`]).
    pub wy_neighbours: f64,
}

impl ColumnMoments {
    /// The values of a row without noise (w = V², x̃₃ = −g cos θ, ỹ = a + g sin θ).
    pub fn noise_free(r: &TrueRow) -> Self {
        let (g, a, sin, cos) = (r.g, r.accel, r.sin_grade, r.cos_grade);
        let v2 = r.v * r.v;
        ColumnMoments {
            mean: [r.f, v2, -g * cos, a + g * sin],
            ff: r.f * r.f,
            ww: v2 * v2,
            cc: g * g * (cos * cos),
            cy: -g * a * cos - g * g * (sin * cos),
            wy_neighbours: 0.0,
        }
    }
}

impl Channel {
    /// Move the expectations `e` of row `r`'s measured columns by this channel's noise at
    /// SD `sd` > 0 (docs/model.md#control-variates). Each channel sets the moments of the
    /// columns it moves ([`Channel::columns`]), from the noise-free row: the channels are
    /// independent, so the order does not matter.
    pub fn expect(self, sd: f64, r: &TrueRow, e: &mut ColumnMoments) {
        let s2 = sd * sd;
        match self {
            Channel::Velocity => {
                // E[Ṽ²] = V² + σ², E[Ṽ⁴] = V⁴ + 6σ²V² + 3σ⁴.
                let v2 = r.v * r.v;
                e.mean[Column::W.index()] = v2 + s2;
                e.ww = v2 * v2 + 6.0 * s2 * v2 + 3.0 * s2 * s2;
            }
            // Zero-mean, independent of everything else.
            Channel::Output => {}
            Channel::Grade => {
                let (g, a) = (r.g, r.accel);
                let [e_cos, e_cos2, e_sin, e_sin_cos] = grade_moments(r.sin_grade, r.cos_grade, sd);
                e.mean[Column::C.index()] = -g * e_cos;
                e.mean[Column::Y.index()] = a + g * e_sin;
                e.cc = g * g * e_cos2;
                e.cy = -g * a * e_cos - g * g * e_sin_cos;
            }
            Channel::Force => e.ff = r.f * r.f + s2,
        }
    }
}

/// E\[cos(θ + δ)\], E\[cos²(θ + δ)\], E\[sin(θ + δ)\], E\[sin(θ + δ) cos(θ + δ)\] for
/// δ ~ N(0, σ²), from sin θ and cos θ: with ρ = E\[cos δ\] = e^(−σ²/2),
/// E\[sin δ\] = E\[sin δ cos δ\] = 0 and E\[cos 2δ\] = ρ⁴.
fn grade_moments(sin: f64, cos: f64, sd: f64) -> [f64; 4] {
    let rho = (-0.5 * sd * sd).exp();
    let rho4 = (-2.0 * sd * sd).exp();
    [
        rho * cos,
        0.5 * (cos * cos * (1.0 + rho4) + sin * sin * (1.0 - rho4)),
        rho * sin,
        rho4 * sin * cos,
    ]
}

impl Channel {
    /// Set the terms of row `i`'s expectations `e` that this channel's noise adds through
    /// the rows it shares with its neighbours (speed noise through a differentiated
    /// acceleration with AR(1) correlation: [`ColumnMoments::wy_neighbours`]); `ar1` the
    /// AR(1) coefficients of correlated speed noise over [`Regression::noise_times`]
    /// (`None` when white). Nothing for a channel whose rows are independent.
    pub fn expect_shared(
        self,
        reg: &Regression,
        noise: &NoiseLevels,
        ar1: Option<&[[f64; 2]]>,
        i: usize,
        e: &mut ColumnMoments,
    ) {
        match self {
            Channel::Velocity => velocity::expect_shared(reg, noise, ar1, i, e),
            Channel::Output | Channel::Grade | Channel::Force => {}
        }
    }

    /// The place for this channel's covariances, which the spread control variates will
    /// read (docs/model.md#control-variates): Cov(aᵢ, bᵢ) of row `r`'s terms of sums `a` and
    /// `b` under this channel's noise alone at SD `sd`. `None`: not derived for the channel
    /// (no spread control variate exists yet, so none is derived for any channel; a channel
    /// fills its arm here when they come).
    pub fn sum_covariance(self, sd: f64, r: &TrueRow, a: Sum, b: Sum) -> Option<f64> {
        let _ = (sd, r, a, b);
        match self {
            Channel::Velocity | Channel::Output | Channel::Grade | Channel::Force => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The grade moments against the integrals themselves: the trapezoid rule over
    /// δ ∈ [−12σ, 12σ] with 4001 points (spectrally accurate for these smooth, rapidly
    /// decaying integrands: agreement to 1e-12) at σ = 0.3 rad, where ρ = 0.956 and
    /// ρ⁴ = 0.835 differ clearly from 1, and at grades of either sign.
    #[test]
    fn grade_moments_are_the_gaussian_integrals() {
        let sd = 0.3;
        for theta in [-0.4f64, -0.05, 0.0, 0.1, 0.7] {
            let (n, half) = (4001, 12.0 * sd);
            let h = 2.0 * half / (n - 1) as f64;
            let mut q = [0.0; 4];
            for k in 0..n {
                let d = -half + k as f64 * h;
                let w = h * (-0.5 * (d / sd).powi(2)).exp()
                    / (sd * (2.0 * std::f64::consts::PI).sqrt());
                let (s, c) = (theta + d).sin_cos();
                for (q, v) in q.iter_mut().zip([c, c * c, s, s * c]) {
                    *q += w * v;
                }
            }
            let e = grade_moments(theta.sin(), theta.cos(), sd);
            for j in 0..4 {
                assert!(
                    (e[j] - q[j]).abs() <= 1e-12,
                    "θ = {theta}, moment {j}: {} vs {}",
                    e[j],
                    q[j]
                );
            }
        }
    }
}
