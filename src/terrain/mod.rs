//! Road terrain: the elevation profile, its grade table and the terrain-variability metric.
//!
//! The thesis builds the road on a 1 m grid, takes the grade by forward Euler
//! (`θ_i = atan(y_{i+1} − y_i)`) and scales the terrain by multiplying the **grade**
//! (`w1 = w1_1 .* a`). Scaling the elevation instead (`θ_i = atan(a (y_{i+1} − y_i))`) is an
//! option. Its variability metric ς is the mean of θ² (thesis eq. 43). The elevation comes
//! from a [`Profile`]: the thesis's cos² hill or another entry of [`profiles::PROFILES`].

pub mod profiles;

use std::sync::Arc;

use crate::numeric::sum::exact_sum;
use crate::settings::{KeyError, Params};
pub use profiles::Profile;

/// Grid spacing of the terrain tables \[m\] (the thesis's `x = (0:50000)'`).
pub const GRID_STEP_M: f64 = 1.0;

/// Largest grade magnitude a terrain table may have \[rad\] (≈ 29°, a 55 % slope, far
/// beyond any road): a larger one means a scale or profile typo, and grades of tens of
/// radians would wrap through sin and cos into plausible-looking nonsense.
pub const MAX_GRADE_RAD: f64 = 0.5;

/// What a terrain scale factor multiplies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScaleTarget {
    /// θ_i = a · atan(Δy_i): the thesis code.
    Grade,
    /// θ_i = atan(a · Δy_i): a geometrically scaled road.
    Elevation,
}

impl ScaleTarget {
    /// The name used in study files.
    pub fn name(self) -> &'static str {
        match self {
            ScaleTarget::Grade => "grade",
            ScaleTarget::Elevation => "elevation",
        }
    }
}

/// Unit of a grade column in a data file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GradeUnit {
    /// The angle in radians.
    Rad,
    /// Rise over run; θ = atan(g).
    Fraction,
    /// 100 × rise over run; θ = atan(p / 100).
    Percent,
}

impl GradeUnit {
    /// Every unit, as study files name them.
    pub const ALL: [(&'static str, GradeUnit); 3] = [
        ("rad", GradeUnit::Rad),
        ("fraction", GradeUnit::Fraction),
        ("percent", GradeUnit::Percent),
    ];

    /// A grade in this unit, as an angle \[rad\].
    pub fn to_rad(self, g: f64) -> f64 {
        match self {
            GradeUnit::Rad => g,
            GradeUnit::Fraction => g.atan(),
            GradeUnit::Percent => (g / 100.0).atan(),
        }
    }

    /// Read `key` of `p` as a grade unit.
    pub fn parse(p: &Params<'_>, key: &str) -> Result<GradeUnit, KeyError> {
        p.named(key, &Self::ALL)
    }
}

/// A road: its elevation profile on a 1 m grid `x = 0 … length`, and what a scale factor
/// multiplies.
#[derive(Debug, Clone)]
pub struct TerrainSpec {
    /// The elevation profile (one of [`profiles::PROFILES`]).
    pub profile: Arc<dyn Profile>,
    /// Length L of the road \[m\]; the grade table has L entries.
    pub length_m: usize,
    /// What the scale factor multiplies.
    pub scale_applies_to: ScaleTarget,
}

impl TerrainSpec {
    /// The grade table of this profile at terrain scale `scale`.
    pub fn grade_table(&self, scale: f64) -> GradeTable {
        let grade_rad = self
            .profile
            .rises_m(self.length_m)
            .into_iter()
            .map(|rise| match self.scale_applies_to {
                ScaleTarget::Grade => scale * (rise / GRID_STEP_M).atan(),
                ScaleTarget::Elevation => (scale * rise / GRID_STEP_M).atan(),
            })
            .collect();
        GradeTable { grade_rad }
    }
}

/// Road grade θ_i \[rad\] at grid points x_i = i m, i = 0 … L−1.
#[derive(Debug, Clone, PartialEq)]
pub struct GradeTable {
    grade_rad: Vec<f64>,
}

impl GradeTable {
    /// A table from explicit grades \[rad\] at x = 0, 1, … m (at least two points).
    pub fn from_grades(grade_rad: Vec<f64>) -> Self {
        assert!(grade_rad.len() >= 2, "a grade table needs two points");
        GradeTable { grade_rad }
    }

    /// The grades \[rad\], one per grid point.
    pub fn grades(&self) -> &[f64] {
        &self.grade_rad
    }

    /// Position of the last grid point \[m\]; beyond it the vehicle has run off the table.
    pub fn end_m(&self) -> f64 {
        (self.grade_rad.len() - 1) as f64 * GRID_STEP_M
    }

    /// Grade \[rad\] at position `x_m` by linear interpolation, clamped below x = 0;
    /// `None` beyond the end of the table.
    #[inline]
    pub fn grade_at(&self, x_m: f64) -> Option<f64> {
        let u = x_m / GRID_STEP_M;
        if u <= 0.0 {
            return Some(self.grade_rad[0]);
        }
        let last = self.grade_rad.len() - 1;
        if u.is_nan() || u > last as f64 {
            return None;
        }
        // u > 0 here: truncation is its floor.
        let i = (u as usize).min(last - 1);
        let f = u - i as f64;
        Some(self.grade_rad[i] + f * (self.grade_rad[i + 1] - self.grade_rad[i]))
    }

    /// The grade of largest magnitude and its position \[m\], if it reaches
    /// [`MAX_GRADE_RAD`] (or is not a number).
    pub fn steepest_beyond_limit(&self) -> Option<(f64, f64)> {
        let mut steepest = 0;
        for (i, g) in self.grade_rad.iter().enumerate() {
            if g.is_nan() {
                return Some((*g, i as f64 * GRID_STEP_M));
            }
            if g.abs() > self.grade_rad[steepest].abs() {
                steepest = i;
            }
        }
        let g = self.grade_rad[steepest];
        (g.abs() >= MAX_GRADE_RAD).then_some((g, steepest as f64 * GRID_STEP_M))
    }

    /// Terrain variability over the table, ς = mean of θ² over all grid points \[rad²\]
    /// (the thesis code's `rgm = mean(w1.^2)`), from an exactly rounded sum.
    pub fn mean_square(&self) -> f64 {
        mean_square(&self.grade_rad)
    }
}

/// Mean of squares of `values` (ς of thesis eq. 43 when the values are grades) \[rad²\].
pub fn mean_square(values: &[f64]) -> f64 {
    exact_sum(values.iter().map(|v| v * v)) / values.len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    fn thesis_terrain() -> TerrainSpec {
        TerrainSpec {
            profile: Arc::new(profiles::Cos2 {
                height_m: 25.0,
                period_m: 300.0,
            }),
            length_m: 50_000,
            scale_applies_to: ScaleTarget::Grade,
        }
    }

    #[test]
    fn interpolation_is_linear_clamped_below_and_ends_at_the_table() {
        let t = GradeTable::from_grades(vec![0.0, 0.1, 0.3]);
        assert_eq!(t.grade_at(-5.0), Some(0.0));
        assert_eq!(t.grade_at(0.5), Some(0.05));
        assert!((t.grade_at(1.25).unwrap() - 0.15).abs() < 1e-15);
        assert_eq!(t.grade_at(2.0), Some(0.3));
        assert_eq!(t.grade_at(2.0001), None);
        assert_eq!(t.grade_at(f64::NAN), None);
    }

    #[test]
    fn grade_scaling_multiplies_and_elevation_scaling_goes_inside_atan() {
        let mut spec = thesis_terrain();
        spec.length_m = 100;
        let base = spec.grade_table(1.0);
        let by_grade = spec.grade_table(2.0);
        spec.scale_applies_to = ScaleTarget::Elevation;
        let by_elevation = spec.grade_table(2.0);
        for i in 0..100 {
            let g = base.grades()[i];
            assert_eq!(by_grade.grades()[i], 2.0 * g);
            assert!((by_elevation.grades()[i] - (2.0 * g.tan()).atan()).abs() < 1e-15);
        }
    }

    #[test]
    fn thesis_terrain_metric_is_about_0_00346() {
        // docs/model.md#terrain: at a = 1 they are about 0.00346 and 0.00340 rad².
        let ms = thesis_terrain().grade_table(1.0).mean_square();
        assert!((ms - 0.00346).abs() < 0.000005, "{ms}");
    }
}
