//! The noise channels of the vehicle regression's measurements (docs/model.md#noise-channels).
//!
//! A channel is one file here: a unit struct implementing [`ChannelTerms`] (its study key
//! and output column, unit, default, the stream that draws its noise, the measured columns
//! it moves, how its draw perturbs a sample, its term of the equation-error variance Ω, its
//! expectations of the measured columns, its correction of the sums for BCLS and, for noise
//! that rows share, its terms beyond a row), and one line of the `channels!` registry
//! below, which generates [`Channel`] and its dispatch. The condition axes, the study keys
//! under `[noise]`, the streams, the kernel, the bounds, `wbcls`, the control variates and
//! BCLS ask [`Channel`]; none of them knows a channel's internals.
//!
//! - `velocity.rs`, `output.rs`, `grade.rs`, `force.rs`, `air_speed.rs`: the channels;
//! - `omega.rs`: what Ω and the sandwich's off-diagonal part are evaluated at, and the
//!   order the channels' Ω terms are added in ([`Channel::OMEGA_ORDER`]);
//! - `covariance.rs`: the exact covariances of the sums, from each channel's moments of
//!   the parts it moves, for the spread's control variates;
//! - `expect.rs`: the noise-free row and the expectations the control variates centre
//!   the sums with;
//! - `levels.rs`: [`NoiseLevels`], a condition's levels, and what follows from them;
//! - `signal.rs`: [`Signal`], what a sensor records, and [`Sample`], one sample's measured
//!   quantities.

use std::ops::{Index, IndexMut};

use super::regression::Regression;
use super::sums::Moments;
use super::sums::{Column, Sum};
use crate::numeric::simd::Lanes;

mod covariance;
mod expect;
mod levels;
mod omega;
mod signal;

pub use covariance::{
    AcrossRows, Part, Powers, RowMoments, SumCovariances, packed, sum_covariances,
};
pub use expect::{ColumnMoments, TrueRow};
pub use levels::{Acceleration, NoiseLevels};
pub use omega::{GradeLoading, OmegaAt, RowCovariance, SecondOrder};
pub use signal::{Sample, Signal};
pub use velocity::measured_speed;

/// One noise channel's terms, implemented by a unit struct in the channel's own file and
/// registered by one line of `channels!` (docs/model.md#noise-channels). The defaults
/// are those of noise drawn independently per sample that enters one row only.
pub trait ChannelTerms {
    /// The key under `[noise]` in study files, and the condition column in every table.
    const KEY: &'static str;
    /// Unit of the standard deviation.
    const UNIT: &'static str;
    /// What the standard deviation is of.
    const DESCRIPTION: &'static str;
    /// The levels a study gets when it does not list the key (`None`: the key is required).
    const DEFAULT_LEVELS: Option<&'static [f64]>;
    /// The channel's part of the ChaCha key of its stream (docs/model.md#streams). Part of
    /// every study's numbers: never change or reuse one.
    const STREAM: crate::noise::Stream;
    /// True when the noise enters a regressor (so OLS is biased), not only the output.
    const IN_REGRESSORS: bool;
    /// The measured columns of the regression its noise enters.
    const COLUMNS: &'static [Column];
    /// The logged signal its noise is added to, at its SD times its draw (the column of a
    /// log `simulate-log` writes).
    const SIGNAL: Signal;
    /// Its place in the order the channels' terms of Ω are added ([`Channel::OMEGA_ORDER`]:
    /// 0 first; the ranks of the channels are 0, 1, …, one each). Fixed once chosen: the
    /// bounds' and the weighted estimator's bits depend on it; a new channel takes the next.
    const OMEGA_RANK: usize;
    /// True when the vectorised kernel handles the channel.
    const ON_FAST_PATH: bool = false;
    /// True when studies list its levels under [`KEY`](Self::KEY) as a condition axis of
    /// the channels'; false when the study's level axis of that key sets its level (the
    /// air-speed sensor's, whose axis has its own place among the level axes).
    const OWN_AXIS: bool = true;

    /// Move one sample's measured quantities (or those of `L::WIDTH` consecutive samples in
    /// lanes) by its draw `e` ~ N(0, 1) at standard deviation `sd`: the per-sample
    /// arithmetic of its noise, written once for every number type and run by every path
    /// that measures rows (the general path's pass, its scalar tail, the fast path's speed).
    fn measure<L: Lanes>(l: L, x: &mut Sample<L::F64>, sd: f64, e: L::F64);

    /// Whether its noise at SD `sd` moves the sample at all (`false`: its draws are not
    /// read, and the columns it moves stay the regression's own).
    fn moves_at(_sd: f64) -> bool {
        true
    }

    /// Its term of the first-order equation-error variance Ω of u = ỹ − x̃ᵀθ at SD `sd`
    /// (docs/model.md#bounds).
    fn omega_term(sd: f64, at: &OmegaAt) -> f64;

    /// Move the expectations `e` of row `r`'s measured columns by its noise at SD `sd` > 0:
    /// set the moments of the columns it moves, from the noise-free row.
    fn expect(sd: f64, r: &TrueRow, e: &mut ColumnMoments);

    /// The sums `m` corrected for its noise at SD `sd` (docs/model.md#bcls): each sum gets
    /// the expectation it would have without this noise; `g` \[m/s²\] is gravity.
    fn compensate(m: &Moments, sd: f64, g: f64) -> Moments;

    /// Its part of the sandwich's XᵀΣX beyond its Ω terms (`None`: independent across rows,
    /// or off).
    fn row_covariance(
        _reg: &Regression,
        _theta: &[f64; 3],
        _noise: &NoiseLevels,
    ) -> Option<RowCovariance> {
        None
    }

    /// Its terms of the compensated estimating function's variance at a row beyond the
    /// first order (docs/model.md#compensated-sandwich), at SD `sd` > 0 under `noise`;
    /// `x` is the noise-free row. Nothing by default (noise that enters the output only, or
    /// whose second order is not derived).
    fn second_order(_sd: f64, _noise: &NoiseLevels, _at: &OmegaAt, _x: &[f64; 3]) -> SecondOrder {
        SecondOrder::NONE
    }

    /// Per segment of rows, the variance it adds to ỹ beyond its Ω term (`None`: nothing).
    fn derivative_variance(
        _reg: &Regression,
        _noise: &NoiseLevels,
        _segments: &[(usize, usize)],
    ) -> Option<Vec<f64>> {
        None
    }

    /// The correlation time of its noise \[s\] (0: independent draws per sample, or off).
    fn correlation_time_s(_noise: &NoiseLevels) -> f64 {
        0.0
    }

    /// True when a row's equation error carries its draws of neighbouring samples.
    fn enters_neighbours(_noise: &NoiseLevels) -> bool {
        false
    }

    /// Set the terms of row `i`'s expectations `e` that its noise adds through the rows it
    /// shares with its neighbours (nothing when its rows are independent).
    fn expect_shared(
        _reg: &Regression,
        _noise: &NoiseLevels,
        _ar1: Option<&[[f64; 2]]>,
        _i: usize,
        _e: &mut ColumnMoments,
    ) {
    }

    /// The parts of the measured columns its noise moves (docs/model.md#spread-control-variates).
    const PARTS: &'static [Part];

    /// E\[Π pᵏᵖ\] over its noise of its [`PARTS`](Self::PARTS) p at row `r`, raised to the
    /// powers `k` (the others' powers are ignored), under `noise` with it on; `None`: not
    /// derived at these levels (docs/model.md#spread-control-variates).
    fn raw_moment(noise: &NoiseLevels, r: &TrueRow, k: &Powers) -> Option<f64>;

    /// Its part of the covariances of `sums` from distinct rows that share its draws,
    /// Σ_{i≠j} Cov(aᵢ, bⱼ), given every row's moments `rows`; `ar1` the AR(1) coefficients
    /// of correlated speed noise over [`Regression::noise_times`] (`None`: white).
    fn covariance_across_rows(
        _reg: &Regression,
        _noise: &NoiseLevels,
        _ar1: Option<&[[f64; 2]]>,
        _rows: &dyn Fn(usize) -> RowMoments,
        _sums: &[Sum],
    ) -> AcrossRows {
        AcrossRows::Nothing
    }
}

/// The registry: one line per channel, `Variant => its file::its ChannelTerms type` (a doc
/// comment above it is optional), in the order of the study keys, the condition axes (the
/// last varies fastest) and the output columns. Declares the channel's file and generates [`Channel`], [`Channel::ALL`] and the
/// dispatch of every [`ChannelTerms`] item.
macro_rules! channels {
    ($($(#[$doc:meta])* $variant:ident => $module:ident :: $terms:ident,)*) => {
        $(mod $module;)*

        /// An independent noise source of a realisation's measurements. Each has its own
        /// random stream, so switching one on does not change the draws of another.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum Channel {
            $(
                $(#[$doc])*
                #[doc = concat!("\n\nIts terms: `", stringify!($module), "::", stringify!($terms), "`.")]
                $variant,
            )*
        }

        impl Channel {
            /// Every channel, in the order of the study keys, the condition axes (the last
            /// varies fastest) and the output columns.
            pub const ALL: [Channel; [$(Channel::$variant),*].len()] = [$(Channel::$variant),*];

            /// The key under `[noise]` in study files, and the condition column in every
            /// table ([`ChannelTerms::KEY`]).
            pub const fn key(self) -> &'static str {
                match self { $(Channel::$variant => <$module::$terms>::KEY,)* }
            }

            /// Unit of the standard deviation.
            pub const fn unit(self) -> &'static str {
                match self { $(Channel::$variant => <$module::$terms>::UNIT,)* }
            }

            /// What the standard deviation is of.
            pub const fn description(self) -> &'static str {
                match self { $(Channel::$variant => <$module::$terms>::DESCRIPTION,)* }
            }

            /// The levels a study gets when it does not list the key (`None`: required).
            pub const fn default_levels(self) -> Option<&'static [f64]> {
                match self { $(Channel::$variant => <$module::$terms>::DEFAULT_LEVELS,)* }
            }

            /// The channel's part of the ChaCha key of its stream (docs/model.md#streams).
            pub const fn stream(self) -> crate::noise::Stream {
                match self { $(Channel::$variant => <$module::$terms>::STREAM,)* }
            }

            /// True when the channel's noise enters a regressor (so OLS is biased), not
            /// only the output.
            pub const fn in_regressors(self) -> bool {
                match self { $(Channel::$variant => <$module::$terms>::IN_REGRESSORS,)* }
            }

            /// The measured columns of the regression its noise enters (speed noise enters
            /// ỹ as well through a differentiated acceleration: [`NoiseLevels::moves`]).
            pub const fn columns(self) -> &'static [Column] {
                match self { $(Channel::$variant => <$module::$terms>::COLUMNS,)* }
            }

            /// The logged signal its noise is added to ([`ChannelTerms::SIGNAL`]).
            pub const fn signal(self) -> Signal {
                match self { $(Channel::$variant => <$module::$terms>::SIGNAL,)* }
            }

            /// Its place in the order of the terms of Ω ([`ChannelTerms::OMEGA_RANK`]).
            pub const fn omega_rank(self) -> usize {
                match self { $(Channel::$variant => <$module::$terms>::OMEGA_RANK,)* }
            }

            /// True when the vectorised kernel handles the channel.
            pub const fn on_fast_path(self) -> bool {
                match self { $(Channel::$variant => <$module::$terms>::ON_FAST_PATH,)* }
            }

            /// True when studies list its levels as a condition axis of the channels'
            /// ([`ChannelTerms::OWN_AXIS`]).
            pub const fn own_axis(self) -> bool {
                match self { $(Channel::$variant => <$module::$terms>::OWN_AXIS,)* }
            }

            /// Move one sample's measured quantities (or `L::WIDTH` samples' in lanes) by
            /// this channel's draw `e` ~ N(0, 1) at standard deviation `sd`
            /// ([`ChannelTerms::measure`]; docs/model.md#noise-channels).
            #[inline(always)]
            pub fn measure<L: Lanes>(self, l: L, x: &mut Sample<L::F64>, sd: f64, e: L::F64) {
                match self { $(Channel::$variant => <$module::$terms>::measure(l, x, sd, e),)* }
            }

            /// Every channel for which `draw` gives (SD, draw) moves the sample, in the
            /// order of [`Channel::ALL`]: one `if` per channel, not a loop, so that a pass
            /// compiled for a set of channels holds their arithmetic alone.
            #[inline(always)]
            pub fn measure_each<L: Lanes>(
                l: L,
                x: &mut Sample<L::F64>,
                mut draw: impl FnMut(Channel) -> Option<(f64, L::F64)>,
            ) {
                $(if let Some((sd, e)) = draw(Channel::$variant) {
                    <$module::$terms>::measure(l, x, sd, e);
                })*
            }

            /// Whether this channel's noise at SD `sd` moves the samples at all
            /// ([`ChannelTerms::moves_at`]).
            pub fn moves_at(self, sd: f64) -> bool {
                match self { $(Channel::$variant => <$module::$terms>::moves_at(sd),)* }
            }

            /// This channel's term of the first-order equation-error variance Ω at SD `sd`
            /// (docs/model.md#bounds).
            pub fn omega_term(self, sd: f64, at: &OmegaAt) -> f64 {
                match self { $(Channel::$variant => <$module::$terms>::omega_term(sd, at),)* }
            }

            /// Move the expectations `e` of row `r`'s measured columns by this channel's
            /// noise at SD `sd` > 0 (docs/model.md#control-variates). The channels are
            /// independent, so the order does not matter.
            pub fn expect(self, sd: f64, r: &TrueRow, e: &mut ColumnMoments) {
                match self { $(Channel::$variant => <$module::$terms>::expect(sd, r, e),)* }
            }

            /// The sums `m` corrected for this channel's noise at SD `sd`, the other
            /// channels' left as they are (docs/model.md#bcls).
            pub fn compensate(self, m: &Moments, sd: f64, g: f64) -> Moments {
                match self { $(Channel::$variant => <$module::$terms>::compensate(m, sd, g),)* }
            }

            /// This channel's terms of the compensated estimating function's variance at a
            /// row beyond the first order ([`ChannelTerms::second_order`]).
            pub fn second_order(
                self,
                sd: f64,
                noise: &NoiseLevels,
                at: &OmegaAt,
                x: &[f64; 3],
            ) -> SecondOrder {
                match self { $(Channel::$variant => <$module::$terms>::second_order(sd, noise, at, x),)* }
            }

            /// This channel's part of the sandwich's XᵀΣX beyond its Ω terms at the
            /// noise-free rows of `reg` and θ = `theta` (`None`: independent across rows).
            pub fn row_covariance(
                self,
                reg: &Regression,
                theta: &[f64; 3],
                noise: &NoiseLevels,
            ) -> Option<RowCovariance> {
                match self { $(Channel::$variant => <$module::$terms>::row_covariance(reg, theta, noise),)* }
            }

            /// Per segment of rows (`segments`, index ranges of `reg`), the variance this
            /// channel adds to ỹ beyond its Ω term (`None`: nothing).
            pub fn derivative_variance(
                self,
                reg: &Regression,
                noise: &NoiseLevels,
                segments: &[(usize, usize)],
            ) -> Option<Vec<f64>> {
                match self {
                    $(Channel::$variant => <$module::$terms>::derivative_variance(reg, noise, segments),)*
                }
            }

            /// The correlation time of this channel's noise \[s\] under `noise` (0:
            /// independent draws per sample, or off).
            pub fn correlation_time_s(self, noise: &NoiseLevels) -> f64 {
                match self { $(Channel::$variant => <$module::$terms>::correlation_time_s(noise),)* }
            }

            /// True when a row's equation error carries this channel's draws of
            /// neighbouring samples.
            pub fn enters_neighbours(self, noise: &NoiseLevels) -> bool {
                match self { $(Channel::$variant => <$module::$terms>::enters_neighbours(noise),)* }
            }

            /// Set the terms of row `i`'s expectations `e` that this channel's noise adds
            /// through the rows it shares with its neighbours; `ar1` the AR(1) coefficients
            /// of correlated speed noise over [`Regression::noise_times`] (`None`: white).
            pub fn expect_shared(
                self,
                reg: &Regression,
                noise: &NoiseLevels,
                ar1: Option<&[[f64; 2]]>,
                i: usize,
                e: &mut ColumnMoments,
            ) {
                match self {
                    $(Channel::$variant => <$module::$terms>::expect_shared(reg, noise, ar1, i, e),)*
                }
            }

            /// The parts of the measured columns its noise moves.
            pub const fn parts(self) -> &'static [Part] {
                match self { $(Channel::$variant => <$module::$terms>::PARTS,)* }
            }

            /// E\[Π pᵏᵖ\] over this channel's noise of its parts at row `r` (on under
            /// `noise`); `None`: not derived (docs/model.md#spread-control-variates).
            pub fn raw_moment(self, noise: &NoiseLevels, r: &TrueRow, k: &Powers) -> Option<f64> {
                match self { $(Channel::$variant => <$module::$terms>::raw_moment(noise, r, k),)* }
            }

            /// Its part of the covariances of `sums` from distinct rows sharing its draws.
            pub fn covariance_across_rows(
                self,
                reg: &Regression,
                noise: &NoiseLevels,
                ar1: Option<&[[f64; 2]]>,
                rows: &dyn Fn(usize) -> RowMoments,
                sums: &[Sum],
            ) -> AcrossRows {
                match self {
                    $(Channel::$variant =>
                        <$module::$terms>::covariance_across_rows(reg, noise, ar1, rows, sums),)*
                }
            }
        }
    };
}

channels! {
    /// Speed-measurement noise.
    Velocity => velocity::Speed,
    /// Additive noise on the regression output.
    Output => output::OutputNoise,
    /// Noise on the measured grade signal.
    Grade => grade::GradeNoise,
    /// Noise on the measured propulsion force.
    Force => force::ForceNoise,
    /// Noise on a measured air speed (a mobile anemometer's), which the drag regressor
    /// reads in place of the ground speed.
    AirSpeed => air_speed::AirSpeedNoise,
}

/// Number of channels.
pub const CHANNEL_COUNT: usize = Channel::ALL.len();

impl Channel {
    /// Position in [`Channel::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The sensor's own noise channel of `signal`: the first registered whose noise is
    /// added to it ([`ChannelTerms::SIGNAL`]). What the rest of the crate names a channel
    /// by where a path treats one specially (the fast path's speed and output noise, the
    /// AR(1) filter and differentiation of the speed noise, the bounds that read σ_v or
    /// σ_y); a channel registered after it on the same signal is one more source of noise
    /// there, handled by the general path. Every signal has one (a test checks it).
    pub const fn of(signal: Signal) -> Channel {
        let mut i = 0;
        while i < CHANNEL_COUNT {
            let c = Channel::ALL[i];
            if c.signal() as usize == signal as usize {
                return c;
            }
            i += 1;
        }
        panic!("no channel measures the signal")
    }
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
mod tests;
