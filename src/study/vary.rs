//! Typed edits of a validated study: one setting given one value, the result validated
//! exactly as a study file is. `design` searches over such a setting (docs/model.md#design);
//! the study stays typed throughout, with no text written to be parsed again.

use std::sync::LazyLock;

use super::{Study, StudyError};
use crate::dynamics::truth::{MODEL_ERROR_COUNT, MODEL_ERRORS, ModelErrorEntry};
use crate::dynamics::{DRIVE_MODES, RUN_PAIR};
use crate::estimate::channels::{Channel, Signal};

/// A setting of a vehicle study that can be given one value by [`Study::varied`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VariedKey {
    /// `drive.duration` \[s\] (a drive mode with a duration, e.g. `torque`).
    Duration,
    /// `drive.runs`: the one level of a coast-down's number of runs, an even positive
    /// integer (a drive mode made of runs, docs/model.md#coastdown).
    Runs,
    /// `terrain.scale`: the one entry of `terrain.scales`.
    Scale,
    /// `noise.velocity_sd` \[m/s\]: the one level of the speed noise.
    VelocitySd,
    /// `truth.<key>`: the one value of a model error that is a condition axis.
    Truth(TruthKey),
}

/// A steady model error of [`MODEL_ERRORS`] that is a condition axis (`axis: true`,
/// `drawn: false`): the `[truth]` keys [`Study::varied`] can set. Only the registry makes
/// one, so every such entry is one and no other is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TruthKey(usize);

impl TruthKey {
    /// Every steady model error that is an axis, in the registry's order.
    pub fn all() -> impl Iterator<Item = TruthKey> {
        (0..MODEL_ERROR_COUNT)
            .filter(|&i| MODEL_ERRORS[i].axis && !MODEL_ERRORS[i].drawn)
            .map(TruthKey)
    }

    /// Its entry of [`MODEL_ERRORS`].
    pub fn entry(self) -> &'static ModelErrorEntry {
        &MODEL_ERRORS[self.0]
    }
}

/// `truth.<key>` of every entry of [`MODEL_ERRORS`], by index (their command-line names).
static TRUTH_NAMES: LazyLock<[String; MODEL_ERROR_COUNT]> =
    LazyLock::new(|| MODEL_ERRORS.map(|e| format!("truth.{}", e.key)));

impl VariedKey {
    /// Every key, as named on the command line: the fixed ones, then each model error that
    /// is an axis.
    pub fn all() -> Vec<VariedKey> {
        [
            VariedKey::Duration,
            VariedKey::Runs,
            VariedKey::Scale,
            VariedKey::VelocitySd,
        ]
        .into_iter()
        .chain(TruthKey::all().map(VariedKey::Truth))
        .collect()
    }

    /// The name on the command line and in `design.parquet`.
    pub fn name(self) -> &'static str {
        match self {
            VariedKey::Duration => "drive.duration",
            VariedKey::Runs => "drive.runs",
            VariedKey::Scale => "terrain.scale",
            VariedKey::VelocitySd => "noise.velocity_sd",
            VariedKey::Truth(t) => &TRUTH_NAMES[t.0],
        }
    }

    /// The key's unit (`-` when dimensionless; `runs` for the number of runs).
    pub fn unit(self) -> &'static str {
        match self {
            VariedKey::Duration => "s",
            VariedKey::Runs => "runs",
            VariedKey::Scale => "-",
            VariedKey::VelocitySd => Channel::of(Signal::Speed).unit(),
            VariedKey::Truth(t) => match t.entry().unit {
                "" => "-",
                unit => unit,
            },
        }
    }

    /// Whether the key's values must be positive: a duration, a number of runs, a scale or
    /// a noise level. A model error takes the values its entry accepts, which the varied
    /// study checks.
    pub fn positive(self) -> bool {
        !matches!(self, VariedKey::Truth(_))
    }

    /// The step the key's values are whole multiples of when it is a count: [`RUN_PAIR`]
    /// for `drive.runs` (an even number of runs, a run each way per pair). `None`: the key
    /// is a real number (a duration's time step is the study's, not the key's).
    pub fn count_step(self) -> Option<usize> {
        match self {
            VariedKey::Runs => Some(RUN_PAIR),
            _ => None,
        }
    }

    /// Parse a command-line name; an unknown one is refused with every accepted name (and,
    /// for a `[truth]` key that is not an axis, why).
    pub fn parse(text: &str) -> Result<VariedKey, String> {
        let all = VariedKey::all();
        if let Some(key) = all.iter().find(|k| k.name() == text) {
            return Ok(*key);
        }
        let names: Vec<&str> = all.iter().map(|k| k.name()).collect();
        let not_axis = MODEL_ERRORS
            .iter()
            .find(|e| (!e.axis || e.drawn) && text.strip_prefix("truth.") == Some(e.key));
        Err(match not_axis {
            Some(e) if e.drawn => format!(
                "\"{text}\" ({}) is drawn anew in every realisation, and design predicts \
                 only the steady model errors; the keys design varies are {names:?}",
                e.name
            ),
            Some(e) => format!(
                "\"{text}\" ({}) takes one value per study, not a list of conditions, so \
                 design cannot vary it; the keys design varies are {names:?}",
                e.name
            ),
            None => format!("unknown key \"{text}\"; expected one of {names:?}"),
        })
    }
}

impl Study {
    /// This study with `key` set to `value` (a list of that one value, for an axis; a
    /// `[truth]` key in a `[truth]` table made when the study has none), validated as a
    /// study file is; errors name this study's file with the edit
    /// (`study.toml with drive.duration = 60`) and the key.
    pub fn varied(&self, key: VariedKey, value: f64) -> Result<Study, StudyError> {
        let origin = format!("{} with {} = {value}", self.origin, key.name());
        let fail = |at: &str, reason: String| StudyError {
            file: origin.clone(),
            key: Some(at.to_string()),
            line: self.spans.line(at),
            reason,
        };
        let mut raw = self.raw.clone();
        match key {
            VariedKey::Duration => {
                let has_duration = self
                    .vehicle()
                    .is_some_and(|v| v.drive.duration_step().is_some());
                match raw.drive.as_mut() {
                    Some(drive) if has_duration => {
                        drive
                            .params
                            .insert("duration".into(), toml::Value::Float(value));
                    }
                    _ => {
                        return Err(fail(
                            "drive.duration",
                            "the study's drive mode has no duration (a speed trace lasts as \
                             long as its log; vary it with drive.durations in a run)"
                                .into(),
                        ));
                    }
                }
            }
            VariedKey::Runs => {
                let has_runs = self.vehicle().is_some_and(|v| v.drive.runs().is_some());
                match raw.drive.as_mut() {
                    Some(drive) if has_runs => {
                        // A whole number is written as a TOML integer, as a study file
                        // gives it; any other value is written as it is, and refused by the
                        // validation below as a file's would be.
                        let level = if value.fract() == 0.0 && value.abs() < i64::MAX as f64 {
                            toml::Value::Integer(value as i64)
                        } else {
                            toml::Value::Float(value)
                        };
                        drive
                            .params
                            .insert("runs".into(), toml::Value::Array(vec![level]));
                    }
                    _ => {
                        let mode = raw
                            .drive
                            .as_ref()
                            .and_then(|d| d.mode.clone())
                            .unwrap_or_else(|| DRIVE_MODES[0].name.to_string());
                        let with_runs: Vec<&str> = DRIVE_MODES
                            .iter()
                            .filter(|m| m.keys.contains(&"runs"))
                            .map(|m| m.name)
                            .collect();
                        return Err(fail(
                            "drive.runs",
                            format!(
                                "the study's drive mode \"{mode}\" has no runs (its cycle is \
                                 one run); drive.runs is a key of drive.mode {with_runs:?}"
                            ),
                        ));
                    }
                }
            }
            VariedKey::Scale => match raw.terrain.as_mut() {
                Some(terrain) => terrain.scales = Some(vec![value]),
                None => {
                    return Err(fail(
                        "terrain.scales",
                        "the study has no [terrain] table".into(),
                    ));
                }
            },
            VariedKey::VelocitySd => match raw.noise.as_mut() {
                Some(noise) => {
                    noise.0.insert(
                        Channel::of(Signal::Speed).key().into(),
                        toml::Value::Array(vec![toml::Value::Float(value)]),
                    );
                }
                None => {
                    return Err(fail(
                        "noise.velocity_sd",
                        "the study has no [noise] table".into(),
                    ));
                }
            },
            VariedKey::Truth(t) => {
                raw.truth.get_or_insert_with(toml::Table::new).insert(
                    t.entry().key.into(),
                    toml::Value::Array(vec![toml::Value::Float(value)]),
                );
            }
        }
        super::validate_any(raw, self.spans.clone(), &origin, self.dir.clone())
    }
}
