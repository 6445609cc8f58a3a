//! The study file exactly as written: serde structs, no checks beyond types.
//!
//! `deny_unknown_fields` everywhere so a misspelt key is an error, not a silent default.
//! These structs also serialise back, which is how the study "as run" is stored in every
//! output file's metadata.

use serde::{Deserialize, Serialize};

fn default_model() -> String {
    "vehicle".to_string()
}

/// Top level of a study file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawStudy {
    /// Free-text study name.
    pub name: String,
    /// Master seed (≥ 0).
    pub seed: i64,
    /// Realisations per condition (≥ 1).
    pub realisations: i64,
    /// Which model the study runs; defaults to "vehicle".
    #[serde(default = "default_model")]
    pub model: String,
    /// `[vehicle]`: the vehicle's parameters.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vehicle: Option<RawVehicle>,
    /// `[drive]`: the drive cycle.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drive: Option<RawDrive>,
    /// `[terrain]`: the road profile and its scales.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub terrain: Option<RawTerrain>,
    /// `[noise]`: measurement-noise axes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise: Option<RawNoise>,
    /// `[estimation]`: estimators to run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub estimation: Option<RawEstimation>,
    /// `[line_fit]`: the worked example of thesis §3.2–3.3 (model = "line_fit").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub line_fit: Option<RawLineFit>,
}

/// `[vehicle]`
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawVehicle {
    pub mass: f64,
    pub drag_coefficient: f64,
    pub rolling_resistance: f64,
    pub frontal_area: f64,
    pub air_density: f64,
    pub gravity: f64,
    pub final_drive_ratio: f64,
    pub wheel_radius: f64,
}

/// `[drive]`
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawDrive {
    pub duration: f64,
    pub time_step: f64,
    pub initial_speed: f64,
    pub torque_mean: f64,
    pub torque_amplitude: f64,
    pub torque_frequency: f64,
}

/// `[terrain]`: the keys every profile has, and the profile's own keys (e.g. `height` and
/// `period` of `cos2`), which the profile reads and checks itself (unknown keys included:
/// serde cannot deny unknown fields next to a flattened table).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RawTerrain {
    pub profile: String,
    #[serde(flatten)]
    pub params: toml::Table,
    pub length: u64,
    pub scales: Vec<f64>,
    pub scale_applies_to: String,
}

/// `[noise]`
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawNoise {
    pub velocity_sd: Vec<f64>,
    pub output_sd: Vec<f64>,
    #[serde(default = "zero_axis")]
    pub grade_sd: Vec<f64>,
    #[serde(default = "zero_axis")]
    pub force_sd: Vec<f64>,
}

fn zero_axis() -> Vec<f64> {
    vec![0.0]
}

/// `[line_fit]`
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawLineFit {
    pub intercept: f64,
    pub slope: f64,
    pub t_start: f64,
    pub t_step: f64,
    pub t_end: f64,
    pub assumed_sd: f64,
    pub noise: Vec<String>,
    pub noise_sd: Vec<f64>,
}

/// `[estimation]`
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawEstimation {
    pub estimators: Vec<String>,
}
