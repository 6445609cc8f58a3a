//! `[estimation]`'s keys of the filters that estimate the grade with the mass, and
//! `estimation.grade` (docs/model.md#no-grade-sensor).

use serde::{Deserialize, Serialize};

use super::StudyError;
use super::checker::Checker;
use crate::estimate::estimators::{ESTIMATORS, EstimatorRef};
use crate::estimate::filters::{FilterSettings, GradeSource, Prior};

/// The keys as read (each optional), in a study's and a fit's `[estimation]`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilterKeys {
    /// "measured" (default) or "none".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grade: Option<String>,
    /// \[m/s per step\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_process_sd: Option<f64>,
    /// \[rad²/m\], one level per condition.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grade_walk: Option<Vec<f64>>,
    /// \[kg\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prior_mass: Option<f64>,
    /// \[kg\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prior_mass_sd: Option<f64>,
    /// \[rad\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grade_sd0: Option<f64>,
    /// λ₁ of rls_mf.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub forgetting_mass: Option<f64>,
    /// λ₂ of rls_mf.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub forgetting_grade: Option<f64>,
    /// \[s\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub difference_window: Option<f64>,
}

/// The vehicle's values the filters take as known.
#[derive(Debug, Clone, Copy)]
pub(super) struct KnownVehicle {
    /// Its mass \[kg\] (the prior's default mean).
    pub mass_kg: f64,
    /// Cd.
    pub drag_coefficient: f64,
    /// Cr.
    pub rolling: f64,
}

/// `estimation.grade` and the filters' settings: each key in its range, the filters' keys
/// only with a filter listed, `rls_mf`'s only with it listed; the prior's mean the vehicle's
/// mass and its SD a sixth of it by default. Also the levels of `grade_walk` (an axis; the
/// settings hold the first).
pub(super) fn validate_filter_keys(
    keys: &FilterKeys,
    estimators: &[EstimatorRef],
    vehicle: KnownVehicle,
    c: &Checker<'_>,
) -> Result<(GradeSource, FilterSettings, Vec<f64>), StudyError> {
    let grade = match keys.grade.as_deref() {
        None => GradeSource::Measured,
        Some(name) => c.named(
            "estimation.grade",
            name,
            &[
                ("measured", GradeSource::Measured),
                ("none", GradeSource::None),
            ],
        )?,
    };
    let listed = |name: &str| estimators.iter().any(|e| e.name() == name);
    let filters: Vec<&str> = ESTIMATORS
        .iter()
        .filter(|e| e.estimates_grade())
        .map(|e| e.name())
        .collect();
    let any_filter = estimators.iter().any(|e| e.estimates_grade());
    let only = |key: &str, value: Option<f64>, applies: bool, to: &str| match value {
        Some(_) if !applies => Err(c.fail(
            &format!("estimation.{key}"),
            format!("applies to {to}, which estimation.estimators does not list"),
        )),
        _ => Ok(value),
    };
    let to_filters = format!("the {} estimators", filters.join(" and "));
    let d = FilterSettings::default();
    let positive = |key: &str, value: Option<f64>, default: f64| -> Result<f64, StudyError> {
        let value = only(key, value, any_filter, &to_filters)?;
        value.map_or(Ok(default), |v| c.positive(&format!("estimation.{key}"), v))
    };
    let prior_mass = positive("prior_mass", keys.prior_mass, vehicle.mass_kg)?;
    let prior = Prior {
        mass_kg: prior_mass,
        mass_sd_kg: positive("prior_mass_sd", keys.prior_mass_sd, prior_mass / 6.0)?,
        grade_sd_rad: positive("grade_sd0", keys.grade_sd0, d.prior.grade_sd_rad)?,
    };
    let forgetting = |key: &str, value: Option<f64>, default: f64| {
        let value = only(key, value, listed("rls_mf"), "the rls_mf estimator")?;
        match value {
            Some(l) if !(l > 0.0 && l <= 1.0) => Err(c.fail(
                &format!("estimation.{key}"),
                format!("must lie in (0, 1] (1: no forgetting), got {l}"),
            )),
            Some(l) => Ok(l),
            None => Ok(default),
        }
    };
    let walks = match &keys.grade_walk {
        Some(_) if !any_filter => {
            return Err(c.fail(
                "estimation.grade_walk",
                format!("applies to {to_filters}, which estimation.estimators does not list"),
            ));
        }
        Some(levels) => c.list("estimation.grade_walk", levels, |c, k, v| c.positive(k, v))?,
        None => vec![d.grade_walk],
    };
    let window = only(
        "difference_window",
        keys.difference_window,
        listed("rls_mf"),
        "the rls_mf estimator",
    )?;
    Ok((
        grade,
        FilterSettings {
            prior,
            speed_process_sd: positive(
                "speed_process_sd",
                keys.speed_process_sd,
                d.speed_process_sd,
            )?,
            grade_walk: walks[0],
            forgetting_mass: forgetting("forgetting_mass", keys.forgetting_mass, 1.0)?,
            forgetting_grade: forgetting("forgetting_grade", keys.forgetting_grade, 0.999)?,
            difference_window_s: window.map_or(Ok(d.difference_window_s), |w| {
                c.positive("estimation.difference_window", w)
            })?,
            drag_coefficient: vehicle.drag_coefficient,
            rolling: vehicle.rolling,
        },
        walks,
    ))
}

/// With `estimation.grade = "none"` no grade signal reaches an estimator: one that reads
/// the grade's column (all but the filters) needs an accelerometer, whose output holds the
/// grade (`accelerometer`: every acceleration source is the model's), and no grade sensor's
/// noise, offset or map error may be set (`grade_keys`: the keys of those set, first).
pub(super) fn check_grade_none(
    grade: GradeSource,
    estimators: &[EstimatorRef],
    accelerometer: bool,
    grade_keys: &[&str],
    c: &Checker<'_>,
) -> Result<(), StudyError> {
    if grade == GradeSource::Measured {
        return Ok(());
    }
    if let Some(key) = grade_keys.first() {
        return Err(c.fail(
            key,
            "is a grade sensor's error, but estimation.grade = \"none\" reads no grade",
        ));
    }
    if accelerometer {
        return Ok(());
    }
    match estimators.iter().position(|e| !e.estimates_grade()) {
        Some(i) => {
            let filters: Vec<&str> = ESTIMATORS
                .iter()
                .filter(|e| e.estimates_grade())
                .map(|e| e.name())
                .collect();
            Err(c.fail(
                &format!("estimation.estimators[{i}]"),
                format!(
                    "{} reads the grade, which estimation.grade = \"none\" takes away: it needs \
                     an accelerometer (estimation.acceleration = \"model\", whose output holds \
                     the grade; cos θ is then taken as 1), or an estimator that estimates the \
                     grade with the mass, {filters:?}",
                    estimators[i].name()
                ),
            ))
        }
        None => Ok(()),
    }
}

/// What the filters need of the rows: consecutive samples of one drive (no row selection,
/// no coast-down's runs), the vehicle's speed (not an air speed) and the truth's grade in
/// the regression (no grade offset or map error, which the regression's grade carries):
/// `conflicts` are the keys set against that, first.
pub(super) fn check_filter_inputs(
    estimators: &[EstimatorRef],
    conflicts: &[(&str, &str)],
    c: &Checker<'_>,
) -> Result<(), StudyError> {
    let Some(filter) = estimators.iter().find(|e| e.estimates_grade()) else {
        return Ok(());
    };
    match conflicts.first() {
        Some((key, why)) => {
            Err(c.fail(key, format!("cannot be used with {}: {why}", filter.name())))
        }
        None => Ok(()),
    }
}
