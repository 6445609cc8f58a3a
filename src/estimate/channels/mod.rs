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
//! - `velocity.rs`, `output.rs`, `grade.rs`, `force.rs`: the channels;
//! - `omega.rs`: what Ω and the sandwich's off-diagonal part are evaluated at, and the
//!   order the channels' Ω terms are added in ([`Channel::OMEGA_ORDER`]);
//! - `covariance.rs`: the exact covariances of the sums, from each channel's moments of
//!   the parts it moves, for the spread's control variates;
//! - `expect.rs`: the noise-free row and the expectations the control variates centre
//!   the sums with;
//! - `levels.rs`: [`NoiseLevels`], a condition's levels, and what follows from them.

use std::ops::{Index, IndexMut};

use super::moments::Moments;
use super::regression::Regression;
use super::sums::{Column, Sum};
use crate::noise::BLOCK;

mod covariance;
mod expect;
mod force;
mod grade;
mod levels;
mod omega;
mod output;
mod velocity;

pub use covariance::{
    AcrossRows, Part, Powers, RowMoments, SumCovariances, packed, sum_covariances,
};
pub use expect::{ColumnMoments, TrueRow};
pub use levels::{Acceleration, NoiseLevels};
pub use omega::{GradeLoading, OmegaAt, RowCovariance, SecondOrder};

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
    /// True when the vectorised kernel handles the channel.
    const ON_FAST_PATH: bool = false;

    /// Apply the draws `e` ~ N(0, 1) at standard deviation `sd` to a block of measured
    /// samples (`e[j]` to sample j; as many draws as samples), column by column so that
    /// the loop vectorises.
    fn perturb(s: &mut Samples, sd: f64, e: &[f64]);

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

/// The registry: one line per channel, `Variant => its ChannelTerms type`, in the order of
/// the study keys, the condition axes (the last varies fastest), the output columns and the
/// streams' listing. Generates [`Channel`], [`Channel::ALL`] and the dispatch of every
/// [`ChannelTerms`] item.
macro_rules! channels {
    ($($(#[$doc:meta])* $variant:ident => $terms:ty,)*) => {
        /// An independent noise source of a realisation's measurements. Each has its own
        /// random stream, so switching one on does not change the draws of another.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum Channel {
            $($(#[$doc])* $variant,)*
        }

        impl Channel {
            /// Every channel, in the order of the study keys, the condition axes (the last
            /// varies fastest) and the output columns.
            pub const ALL: [Channel; [$(Channel::$variant),*].len()] = [$(Channel::$variant),*];

            /// The key under `[noise]` in study files, and the condition column in every
            /// table ([`ChannelTerms::KEY`]).
            pub const fn key(self) -> &'static str {
                match self { $(Channel::$variant => <$terms>::KEY,)* }
            }

            /// Unit of the standard deviation.
            pub const fn unit(self) -> &'static str {
                match self { $(Channel::$variant => <$terms>::UNIT,)* }
            }

            /// What the standard deviation is of.
            pub const fn description(self) -> &'static str {
                match self { $(Channel::$variant => <$terms>::DESCRIPTION,)* }
            }

            /// The levels a study gets when it does not list the key (`None`: required).
            pub const fn default_levels(self) -> Option<&'static [f64]> {
                match self { $(Channel::$variant => <$terms>::DEFAULT_LEVELS,)* }
            }

            /// The channel's part of the ChaCha key of its stream (docs/model.md#streams).
            pub const fn stream(self) -> crate::noise::Stream {
                match self { $(Channel::$variant => <$terms>::STREAM,)* }
            }

            /// True when the channel's noise enters a regressor (so OLS is biased), not
            /// only the output.
            pub const fn in_regressors(self) -> bool {
                match self { $(Channel::$variant => <$terms>::IN_REGRESSORS,)* }
            }

            /// The measured columns of the regression its noise enters (speed noise enters
            /// ỹ as well through a differentiated acceleration: [`NoiseLevels::moves`]).
            pub const fn columns(self) -> &'static [Column] {
                match self { $(Channel::$variant => <$terms>::COLUMNS,)* }
            }

            /// True when the vectorised kernel handles the channel.
            pub const fn on_fast_path(self) -> bool {
                match self { $(Channel::$variant => <$terms>::ON_FAST_PATH,)* }
            }

            /// Apply this channel's draws `e` ~ N(0, 1) at standard deviation `sd` to a
            /// block of measured samples (the general kernel; see
            /// docs/model.md#noise-channels).
            #[inline(always)]
            pub fn perturb(self, s: &mut Samples, sd: f64, e: &[f64]) {
                match self { $(Channel::$variant => <$terms>::perturb(s, sd, e),)* }
            }

            /// This channel's term of the first-order equation-error variance Ω at SD `sd`
            /// (docs/model.md#bounds).
            pub fn omega_term(self, sd: f64, at: &OmegaAt) -> f64 {
                match self { $(Channel::$variant => <$terms>::omega_term(sd, at),)* }
            }

            /// Move the expectations `e` of row `r`'s measured columns by this channel's
            /// noise at SD `sd` > 0 (docs/model.md#control-variates). The channels are
            /// independent, so the order does not matter.
            pub fn expect(self, sd: f64, r: &TrueRow, e: &mut ColumnMoments) {
                match self { $(Channel::$variant => <$terms>::expect(sd, r, e),)* }
            }

            /// The sums `m` corrected for this channel's noise at SD `sd`, the other
            /// channels' left as they are (docs/model.md#bcls).
            pub fn compensate(self, m: &Moments, sd: f64, g: f64) -> Moments {
                match self { $(Channel::$variant => <$terms>::compensate(m, sd, g),)* }
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
                match self { $(Channel::$variant => <$terms>::second_order(sd, noise, at, x),)* }
            }

            /// This channel's part of the sandwich's XᵀΣX beyond its Ω terms at the
            /// noise-free rows of `reg` and θ = `theta` (`None`: independent across rows).
            pub fn row_covariance(
                self,
                reg: &Regression,
                theta: &[f64; 3],
                noise: &NoiseLevels,
            ) -> Option<RowCovariance> {
                match self { $(Channel::$variant => <$terms>::row_covariance(reg, theta, noise),)* }
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
                    $(Channel::$variant => <$terms>::derivative_variance(reg, noise, segments),)*
                }
            }

            /// The correlation time of this channel's noise \[s\] under `noise` (0:
            /// independent draws per sample, or off).
            pub fn correlation_time_s(self, noise: &NoiseLevels) -> f64 {
                match self { $(Channel::$variant => <$terms>::correlation_time_s(noise),)* }
            }

            /// True when a row's equation error carries this channel's draws of
            /// neighbouring samples.
            pub fn enters_neighbours(self, noise: &NoiseLevels) -> bool {
                match self { $(Channel::$variant => <$terms>::enters_neighbours(noise),)* }
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
                    $(Channel::$variant => <$terms>::expect_shared(reg, noise, ar1, i, e),)*
                }
            }

            /// The parts of the measured columns its noise moves.
            pub const fn parts(self) -> &'static [Part] {
                match self { $(Channel::$variant => <$terms>::PARTS,)* }
            }

            /// E\[Π pᵏᵖ\] over this channel's noise of its parts at row `r` (on under
            /// `noise`); `None`: not derived (docs/model.md#spread-control-variates).
            pub fn raw_moment(self, noise: &NoiseLevels, r: &TrueRow, k: &Powers) -> Option<f64> {
                match self { $(Channel::$variant => <$terms>::raw_moment(noise, r, k),)* }
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
                        <$terms>::covariance_across_rows(reg, noise, ar1, rows, sums),)*
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
}

/// Number of channels.
pub const CHANNEL_COUNT: usize = Channel::ALL.len();

impl Channel {
    /// Position in [`Channel::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }
}

/// A measured quantity of a sample that a channel's noise moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// The propulsion force \[N\].
    Force,
    /// The speed \[m/s\].
    Speed,
    /// sin of the grade.
    SinGrade,
    /// cos of the grade.
    CosGrade,
    /// The noise added to the output \[m/s²\] (none: 0).
    OutputNoise,
}

/// Number of [`Quantity`] variants.
const QUANTITIES: usize = 5;

/// The columns of a block of samples that the channels' noise moved, with room for each
/// (memory a kernel keeps from block to block).
#[derive(Debug, Clone, PartialEq)]
pub struct SampleColumns {
    moved: [bool; QUANTITIES],
    data: [[f64; BLOCK]; QUANTITIES],
    /// Scratch for a channel's work on a block.
    pub scratch: [[f64; BLOCK]; 3],
}

impl SampleColumns {
    /// The first `len` measured values of `q` when a channel moved it in the last block.
    pub fn moved(&self, q: Quantity, len: usize) -> Option<&[f64]> {
        self.moved[q as usize].then(|| &self.data[q as usize][..len])
    }

    /// Start a block measured without [`Samples`] (the general kernel's one pass): nothing
    /// moved yet.
    pub fn clear(&mut self) {
        self.moved = [false; QUANTITIES];
    }

    /// The column to write the measured values of `q` to, recording whether a channel
    /// moved it (`false`: the column is scratch, and the noise-free values stand).
    pub fn write(&mut self, q: Quantity, moved: bool) -> &mut [f64; BLOCK] {
        self.moved[q as usize] = moved;
        &mut self.data[q as usize]
    }
}

impl Default for SampleColumns {
    fn default() -> Self {
        SampleColumns {
            moved: [false; QUANTITIES],
            data: [[0.0; BLOCK]; QUANTITIES],
            scratch: [[0.0; BLOCK]; 3],
        }
    }
}

/// A block of measured samples of the cycle as the general kernel builds them, quantity by
/// quantity: samples `start .. start + len` of a regression, each quantity the
/// regression's noise-free one until a channel's [`Channel::perturb`] moves it (each
/// quantity is moved by one channel: [`ChannelTerms::COLUMNS`] are disjoint).
#[derive(Debug)]
pub struct Samples<'a> {
    reg: &'a Regression,
    start: usize,
    len: usize,
    columns: &'a mut SampleColumns,
}

impl<'a> Samples<'a> {
    /// Samples `start .. start + len` of `reg` (`len` ≤ [`BLOCK`]), none moved yet.
    pub fn new(
        reg: &'a Regression,
        start: usize,
        len: usize,
        columns: &'a mut SampleColumns,
    ) -> Self {
        columns.moved = [false; QUANTITIES];
        Samples {
            reg,
            start,
            len,
            columns,
        }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The noise-free values of `q` (the regression's; no noise: zeros).
    fn noise_free(&self, q: Quantity) -> &'a [f64] {
        let range = self.start..self.start + self.len;
        let reg: &'a Regression = self.reg;
        match q {
            Quantity::Force => &reg.f[range],
            Quantity::Speed => &reg.v[range],
            Quantity::SinGrade => &reg.sin_grade[range],
            Quantity::CosGrade => &reg.cos_grade[range],
            Quantity::OutputNoise => &ZEROS[..self.len],
        }
    }

    /// The measured values of `q`: moved by a channel, or the noise-free ones.
    pub fn get(&self, q: Quantity) -> &[f64] {
        match self.columns.moved[q as usize] {
            true => &self.columns.data[q as usize][..self.len],
            false => self.noise_free(q),
        }
    }

    /// Whether a channel moved `q`.
    pub fn moved(&self, q: Quantity) -> bool {
        self.columns.moved[q as usize]
    }

    /// Move `q`: its noise-free values, and the column its measured values are written to.
    pub fn moving(&mut self, q: Quantity) -> (&'a [f64], &mut [f64]) {
        debug_assert!(!self.moved(q), "{q:?} moved by two channels");
        self.columns.moved[q as usize] = true;
        (
            self.noise_free(q),
            &mut self.columns.data[q as usize][..self.len],
        )
    }

    /// Move the grade's sin and cos together: their noise-free values, their columns, and
    /// the scratch columns.
    #[allow(clippy::type_complexity)]
    pub fn moving_grade(&mut self) -> ([&'a [f64]; 2], [&mut [f64]; 2], &mut [[f64; BLOCK]; 3]) {
        let base = [
            self.noise_free(Quantity::SinGrade),
            self.noise_free(Quantity::CosGrade),
        ];
        for q in [Quantity::SinGrade, Quantity::CosGrade] {
            debug_assert!(!self.moved(q), "{q:?} moved by two channels");
            self.columns.moved[q as usize] = true;
        }
        let n = self.len;
        let [_, _, sin, cos, _] = &mut self.columns.data;
        (
            base,
            [&mut sin[..n], &mut cos[..n]],
            &mut self.columns.scratch,
        )
    }
}

/// Zeros: the output noise of a block without it.
static ZEROS: [f64; BLOCK] = [0.0; BLOCK];

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
    fn a_zero_draw_leaves_the_samples_unchanged() {
        let reg = crate::estimate::regression::test_regression();
        let quantities = [
            Quantity::Force,
            Quantity::Speed,
            Quantity::SinGrade,
            Quantity::CosGrade,
            Quantity::OutputNoise,
        ];
        let mut columns = SampleColumns::default();
        for c in Channel::ALL {
            let mut s = Samples::new(&reg, 100, 37, &mut columns);
            let before: Vec<Vec<f64>> = quantities.iter().map(|&q| s.get(q).to_vec()).collect();
            c.perturb(&mut s, 0.0, &[0.0; 37]);
            let after: Vec<Vec<f64>> = quantities.iter().map(|&q| s.get(q).to_vec()).collect();
            assert_eq!(after, before, "{c:?}");
        }
    }
}
