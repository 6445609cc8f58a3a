//! The signals a vehicle's sensors record ([`Signal`]) and one sample's measured quantities
//! ([`Sample`]), which the channels' `measure` move (docs/model.md#noise-channels).

#[cfg(doc)]
use super::ChannelTerms;

/// A signal of a vehicle's log, as a sensor records it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Signal {
    /// The speed \[m/s\].
    Speed,
    /// The propulsion force \[N\].
    Force,
    /// The grade angle \[rad\].
    Grade,
    /// The acceleration \[m/s²\] (an accelerometer's).
    Acceleration,
    /// The air speed \[m/s\] (a mobile anemometer's): the speed the drag regressor reads
    /// where it is measured (docs/model.md#air-speed).
    AirSpeed,
}

impl Signal {
    /// Every signal: a log's columns after the time, in order, then the air speed (which
    /// no log holds).
    pub const ALL: [Signal; 5] = [
        Signal::Speed,
        Signal::Force,
        Signal::Grade,
        Signal::Acceleration,
        Signal::AirSpeed,
    ];

    /// The signals a log holds, its columns after the time in order.
    pub const LOGGED: [Signal; 4] = [
        Signal::Speed,
        Signal::Force,
        Signal::Grade,
        Signal::Acceleration,
    ];
}

/// One sample's measured quantities in the number type `R` (one sample, or lanes of
/// consecutive samples), as the channels' [`ChannelTerms::measure`] move them from the
/// noise-free ones (docs/model.md#noise-channels).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample<R> {
    /// The propulsion force x̃₁ \[N\].
    pub force: R,
    /// The speed Ṽ \[m/s\].
    pub speed: R,
    /// x̃₃ = −g cos θ̃ \[m/s²\] (the noise-free one until a channel moves the grade).
    pub c: R,
    /// The grade term s̃ = g sin θ̃ of the output \[m/s²\] (likewise).
    pub s: R,
    /// The noise added to the output \[m/s²\] (`None`: none).
    pub output_noise: Option<R>,
}
