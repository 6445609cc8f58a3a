//! The correlation time of the speed noise \[s\] (`noise.velocity_correlation_time`; `[0]`,
//! white noise, without it; docs/model.md#correlated-speed-noise).

use super::LevelAxisEntry;
use crate::estimate::channels::NoiseLevels;

/// The `[noise]` key of the speed noise's correlation time.
pub(in crate::study) const VELOCITY_CORRELATION: &str = "velocity_correlation_time";

/// The speed noise's correlation time.
pub struct VelocityCorrelation;

impl LevelAxisEntry for VelocityCorrelation {
    const KEY: &'static str = VELOCITY_CORRELATION;
    const UNIT: &'static str = "s";

    fn apply(level: f64, noise: &mut NoiseLevels) {
        noise.velocity_correlation_s = level;
    }
}
