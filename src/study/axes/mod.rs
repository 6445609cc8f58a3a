//! The condition axes a vehicle study lists as plain levels in `[noise]`, one entry each: a
//! [`LevelAxisEntry`] in its own file (its key, unit, levels without the key, the check of
//! a level, and what a level does to a condition's noise), and one line of
//! `level_axes!` below. The study reads each entry's levels into [`LevelAxes`]; a
//! condition holds the index of its level on every axis, and the model's axis list, its
//! columns and every consumer read them by [`LevelAxis`] (docs/model.md#condition-axes).

use std::ops::Index;

use super::StudyError;
use super::checker::Checker;
use super::raw::RawNoise;
use crate::estimate::channels::NoiseLevels;

pub use air_speed::AIR_SPEED_SD;
pub use grade_map::GRADE_MAP_SD;
pub(super) use velocity_correlation::VELOCITY_CORRELATION;

/// A condition axis whose levels are a list of numbers under one `[noise]` key.
pub(in crate::study) trait LevelAxisEntry {
    /// The `[noise]` key, also the axis column's name.
    const KEY: &'static str;
    /// The unit of a level (the column's).
    const UNIT: &'static str;
    /// The one level of a study without the key.
    const DEFAULT: f64 = 0.0;

    /// Check one level, named `key` in an error (by default: a number ≥ 0).
    fn check(c: &Checker<'_>, key: &str, level: f64) -> Result<f64, StudyError> {
        c.non_negative(key, level)
    }

    /// What the level does to a condition's noise levels (by default nothing: its
    /// consumer reads the level by its [`LevelAxis`]).
    fn apply(_level: f64, _noise: &mut NoiseLevels) {}
}

macro_rules! level_axes {
    ($($module:ident :: $entry:ident),* $(,)?) => {
        $(mod $module;)*

        /// A condition axis of a `LevelAxisEntry`, in the order of the registry.
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub enum LevelAxis {
            $(
                #[doc = concat!("The axis of `", stringify!($module), "::", stringify!($entry), "`.")]
                $entry,
            )*
        }

        impl LevelAxis {
            /// Every level axis, in the registry's order.
            pub const ALL: [LevelAxis; LEVEL_AXIS_COUNT] = [$(LevelAxis::$entry),*];

            /// The `[noise]` key, also the axis column's name.
            pub fn key(self) -> &'static str {
                match self { $(LevelAxis::$entry => <$module::$entry>::KEY,)* }
            }

            /// The unit of a level.
            pub fn unit(self) -> &'static str {
                match self { $(LevelAxis::$entry => <$module::$entry>::UNIT,)* }
            }

            fn default_level(self) -> f64 {
                match self { $(LevelAxis::$entry => <$module::$entry>::DEFAULT,)* }
            }

            fn check(self, c: &Checker<'_>, key: &str, level: f64) -> Result<f64, StudyError> {
                match self { $(LevelAxis::$entry => <$module::$entry>::check(c, key, level),)* }
            }

            /// What `level` does to a condition's noise levels.
            pub fn apply(self, level: f64, noise: &mut NoiseLevels) {
                match self { $(LevelAxis::$entry => <$module::$entry>::apply(level, noise),)* }
            }
        }

        /// Number of level axes.
        pub const LEVEL_AXIS_COUNT: usize = [$(stringify!($entry)),*].len();
    };
}

level_axes! {
    velocity_correlation::VelocityCorrelation,
    grade_bias::GradeBias,
    grade_map::GradeMap,
    air_speed::AirSpeedNoise,
}

/// Each level axis's levels in a study (each list non-empty).
#[derive(Debug, Clone, PartialEq)]
pub struct LevelAxes([Vec<f64>; LEVEL_AXIS_COUNT]);

impl LevelAxes {
    /// One level per axis, its default (a study without the keys, such as a fit's).
    pub fn defaults() -> Self {
        LevelAxes(LevelAxis::ALL.map(|a| vec![a.default_level()]))
    }

    /// These levels with `axis`'s replaced by `levels` (non-empty).
    pub fn with(mut self, axis: LevelAxis, levels: Vec<f64>) -> Self {
        assert!(!levels.is_empty(), "an axis has at least one level");
        self.0[axis as usize] = levels;
        self
    }

    /// The levels of every axis under its key of `[noise]`, or its default.
    pub(super) fn read(n: &RawNoise, c: &Checker<'_>) -> Result<Self, StudyError> {
        let mut levels = Self::defaults();
        for axis in LevelAxis::ALL {
            if let Some(value) = n.0.get(axis.key()) {
                let key = format!("noise.{}", axis.key());
                let check = |c: &Checker<'_>, k: &str, v: f64| axis.check(c, k, v);
                levels.0[axis as usize] = c.list(&key, &c.numbers(&key, value)?, check)?;
            }
        }
        Ok(levels)
    }
}

impl Index<LevelAxis> for LevelAxes {
    type Output = [f64];

    fn index(&self, axis: LevelAxis) -> &[f64] {
        &self.0[axis as usize]
    }
}
