//! The air-speed sensor's noise \[m/s\] (`noise.air_speed_sd`; `[0]` without it). With a
//! measured air speed it is the noise in the drag regressor: the speed channel's level of
//! the condition, whose own key is then `[0]` (docs/model.md#air-speed).

use super::LevelAxisEntry;
use crate::estimate::channels::{Channel, NoiseLevels, Signal};
use crate::study::{AirSpeed, VehicleStudy};

/// The `[noise]` key of the air-speed sensor's noise.
pub const AIR_SPEED_SD: &str = "air_speed_sd";

/// The speed's channel, whose level the air-speed sensor's takes.
const SPEED: Channel = Channel::of(Signal::Speed);

/// The air-speed sensor's noise.
pub struct AirSpeedNoise;

impl LevelAxisEntry for AirSpeedNoise {
    const KEY: &'static str = AIR_SPEED_SD;
    const UNIT: &'static str = SPEED.unit();

    fn apply(study: &VehicleStudy, level: f64, noise: &mut NoiseLevels) {
        if study.air_speed == AirSpeed::Measured {
            noise[SPEED] = level;
        }
    }
}
