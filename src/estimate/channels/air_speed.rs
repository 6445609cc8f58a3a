//! The air-speed sensor (docs/model.md#air-speed): white or correlated noise on a measured
//! air speed Ṽ_a = V + w + e_a, which the drag regressor reads in place of the ground speed
//! (the regression's speed column is then the air speed). Its noise enters w = Ṽ_a² as the
//! speed sensor's enters Ṽ², so its terms are the speed sensor's of w; it enters no other
//! column (the acceleration is the model's), so never the output. Its level is set by the
//! study's level axis `noise.air_speed_sd`, and `noise.velocity_correlation_time`
//! correlates it as it does the speed sensor's.

use super::covariance::{AcrossRows, gaussian_moment};
use super::velocity::{
    Speed, correlated_across_rows, correlated_in_time, correlated_meat, white_second_order,
};
use super::{
    Channel, ChannelTerms, ColumnMoments, NoiseLevels, OmegaAt, Part, Powers, RowCovariance,
    RowMoments, Sample, SecondOrder, Signal, TrueRow,
};
use crate::estimate::regression::Regression;
use crate::estimate::sums::{Column, Moments, Sum};
use crate::numeric::simd::Lanes;

/// The air-speed noise channel.
#[derive(Debug, Clone, Copy)]
pub struct AirSpeedNoise;

impl ChannelTerms for AirSpeedNoise {
    const KEY: &'static str = "air_speed_sd";
    const UNIT: &'static str = "m/s";
    const DESCRIPTION: &'static str = "air-speed measurement noise σ_a";
    const DEFAULT_LEVELS: Option<&'static [f64]> = Some(&[0.0]);
    const STREAM: crate::noise::Stream = crate::noise::Stream::Channel(9);
    const IN_REGRESSORS: bool = true;
    const COLUMNS: &'static [Column] = &[Column::W];
    const SIGNAL: Signal = Signal::AirSpeed;
    const OMEGA_RANK: usize = 4;
    const PARTS: &'static [Part] = &[Part::W];
    const ON_FAST_PATH: bool = true;
    const OWN_AXIS: bool = false;

    /// Ṽ_a = V_a + σe: the measured speed of the drag regressor, as the speed sensor's.
    #[inline(always)]
    fn measure<L: Lanes>(l: L, x: &mut Sample<L::F64>, sd: f64, e: L::F64) {
        Speed::measure(l, x, sd, e);
    }

    /// The speed sensor's term: Ṽ_a² − V_a² has variance 4V_a²σ² + 2σ⁴, through −kθ₂.
    fn omega_term(sd: f64, at: &OmegaAt) -> f64 {
        Speed::omega_term(sd, at)
    }

    /// White noise: the speed sensor's terms of w (correlated noise: not derived).
    fn second_order(sd: f64, noise: &NoiseLevels, at: &OmegaAt, x: &[f64; 3]) -> SecondOrder {
        if Channel::AirSpeed.shares_rows(noise) {
            return SecondOrder::NONE;
        }
        white_second_order(sd, at, x)
    }

    /// E\[Ṽ_a²\] = V_a² + σ², E\[Ṽ_a⁴\] = V_a⁴ + 6σ²V_a² + 3σ⁴.
    fn expect(sd: f64, r: &TrueRow, e: &mut ColumnMoments) {
        Speed::expect(sd, r, e);
    }

    /// `V_a² → Ṽ_a² − σ²` and `V_a⁴ → Ṽ_a⁴ − 6σ²Ṽ_a² + 3σ⁴` wherever w appears.
    fn compensate(m: &Moments, sd: f64, g: f64) -> Moments {
        Speed::compensate(m, sd, g)
    }

    /// Correlated noise: the covariance of rows through w (`None`: white).
    fn row_covariance(
        reg: &Regression,
        theta: &[f64; 3],
        noise: &NoiseLevels,
    ) -> Option<RowCovariance> {
        correlated_in_time(noise, Channel::AirSpeed).then(|| RowCovariance {
            meat: correlated_meat(
                reg,
                theta,
                noise[Channel::AirSpeed],
                noise.velocity_correlation_s,
            ),
            replaces_omega_term: false,
        })
    }

    /// The correlation time of its noise \[s\] (0: white or off).
    fn correlation_time_s(noise: &NoiseLevels) -> f64 {
        if correlated_in_time(noise, Channel::AirSpeed) {
            noise.velocity_correlation_s
        } else {
            0.0
        }
    }

    /// E\[wᵏ\] = E\[(V_a + σe)²ᵏ\].
    fn raw_moment(noise: &NoiseLevels, r: &TrueRow, k: &Powers) -> Option<f64> {
        let sd = noise[Channel::AirSpeed];
        Some(gaussian_moment(r.v, sd, 2 * k[Part::W as usize]))
    }

    /// Correlated noise: the speed sensor's terms of w across rows (white: nothing).
    fn covariance_across_rows(
        reg: &Regression,
        noise: &NoiseLevels,
        ar1: Option<&[[f64; 2]]>,
        rows: &dyn Fn(usize) -> RowMoments,
        sums: &[Sum],
    ) -> AcrossRows {
        match ar1 {
            Some(ar1) => AcrossRows::Covariance(correlated_across_rows(
                reg,
                Channel::AirSpeed,
                noise,
                ar1,
                rows,
                sums,
            )),
            None => AcrossRows::Nothing,
        }
    }
}
