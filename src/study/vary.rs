//! Typed edits of a validated study: one setting given one value, the result validated
//! exactly as a study file is. `design` searches over such a setting (docs/model.md#design);
//! the study stays typed throughout, with no text written to be parsed again.

use super::validate::validate;
use super::{Study, StudyError};
use crate::estimate::channels::Channel;

/// A setting of a vehicle study that can be given one value by [`Study::varied`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VariedKey {
    /// `drive.duration` \[s\] (a drive mode with a duration, e.g. `torque`).
    Duration,
    /// `terrain.scale`: the one entry of `terrain.scales`.
    Scale,
    /// `noise.velocity_sd` \[m/s\]: the one level of the speed noise.
    VelocitySd,
}

impl VariedKey {
    /// Every key, as named on the command line.
    pub const ALL: [VariedKey; 3] = [VariedKey::Duration, VariedKey::Scale, VariedKey::VelocitySd];

    /// The name on the command line and in `design.parquet`.
    pub fn name(self) -> &'static str {
        match self {
            VariedKey::Duration => "drive.duration",
            VariedKey::Scale => "terrain.scale",
            VariedKey::VelocitySd => "noise.velocity_sd",
        }
    }

    /// The key's unit.
    pub fn unit(self) -> &'static str {
        match self {
            VariedKey::Duration => "s",
            VariedKey::Scale => "-",
            VariedKey::VelocitySd => Channel::Velocity.unit(),
        }
    }

    /// Parse a command-line name.
    pub fn parse(text: &str) -> Result<VariedKey, String> {
        VariedKey::ALL
            .into_iter()
            .find(|k| k.name() == text)
            .ok_or_else(|| {
                let names: Vec<&str> = VariedKey::ALL.map(VariedKey::name).to_vec();
                format!("unknown key \"{text}\"; expected one of {names:?}")
            })
    }
}

impl Study {
    /// This study with `key` set to `value` (a list of that one value, for an axis),
    /// validated as a study file is; errors name this study's file with the edit
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
                        Channel::Velocity.key().into(),
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
        }
        validate(raw, self.spans.clone(), &origin, self.dir.clone())
    }
}
