//! The study file exactly as written: serde structs, no checks beyond types.
//!
//! `deny_unknown_fields` wherever the keys are fixed, so a misspelt key is an error, not a
//! silent default (the open tables are checked key by key in validation).
//! These structs also serialise back, which is how the study "as run" is stored in every
//! output file's metadata.

use std::collections::BTreeMap;

use serde::de::{self, IntoDeserializer, SeqAccess, Visitor};
use serde::ser::SerializeMap;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::estimate::channels::Channel;

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
    /// `[truth]`: how the simulated vehicle differs from the regression's equation (each
    /// key read by its model error, in `truth.rs`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub truth: Option<toml::Table>,
    /// `[fleet]`: one condition per vehicle of a table (read key by key, in `fleet/`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fleet: Option<toml::Table>,
    /// `[campaign]`: a coast-down campaign's criterion (read key by key, in `campaign.rs`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub campaign: Option<toml::Table>,
    /// `[line_fit]`: the worked example of thesis §3.2–3.3 (model = "line_fit").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub line_fit: Option<RawLineFit>,
}

/// `[vehicle]`
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawVehicle {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mass: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drag_coefficient: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rolling_resistance: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub road_load_a: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub road_load_b: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub road_load_c: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test_mass: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub road_load_a_lbf: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub road_load_b_lbf_per_mph: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub road_load_c_lbf_per_mph2: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test_weight_lb: Option<f64>,
    pub frontal_area: f64,
    pub air_density: f64,
    pub gravity: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub final_drive_ratio: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wheel_radius: Option<f64>,
}

/// `[drive]`: the drive mode (absent: the first of the drive modes, `torque`) and the mode's
/// own keys, which the mode reads and checks itself.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RawDrive {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mode: Option<String>,
    #[serde(flatten)]
    pub params: toml::Table,
}

/// `[terrain]`: the keys every profile has, and the profile's own keys (e.g. `height` and
/// `period` of `cos2`), which the profile reads and checks itself (unknown keys included:
/// serde cannot deny unknown fields next to a flattened table).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RawTerrain {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub profile: Option<String>,
    #[serde(flatten)]
    pub params: toml::Table,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub length: Option<u64>,
    #[serde(
        default,
        deserialize_with = "some_one_or_many",
        skip_serializing_if = "Option::is_none"
    )]
    pub scales: Option<Vec<f64>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale_applies_to: Option<String>,
}

/// `[noise]`: a list of levels per channel key (`velocity_sd`, …) and the optional keys
/// (lists, or the `share_across_scales` switch). Validation checks the keys and their types
/// and fills in the defaults; the channels serialise in channel order, so the study as run
/// reads the same whatever order the file had.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(transparent)]
pub struct RawNoise(pub BTreeMap<String, toml::Value>);

impl Serialize for RawNoise {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let known = Channel::ALL.map(Channel::key);
        let ordered = known
            .iter()
            .filter_map(|k| self.0.get_key_value(*k))
            .chain(self.0.iter().filter(|(k, _)| !known.contains(&k.as_str())));
        let mut map = serializer.serialize_map(Some(self.0.len()))?;
        for (k, v) in ordered {
            map.serialize_entry(k, v)?;
        }
        map.end()
    }
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
    #[serde(deserialize_with = "one_or_many")]
    pub noise: Vec<String>,
    #[serde(deserialize_with = "one_or_many")]
    pub noise_sd: Vec<f64>,
}

/// `[estimation]`
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawEstimation {
    #[serde(deserialize_with = "one_or_many")]
    pub estimators: Vec<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub forgetting: Option<f64>,
    /// A name or a list of names (an axis).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub acceleration: Option<toml::Value>,
    /// What the drag regressor reads: "ground" or "measured".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub air_speed: Option<String>,
    /// Whether the mass is weighed (known): the estimators fit \[Cd/M, Cr\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub known_mass: Option<bool>,
    /// The rotating-mass factor `road_load` assumes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub effective_mass_factor: Option<f64>,
    /// "measured" or "none".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grade: Option<String>,
    /// The filters' speed process noise per step \[m/s\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_process_sd: Option<f64>,
    /// The filters' grade walk \[rad²/m\]: a number or a list (an axis).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "some_one_or_many"
    )]
    pub grade_walk: Option<Vec<f64>>,
    /// The filters' prior mass \[kg\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prior_mass: Option<f64>,
    /// Its SD \[kg\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prior_mass_sd: Option<f64>,
    /// The filters' prior SD of the grade \[rad\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grade_sd0: Option<f64>,
    /// `rls_mf`'s forgetting factor of 1/M.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub forgetting_mass: Option<f64>,
    /// `rls_mf`'s forgetting factor of the grade term.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub forgetting_grade: Option<f64>,
    /// `rls_mf`'s difference half-width \[s\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub difference_window: Option<f64>,
}

impl RawEstimation {
    /// The keys of the filters and of the grade's source.
    pub(super) fn filter_keys(&self) -> super::filter_keys::FilterKeys {
        super::filter_keys::FilterKeys {
            grade: self.grade.clone(),
            speed_process_sd: self.speed_process_sd,
            grade_walk: self.grade_walk.clone(),
            prior_mass: self.prior_mass,
            prior_mass_sd: self.prior_mass_sd,
            grade_sd0: self.grade_sd0,
            forgetting_mass: self.forgetting_mass,
            forgetting_grade: self.forgetting_grade,
            difference_window: self.difference_window,
        }
    }
}

/// A list, or one value standing for the list of that value (`scales = 1.0` is
/// `scales = [1.0]`); the study as run always lists it.
pub(super) fn one_or_many<'de, D, T>(d: D) -> Result<Vec<T>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    struct OneOrMany<T>(std::marker::PhantomData<T>);

    impl<'de, T: Deserialize<'de>> OneOrMany<T> {
        fn one<E: de::Error>(value: impl IntoDeserializer<'de, E>) -> Result<Vec<T>, E> {
            T::deserialize(value.into_deserializer()).map(|t| vec![t])
        }
    }

    impl<'de, T: Deserialize<'de>> Visitor<'de> for OneOrMany<T> {
        type Value = Vec<T>;

        fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str("a list, or one value")
        }

        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Vec<T>, A::Error> {
            let mut items = Vec::new();
            while let Some(item) = seq.next_element()? {
                items.push(item);
            }
            Ok(items)
        }

        fn visit_f64<E: de::Error>(self, v: f64) -> Result<Vec<T>, E> {
            Self::one(v)
        }

        fn visit_i64<E: de::Error>(self, v: i64) -> Result<Vec<T>, E> {
            Self::one(v)
        }

        fn visit_u64<E: de::Error>(self, v: u64) -> Result<Vec<T>, E> {
            Self::one(v)
        }

        fn visit_bool<E: de::Error>(self, v: bool) -> Result<Vec<T>, E> {
            Self::one(v)
        }

        fn visit_str<E: de::Error>(self, v: &str) -> Result<Vec<T>, E> {
            Self::one(v.to_string())
        }
    }

    d.deserialize_any(OneOrMany(std::marker::PhantomData))
}

/// [`one_or_many`] for an optional key.
fn some_one_or_many<'de, D, T>(d: D) -> Result<Option<Vec<T>>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    one_or_many(d).map(Some)
}
