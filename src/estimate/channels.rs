//! The noise channels of the vehicle regression's measurements (docs/model.md#noise-channels).
//!
//! A channel is one variant of [`Channel`]: every property of it — its study key and output
//! column, unit, default, the stream that draws its noise, whether it enters the regressors
//! and how its draw perturbs a measured sample — is a `match` arm in this file, so the
//! compiler lists every place a new channel needs. The condition axes, the study keys under
//! `[noise]`, the streams and the kernel are derived from [`Channel::ALL`]; the
//! equation-error variance Ω of the bounds (`bounds.rs`) and BCLS's correction of the sums
//! (`Moments::compensate` in `estimators.rs`, an exhaustive match) are the other places a
//! channel appears, because they are physics, not wiring.

use std::ops::{Index, IndexMut};

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

/// Where the acceleration in the regression output comes from (`estimation.acceleration`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Acceleration {
    /// The true dV/dt (the thesis; an ideal accelerometer).
    #[default]
    Model,
    /// The central difference of the *measured* speed, as a log without an accelerometer
    /// has it: the speed noise then enters the output too.
    Differentiated,
}

impl Acceleration {
    /// Every source, in the order of messages.
    pub const ALL: [Acceleration; 2] = [Acceleration::Model, Acceleration::Differentiated];

    /// Its name in study files and in the `acceleration` column.
    pub const fn name(self) -> &'static str {
        match self {
            Acceleration::Model => "model",
            Acceleration::Differentiated => "differentiated",
        }
    }
}

/// Noise levels of one condition: a standard deviation per channel (0 = off), the
/// correlation time of the speed noise, and where the acceleration comes from.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct NoiseLevels {
    /// Standard deviation per channel, in the channel's unit (0 = off).
    pub sd: PerChannel<f64>,
    /// Correlation time τ_c of the speed noise \[s\]: a stationary AR(1) process with
    /// φ = exp(−Δt/τ_c) between consecutive samples (0 = white).
    pub velocity_correlation_s: f64,
    /// The source of the acceleration in ỹ.
    pub acceleration: Acceleration,
}

impl Index<Channel> for NoiseLevels {
    type Output = f64;
    fn index(&self, c: Channel) -> &f64 {
        &self.sd[c]
    }
}

impl IndexMut<Channel> for NoiseLevels {
    fn index_mut(&mut self, c: Channel) -> &mut f64 {
        &mut self.sd[c]
    }
}

impl NoiseLevels {
    /// (channel, standard deviation) pairs in [`Channel::ALL`] order.
    pub fn iter(&self) -> impl Iterator<Item = (Channel, &f64)> {
        self.sd.iter()
    }

    /// True when the acceleration is differentiated from the noisy measured speed: the
    /// speed noise then enters the output as well, and rows share noise with their
    /// neighbours.
    pub fn speed_noise_differentiated(&self) -> bool {
        self.acceleration == Acceleration::Differentiated && self.is_on(Channel::Velocity)
    }

    /// True when the rows' equation errors are independent (no correlated speed noise, no
    /// differentiated speed noise).
    pub fn independent_rows(&self) -> bool {
        !self.velocity_correlated() && !self.speed_noise_differentiated()
    }

    /// True when the speed noise is on and correlated in time.
    pub fn velocity_correlated(&self) -> bool {
        self.is_on(Channel::Velocity) && self.velocity_correlation_s > 0.0
    }

    /// Whether `channel` is on.
    pub fn is_on(&self, channel: Channel) -> bool {
        self[channel] > 0.0
    }

    /// True when noise enters a regressor, not only the output.
    pub fn in_regressors(&self) -> bool {
        self.iter().any(|(c, &sd)| c.in_regressors() && sd > 0.0)
    }

    /// True when the output is noisy and nothing else is.
    pub fn output_only(&self) -> bool {
        self.is_on(Channel::Output) && !self.in_regressors()
    }

    /// True when every channel that is on is handled by the vectorised kernel (whose output
    /// noise is the output channel's alone).
    pub fn fast_path(&self) -> bool {
        !self.speed_noise_differentiated()
            && self.iter().all(|(c, &sd)| c.on_fast_path() || sd == 0.0)
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
