//! A constant offset of the measured grade \[rad\] (`noise.grade_bias`; `[0]` without it):
//! the model prepares a regression per level.

use super::LevelAxisEntry;
use crate::study::StudyError;
use crate::study::checker::Checker;

/// The grade sensor's constant offset.
pub struct GradeBias;

impl LevelAxisEntry for GradeBias {
    const KEY: &'static str = "grade_bias";
    const UNIT: &'static str = "rad";

    /// An offset of either sign.
    fn check(c: &Checker<'_>, key: &str, level: f64) -> Result<f64, StudyError> {
        c.finite(key, level)
    }
}
