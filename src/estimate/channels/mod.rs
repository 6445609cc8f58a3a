//! The noise channels of the vehicle regression's measurements (docs/model.md#noise-channels).
//!
//! A channel is one variant of [`Channel`], and every term of it is a `match` arm on it in
//! this directory, so the compiler lists every place a new channel needs:
//!
//! - here: its study key and output column, unit, default, the stream that draws its
//!   noise, the measured columns it moves (from which the control variates that vary are
//!   derived) and how its draw perturbs a measured sample ([`Channel::perturb`]);
//! - `omega.rs`: its term of the equation-error variance Ω ([`Channel::omega_term`]) and,
//!   for noise that rows share, its part of the sandwich's XᵀΣX off the diagonal, the
//!   variance it adds to a differentiated ỹ and its correlation time (which the bounds and
//!   `wbcls` ask);
//! - `expect.rs`: its expectations of the measured columns ([`Channel::expect`],
//!   [`Channel::expect_shared`]; the control variates ask) and the place for its
//!   covariances ([`Channel::sum_covariance`], for the spread control variates);
//! - `levels.rs`: [`NoiseLevels`], a condition's levels, and what follows from them;
//! - `velocity.rs`: the speed sensor's terms that reach beyond a row (AR(1) correlation,
//!   a differentiated acceleration), which the `Channel::Velocity` arms call.
//!
//! The condition axes, the study keys under `[noise]`, the streams and the kernel are
//! derived from [`Channel::ALL`]. BCLS's correction of the sums (`Moments::compensate` in
//! `estimators.rs`, an exhaustive match) is the other place a channel appears, because it
//! is physics, not wiring.

use std::ops::{Index, IndexMut};

use super::sums::Column;

mod expect;
mod levels;
mod omega;
mod velocity;

pub use expect::{ColumnMoments, TrueRow};
pub use levels::{Acceleration, NoiseLevels};
pub use omega::{GradeLoading, OmegaAt, RowCovariance};

/// An independent noise source of a realisation's measurements. Each has its own random
/// stream, so switching one on does not change the draws of another.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Channel {
    /// Speed-measurement noise.
    Velocity,
    /// Additive noise on the regression output.
    Output,
    /// Noise on the measured grade signal.
    Grade,
    /// Noise on the measured propulsion force.
    Force,
}

/// Number of channels.
pub const CHANNEL_COUNT: usize = Channel::ALL.len();

impl Channel {
    /// Every channel, in the order of the study keys, the condition axes (the last varies
    /// fastest) and the output columns.
    pub const ALL: [Channel; 4] = [
        Channel::Velocity,
        Channel::Output,
        Channel::Grade,
        Channel::Force,
    ];

    /// Position in [`Channel::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The key under `[noise]` in study files, and the condition column in every table.
    pub const fn key(self) -> &'static str {
        match self {
            Channel::Velocity => "velocity_sd",
            Channel::Output => "output_sd",
            Channel::Grade => "grade_sd",
            Channel::Force => "force_sd",
        }
    }

    /// Unit of the standard deviation.
    pub const fn unit(self) -> &'static str {
        match self {
            Channel::Velocity => "m/s",
            Channel::Output => "m/s^2",
            Channel::Grade => "rad",
            Channel::Force => "N",
        }
    }

    /// What the standard deviation is of.
    pub const fn description(self) -> &'static str {
        match self {
            Channel::Velocity => "speed-measurement noise σ_v",
            Channel::Output => "additive noise σ_y on the regression output (acceleration)",
            Channel::Grade => "grade-measurement noise σ_θ",
            Channel::Force => "propulsion-force measurement noise σ_F",
        }
    }

    /// The levels a study gets when it does not list the key (`None`: the key is required).
    pub const fn default_levels(self) -> Option<&'static [f64]> {
        match self {
            Channel::Velocity | Channel::Output => None,
            Channel::Grade | Channel::Force => Some(&[0.0]),
        }
    }

    /// The channel's part of the ChaCha key of its stream (docs/model.md#streams). Part of
    /// every study's numbers: never change or reuse one.
    pub const fn stream(self) -> u64 {
        match self {
            Channel::Velocity => 1,
            Channel::Output => 2,
            Channel::Grade => 3,
            Channel::Force => 4,
        }
    }

    /// True when the channel's noise enters a regressor (so OLS is biased), not only the
    /// output.
    pub const fn in_regressors(self) -> bool {
        match self {
            Channel::Velocity | Channel::Grade | Channel::Force => true,
            Channel::Output => false,
        }
    }

    /// The measured columns of the regression its noise enters (speed noise enters ỹ as
    /// well through a differentiated acceleration: [`NoiseLevels::moves`]).
    pub const fn columns(self) -> &'static [Column] {
        match self {
            Channel::Velocity => &[Column::W],
            Channel::Output => &[Column::Y],
            Channel::Grade => &[Column::C, Column::Y],
            Channel::Force => &[Column::F],
        }
    }

    /// True when the vectorised kernel (speed and output noise only) handles the channel.
    pub const fn on_fast_path(self) -> bool {
        matches!(self, Channel::Velocity | Channel::Output)
    }

    /// Apply this channel's draw `e` ~ N(0, 1) at standard deviation `sd` to a measured
    /// sample (the general kernel; see docs/model.md#noise-channels).
    #[inline(always)]
    pub fn perturb(self, s: &mut Sample, sd: f64, e: f64) {
        match self {
            Channel::Velocity => s.v += sd * e,
            Channel::Output => s.output_noise = sd * e,
            Channel::Grade => {
                if sd > 0.0 {
                    // sin/cos of θ + δ from those of θ and δ (angle addition)
                    let (sd, cd) = (sd * e).sin_cos();
                    (s.sin_grade, s.cos_grade) = (
                        s.sin_grade * cd + s.cos_grade * sd,
                        s.cos_grade * cd - s.sin_grade * sd,
                    );
                }
            }
            Channel::Force => s.f += sd * e,
        }
    }
}

/// One measured sample of the cycle as the general kernel builds it: the noise-free values,
/// then each channel's [`Channel::perturb`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Measured propulsion force \[N\].
    pub f: f64,
    /// Measured speed \[m/s\].
    pub v: f64,
    /// sin of the measured grade.
    pub sin_grade: f64,
    /// cos of the measured grade.
    pub cos_grade: f64,
    /// Noise added to the output \[m/s²\].
    pub output_noise: f64,
}

/// A value per channel, indexed by [`Channel`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PerChannel<T>(pub [T; CHANNEL_COUNT]);

impl<T> PerChannel<T> {
    /// `f(channel)` for every channel.
    pub fn from_fn(mut f: impl FnMut(Channel) -> T) -> Self {
        PerChannel(Channel::ALL.map(&mut f))
    }

    /// (channel, value) pairs in [`Channel::ALL`] order.
    pub fn iter(&self) -> impl Iterator<Item = (Channel, &T)> {
        Channel::ALL.into_iter().zip(&self.0)
    }
}

impl<T> Index<Channel> for PerChannel<T> {
    type Output = T;
    fn index(&self, c: Channel) -> &T {
        &self.0[c.index()]
    }
}

impl<T> IndexMut<Channel> for PerChannel<T> {
    fn index_mut(&mut self, c: Channel) -> &mut T {
        &mut self.0[c.index()]
    }
}

/// Standard-normal draws of one block, per channel (`None` when the channel is off).
pub type BlockNoise<'a> = PerChannel<Option<&'a [f64]>>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channels_are_listed_in_index_order_with_distinct_keys_and_streams() {
        for (i, c) in Channel::ALL.into_iter().enumerate() {
            assert_eq!(c.index(), i);
            for d in &Channel::ALL[i + 1..] {
                assert_ne!(c.key(), d.key());
                assert_ne!(c.stream(), d.stream());
            }
        }
    }

    #[test]
    fn a_zero_draw_leaves_the_sample_unchanged() {
        let s0 = Sample {
            f: 1200.0,
            v: 20.0,
            sin_grade: 0.05f64.sin(),
            cos_grade: 0.05f64.cos(),
            output_noise: 0.0,
        };
        for c in Channel::ALL {
            let mut s = s0;
            c.perturb(&mut s, 0.0, 0.0);
            assert_eq!(s, s0, "{c:?}");
        }
    }
}
