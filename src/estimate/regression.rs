//! The vehicle regression (thesis eqs. 32–37) of one drive cycle: its noise-free columns and
//! the sums that do not depend on the noise (see docs/model.md#regression).
//!
//! One row per sample i:
//!
//! ```text
//! y_i = dV/dt_i + g sin θ_i
//! x_i = [ F_prop,i , −k V_i² , −g cos θ_i ],   k = ½ ρ A
//! θ   = [ 1/M , Cd/M , Cr ]                     y = X θ
//! ```
//!
//! Noise channels and what they do to OLS (each a condition axis, σ = 0 means off):
//!
//! | channel | enters | effect on OLS | bounds that apply |
//! |---|---|---|---|
//! | speed, σ_v \[m/s\] | Ṽ² in column 2 | errors-in-variables: Cd/M biased low (attenuation), Cr biased high (the lost drag is absorbed by the constant-like column 3) | `thesis_bound` (not a real bound), `eiv_sandwich`, `eiv_crlb_linearized` |
//! | output, σ_y \[m/s²\] | y | none: OLS unbiased and efficient | `crlb_output` (when alone) |
//! | grade, σ_θ \[rad\] | sin θ̃ in y, cos θ̃ in column 3 | mostly output-like (y gets ≈ g σ_θ of noise); E cos θ̃ = cos θ e^(−σ_θ²/2) shrinks column 3, so Cr is biased up by ≈ σ_θ²/2 relative | `eiv_sandwich`, `eiv_crlb_linearized` (first order) |
//! | force, σ_F \[N\] | F̃ in column 1 | errors-in-variables in column 1: 1/M attenuated towards the part of F that column 3 cannot absorb (F varies only ±10 % about its mean, so even σ_F ≈ 50 N gives a large bias) | `eiv_sandwich`, `eiv_crlb_linearized` (first order) |

use std::any::Any;
use std::sync::Arc;

use nalgebra::{Matrix3, Vector3};

use super::sums::{GradeSums, Moments};
use crate::dynamics::{DriveCycle, VehicleParams};
use crate::numeric::sum::{Dot, Plain, SquareDot, exact_sum_of};

mod column;
mod derived;
mod differentiation;
mod redrawn;
mod terms;
pub use column::Column;
use derived::Derived;
pub use differentiation::{Differentiation, ar1_coefficients};
use terms::{DragDot, DragSquare, grade_columns};

/// Row ranges a..b and a value of each: the weight segments and their noise-free sums
/// without w (`wbcls::WeightSegments`), or the spans of a differentiated acceleration.
type Segments<T = Moments> = (Vec<(usize, usize)>, Vec<T>);

/// The noise-free regression of one drive cycle and its constant sums.
#[derive(Debug, Clone)]
pub struct Regression {
    /// Sample times \[s\] (for noise correlated in time).
    pub t: Column,
    /// The run of each row ([`DriveCycle::run`]): noise correlated in time restarts at a
    /// run's first row.
    pub run: Column<u32>,
    /// Column 1: F_prop \[N\].
    pub f: Column,
    /// Column 3: c = −g cos θ \[m/s²\].
    pub c: Column,
    /// Speed V \[m/s\] (column 2 is −k V²).
    pub v: Column,
    /// Output y = dV/dt + g sin θ \[m/s²\].
    pub y: Column,
    /// Model acceleration dV/dt \[m/s²\] (y without the grade term).
    pub accel: Column,
    /// The grade term g sin θ of y \[m/s²\] (y = dV/dt + this).
    pub g_sin: Column,
    /// sin θ of each sample.
    pub sin_grade: Column,
    /// cos θ of each sample.
    pub cos_grade: Column,
    /// k = ½ ρ A \[kg/m\].
    pub k: f64,
    /// g \[m/s²\].
    pub g: f64,
    /// Noise-free XᵀX.
    pub xtx: Matrix3<f64>,
    /// Noise-free Xᵀy.
    pub xty: Vector3<f64>,
    /// Σ F.
    pub sum_f: f64,
    /// Σ c.
    pub sum_c: f64,
    /// Σ y.
    pub sum_y: f64,
    /// The sums of the grade term s = g sin θ: Σs, ΣFs, Σcs, ΣV²s, exactly rounded.
    pub(crate) grade_sums_noise_free: GradeSums,
    /// The logged speed samples a differentiated acceleration reads (`None`: the
    /// regression's output holds the model acceleration).
    pub differentiation: Option<Differentiation>,
    /// What estimators derive from the noise-free rows and share between realisations
    /// (the weight segments of `wbcls`, the plan of `rls`), each made on first use.
    derived: Derived,
}

impl Regression {
    /// The regression of `cycle` for `vehicle`; constant sums are exactly rounded.
    pub fn new(cycle: &DriveCycle, vehicle: &VehicleParams) -> Self {
        let sin_grade = Column::collected(cycle.grade_rad.iter().map(|t| t.sin()));
        let cos_grade = Column::collected(cycle.grade_rad.iter().map(|t| t.cos()));
        Self::with_sin_cos(cycle, sin_grade, cos_grade, vehicle)
    }

    /// [`Regression::new`] with the grade given by its sine and cosine at each sample (a
    /// grade known by its tangent, as an elevation map's: docs/model.md#grade-map); the
    /// cycle's `grade_rad` is not read.
    pub fn with_sin_cos(
        cycle: &DriveCycle,
        sin_grade: Column,
        cos_grade: Column,
        vehicle: &VehicleParams,
    ) -> Self {
        let g = vehicle.gravity_m_s2;
        let k = vehicle.drag_factor_kg_m();
        let (c, g_sin, y) = grade_columns(g, &cycle.accel_m_s2, &sin_grade, &cos_grade);
        let column = |values: &[f64]| Column::collected(values.iter().copied());
        Self::with_sums(
            RowColumns {
                t: column(&cycle.t_s),
                run: cycle.run[..].into(),
                f: column(&cycle.f_prop_n),
                c,
                v: column(&cycle.v_m_s),
                y,
                accel: column(&cycle.accel_m_s2),
                g_sin,
                sin_grade,
                cos_grade,
            },
            k,
            g,
        )
    }

    /// The regression an estimator reads without a grade signal (`estimation.grade =
    /// "none"`) under a measured acceleration (an accelerometer, whose output
    /// y = dV/dt + g sin θ holds the grade): column 3 is −g, cos θ taken as 1
    /// (docs/model.md#no-grade-accelerometer). The truth's grade stays in y, `g_sin`,
    /// `sin_grade` and `cos_grade`; the constant sums are those of the new column.
    pub fn without_grade(&self) -> Regression {
        let columns = RowColumns {
            t: self.t.clone(),
            run: self.run.clone(),
            f: self.f.clone(),
            c: vec![-self.g; self.len()].into(),
            v: self.v.clone(),
            y: self.y.clone(),
            accel: self.accel.clone(),
            g_sin: self.g_sin.clone(),
            sin_grade: self.sin_grade.clone(),
            cos_grade: self.cos_grade.clone(),
        };
        let mut reg = Self::with_sums(columns, self.k, self.g);
        reg.differentiation = self.differentiation.clone();
        reg
    }

    /// The regression of its first `n` rows, sharing its columns: bit for bit the regression
    /// of those rows built alone (the same values, summed the same way). A duration's rows
    /// are the first rows of the whole cycle's (docs/model.md#row-selection), so the
    /// regressions of every duration of a cycle hold its columns once.
    pub fn prefix(&self, n: usize) -> Regression {
        let columns = RowColumns {
            t: self.t.prefix(n),
            run: self.run.prefix(n),
            f: self.f.prefix(n),
            c: self.c.prefix(n),
            v: self.v.prefix(n),
            y: self.y.prefix(n),
            accel: self.accel.prefix(n),
            g_sin: self.g_sin.prefix(n),
            sin_grade: self.sin_grade.prefix(n),
            cos_grade: self.cos_grade.prefix(n),
        };
        let mut reg = Self::with_sums(columns, self.k, self.g);
        reg.differentiation = self.differentiation.as_ref().map(|d| d.prefix(n));
        reg
    }

    /// The regression of `columns`, its constant sums computed.
    fn with_sums(columns: RowColumns, k: f64, g: f64) -> Self {
        let RowColumns {
            t,
            run,
            f,
            c,
            v,
            y,
            accel,
            g_sin,
            sin_grade,
            cos_grade,
        } = columns;
        let dot = |a: &[f64], b: &[f64]| exact_sum_of(&Dot(a, b));
        let drag = |a: &[f64]| exact_sum_of(&DragDot { a, v: &v, k });
        let mut xtx = Matrix3::zeros();
        let mut xty = Vector3::zeros();
        xtx[(0, 0)] = dot(&f, &f);
        xtx[(0, 1)] = drag(&f);
        xtx[(0, 2)] = dot(&f, &c);
        xtx[(1, 1)] = exact_sum_of(&DragSquare { v: &v, k });
        xtx[(1, 2)] = drag(&c);
        xtx[(2, 2)] = dot(&c, &c);
        for (i, j) in [(1, 0), (2, 0), (2, 1)] {
            xtx[(i, j)] = xtx[(j, i)];
        }
        xty[0] = dot(&f, &y);
        xty[1] = drag(&y);
        xty[2] = dot(&c, &y);
        let sum = |a: &[f64]| exact_sum_of(&Plain(a));
        let grade_sums_noise_free = GradeSums {
            s_s: sum(&g_sin),
            s_1s: dot(&f, &g_sin),
            s_3s: dot(&c, &g_sin),
            s_ws: exact_sum_of(&SquareDot(&v, &g_sin)),
        };
        Regression {
            differentiation: None,
            derived: Derived::default(),
            t,
            run,
            grade_sums_noise_free,
            sum_f: sum(&f),
            sum_c: sum(&c),
            sum_y: sum(&y),
            accel,
            g_sin,
            sin_grade,
            cos_grade,
            f,
            c,
            v,
            y,
            k,
            g,
            xtx,
            xty,
        }
    }

    /// The value of type `T` derived from this regression's rows by `make`, made on the
    /// first call and shared by every later one (and by the regression's clones): what an
    /// estimator that reads rows computes once per regression, not per realisation.
    pub fn derived<T: Any + Send + Sync>(&self, make: impl FnOnce(&Regression) -> T) -> Arc<T> {
        self.derived.get_or_make(|| make(self))
    }

    /// Number of samples N.
    pub fn len(&self) -> usize {
        self.f.len()
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.f.is_empty()
    }

    /// The AR(1) coefficients of speed noise with correlation time `tau_s` \[s\] at the
    /// samples that carry it ([`noise_times`](Self::noise_times); see [`ar1_coefficients`]),
    /// restarting at each run's first sample.
    pub fn ar1_coefficients(&self, tau_s: f64) -> Vec<[f64; 2]> {
        match &self.differentiation {
            Some(d) => ar1_coefficients(&d.span_t, &d.span_run, tau_s),
            None => self.row_ar1_coefficients(tau_s),
        }
    }

    /// The AR(1) coefficients of noise with correlation time `tau_s` \[s\] between
    /// consecutive rows ([`ar1_coefficients`] over the rows' times and runs).
    pub fn row_ar1_coefficients(&self, tau_s: f64) -> Vec<[f64; 2]> {
        ar1_coefficients(&self.t, &self.run, tau_s)
    }
}

/// The per-row columns of a regression, before its sums.
struct RowColumns {
    t: Column,
    run: Column<u32>,
    f: Column,
    c: Column,
    v: Column,
    y: Column,
    accel: Column,
    g_sin: Column,
    sin_grade: Column,
    cos_grade: Column,
}

/// A short thesis-like cycle (60 s over a sinusoidal grade) for unit tests.
#[cfg(test)]
pub(crate) fn test_regression() -> Regression {
    Regression::new(&test_cycle(), &VehicleParams::thesis())
}

/// The cycle of [`test_regression`].
#[cfg(test)]
pub(crate) fn test_cycle() -> DriveCycle {
    use crate::dynamics::{TorqueDrive, simulate};
    use crate::terrain::GradeTable;
    let vehicle = VehicleParams::thesis();
    let drive = TorqueDrive {
        duration_s: 60.0,
        time_step_s: 0.01,
        steps: 6000,
        initial_speed_m_s: 0.0,
        torque_mean_n_m: 225.0,
        torque_amplitude: 0.1,
        torque_frequency_rad_s: 0.1,
    };
    let grades = (0..3000).map(|i| 0.08 * (i as f64 / 150.0).sin()).collect();
    simulate(&vehicle, &drive, &GradeTable::from_grades(grades)).unwrap()
}

#[cfg(test)]
mod tests;
