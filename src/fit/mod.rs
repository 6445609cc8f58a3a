//! `fit`: the estimates from a measured log, with sandwich standard errors and a parametric
//! bootstrap (see docs/model.md#fit); and `simulate-log`, which writes such a log from a
//! study (the project's own generator of synthetic logs).
//!
//! One job a file: the fit file and its log are read and checked with the study files
//! ([`crate::study::FitSpec`], `study/fit.rs`), `bootstrap.rs`
//! builds each estimator's bootstrap world and resamples it, `systematic.rs` moves the
//! estimates under the model errors of `[systematic]`, `outputs.rs` writes fit.parquet,
//! systematic.parquet and fit.svg (and the printed tables), `report.rs` report.html, `simulate_log.rs`
//! writes a synthetic log; this file fits the log and puts the rows together.

mod bootstrap;
mod outputs;
mod report;
mod simulate_log;
mod systematic;

pub use crate::study::FitSpec;
pub use outputs::{budget_batch, budget_table, format_value, rows_batch, table};
pub use simulate_log::{
    LOG_HEADER, ensure_replaceable, log_batch, simulate_log, simulated_log, write_log,
};
pub use systematic::SystematicRow;

use std::path::{Path, PathBuf};

use nalgebra::{Matrix3, Vector3};
use thiserror::Error;

use crate::dynamics::Replay;
use crate::dynamics::truth::MODEL_ERRORS;
use crate::estimate::channels::NoiseLevels;
use crate::estimate::estimators::{EstimatorRef, EstimatorSettings, estimates_without_draws};
use crate::estimate::filtering::FILTER_SD_INV_MASS;
use crate::estimate::parameters::Parameters;
use crate::estimate::regression::Regression;
use crate::figures::FigureError;
use crate::model::vehicle::{PARAMETERS, VehicleModel};
use crate::output::lock::DirLock;
use crate::output::{self, FileMetadata, OutputError, set};
use crate::stats::measures::Z_95;
use crate::study::{MIN_REALISATIONS, StudyError, TruthAxes};

/// The output file of `fit`.
pub const FIT_FILE: &str = "fit.parquet";

/// The systematic-error budget of `fit`, written when the fit file has `[systematic]`.
pub const SYSTEMATIC_FILE: &str = "systematic.parquet";

/// The figure of `fit`: each estimator's estimate and 95 % bootstrap interval of M, Cd and
/// Cr, against the `[reference]` values when given.
pub const FIT_FIGURE: &str = "fit.svg";

/// Half-width \[s\] of the centred moving average that smooths the measured speed into the
/// bootstrap's true speed trace.
pub const SMOOTHING_S: f64 = 0.5;

/// Why a fit cannot be made.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum FitError {
    /// The fit file or its log is invalid.
    #[error(transparent)]
    Study(#[from] StudyError),
    /// Writing the output failed.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// Drawing the figure failed.
    #[error(transparent)]
    Figure(#[from] FigureError),
}

impl FitError {
    /// Whether the cause is the user's input (exit status 2 at the command line): an invalid
    /// fit file, log or study, or an output directory that cannot be used as it is
    /// ([`OutputError::is_bad_input`]); otherwise a failure while running (exit status 1).
    pub fn is_bad_input(&self) -> bool {
        match self {
            FitError::Study(_) => true,
            FitError::Output(e) => e.is_bad_input(),
            FitError::Figure(e) => e.is_bad_input(),
        }
    }
}

/// Each estimator's θ̂ on the measured rows of `reg` (taken as they are), and a filter's
/// own SD of 1/M.
fn estimates(
    reg: &Regression,
    noise: &NoiseLevels,
    estimators: &[EstimatorRef],
    settings: &EstimatorSettings,
) -> Vec<(Option<Vector3<f64>>, Option<f64>)> {
    estimates_without_draws(
        reg,
        &NoiseLevels::default(),
        noise,
        estimators,
        settings,
        &[f64::NAN; 3],
    )
    .into_iter()
    .zip(estimators)
    .map(|(e, est)| {
        let sd = est
            .columns()
            .iter()
            .position(|c| c.name == FILTER_SD_INV_MASS)
            .map(|i| e.columns[i]);
        (e.theta.ok(), sd)
    })
    .collect()
}

/// A filter's own 95 % interval of 1/M, θ̂₁ ± z·SD, and of M, its image under M = 1/θ₁
/// (unbounded above, +∞, where the interval of 1/M reaches 0); with the SD of M by the
/// delta method, SD/θ̂₁² (docs/model.md#fit).
fn filter_intervals(inv_mass: f64, sd: f64) -> [(f64, f64, f64); 2] {
    let (low, high) = (inv_mass - Z_95 * sd, inv_mass + Z_95 * sd);
    let mass_high = if low > 0.0 { 1.0 / low } else { f64::INFINITY };
    [
        (sd, low, high),
        (sd / (inv_mass * inv_mass), 1.0 / high, mass_high),
    ]
}

/// θ and the derived M = 1/θ₁ \[kg\] and Cd = θ₂/θ₁ (a quotient, where a run's `drag` column
/// is M̂ θ̂₂: the two can differ in the last bit, and fit.parquet keeps its own).
fn with_derived(theta: &Vector3<f64>) -> [f64; 5] {
    [
        theta[0],
        theta[1],
        theta[2],
        1.0 / theta[0],
        theta[1] / theta[0],
    ]
}

/// The standard errors of [`with_derived`] from θ's covariance `cov`: θ's own, and M's and
/// Cd's by the delta method (M = 1/θ₁: ∂M/∂θ₁ = −1/θ₁²; Cd = θ₂/θ₁: ∇ = [−θ₂/θ₁², 1/θ₁, 0]).
fn derived_se(theta: &Vector3<f64>, cov: &Matrix3<f64>) -> [f64; 5] {
    let (t1, t2) = (theta[0], theta[1]);
    let cd = Vector3::new(-t2 / (t1 * t1), 1.0 / t1, 0.0);
    [
        cov[(0, 0)].sqrt(),
        cov[(1, 1)].sqrt(),
        cov[(2, 2)].sqrt(),
        cov[(0, 0)].sqrt() / (t1 * t1),
        (cd.transpose() * cov * cd)[(0, 0)].sqrt(),
    ]
}

/// Names of the rows of `fit.parquet`, in order: θ, then M and Cd.
pub const FIT_PARAMETERS: [&str; 5] = [
    PARAMETERS[0],
    PARAMETERS[1],
    PARAMETERS[2],
    "mass",
    "drag_coefficient",
];

/// The rows of [`FIT_PARAMETERS`] a fit of `estimator` reports: all; without 1/M and M
/// when the mass is known (`estimation.known_mass`); only 1/M and M for a filter, to which
/// Cd and Cr are known.
fn fit_rows(parameters: Parameters, estimator: EstimatorRef) -> impl Iterator<Item = usize> {
    // 1/M (row 0) and M (row 3) are known, not fitted.
    let known_mass = parameters != Parameters::All;
    let filter = estimator.estimates_grade();
    (0..FIT_PARAMETERS.len()).filter(move |&p| {
        let mass = p == 0 || p == 3;
        match filter {
            true => mass,
            false => !(known_mass && mass),
        }
    })
}

/// One row of `fit.parquet`.
#[derive(Debug, Clone, PartialEq)]
pub struct FitRow {
    /// Estimator name.
    pub estimator: &'static str,
    /// One of [`FIT_PARAMETERS`].
    pub parameter: &'static str,
    /// The estimate from the log.
    pub estimate: f64,
    /// Its sandwich SE (for M and Cd by the delta method from θ's sandwich covariance).
    pub sandwich_se: f64,
    /// Mean of the bootstrap estimates.
    pub boot_mean: f64,
    /// boot_mean − estimate: the estimator's bias where the truth is the fit.
    pub boot_bias: f64,
    /// estimate − boot_bias.
    pub bias_corrected: f64,
    /// 2.5 % quantile of the bootstrap estimates.
    pub ci_low: f64,
    /// 97.5 % quantile of the bootstrap estimates.
    pub ci_high: f64,
    /// The fit file's `[reference]` value, if it gives one.
    pub reference: Option<f64>,
    /// The bootstrap realisations kept (all but those whose world could not be simulated).
    pub boot_n: usize,
    /// A filter's own SD, 2.5 % and 97.5 % limits (of 1/M; of M its image, the SD by the
    /// delta method; `None` for the other estimators).
    pub filter: Option<FilterInterval>,
}

/// A filter's own SD and 95 % interval of one parameter (docs/model.md#fit).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilterInterval {
    /// The filter's own SD.
    pub sd: f64,
    /// The interval's lower limit.
    pub low: f64,
    /// Its upper limit (+∞ for M when the interval of 1/M reaches 0).
    pub high: f64,
}

/// What `fit` found.
#[derive(Debug, Clone)]
pub struct FitResult {
    /// One row per estimator × parameter.
    pub rows: Vec<FitRow>,
    /// The systematic-error budget: one row per estimator × parameter × model error of
    /// `[systematic]` (empty without it).
    pub systematic: Vec<SystematicRow>,
    /// Files written.
    pub files: Vec<PathBuf>,
}

/// The q-quantile of sorted `v` (linear interpolation).
fn quantile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let h = q * (v.len() - 1) as f64;
    let (i, frac) = (h.floor() as usize, h.fract());
    let j = (i + 1).min(v.len() - 1);
    v[i] + frac * (v[j] - v[i])
}

/// Fit `spec`'s log and write `fit.parquet` and `report.html` into `out`.
pub fn fit(spec: &FitSpec, out: &Path) -> Result<FitResult, FitError> {
    fit_to(spec, Some(out))
}

/// [`fit`] with nothing written: the rows are the result's (the tables of fit.parquet and
/// systematic.parquet by [`rows_batch`] and [`budget_batch`]), `files` is empty.
pub fn fit_in_memory(spec: &FitSpec) -> Result<FitResult, FitError> {
    fit_to(spec, None)
}

fn fit_to(spec: &FitSpec, out: Option<&Path>) -> Result<FitResult, FitError> {
    let reg = spec.regression();
    let fits = estimates(&reg, &spec.noise, &spec.estimators, &spec.settings);
    // Every refusal before anything is created.
    let mut thetas = Vec::with_capacity(fits.len());
    let mut filter_sds = Vec::with_capacity(fits.len());
    for (est, (theta, filter_sd)) in spec.estimators.iter().zip(fits) {
        filter_sds.push(filter_sd);
        let Some(theta) = theta else {
            return Err(StudyError {
                file: spec.origin.clone(),
                key: Some("estimation.estimators".into()),
                line: None,
                reason: match est.estimates_grade() {
                    true => format!(
                        "{}: no estimate from the log (fewer samples than its difference \
                         window, or a step its recursion cannot take)",
                        est.name()
                    ),
                    false => format!(
                        "{}: the normal equations of the log are singular",
                        est.name()
                    ),
                },
            }
            .into());
        };
        if !(theta[0] > 0.0 && theta[1] >= 0.0 && theta[2] >= 0.0) {
            return Err(StudyError {
                file: spec.origin.clone(),
                key: Some("estimation.estimators".into()),
                line: None,
                reason: format!(
                    "{}: the fit θ = [{:e}, {:e}, {:e}] is not a vehicle (1/M must be \
                     positive, Cd/M and Cr not negative), so it cannot be bootstrapped",
                    est.name(),
                    theta[0],
                    theta[1],
                    theta[2]
                ),
            }
            .into());
        }
        thetas.push((*est, theta));
    }
    let replays: Vec<Replay> = thetas
        .iter()
        .map(|(est, theta)| bootstrap::replay(spec, *est, theta))
        .collect();
    let worlds = thetas
        .iter()
        .zip(&replays)
        .map(|((est, theta), replay)| {
            bootstrap::world(spec, *est, theta, replay.clone(), TruthAxes::default())
        })
        .collect::<Result<Vec<VehicleModel>, FitError>>()?;
    // Per estimator, per model error of [systematic], per parameter.
    let shifts = thetas
        .iter()
        .zip(&replays)
        .zip(&worlds)
        .map(|(((est, theta), replay), world)| systematic::shifts(spec, *est, theta, replay, world))
        .collect::<Result<Vec<Vec<[f64; 5]>>, FitError>>()?;
    drop(replays);
    // The bootstraps, before anything is written: a world whose realisations mostly fail (a
    // filter's model stalling under the logged force) is refused.
    let mut boots = Vec::with_capacity(worlds.len());
    for ((est, _), model) in thetas.iter().zip(&worlds) {
        let boot = bootstrap::resample(spec, model);
        if (boot.len() as i64) < MIN_REALISATIONS {
            return Err(StudyError {
                file: spec.origin.clone(),
                key: Some("realisations".into()),
                line: None,
                reason: format!(
                    "{}'s bootstrap kept {} of {} realisations (fewer than {MIN_REALISATIONS}): \
                     the others' worlds could not be simulated{}",
                    est.name(),
                    boot.len(),
                    spec.realisations,
                    match est.estimates_grade() {
                        true =>
                            " (the filters' model stalls under the logged force: the log \
                                 stops or brakes, which the model has no term for)",
                        false => "",
                    }
                ),
            }
            .into());
        }
        boots.push(boot);
    }

    let mut rows = Vec::new();
    let mut budget = Vec::new();
    for ((((est, theta), boot), shifts), filter_sd) in
        thetas.iter().zip(&boots).zip(&shifts).zip(&filter_sds)
    {
        let se = reg
            .sandwich_covariance(
                &[theta[0], theta[1], theta[2]],
                &spec.noise,
                spec.settings.parameters,
            )
            .map_or([f64::NAN; 5], |cov| derived_se(theta, &cov));
        // A filter's rows have no sandwich SE (it is OLS's); they have the filter's own.
        let se = match est.estimates_grade() {
            true => [f64::NAN; 5],
            false => se,
        };
        let intervals = filter_sd.map(|sd| filter_intervals(theta[0], sd));
        let estimate = with_derived(theta);
        let first = rows.len();
        for p in fit_rows(spec.settings.parameters, *est) {
            let name = &FIT_PARAMETERS[p];
            let mut values: Vec<f64> = boot.iter().map(|b| with_derived(b)[p]).collect();
            values.sort_by(f64::total_cmp);
            let boot_mean = values.iter().sum::<f64>() / values.len() as f64;
            let boot_bias = boot_mean - estimate[p];
            rows.push(FitRow {
                estimator: est.name(),
                parameter: name,
                estimate: estimate[p],
                sandwich_se: se[p],
                boot_mean,
                boot_bias,
                bias_corrected: estimate[p] - boot_bias,
                ci_low: quantile(&values, 0.025),
                ci_high: quantile(&values, 0.975),
                reference: spec.reference[p],
                boot_n: boot.len(),
                filter: intervals.map(|i| {
                    let (sd, low, high) = i[usize::from(p == 3)];
                    FilterInterval { sd, low, high }
                }),
            });
        }
        let mine = &rows[first..];
        for (p, row) in fit_rows(spec.settings.parameters, *est).zip(mine) {
            for (&(entry, magnitude), shift) in spec.systematic.iter().zip(shifts) {
                let entry = &MODEL_ERRORS[entry];
                budget.push(SystematicRow {
                    estimator: row.estimator,
                    parameter: row.parameter,
                    entry: entry.key,
                    unit: entry.unit,
                    magnitude,
                    shift: shift[p],
                    rel_shift: shift[p] / row.estimate,
                    ci_half_width: 0.5 * (row.ci_high - row.ci_low),
                });
            }
        }
    }
    let files = match out {
        Some(out) => write(spec, out, &rows, &budget)?,
        None => Vec::new(),
    };
    Ok(FitResult {
        rows,
        systematic: budget,
        files,
    })
}

/// Write fit.parquet, systematic.parquet (or remove an earlier one), fit.svg and the report
/// into `out`, committed together; returns the files written.
fn write(
    spec: &FitSpec,
    out: &Path,
    rows: &[FitRow],
    budget: &[SystematicRow],
) -> Result<Vec<PathBuf>, FitError> {
    std::fs::create_dir_all(out).map_err(|e| OutputError::io(out, e))?;
    let _lock = DirLock::acquire(out)?;
    set::ensure_complete(out)?;
    let meta = FileMetadata {
        study_toml: spec.text.clone(),
        study_dir: spec.dir.display().to_string(),
        seed: spec.seed,
        realisations: spec.realisations,
        identity: String::new(),
        extra: Vec::new(),
    };
    let svg = outputs::figure(rows)?;
    let figure = output::write_pending(out, FIT_FIGURE, svg.as_bytes())?;
    let mut pending = vec![
        outputs::write_rows(out, rows, &meta)?,
        figure,
        report::write_report(out, spec, rows, budget, &svg)?,
    ];
    if !budget.is_empty() {
        pending.push(outputs::write_budget(out, budget, &meta)?);
    }
    // An earlier fit's budget is replaced, or removed when this one has none.
    let files = set::commit(out, pending, &|p| {
        p == FIT_FILE || p == FIT_FIGURE || p == "report.html" || p == SYSTEMATIC_FILE
    })?;
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_filters_interval_of_m_is_the_image_of_one_over_ms_and_unbounded_past_zero() {
        // 1/M = 5e-4 ± 1e-5: M's limits are 1/(5e-4 ± 1.96e-5), its SD 1e-5 / (5e-4)².
        let [inv, mass] = filter_intervals(5e-4, 1e-5);
        assert_eq!(inv, (1e-5, 5e-4 - Z_95 * 1e-5, 5e-4 + Z_95 * 1e-5));
        assert_eq!(mass.1, 1.0 / inv.2);
        assert_eq!(mass.2, 1.0 / inv.1);
        assert!((mass.0 - 1e-5 / 25e-8).abs() < 1e-9);
        // An interval of 1/M that reaches 0 leaves M unbounded above.
        let [inv, mass] = filter_intervals(5e-4, 3e-4);
        assert!(inv.1 < 0.0);
        assert_eq!(mass.2, f64::INFINITY);
        assert_eq!(mass.1, 1.0 / inv.2);
    }
}
