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

use std::fmt;
use std::ops::Deref;
use std::sync::{Arc, OnceLock};

use nalgebra::{Matrix3, Vector3};

use super::kernels::{Columns, ZEROS, speed_sums};
use super::moments::{GradeSums, Moments};
use super::rls::scan::RlsPlan;
use super::row_sums::output_sums;
use super::sums::{Column as Factor, Sum};
use crate::noise::BLOCK;
use crate::numeric::sum::exact_sum;
use crate::vehicle::{DriveCycle, VehicleParams};

mod differentiation;
pub use differentiation::{Differentiation, ar1_coefficients};

/// A column of a regression: the first `len` values of storage shared with the regression
/// of a longer duration of the same cycle, whose rows begin with these
/// ([`Regression::prefix`]; docs/model.md#row-selection). Reads as a slice.
#[derive(Clone, PartialEq)]
pub struct Column<T = f64> {
    values: Arc<[T]>,
    len: usize,
}

impl<T> Column<T> {
    /// The first `n` values, sharing the storage.
    pub fn prefix(&self, n: usize) -> Column<T> {
        assert!(n <= self.len, "a prefix of {n} of {} values", self.len);
        Column {
            values: self.values.clone(),
            len: n,
        }
    }
}

impl<T> From<Vec<T>> for Column<T> {
    fn from(values: Vec<T>) -> Self {
        let len = values.len();
        Column {
            values: values.into(),
            len,
        }
    }
}

impl<T> Deref for Column<T> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        &self.values[..self.len]
    }
}

impl<T: fmt::Debug> fmt::Debug for Column<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        (**self).fmt(f)
    }
}

/// Row ranges a..b and a value of each: the weight segments and their noise-free sums
/// without w (see [`Regression::segments`]), or the spans of a differentiated acceleration.
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
    /// Σw, ΣwF, Σwc, Σw², Σwy with w = V², summed per block of [`BLOCK`] samples and then
    /// over blocks, exactly as a realisation without speed noise would sum them: such a
    /// realisation starts from these instead of recomputing them.
    pub(crate) speed_sums_noise_free: [f64; 5],
    /// The sums of the grade term s = g sin θ: Σs, ΣFs, Σcs, ΣV²s, exactly rounded.
    grade_sums_noise_free: GradeSums,
    /// The logged speed samples a differentiated acceleration reads (`None`: the
    /// regression's output holds the model acceleration).
    pub differentiation: Option<Differentiation>,
    /// The weight segments of `wbcls` and the noise-free sums without w over each
    /// (those of x₁ and x₃ alone, Σx₁y, Σx₃y, Σy), computed when first asked for.
    segments: OnceLock<Segments>,
    /// What the `rls` scans of the realisations share, computed when first asked for.
    rls: OnceLock<Arc<RlsPlan>>,
}

impl Regression {
    /// The regression of `cycle` for `vehicle`; constant sums are exactly rounded.
    pub fn new(cycle: &DriveCycle, vehicle: &VehicleParams) -> Self {
        let g = vehicle.gravity_m_s2;
        let k = vehicle.drag_factor_kg_m();
        let sin_grade: Vec<f64> = cycle.grade_rad.iter().map(|t| t.sin()).collect();
        let cos_grade: Vec<f64> = cycle.grade_rad.iter().map(|t| t.cos()).collect();
        let c: Vec<f64> = cos_grade.iter().map(|cs| -g * cs).collect();
        let g_sin: Vec<f64> = sin_grade.iter().map(|s| g * s).collect();
        let y: Vec<f64> = cycle
            .accel_m_s2
            .iter()
            .zip(&g_sin)
            .map(|(a, gs)| a + gs)
            .collect();
        Self::with_sums(
            RowColumns {
                t: cycle.t_s.clone().into(),
                run: cycle.run.clone().into(),
                f: cycle.f_prop_n.clone().into(),
                c: c.into(),
                v: cycle.v_m_s.clone().into(),
                y: y.into(),
                accel: cycle.accel_m_s2.clone().into(),
                g_sin: g_sin.into(),
                sin_grade: sin_grade.into(),
                cos_grade: cos_grade.into(),
            },
            k,
            g,
        )
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
        let dot = |a: &[f64], b: &[f64]| exact_sum(a.iter().zip(b).map(|(p, q)| p * q));
        let x2: Vec<f64> = v.iter().map(|v| -k * v * v).collect();
        let cols: [&[f64]; 3] = [&f, &x2, &c];
        let mut xtx = Matrix3::zeros();
        let mut xty = Vector3::zeros();
        for i in 0..3 {
            for j in 0..3 {
                xtx[(i, j)] = dot(cols[i], cols[j]);
            }
            xty[i] = dot(cols[i], &y);
        }
        let sum = |a: &[f64]| exact_sum(a.iter().copied());
        let grade_sums_noise_free = GradeSums {
            s_s: sum(&g_sin),
            s_1s: dot(&f, &g_sin),
            s_3s: dot(&c, &g_sin),
            s_ws: exact_sum(v.iter().zip(g_sin.iter()).map(|(v, s)| v * v * s)),
        };
        let mut speed_sums_noise_free = [0.0; 5];
        for start in (0..v.len()).step_by(BLOCK) {
            let range = start..(start + BLOCK).min(v.len());
            let cols = Columns {
                v: &v[range.clone()],
                f: &f[range.clone()],
                c: &c[range.clone()],
                y: &y[range.clone()],
            };
            let block = speed_sums(&cols, &ZEROS[..range.len()], 0.0);
            for (total, b) in speed_sums_noise_free.iter_mut().zip(block) {
                *total += b;
            }
        }
        Regression {
            differentiation: None,
            segments: OnceLock::new(),
            rls: OnceLock::new(),
            t,
            run,
            speed_sums_noise_free,
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

    /// What the `rls` scans of this regression's rows share under forgetting factor
    /// `lambda` ([`RlsPlan`]); computed on first use, `lambda` must be the same at every
    /// call.
    pub fn rls_plan(&self, lambda: f64) -> Arc<RlsPlan> {
        let plan = self.rls.get_or_init(|| {
            let columns = [&self.f[..], &self.c[..], &self.y[..]];
            Arc::new(RlsPlan::new(&self.t, Some(columns), lambda))
        });
        assert_eq!(
            plan.lambda().to_bits(),
            lambda.to_bits(),
            "one forgetting factor per regression"
        );
        Arc::clone(plan)
    }

    /// Consecutive row ranges of at least `segment_s` \[s\] each (the last may be shorter;
    /// a range holds at least one row), and over each the noise-free sums of the terms
    /// without w: those of x₁ and x₃ alone (Σx₁², Σx₁x₃, Σx₃², Σx₁, Σx₃), and Σx₁y, Σx₃y,
    /// Σy in four lanes as `row_sums.rs` sums a segment (so a segment whose ỹ is y takes
    /// them to the same bits); the rest zero. Computed on first use; `segment_s` must be the
    /// same at every call.
    pub fn segments(&self, segment_s: f64) -> (&[(usize, usize)], &[Moments]) {
        let (ranges, sums) = self.segments.get_or_init(|| {
            let t = &self.t;
            let mut ranges = Vec::new();
            let mut start = 0;
            for i in 1..t.len() {
                if t[i] - t[start] >= segment_s {
                    ranges.push((start, i));
                    start = i;
                }
            }
            if !t.is_empty() {
                ranges.push((start, t.len()));
            }
            let sums = ranges
                .iter()
                .map(|&(a, b)| {
                    let mut m = Moments::default();
                    for s in Sum::ALL.into_iter().filter(|s| s.regressors_only()) {
                        let column = |c: &Factor| match c {
                            Factor::F => &self.f[a..b],
                            _ => &self.c[a..b],
                        };
                        m[s] = match s.factors() {
                            [x] => column(x).iter().sum(),
                            [x, z] => column(x).iter().zip(column(z)).map(|(x, z)| x * z).sum(),
                            _ => unreachable!("a sum has one or two factors"),
                        };
                    }
                    [m.s_1y, m.s_3y, m.s_y] =
                        output_sums(&self.f[a..b], &self.c[a..b], &self.y[a..b]);
                    m
                })
                .collect();
            (ranges, sums)
        });
        (ranges, sums)
    }

    /// The [`Moments`] of the rows as they are (no noise added): what a realisation without
    /// noise sums, and the sums of a measured log taken as it is.
    pub fn noise_free_moments(&self) -> Moments {
        let [s_w, s_1w, s_3w, s_ww, s_wy] = self.speed_sums_noise_free;
        Moments {
            s_11: self.xtx[(0, 0)],
            s_13: self.xtx[(0, 2)],
            s_33: self.xtx[(2, 2)],
            s_1y: self.xty[0],
            s_3y: self.xty[2],
            s_1w,
            s_3w,
            s_ww,
            s_wy,
            s_w,
            s_1: self.sum_f,
            s_3: self.sum_c,
            s_y: self.sum_y,
            n: self.len() as f64,
            grade: Some(self.grade_sums_noise_free),
        }
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
    use crate::terrain::GradeTable;
    use crate::vehicle::{TorqueDrive, simulate};
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
    let cycle = simulate(&vehicle, &drive, &GradeTable::from_grades(grades)).unwrap();
    Regression::new(&cycle, &vehicle)
}

#[cfg(test)]
mod tests;
