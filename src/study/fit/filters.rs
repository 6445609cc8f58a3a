//! What the filters that estimate the grade with the mass need of a fit file.

use super::RawFit;
use crate::estimate::channels::NoiseLevels;
use crate::estimate::estimators::EstimatorRef;
use crate::study::StudyError;
use crate::study::checker::Checker;
use crate::study::spacing::evenly_spaced;

/// What the filters need of a fit file (docs/model.md#fit-no-grade): Cd and Cr in
/// `[vehicle]` (known to them), the prior's mass in `[estimation]` (a fit has no vehicle
/// mass to default it to), the speed sensor's noise (which weighs each speed), consecutive
/// samples (no `min_speed` that removes any), the mass not weighed, no `[systematic]`;
/// and without a filter, no Cd or Cr in `[vehicle]` (the other estimators fit them).
pub(super) fn check_filters(
    raw: &RawFit,
    estimators: &[EstimatorRef],
    noise: &NoiseLevels,
    c: &Checker<'_>,
) -> Result<(), StudyError> {
    let v = &raw.vehicle;
    let Some(filter) = estimators.iter().find(|e| e.estimates_grade()) else {
        let given = [
            ("vehicle.drag_coefficient", v.drag_coefficient),
            ("vehicle.rolling_resistance", v.rolling_resistance),
        ];
        return match given.iter().find(|(_, value)| value.is_some()) {
            Some((key, _)) => Err(c.fail(
                key,
                "is known only to the filters (ekf, rls_mf), which estimation.estimators does \
                 not list; the other estimators fit Cd/M and Cr",
            )),
            None => Ok(()),
        };
    };
    let name = filter.name();
    for (key, value) in [
        ("vehicle.drag_coefficient", v.drag_coefficient),
        ("vehicle.rolling_resistance", v.rolling_resistance),
    ] {
        match value {
            None => {
                return Err(c.fail(
                    key,
                    format!("required key is missing ({name} takes Cd and Cr as known)"),
                ));
            }
            Some(x) => {
                c.non_negative(key, x)?;
            }
        }
    }
    if noise.speed_sd() <= 0.0 {
        return Err(c.fail(
            "noise.velocity_sd",
            format!(
                "required key is missing or 0: {name} weighs each measured speed by the speed \
                 sensor's noise [m/s], which must be positive"
            ),
        ));
    }
    if raw.estimation.prior_mass.is_none() {
        return Err(c.fail(
            "estimation.prior_mass",
            format!("required key is missing ({name} starts from a prior of the mass [kg])"),
        ));
    }
    let conflicts = [
        (
            raw.estimation.known_mass == Some(true),
            "estimation.known_mass",
            "it estimates the mass",
        ),
        (
            raw.log.min_speed.is_some_and(|s| s > 0.0),
            "log.min_speed",
            "it runs along consecutive samples of the log",
        ),
        (
            raw.systematic.is_some(),
            "systematic",
            "the systematic-error budget is not built for the filters",
        ),
    ];
    let set: Vec<(&str, &str)> = conflicts
        .iter()
        .filter(|(on, _, _)| *on)
        .map(|(_, key, why)| (*key, *why))
        .collect();
    crate::study::filter_keys::check_filter_inputs(estimators, &set, c)
}

/// `rls_mf` differentiates the speed over a window of samples sized by the first step: the
/// log's times must be evenly spaced for it (to [`crate::study::EVEN_STEPS_TOLERANCE`]).
pub(super) fn check_filter_log(
    estimators: &[EstimatorRef],
    t: &[f64],
    c: &Checker<'_>,
) -> Result<(), StudyError> {
    match estimators.iter().find(|e| e.name() == "rls_mf") {
        Some(e) if !evenly_spaced(t) => Err(c.fail(
            "log.file",
            format!(
                "{}'s difference window is a number of samples, sized by the first step; the \
                 log's sample times are not evenly spaced",
                e.name()
            ),
        )),
        _ => Ok(()),
    }
}
