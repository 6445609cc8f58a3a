//! Force noise: white noise σ_F on the measured propulsion force (docs/model.md#noise-channels).

use super::covariance::gaussian_moment;
use nalgebra::{Matrix3, Vector3};

use super::{
    Channel, ChannelTerms, ColumnMoments, NoiseLevels, OmegaAt, Part, Powers, Sample, SecondOrder,
    Signal, TrueRow,
};
use crate::estimate::sums::Column;
use crate::estimate::sums::Moments;
use crate::numeric::simd::Lanes;

/// The force-noise channel.
#[derive(Debug, Clone, Copy)]
pub struct ForceNoise;

impl ChannelTerms for ForceNoise {
    const KEY: &'static str = "force_sd";
    const UNIT: &'static str = "N";
    const DESCRIPTION: &'static str = "propulsion-force measurement noise σ_F";
    const DEFAULT_LEVELS: Option<&'static [f64]> = Some(&[0.0]);
    const STREAM: crate::noise::Stream = crate::noise::Stream::Channel(4);
    const IN_REGRESSORS: bool = true;
    const COLUMNS: &'static [Column] = &[Column::F];
    const SIGNAL: Signal = Signal::Force;
    const OMEGA_RANK: usize = 1;
    const PARTS: &'static [Part] = &[Part::F];

    /// F̃ = F + σe.
    #[inline(always)]
    fn measure<L: Lanes>(l: L, x: &mut Sample<L::F64>, sd: f64, e: L::F64) {
        x.force = x.force + l.splat(sd) * e;
    }

    /// (F̃ − F)θ₁.
    fn omega_term(sd: f64, at: &OmegaAt) -> f64 {
        (at.theta[0] * sd).powi(2)
    }

    /// Δ = δ e₁ and ε = −θ₁δ, δ ~ N(0, σ²): the compensation of Σx̃₁² leaves −θ₁(δ² − σ²)
    /// in ψ₁, of variance 2θ₁²σ⁴ and uncorrelated with the first-order part (odd moments).
    fn second_order(sd: f64, _noise: &NoiseLevels, at: &OmegaAt, _x: &[f64; 3]) -> SecondOrder {
        let (s2, t1) = (sd * sd, at.theta[0]);
        let e1 = Matrix3::new(1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        SecondOrder {
            own: e1 * (2.0 * t1 * t1 * s2 * s2),
            perturbation: e1 * s2,
            loading: Vector3::new(-t1 * s2, 0.0, 0.0),
        }
    }

    /// E\[F̃²\] = F² + σ².
    fn expect(sd: f64, r: &TrueRow, e: &mut ColumnMoments) {
        let s2 = sd * sd;
        e.ff = r.f * r.f + s2;
    }

    /// E\[F̃²\] = F² + σ²: `Σx̃₁² → Σx̃₁² − Nσ²` (F̃ enters every other sum linearly).
    fn compensate(m: &Moments, sd: f64, _g: f64) -> Moments {
        let s2 = sd * sd;
        Moments {
            s_11: m.s_11 - s2 * m.n,
            ..*m
        }
    }

    /// E\[(F + σz)ᵏ\].
    fn raw_moment(noise: &NoiseLevels, r: &TrueRow, k: &Powers) -> Option<f64> {
        Some(gaussian_moment(
            r.f,
            noise[Channel::Force],
            k[Part::F as usize],
        ))
    }
}
