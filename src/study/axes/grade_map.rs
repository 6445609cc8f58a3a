//! The elevation map's error \[m\] (`noise.grade_map_sd`; `[0]`, an exact map, without it):
//! the model draws a map per realisation at a level above 0 (docs/model.md#grade-map).

use super::LevelAxisEntry;

/// The `[noise]` key of the elevation map's error.
pub const GRADE_MAP_SD: &str = "grade_map_sd";

/// The elevation map's error.
pub struct GradeMap;

impl LevelAxisEntry for GradeMap {
    const KEY: &'static str = GRADE_MAP_SD;
    const UNIT: &'static str = "m";
}
