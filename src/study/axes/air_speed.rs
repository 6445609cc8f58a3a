//! The air-speed sensor's noise \[m/s\] (`noise.air_speed_sd`; `[0]` without it). With a
//! measured air speed it is the noise in the drag regressor: the speed channel's level of
//! the condition, whose own key is then `[0]` (docs/model.md#air-speed).

use super::LevelAxisEntry;
use crate::estimate::channels::{Channel, NoiseLevels, Signal};

/// The `[noise]` key of the air-speed sensor's noise.
pub const AIR_SPEED_SD: &str = "air_speed_sd";

/// The speed's channel, whose level the air-speed sensor's takes.
const SPEED: Channel = Channel::of(Signal::Speed);

/// The air-speed sensor's noise.
pub struct AirSpeedNoise;

impl LevelAxisEntry for AirSpeedNoise {
    const KEY: &'static str = AIR_SPEED_SD;
    const UNIT: &'static str = SPEED.unit();

    /// A level above 0 is the speed channel's: the study checks that it comes only with
    /// `estimation.air_speed = "measured"`, and then with the speed's own level 0.
    fn apply(level: f64, noise: &mut NoiseLevels) {
        if level > 0.0 {
            noise[SPEED] = level;
        }
    }
}
