//! The air-speed sensor's noise \[m/s\] (`noise.air_speed_sd`; `[0]` without it): the level of
//! the air-speed channel, which the drag regressor reads with `estimation.air_speed =
//! "measured"` (docs/model.md#air-speed). Its axis nests inside the map's error.

use super::LevelAxisEntry;
use crate::estimate::channels::{Channel, NoiseLevels, Signal};

/// The air-speed sensor's channel.
const AIR_SPEED: Channel = Channel::of(Signal::AirSpeed);

/// The `[noise]` key of the air-speed sensor's noise (its channel's key).
pub const AIR_SPEED_SD: &str = AIR_SPEED.key();

/// The air-speed sensor's noise.
pub struct AirSpeedNoise;

impl LevelAxisEntry for AirSpeedNoise {
    const KEY: &'static str = AIR_SPEED_SD;
    const UNIT: &'static str = AIR_SPEED.unit();

    /// The air-speed channel's level (the study checks that a level above 0 comes only
    /// with `estimation.air_speed = "measured"`, and then with the speed sensor's level 0).
    fn apply(level: f64, noise: &mut NoiseLevels) {
        noise[AIR_SPEED] = level;
    }
}
