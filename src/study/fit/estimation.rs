//! A fit file's `[estimation]` as written.

use serde::Deserialize;

use crate::study::raw::one_or_many;

/// `[estimation]`: a study's, without the acceleration axis (a fit's acceleration is the
/// log's: its `acceleration_column`, else differentiated).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(in crate::study) struct RawFitEstimation {
    /// The estimators named.
    #[serde(deserialize_with = "one_or_many")]
    pub(super) estimators: Vec<String>,
    /// `rls`'s forgetting factor.
    #[serde(default)]
    pub(super) forgetting: Option<f64>,
    /// Whether the mass is weighed.
    #[serde(default)]
    pub(super) known_mass: Option<bool>,
    /// The rotating-mass factor `road_load` assumes.
    #[serde(default)]
    pub(super) effective_mass_factor: Option<f64>,
    /// "measured" or "none".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) grade: Option<String>,
    /// The filters' speed process noise per step \[m/s\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) speed_process_sd: Option<f64>,
    /// The filters' grade walk \[rad²/m\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) grade_walk: Option<f64>,
    /// The filters' prior mass \[kg\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) prior_mass: Option<f64>,
    /// Its SD \[kg\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) prior_mass_sd: Option<f64>,
    /// The filters' prior SD of the grade \[rad\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) grade_sd0: Option<f64>,
    /// `rls_mf`'s forgetting factor of 1/M.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) forgetting_mass: Option<f64>,
    /// `rls_mf`'s forgetting factor of the grade term.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) forgetting_grade: Option<f64>,
    /// `rls_mf`'s difference half-width \[s\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) difference_window: Option<f64>,
}

impl RawFitEstimation {
    /// The keys of the filters and of the grade's source.
    pub(super) fn filter_keys(&self) -> crate::study::filter_keys::FilterKeys {
        crate::study::filter_keys::FilterKeys {
            grade: self.grade.clone(),
            speed_process_sd: self.speed_process_sd,
            grade_walk: self.grade_walk.map(|g| vec![g]),
            prior_mass: self.prior_mass,
            prior_mass_sd: self.prior_mass_sd,
            grade_sd0: self.grade_sd0,
            forgetting_mass: self.forgetting_mass,
            forgetting_grade: self.forgetting_grade,
            difference_window: self.difference_window,
        }
    }
}
