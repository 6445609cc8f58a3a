//! `ekf` and `rls_mf` (the filters of `filters/`) as estimators of a realisation: each runs along the measured rows
//! (z = √w̃, the measured speed; the measured force), reports θ̂ = \[θ̂₁, Cd·θ̂₁, Cr\] (Cd and
//! Cr are known to it) and its own columns: its SD of 1/M, its settle time, its error of 1/M
//! against the realisation's truth at the end and at [`CHECKPOINTS_S`], and the bound along
//! the realisation's own true path (docs/model.md#no-grade-sensor).

use std::sync::{Arc, Mutex};

use super::filters::ekf::{self, Prior};
use super::filters::pcrlb::{self, BoundTrack};
use super::filters::rls_mf::{self, RlsMfSettings};
use super::filters::{
    CHECKPOINTS_S, FilterModel, FilterSettings, GRADE, INV_MASS, Settle, TruePath,
    checkpoint_indices,
};
use crate::estimate::estimator::{Estimate, EstimateColumn, Estimator, Realisation};
use crate::estimate::regression::Regression;
use crate::estimate::rls::SETTLE_BAND;
use crate::numeric::linalg::SolveError;
use nalgebra::Vector3;

const fn column(name: &'static str, unit: &'static str, description: &'static str) -> EstimateColumn {
    EstimateColumn {
        name,
        unit,
        description,
        in_every_study: false,
    }
}

/// The name of the column of a filter's error of 1/M at the last row.
pub const INV_MASS_ERROR: &str = "inv_mass_error";
/// The name of the column of the bound's SD of 1/M along the realisation's own path.
pub const PATH_BOUND_INV_MASS: &str = "path_bound_inv_mass";
/// The name of the column of a filter's own SD of 1/M.
pub const FILTER_SD_INV_MASS: &str = "filter_sd_inv_mass";
/// The name of the column of `ekf`'s NEES.
pub const NEES: &str = "nees";
/// The name of the condition metric of the PCRLB's SD of 1/M at the last row.
pub const PCRLB_INV_MASS: &str = "pcrlb_inv_mass";

/// The columns both filters have, in this order at the start of their own.
const SHARED: [EstimateColumn; 7] = [
    column(
        FILTER_SD_INV_MASS,
        "1/kg",
        "ekf, rls_mf: the filter's own SD of 1/M at the last row",
    ),
    column(
        "filter_settle_time",
        "s",
        "ekf, rls_mf: time from the first row after which the 1/M estimate stays within ±2 % of its truth (null if never)",
    ),
    column(
        INV_MASS_ERROR,
        "1/kg",
        "ekf, rls_mf: the estimate of 1/M at the last row minus the realisation's true 1/M",
    ),
    column(
        PATH_BOUND_INV_MASS,
        "1/kg",
        "ekf, rls_mf: the posterior Cramér–Rao bound's SD of 1/M along the realisation's own true path, at the last row",
    ),
    column(
        "inv_mass_error_60s",
        "1/kg",
        "ekf, rls_mf: the estimate of 1/M minus the truth 60 s after the first row (null: the rows end before)",
    ),
    column(
        "inv_mass_error_120s",
        "1/kg",
        "ekf, rls_mf: as inv_mass_error_60s, at 120 s",
    ),
    column(
        "inv_mass_error_300s",
        "1/kg",
        "ekf, rls_mf: as inv_mass_error_60s, at 300 s",
    ),
];

/// `ekf`'s columns: the shared ones, then its grade's.
static EKF_COLUMNS: [EstimateColumn; 14] = [
    SHARED[0],
    SHARED[1],
    SHARED[2],
    SHARED[3],
    SHARED[4],
    SHARED[5],
    SHARED[6],
    column(
        NEES,
        "1",
        "ekf: the normalised estimation error squared of [V, 1/M, φ] at the last row",
    ),
    column(
        "grade_error",
        "rad",
        "ekf: the estimate of the grade at the last row minus the true grade",
    ),
    column(
        "filter_sd_grade",
        "rad",
        "ekf: the filter's own SD of the grade at the last row",
    ),
    column(
        "path_bound_grade",
        "rad",
        "ekf: the posterior Cramér–Rao bound's SD of the grade along the realisation's own true path, at the last row",
    ),
    column(
        "grade_error_60s",
        "rad",
        "ekf: the estimate of the grade minus the truth 60 s after the first row",
    ),
    column(
        "grade_error_120s",
        "rad",
        "ekf: as grade_error_60s, at 120 s",
    ),
    column(
        "grade_error_300s",
        "rad",
        "ekf: as grade_error_60s, at 300 s",
    ),
];

/// What a filter reads of a realisation: the measured speeds and forces at the row times,
/// its model and prior, and the true path.
struct Inputs<'a> {
    t: &'a [f64],
    z: Vec<f64>,
    force: &'a [f64],
    model: FilterModel,
    prior: Prior,
    truth: Arc<TrueGrades>,
    inv_mass: f64,
    regression: &'a Regression,
}

impl<'a> Inputs<'a> {
    fn of(r: &Realisation<'a>) -> Self {
        let rows = r.rows();
        let reg = r.regression;
        let settings = &r.settings.filter;
        // The measured speed is w̃'s square root: √(fl(x²)) = |x| in binary floating point,
        // so z is the measured speed itself wherever it is positive.
        let z = rows.w.iter().map(|w| w.sqrt()).collect();
        Inputs {
            t: &reg.t,
            z,
            force: rows.f,
            model: settings.model(reg.k, reg.g, r.noise.speed_sd()),
            prior: settings.prior,
            truth: true_grades(reg),
            inv_mass: r.truth[0],
            regression: reg,
        }
    }

    fn path(&self) -> TruePath<'_> {
        TruePath {
            t: self.t,
            v: &self.regression.v,
            grade: &self.truth.0,
            force: &self.regression.f,
            inv_mass: self.inv_mass,
        }
    }

    /// The bound along the true path, made once per regression, model and prior.
    fn path_bound(&self) -> Result<BoundTrack, SolveError> {
        let kept = self.regression.derived(|_| PathBounds::default());
        let key = (self.model, self.prior, self.inv_mass.to_bits());
        if let Some(b) = kept.find(&key) {
            return b;
        }
        let made = pcrlb::bound(&self.model, &self.prior, &[self.path()]);
        kept.keep(key, made);
        made
    }

    fn settle(&self) -> Settle {
        Settle::new(self.inv_mass, SETTLE_BAND * self.inv_mass.abs())
    }

    /// The time of sample `k` from the first.
    fn since_start(&self, k: usize) -> f64 {
        self.t[k] - self.t[0]
    }

    /// θ̂ from θ̂₁ (Cd and Cr known).
    fn theta(&self, inv_mass: f64, settings: &FilterSettings) -> Vector3<f64> {
        Vector3::new(inv_mass, settings.drag_coefficient * inv_mass, settings.rolling)
    }
}

/// The path bounds of a regression, per (model, prior, 1/M).
#[derive(Default)]
struct PathBounds(Mutex<Vec<(BoundKey, Result<BoundTrack, SolveError>)>>);

type BoundKey = (FilterModel, Prior, u64);

impl PathBounds {
    fn find(&self, key: &BoundKey) -> Option<Result<BoundTrack, SolveError>> {
        let kept = self.0.lock().expect("no panic while holding the bounds");
        kept.iter().find(|(k, _)| k == key).map(|(_, b)| *b)
    }

    fn keep(&self, key: BoundKey, bound: Result<BoundTrack, SolveError>) {
        let mut kept = self.0.lock().expect("no panic while holding the bounds");
        if !kept.iter().any(|(k, _)| *k == key) {
            kept.push((key, bound));
        }
    }
}

/// The true grade \[rad\] of each row of a regression, atan2(sin θ, cos θ).
#[derive(Debug)]
pub struct TrueGrades(pub Vec<f64>);

/// The true grades of `reg`'s rows, made once per regression and kept with it
/// ([`Regression::derived`]): the filters' truth and the bound's path.
pub fn true_grades(reg: &Regression) -> Arc<TrueGrades> {
    reg.derived(|reg| {
        TrueGrades(
            reg.sin_grade
                .iter()
                .zip(reg.cos_grade.iter())
                .map(|(s, c)| s.atan2(*c))
                .collect(),
        )
    })
}

/// The extended Kalman filter of \[V, 1/M, φ\].
#[derive(Debug, Clone, Copy)]
pub struct Ekf;

impl Estimator for Ekf {
    fn name(&self) -> &'static str {
        "ekf"
    }

    fn description(&self) -> &'static str {
        "extended Kalman filter of speed, 1/M and grade from the measured speed and force (no grade read; Cd and Cr known)"
    }

    fn reads_rows(&self) -> bool {
        true
    }

    fn estimates_grade(&self) -> bool {
        true
    }

    fn columns(&self) -> &'static [EstimateColumn] {
        &EKF_COLUMNS
    }

    fn estimate(&self, r: &Realisation<'_>) -> Estimate {
        let x = Inputs::of(r);
        let mut settle = x.settle();
        let run = ekf::run(&x.model, &x.prior, x.t, &x.z, x.force, |k, th| {
            settle.see(k, th)
        });
        let n = x.t.len() - 1;
        let truth_end = [x.regression.v[n], x.inv_mass, x.truth.0[n]];
        let bound = x.path_bound().ok();
        let at = checkpoint_indices(x.t);
        let error_at = |i: usize, of: usize, truth: &dyn Fn(usize) -> f64| {
            run.checkpoints[i].map_or(f64::NAN, |c| c.state[of] - truth(at[i].unwrap_or(0)))
        };
        let inv_mass = |_: usize| x.inv_mass;
        let grade = |k: usize| x.truth.0[k];
        let values = [
            run.end.cov[(INV_MASS, INV_MASS)].sqrt(),
            settle.settled(n + 1).map_or(f64::NAN, |k| x.since_start(k)),
            run.end.state[INV_MASS] - x.inv_mass,
            bound.map_or(f64::NAN, |b| b.end.inv_mass_var.sqrt()),
            error_at(0, INV_MASS, &inv_mass),
            error_at(1, INV_MASS, &inv_mass),
            error_at(2, INV_MASS, &inv_mass),
            ekf::nees(&run.end, &truth_end),
            run.end.state[GRADE] - x.truth.0[n],
            run.end.cov[(GRADE, GRADE)].sqrt(),
            bound.map_or(f64::NAN, |b| b.end.grade_var.sqrt()),
            error_at(0, GRADE, &grade),
            error_at(1, GRADE, &grade),
            error_at(2, GRADE, &grade),
        ];
        let theta = x.theta(run.end.state[INV_MASS], &r.settings.filter);
        Estimate::with_columns(Ok(theta), &values)
    }
}

/// Recursive least squares with a forgetting factor for 1/M and another for the grade.
#[derive(Debug, Clone, Copy)]
pub struct RlsMf;

impl Estimator for RlsMf {
    fn name(&self) -> &'static str {
        "rls_mf"
    }

    fn description(&self) -> &'static str {
        "recursive least squares with multiple forgetting: 1/M and β = Cr cos θ + sin θ from the differentiated measured speed (no grade read; Cd and Cr known)"
    }

    fn reads_rows(&self) -> bool {
        true
    }

    fn estimates_grade(&self) -> bool {
        true
    }

    fn columns(&self) -> &'static [EstimateColumn] {
        &SHARED
    }

    fn estimate(&self, r: &Realisation<'_>) -> Estimate {
        let x = Inputs::of(r);
        let settings = &r.settings.filter;
        let step = match x.t {
            [a, b, ..] => b - a,
            _ => f64::NAN,
        };
        let rls = RlsMfSettings {
            forgetting_mass: settings.forgetting_mass,
            forgetting_grade: settings.forgetting_grade,
            half_window: rls_mf::half_window(settings.difference_window_s, step),
        };
        let at = checkpoint_indices(x.t);
        let mut settle = x.settle();
        let mut checkpoints = [f64::NAN; CHECKPOINTS_S.len()];
        let run = rls_mf::run(&x.model, &x.prior, &rls, x.t, &x.z, x.force, |k, th| {
            settle.see(k, th);
            for (c, &i) in checkpoints.iter_mut().zip(&at) {
                if i == Some(k) {
                    *c = th - x.inv_mass;
                }
            }
        });
        let Some(run) = run else {
            return Estimate::theta(Err(SolveError::Singular));
        };
        let n = x.t.len();
        let bound = x.path_bound().ok();
        let values = [
            run.inv_mass_sd,
            settle
                .settled(n - rls.half_window)
                .map_or(f64::NAN, |k| x.since_start(k)),
            run.inv_mass - x.inv_mass,
            bound.map_or(f64::NAN, |b| b.end.inv_mass_var.sqrt()),
            checkpoints[0],
            checkpoints[1],
            checkpoints[2],
        ];
        Estimate::with_columns(Ok(x.theta(run.inv_mass, settings)), &values)
    }
}
