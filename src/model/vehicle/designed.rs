//! A designed drive (`drive.mode = "designed"`, docs/model.md#designed-drive) made for its
//! study: the torque profile whose drive minimises the criterion of the chosen estimator's
//! bound under the study's noise, on its terrain, searched by `numeric::profile_search`; the study is
//! then the designed drive's, an ordinary torque drive.

use std::sync::Arc;

use super::ErrorAt;
use super::axes::grid;
use super::prepare::{regressions, used_samples};
use crate::dynamics::{
    Candidate, DesignSummary, DesignedDrive, DriveDesign, Driven, Prefix, VehicleParams,
};
use crate::estimate::bounds::BOUNDS;
use crate::estimate::bounds::BoundKind;
use crate::estimate::channels::NoiseLevels;
use crate::estimate::estimator::EstimatorRef;
use crate::numeric::profile_search::{SquareWave, search};
use crate::study::{Study, StudyError, VehicleStudy};
use crate::terrain::GradeTable;

use super::PARAMETERS;

/// What a designed drive minimises.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Criterion {
    /// ln det of the bound's covariance over the fitted parameters (D-optimal).
    D,
    /// Σ Var(θ̂_j)/θ_j² over the fitted parameters (A-optimal, relative).
    A,
    /// Var(θ̂_j)/θ_j² of one parameter.
    Parameter(usize),
}

impl Criterion {
    /// Its value for the covariance `cov` (zeros at a known parameter) of the fitted
    /// parameters `free` at the truth `theta`.
    pub fn value(self, cov: &nalgebra::Matrix3<f64>, free: &[usize], theta: &[f64; 3]) -> f64 {
        match self {
            Criterion::D => {
                let n = free.len();
                let block = nalgebra::DMatrix::from_fn(n, n, |i, j| cov[(free[i], free[j])]);
                let det = block.determinant();
                if det > 0.0 { det.ln() } else { f64::INFINITY }
            }
            Criterion::A => free
                .iter()
                .map(|&j| cov[(j, j)] / (theta[j] * theta[j]))
                .sum(),
            Criterion::Parameter(j) => cov[(j, j)] / (theta[j] * theta[j]),
        }
    }
}

/// The study whose drive is a [`DriveDesign`] with the drive designed; any other study as
/// it is. An error names the key: a study of more than one condition, an estimator it does
/// not list, an unknown criterion, a profile that cannot hold the limits.
pub(super) fn resolve(
    mut vs: VehicleStudy,
    seed: u64,
    error_at: &ErrorAt<'_>,
) -> Result<VehicleStudy, StudyError> {
    let Some(design) = vs.drive.design().cloned() else {
        return Ok(vs);
    };
    let table = vs
        .terrain
        .as_ref()
        .expect("a designed drive is validated to have a terrain profile")
        .grade_table(vs.scales[0]);
    let judge = judge(&vs, &design, &table, error_at)?;
    let estimator = judge.estimator;
    let (lo, hi) = (design.torque_min_n_m, design.torque_max_n_m);
    let objective = |levels: &[f64]| judge.of_planned(&design.planned(levels)).criterion;
    let found = search(
        &objective,
        design.segments,
        lo,
        hi,
        design.polish_iterations,
        seed,
    )
    .map_err(|e| {
        error_at(
            "drive.mode",
            format!("the search of the designed drive failed: {e}"),
        )
    })?;
    let judged = judge.of_planned(&design.planned(&found.levels));
    let (Some(driven), true) = (judged.driven.clone(), judged.criterion.is_finite()) else {
        return Err(error_at(
            "drive.mode",
            format!(
                "no torque profile within drive.torque_min and drive.torque_max could be driven \
                 within the speed limits with a finite criterion: {}",
                judged.failure.unwrap_or_default()
            ),
        ));
    };
    let (wave, _) = found.square;
    let mut candidates = vec![
        judged.candidate("designed"),
        judge
            .of_planned(&design.planned(&wave.levels(design.segments, lo, hi)))
            .candidate(&square_name(wave, &design)),
    ];
    if let Some(planned) = design.reference_planned() {
        candidates.push(
            judge
                .of_planned(&planned)
                .candidate("the study's own torque"),
        );
    }
    let bound = judged.bound.map_or("none", |k| BOUNDS[k.index()].name);
    vs.drive = Arc::new(DesignedDrive {
        torque_n_m: Arc::new(driven.torque_n_m),
        levels: found.levels,
        summary: DesignSummary {
            criterion: design.criterion.clone(),
            estimator: estimator.0.name().to_string(),
            bound,
            candidates,
            evaluations: found.evaluations,
        },
        design,
    });
    Ok(vs)
}

/// The judge of `design`'s profiles in the study `vs` on `table`: an error names the key of
/// a study of more than one condition, an estimator it does not list, an unknown criterion.
fn judge<'a>(
    vs: &'a VehicleStudy,
    design: &'a DriveDesign,
    table: &'a GradeTable,
    error_at: &ErrorAt<'_>,
) -> Result<Judge<'a>, StudyError> {
    let conditions = grid(vs).len();
    if conditions != 1 {
        return Err(error_at(
            "drive.mode",
            format!(
                "a designed drive is designed for one condition (one terrain scale, one level of \
                 each noise key, one acceleration source, one value of each model error); the \
                 study has {conditions}"
            ),
        ));
    }
    let estimator = match &design.estimator {
        Some(name) => *vs
            .estimators
            .iter()
            .find(|e| e.0.name() == name)
            .ok_or_else(|| {
                error_at(
                    "drive.estimator",
                    format!("\"{name}\" is not one of estimation.estimators"),
                )
            })?,
        None => vs.estimators[0],
    };
    let free = vs.settings.parameters.free();
    let criterion = match design.criterion.as_str() {
        "d" => Criterion::D,
        "a" => Criterion::A,
        name => match PARAMETERS.iter().position(|p| *p == name) {
            Some(j) if free.contains(&j) => Criterion::Parameter(j),
            Some(_) => {
                return Err(error_at(
                    "drive.criterion",
                    format!("{name} is known (estimation.known_mass), not estimated"),
                ));
            }
            None => {
                return Err(error_at(
                    "drive.criterion",
                    format!("must be \"d\", \"a\" or one of {PARAMETERS:?}, got \"{name}\""),
                ));
            }
        },
    };
    let noise = grid(vs)[0].noise;
    Ok(Judge {
        vs,
        design,
        table,
        noise,
        estimator,
        criterion,
    })
}

/// The criterion of the profile of segment `levels` \[N·m\] in `study`, whose drive is
/// designed (`drive.mode = "designed"`): what the search minimises, +∞ where the profile
/// cannot be driven within the limits. An error for another study, or one a designed drive
/// refuses.
pub fn designed_profile_criterion(study: &Study, levels: &[f64]) -> Result<f64, StudyError> {
    let error_at = |key: &str, reason: String| study.error_at(key, reason);
    let vs = study
        .vehicle()
        .ok_or_else(|| error_at("model", "is not a vehicle study".into()))?;
    let design = vs
        .drive
        .design()
        .ok_or_else(|| error_at("drive.mode", "is not \"designed\"".into()))?;
    if levels.len() != design.segments {
        return Err(error_at(
            "drive.segments",
            format!(
                "is {}, but {} levels were given",
                design.segments,
                levels.len()
            ),
        ));
    }
    let table = vs
        .terrain
        .as_ref()
        .expect("a designed drive is validated to have a terrain profile")
        .grade_table(vs.scales[0]);
    let judge = judge(vs, design, &table, &error_at)?;
    Ok(judge.of_planned(&design.planned(levels)).criterion)
}

/// A square wave's name in the report.
fn square_name(wave: SquareWave, design: &DriveDesign) -> String {
    let segment_s = design.duration_s / design.segments as f64;
    format!(
        "best square wave (period {} s, starting {})",
        2.0 * wave.half_segments as f64 * segment_s,
        if wave.low_first { "low" } else { "high" }
    )
}

/// What judges a profile: the study, its one condition's noise and the estimator's bound.
struct Judge<'a> {
    vs: &'a VehicleStudy,
    design: &'a DriveDesign,
    table: &'a GradeTable,
    noise: NoiseLevels,
    estimator: EstimatorRef,
    criterion: Criterion,
}

/// A profile judged.
#[derive(Debug, Clone)]
struct Judged {
    criterion: f64,
    relative_se: [f64; 3],
    bound: Option<BoundKind>,
    driven: Option<Driven>,
    failure: Option<String>,
}

impl Judged {
    fn candidate(&self, name: &str) -> Candidate {
        Candidate {
            name: name.to_string(),
            criterion: self.criterion,
            relative_se: self.relative_se,
            governed_fraction: self
                .driven
                .as_ref()
                .map_or(f64::NAN, |d| d.governed_fraction),
        }
    }
}

impl Judge<'_> {
    /// The planned torque driven under the governor and its criterion (+∞ where it cannot be
    /// driven or the bound is singular).
    fn of_planned(&self, planned: &[f64]) -> Judged {
        let vehicle: &VehicleParams = &self.vs.vehicle;
        let failed = |failure: String| Judged {
            criterion: f64::INFINITY,
            relative_se: [f64::NAN; 3],
            bound: None,
            driven: None,
            failure: Some(failure),
        };
        let driven = match self.design.governed(vehicle, self.table, planned) {
            Ok(d) => d,
            Err(e) => return failed(e.to_string()),
        };
        let theta = vehicle.theta();
        let source = self.vs.acceleration[0];
        let used = used_samples(&driven.cycle, self.vs, Prefix::Whole, source);
        let regression = regressions(self.vs, &driven.cycle, &used, source).swap_remove(0);
        let parameters = self.vs.settings.parameters;
        let Some((kind, cov)) = regression.predicted_covariance(
            &theta,
            &self.noise,
            parameters,
            self.estimator.0.spread(),
            |b| self.estimator.0.reports(b, &self.vs.settings),
        ) else {
            return Judged {
                driven: Some(driven),
                ..failed("no bound applies, or its matrix is singular".into())
            };
        };
        let free = parameters.free();
        let relative_se = std::array::from_fn(|j| match free.contains(&j) {
            true => cov[(j, j)].sqrt() / theta[j].abs(),
            false => f64::NAN,
        });
        Judged {
            criterion: self.criterion.value(&cov, free, &theta),
            relative_se,
            bound: Some(kind),
            driven: Some(driven),
            failure: None,
        }
    }
}
