//! A condition's noise levels: a standard deviation per channel, the correlation time of
//! the speed noise and the source of the acceleration in ỹ.

use std::ops::{Index, IndexMut};

use super::covariance::holder;
use super::{Channel, OmegaAt, Part, PerChannel, Signal};
use crate::estimate::sums::Column;

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
        self.acceleration == Acceleration::Differentiated && self.measures_noisy(Signal::Speed)
    }

    /// True when the rows' equation errors are independent: no channel's noise is shared
    /// between rows ([`Channel::shares_rows`]; for speed noise: neither correlated nor
    /// differentiated).
    pub fn independent_rows(&self) -> bool {
        !Channel::ALL.iter().any(|c| c.shares_rows(self))
    }

    /// True when the noise in w (the speed sensor's or the air-speed sensor's:
    /// [`speed_channel`](Self::speed_channel)) is on and correlated in time.
    pub fn velocity_correlated(&self) -> bool {
        self.speed_sd() > 0.0 && self.velocity_correlation_s > 0.0
    }

    /// The channel of the speed the drag regressor reads, whose noise is in w = Ṽ²: the
    /// holder of the part w (the first channel that is on among those that move it — the
    /// air-speed sensor's, where the air speed is measured — else the speed sensor's). What
    /// the paths that treat the noise in w specially ask (the fast path's sums, the AR(1)
    /// filter, the thesis bound, `wbcls`, the first-order bias of OLS).
    pub fn speed_channel(&self) -> Channel {
        holder(Part::W, self)
    }

    /// The standard deviation of the noise in w \[m/s\] ([`speed_channel`](Self::speed_channel)'s).
    pub fn speed_sd(&self) -> f64 {
        self[self.speed_channel()]
    }

    /// Whether `channel` is on.
    pub fn is_on(&self, channel: Channel) -> bool {
        self[channel] > 0.0
    }

    /// The standard deviation of the noise on `signal` ([`Channel::of`]), in its channel's
    /// unit.
    pub fn sd_of(&self, signal: Signal) -> f64 {
        self[Channel::of(signal)]
    }

    /// Whether `signal` carries noise ([`Channel::of`]).
    pub fn measures_noisy(&self, signal: Signal) -> bool {
        self.is_on(Channel::of(signal))
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
        self.measures_noisy(Signal::Acceleration) && !self.in_regressors()
    }

    /// True when every channel that is on is handled by the vectorised kernel: the
    /// regressors x̃₁ and x̃₃ stay noise-free, and the output's noise is the output channel's
    /// and a differentiated acceleration's.
    pub fn fast_path(&self) -> bool {
        self.iter().all(|(c, &sd)| c.on_fast_path() || sd == 0.0)
    }
}
