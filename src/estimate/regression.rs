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
        reg.differentiation = self.differentiation.as_ref().map(|d| {
            // The span runs to the sample after the last row.
            let span = d.sample[n - 1] + 2;
            Differentiation {
                span_t: d.span_t.prefix(span),
                span_run: d.span_run.prefix(span),
                sample: d.sample.prefix(n),
                inv_dt: d.inv_dt.prefix(n),
                spans: OnceLock::new(),
            }
        });
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

/// Where a differentiated acceleration takes its speeds: the logged samples from the one
/// before the first row to the one after the last (the *span*; rows left out of the
/// regression in between are logged too), and each row's place in it. Row i's output is
/// (Ṽ_{s+1} − Ṽ_{s−1}) / (t_{s+1} − t_{s−1}) + g sin θ̃ with s = `sample[i]`.
#[derive(Debug, Clone)]
pub struct Differentiation {
    /// Times of the span's samples \[s\].
    pub span_t: Column,
    /// The run of each of the span's samples.
    pub span_run: Column<u32>,
    /// Each row's sample in the span (its neighbours are the samples before and after).
    pub sample: Column<usize>,
    /// 1 / (t_{s+1} − t_{s−1}) of each row \[1/s\].
    pub inv_dt: Column,
    /// [`Differentiation::mean_spans`] of the segments first asked for.
    spans: OnceLock<Segments<f64>>,
}

impl PartialEq for Differentiation {
    /// The same samples (the kept spans are derived from them).
    fn eq(&self, other: &Self) -> bool {
        self.span_t == other.span_t
            && self.span_run == other.span_run
            && self.sample == other.sample
            && self.inv_dt == other.inv_dt
    }
}

impl Differentiation {
    /// The mean central-difference span t_{s+1} − t_{s−1} of the rows of each of
    /// `segments` \[s\] (rows a..b), summed in row order; kept for the segments first asked
    /// for (`wbcls` asks for the same ones in every realisation).
    pub fn mean_spans(&self, segments: &[(usize, usize)]) -> std::borrow::Cow<'_, [f64]> {
        let compute = || -> Vec<f64> {
            segments
                .iter()
                .map(|&(a, b)| {
                    let span: f64 = (a..b)
                        .map(|i| self.span_t[self.sample[i] + 1] - self.span_t[self.sample[i] - 1])
                        .sum();
                    span / (b - a) as f64
                })
                .collect()
        };
        let (kept, spans) = self.spans.get_or_init(|| (segments.to_vec(), compute()));
        match kept.as_slice() == segments {
            true => std::borrow::Cow::Borrowed(spans),
            false => std::borrow::Cow::Owned(compute()),
        }
    }
}

impl Regression {
    /// The regression of the samples of `cycle` marked in `used` (none of them the first or
    /// last sample of its run: a speed is differenced within a run, never across two) with
    /// the acceleration differentiated from the speed: the noise-free output is the central
    /// difference of the true speed, and [`Differentiation`] tells the kernel where each
    /// row's speed noise comes from.
    pub fn differentiated(
        cycle: &DriveCycle,
        used: &[bool],
        grade_offset: f64,
        vehicle: &VehicleParams,
    ) -> Regression {
        let (t, v) = (&cycle.t_s, &cycle.v_m_s);
        let rows: Vec<usize> = (0..used.len()).filter(|&i| used[i]).collect();
        assert!(
            !rows.is_empty() && rows.iter().all(|&i| !cycle.at_run_edge(i)),
            "a differentiated row needs a sample of its run on each side"
        );
        let inv_dt: Vec<f64> = rows.iter().map(|&i| 1.0 / (t[i + 1] - t[i - 1])).collect();
        let mut selected = cycle.select(used);
        selected.accel_m_s2 = rows
            .iter()
            .zip(&inv_dt)
            .map(|(&i, q)| (v[i + 1] - v[i - 1]) * q)
            .collect();
        selected
            .grade_rad
            .iter_mut()
            .for_each(|g| *g += grade_offset);
        let start = rows[0] - 1;
        let end = rows[rows.len() - 1] + 1;
        let mut reg = Regression::new(&selected, vehicle);
        reg.differentiation = Some(Differentiation {
            span_t: t[start..=end].to_vec().into(),
            span_run: cycle.run[start..=end].to_vec().into(),
            sample: rows.iter().map(|&i| i - start).collect::<Vec<_>>().into(),
            inv_dt: inv_dt.into(),
            spans: OnceLock::new(),
        });
        reg
    }

    /// The times of the samples that carry speed noise: the span for a differentiated
    /// acceleration, else the rows.
    pub fn noise_times(&self) -> &[f64] {
        self.differentiation.as_ref().map_or(&self.t, |d| &d.span_t)
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

/// The AR(1) coefficients of noise with correlation time `tau_s` \[s\] at samples `t` of
/// runs `run`: φ_i = exp(−(t_i − t_{i−1})/τ) and √(1 − φ_i²), so that
/// e_i = φ_i e_{i−1} + √(1 − φ_i²) z_i is stationary with unit variance for any steps. At the
/// first sample and at each run's first sample the process restarts, \[0, 1\] (e_i = z_i):
/// runs are independent (docs/model.md#coastdown).
pub fn ar1_coefficients(t: &[f64], run: &[u32], tau_s: f64) -> Vec<[f64; 2]> {
    assert_eq!(t.len(), run.len(), "a run per sample");
    (0..t.len())
        .map(|i| match i > 0 && run[i] == run[i - 1] {
            true => {
                let phi = (-(t[i] - t[i - 1]) / tau_s).exp();
                [phi, (1.0 - phi * phi).sqrt()]
            }
            false => [0.0, 1.0],
        })
        .collect()
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
mod tests {
    use super::*;

    /// Two runs of five samples on one clock (t = 0, 1, …, 9 s), run 1 slower.
    fn two_runs() -> DriveCycle {
        let v = vec![30.0, 29.0, 28.2, 27.5, 27.0, 20.0, 19.6, 19.1, 18.8, 18.6];
        DriveCycle {
            t_s: (0..10).map(f64::from).collect(),
            x_m: (0..10).map(|i| 30.0 * f64::from(i)).collect(),
            v_m_s: v,
            grade_rad: vec![0.0; 10],
            f_prop_n: vec![0.0; 10],
            accel_m_s2: vec![-0.5; 10],
            run: vec![0, 0, 0, 0, 0, 1, 1, 1, 1, 1],
            run_heading: vec![1.0, -1.0],
        }
    }

    #[test]
    fn ar1_noise_restarts_at_each_run_s_first_sample() {
        // φ = 0 and a unit innovation where a run begins: its first sample's noise is a
        // fresh draw, independent of every earlier run's.
        let t = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5];
        let ar1 = ar1_coefficients(&t, &[0, 0, 0, 1, 1, 2], 2.0);
        for i in [0, 3, 5] {
            assert_eq!(ar1[i], [0.0, 1.0], "{i}");
        }
        for i in [1, 2, 4] {
            let phi = (-(t[i] - t[i - 1]) / 2.0f64).exp();
            assert_eq!(ar1[i], [phi, (1.0 - phi * phi).sqrt()], "{i}");
        }
        // The regression's rows carry their runs: the same at the first row of run 1.
        let reg = Regression::new(&two_runs(), &VehicleParams::thesis());
        let ar1 = reg.ar1_coefficients(2.0);
        assert_eq!(ar1[5], [0.0, 1.0]);
        assert!(ar1[4][0] > 0.0 && ar1[6][0] > 0.0);
        assert_eq!(reg.prefix(7).row_ar1_coefficients(2.0), ar1[..7]);
    }

    #[test]
    fn a_differentiated_acceleration_differences_within_each_run() {
        let cycle = two_runs();
        // Every sample but each run's first and last.
        let used: Vec<bool> = (0..cycle.len()).map(|i| !cycle.at_run_edge(i)).collect();
        assert_eq!(used.iter().filter(|u| **u).count(), 6);
        let reg = Regression::differentiated(&cycle, &used, 0.0, &VehicleParams::thesis());
        let rows = [1, 2, 3, 6, 7, 8];
        for (r, &i) in rows.iter().enumerate() {
            assert_eq!(cycle.run[i - 1], cycle.run[i + 1]);
            let central = (cycle.v_m_s[i + 1] - cycle.v_m_s[i - 1]) / 2.0;
            assert_eq!(reg.accel[r], central, "row {r}");
        }
        // The span runs from sample 0 to 9; its noise restarts at run 1's first sample.
        let d = reg.differentiation.as_ref().unwrap();
        assert_eq!(&*d.span_run, &cycle.run[..]);
        assert_eq!(reg.ar1_coefficients(2.0)[5], [0.0, 1.0]);
    }

    #[test]
    #[should_panic(expected = "a sample of its run on each side")]
    fn a_differentiated_row_at_a_run_edge_is_refused() {
        // Sample 4 is run 0's last: its central difference would reach into run 1.
        let cycle = two_runs();
        let mut used = vec![false; cycle.len()];
        used[3] = true;
        used[4] = true;
        Regression::differentiated(&cycle, &used, 0.0, &VehicleParams::thesis());
    }
}
