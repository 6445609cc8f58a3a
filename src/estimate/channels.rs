//! The noise channels of the vehicle regression's measurements (docs/model.md#noise-channels).
//!
//! A channel is one variant of [`Channel`]: every property of it — its study key and output
//! column, unit, default, the stream that draws its noise, the measured columns it moves
//! (from which the control variates that vary are derived), how its draw perturbs a
//! measured sample and its term of the equation-error variance Ω (which the bounds and the
//! weighted estimator ask) — is a `match` arm in this file, so the compiler lists every
//! place a new channel needs. The condition axes, the study keys under `[noise]`, the
//! streams and the kernel are derived from [`Channel::ALL`]. Its expectations of the
//! measured columns (`Channel::expect`, which the control variates ask) are here too; BCLS's
//! correction of the sums (`Moments::compensate` in `estimators.rs`, an exhaustive match)
//! is the other place a channel appears, because it is physics, not wiring.

use std::ops::{Index, IndexMut};

use super::sums::Column;

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

/// Where the first-order equation-error variance Ω is evaluated (docs/model.md#bounds): the
/// estimate and the quantities of a row, or of a segment as local means, that the
/// channels' terms read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OmegaAt {
    /// θ = \[1/M, Cd/M, Cr\] at which Ω is evaluated.
    pub theta: [f64; 3],
    /// k of the regression's column 2 (−k w).
    pub k: f64,
    /// V² \[m²/s²\].
    pub v2: f64,
    /// What the grade noise's term is loaded with.
    pub grade: GradeLoading,
}

/// The loading of the grade noise's term of Ω.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GradeLoading {
    /// At a noise-free row: gravity g \[m/s²\] and the slope cos θ − θ₃ sin θ of
    /// d/dθ \[sin θ + θ₃ cos θ\]; the term is (g σ_θ)² slope².
    Row {
        /// Gravity \[m/s²\].
        g: f64,
        /// cos θ − θ₃ sin θ.
        slope: f64,
    },
    /// A local mean of x̃₃² = g² cos² θ̃ \[m²/s⁴\] (the θ₃ sin θ part, below 0.3 % of it,
    /// left out); the term is σ_θ² times it.
    MeanSquare(f64),
}

impl Channel {
    /// The channels in the order their terms of Ω are added (fixed: the bounds' and the
    /// weighted estimator's bits depend on it).
    pub const OMEGA_ORDER: [Channel; CHANNEL_COUNT] = [
        Channel::Velocity,
        Channel::Force,
        Channel::Grade,
        Channel::Output,
    ];

    /// This channel's term of the first-order equation-error variance Ω of u = ỹ − x̃ᵀθ at
    /// SD `sd` (docs/model.md#bounds).
    ///
    /// Speed: Ṽ² − V² = 2Ve + e² has variance 4V²σ² + 2σ⁴ and enters through −kθ₂.
    /// Force: (F̃ − F)θ₁. Grade: d/dθ \[g sin θ + θ₃ g cos θ\] = g (cos θ − θ₃ sin θ).
    /// Output: σ_y².
    pub fn omega_term(self, sd: f64, at: &OmegaAt) -> f64 {
        match self {
            Channel::Velocity => {
                let s2 = sd.powi(2);
                (at.theta[1] * at.k).powi(2) * (4.0 * at.v2 * s2 + 2.0 * s2 * s2)
            }
            Channel::Force => (at.theta[0] * sd).powi(2),
            Channel::Grade => match at.grade {
                GradeLoading::Row { g, slope } => (g * sd).powi(2) * slope * slope,
                GradeLoading::MeanSquare(c2) => sd.powi(2) * c2,
            },
            Channel::Output => sd.powi(2),
        }
    }
}

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
    /// otherwise; the caller sets it from the AR(1) coefficients).
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
pub(crate) fn grade_moments(sin: f64, cos: f64, sd: f64) -> [f64; 4] {
    let rho = (-0.5 * sd * sd).exp();
    let rho4 = (-2.0 * sd * sd).exp();
    [
        rho * cos,
        0.5 * (cos * cos * (1.0 + rho4) + sin * sin * (1.0 - rho4)),
        rho * sin,
        rho4 * sin * cos,
    ]
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

    /// Ω at `at`: every channel's [`Channel::omega_term`], added in
    /// [`Channel::OMEGA_ORDER`].
    pub fn omega(&self, at: &OmegaAt) -> f64 {
        Channel::OMEGA_ORDER
            .iter()
            .fold(0.0, |total, &c| total + c.omega_term(self[c], at))
    }

    /// Whether a channel that is on moves `column` (so that the sums with it as a factor
    /// vary): the columns of [`Channel::columns`], and ỹ under speed noise through a
    /// differentiated acceleration.
    pub fn moves(&self, column: Column) -> bool {
        self.iter()
            .any(|(c, &sd)| sd > 0.0 && c.columns().contains(&column))
            || (column == Column::Y && self.speed_noise_differentiated())
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
