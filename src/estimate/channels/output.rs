//! Output noise: additive, zero-mean noise σ_y on the regression output (the measured
//! acceleration), independent of everything else (docs/model.md#noise-channels).

use super::covariance::gaussian_moment;
use super::{
    Channel, ChannelTerms, ColumnMoments, NoiseLevels, OmegaAt, Part, Powers, Sample, Signal,
    TrueRow,
};
use crate::estimate::sums::Column;
use crate::estimate::sums::Moments;
use crate::numeric::simd::Lanes;

/// The output-noise channel.
#[derive(Debug, Clone, Copy)]
pub struct OutputNoise;

impl ChannelTerms for OutputNoise {
    const KEY: &'static str = "output_sd";
    const UNIT: &'static str = "m/s^2";
    const DESCRIPTION: &'static str = "additive noise σ_y on the regression output (acceleration)";
    const DEFAULT_LEVELS: Option<&'static [f64]> = None;
    const STREAM: crate::noise::Stream = crate::noise::Stream::Channel(2);
    const IN_REGRESSORS: bool = false;
    const COLUMNS: &'static [Column] = &[Column::Y];
    const SIGNAL: Signal = Signal::Acceleration;
    const OMEGA_RANK: usize = 3;
    const PARTS: &'static [Part] = &[Part::O];
    const ON_FAST_PATH: bool = true;

    /// The output's noise σe.
    #[inline(always)]
    fn measure<L: Lanes>(l: L, x: &mut Sample<L::F64>, sd: f64, e: L::F64) {
        x.output_noise = Some(l.splat(sd) * e);
    }

    /// σ_y².
    fn omega_term(sd: f64, _at: &OmegaAt) -> f64 {
        sd.powi(2)
    }

    /// Zero-mean, independent of everything else: no moment moves.
    fn expect(_sd: f64, _r: &TrueRow, _e: &mut ColumnMoments) {}

    /// None: zero-mean, independent, and linear in every sum.
    fn compensate(m: &Moments, _sd: f64, _g: f64) -> Moments {
        *m
    }

    /// E\[(σ_y η)ᵏ\].
    fn raw_moment(noise: &NoiseLevels, _r: &TrueRow, k: &Powers) -> Option<f64> {
        Some(gaussian_moment(
            0.0,
            noise[Channel::Output],
            k[Part::O as usize],
        ))
    }
}
