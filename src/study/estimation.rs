//! The checks of `[estimation]` that every model's validation shares: the estimators named
//! ([`validate_estimators`]) and their settings ([`validate_estimation`]).

use super::StudyError;
use super::checker::Checker;
use super::filter_keys::{FilterKeys, KnownVehicle, validate_filter_keys};
use crate::estimate::estimators::{ESTIMATORS, EstimatorRef, EstimatorSettings};
use crate::estimate::parameters::Parameters;

pub(super) fn validate_estimators(
    names: &[String],
    allowed: &[EstimatorRef],
    c: &Checker<'_>,
) -> Result<Vec<EstimatorRef>, StudyError> {
    if names.is_empty() {
        return Err(c.fail("estimation.estimators", "must list at least one estimator"));
    }
    let mut estimators = Vec::new();
    for (i, name) in names.iter().enumerate() {
        let key = format!("estimation.estimators[{i}]");
        let kind = EstimatorRef::find(name)
            .filter(|k| allowed.contains(k))
            .ok_or_else(|| {
                let known: Vec<_> = allowed.iter().map(|e| e.name()).collect();
                c.fail(
                    &key,
                    format!("unknown estimator \"{name}\"; expected one of {known:?}"),
                )
            })?;
        if estimators.contains(&kind) {
            return Err(c.fail(&key, format!("estimator \"{name}\" is listed twice")));
        }
        estimators.push(kind);
    }
    Ok(estimators)
}

/// The keys of `[estimation]` that set [`EstimatorSettings`], as read.
#[derive(Debug, Clone)]
pub(super) struct SettingKeys {
    /// `forgetting`.
    pub forgetting: Option<f64>,
    /// The weighed 1/M \[1/kg\] when `known_mass` is true.
    pub known_inv_mass: Option<f64>,
    /// `effective_mass_factor`.
    pub effective_mass_factor: Option<f64>,
    /// `grade` and the filters' keys.
    pub filter: FilterKeys,
    /// The vehicle's values the filters take as known.
    pub vehicle: KnownVehicle,
}

/// `[estimation]`'s `estimators` (any of the registry, none twice), `forgetting` (in
/// (0, 1], 1 when absent, and only with rls listed) and `effective_mass_factor` (≥ 0, 0 when
/// absent, only with road_load listed): the estimators and their settings, which fit every
/// parameter unless `keys.known_inv_mass` gives the weighed 1/M (`estimation.known_mass`;
/// an estimator that needs it is refused without it); and the levels of the filters'
/// `grade_walk`.
pub(super) fn validate_estimation(
    names: &[String],
    keys: SettingKeys,
    c: &Checker<'_>,
) -> Result<(Vec<EstimatorRef>, EstimatorSettings, Vec<f64>), StudyError> {
    let SettingKeys {
        forgetting,
        known_inv_mass,
        effective_mass_factor,
        filter,
        vehicle,
    } = keys;
    let all: Vec<EstimatorRef> = ESTIMATORS.iter().map(|&e| EstimatorRef(e)).collect();
    let estimators = validate_estimators(names, &all, c)?;
    if known_inv_mass.is_none()
        && let Some(i) = estimators.iter().position(|e| e.needs_known_mass())
    {
        return Err(c.fail(
            &format!("estimation.estimators[{i}]"),
            format!(
                "{} needs the mass known: set estimation.known_mass = true (and the weighed \
                 vehicle.mass)",
                estimators[i].name()
            ),
        ));
    }
    let effective_mass_factor = match effective_mass_factor {
        Some(_) if !estimators.iter().any(|e| e.reads_effective_mass_factor()) => {
            let readers: Vec<&str> = all
                .iter()
                .filter(|e| e.reads_effective_mass_factor())
                .map(|e| e.name())
                .collect();
            return Err(c.fail(
                "estimation.effective_mass_factor",
                format!(
                    "applies to the {} estimator, which estimation.estimators does not list",
                    readers.join(", ")
                ),
            ));
        }
        Some(d) if !(d >= 0.0 && d.is_finite()) => {
            return Err(c.fail(
                "estimation.effective_mass_factor",
                format!("must be finite and >= 0 (0: no rotating mass assumed), got {d}"),
            ));
        }
        Some(d) => d,
        None => 0.0,
    };
    if forgetting.is_some() && !estimators.iter().any(|e| e.reads_forgetting()) {
        let readers: Vec<&str> = all
            .iter()
            .filter(|e| e.reads_forgetting())
            .map(|e| e.name())
            .collect();
        return Err(c.fail(
            "estimation.forgetting",
            format!(
                "applies to the {} estimator, which estimation.estimators does not list",
                readers.join(", ")
            ),
        ));
    }
    let forgetting = match forgetting {
        Some(l) if !(l > 0.0 && l <= 1.0) => {
            return Err(c.fail(
                "estimation.forgetting",
                format!("must lie in (0, 1] (1: no forgetting), got {l}"),
            ));
        }
        Some(l) => l,
        None => 1.0,
    };
    let (grade, filter, grade_walks) = validate_filter_keys(&filter, &estimators, vehicle, c)?;
    let parameters = match known_inv_mass {
        Some(inv_mass) => Parameters::KnownMass { inv_mass },
        None => Parameters::All,
    };
    Ok((
        estimators,
        EstimatorSettings {
            forgetting,
            parameters,
            effective_mass_factor,
            grade,
            filter,
        },
        grade_walks,
    ))
}
