//! The [`Checker`] of one study or fit file: the value checks every key goes through, each
//! failure a [`StudyError`] at the key's line, and where a misplaced key belongs instead.

use std::path::Path;

use super::{KeySpans, StudyError};
use crate::settings::one_or_many;

/// Where a key unknown in a table belongs instead, in words (`None`: nowhere), for one kind
/// of file: `(table, key, variant)` as [`placement::elsewhere`](super::placement::elsewhere)
/// takes them.
pub(super) type Placement = fn(&str, &str, Option<(&str, &str)>) -> Option<String>;

/// Collects value checks for one study (or fit file); the first failure wins.
pub(super) struct Checker<'a> {
    spans: &'a KeySpans,
    origin: &'a str,
    dir: &'a Path,
    place: Placement,
}

impl<'a> Checker<'a> {
    /// The checks of the file `origin` in `dir` indexed by `spans`, whose misplaced keys
    /// `place` places.
    pub(super) fn new(
        spans: &'a KeySpans,
        origin: &'a str,
        dir: &'a Path,
        place: Placement,
    ) -> Self {
        Checker {
            spans,
            origin,
            dir,
            place,
        }
    }

    /// Where `key`, unknown in `[table]`, belongs instead (see [`Placement`]).
    pub(super) fn elsewhere(
        &self,
        table: &str,
        key: &str,
        variant: Option<(&str, &str)>,
    ) -> Option<String> {
        (self.place)(table, key, variant)
    }

    /// An error at `key`, with the line of the key or, for a missing key, of the nearest
    /// enclosing one (`terrain.components[0]` for a missing `terrain.components[0].phase`).
    pub(super) fn fail(&self, key: &str, reason: impl Into<String>) -> StudyError {
        let mut path = key;
        let line = loop {
            if let Some(line) = self.spans.line(path) {
                break Some(line);
            }
            match path.rfind(['.', '[']) {
                Some(i) => path = &path[..i],
                None => break None,
            }
        };
        StudyError {
            file: self.origin.to_string(),
            key: Some(key.to_string()),
            line,
            reason: reason.into(),
        }
    }

    /// The file checked (for messages).
    pub(super) fn origin(&self) -> &str {
        self.origin
    }

    /// The value named `name` at `key`, one of `named` (name, value) pairs.
    pub(super) fn named<T: Copy>(
        &self,
        key: &str,
        name: &str,
        named: &[(&'static str, T)],
    ) -> Result<T, StudyError> {
        match named.iter().find(|(n, _)| *n == name) {
            Some((_, value)) => Ok(*value),
            None => {
                let names: Vec<&str> = named.iter().map(|(n, _)| *n).collect();
                Err(self.fail(key, format!("must be one of {names:?}, got \"{name}\"")))
            }
        }
    }

    /// The directory of the study file, against which the paths it names are resolved.
    pub(super) fn dir(&self) -> &Path {
        self.dir
    }

    pub(super) fn missing_table(&self, key: &str) -> StudyError {
        StudyError {
            file: self.origin.to_string(),
            key: Some(key.to_string()),
            line: None,
            reason: format!("required table [{key}] is missing"),
        }
    }

    pub(super) fn finite(&self, key: &str, v: f64) -> Result<f64, StudyError> {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.fail(
                key,
                format!("must be a finite number, got {}", crate::settings::shown(v)),
            ))
        }
    }

    pub(super) fn positive(&self, key: &str, v: f64) -> Result<f64, StudyError> {
        let v = self.finite(key, v)?;
        if v > 0.0 {
            Ok(v)
        } else {
            Err(self.fail(
                key,
                format!("must be > 0, got {}", crate::settings::shown(v)),
            ))
        }
    }

    pub(super) fn non_negative(&self, key: &str, v: f64) -> Result<f64, StudyError> {
        let v = self.finite(key, v)?;
        if v >= 0.0 {
            Ok(v)
        } else {
            Err(self.fail(
                key,
                format!("must be >= 0, got {}", crate::settings::shown(v)),
            ))
        }
    }

    /// A TOML list of numbers (integers read as floats); one number stands for the list of
    /// that number.
    pub(super) fn numbers(&self, key: &str, value: &toml::Value) -> Result<Vec<f64>, StudyError> {
        let reason = || format!("must be a number or a list of numbers, got {value}");
        one_or_many(value)
            .iter()
            .map(|v| match v {
                toml::Value::Float(x) => Ok(*x),
                toml::Value::Integer(i) => Ok(*i as f64),
                _ => Err(self.fail(key, reason())),
            })
            .collect()
    }

    /// A non-empty list whose items each pass `item`.
    pub(super) fn list(
        &self,
        key: &str,
        values: &[f64],
        item: impl Fn(&Self, &str, f64) -> Result<f64, StudyError>,
    ) -> Result<Vec<f64>, StudyError> {
        if values.is_empty() {
            return Err(self.fail(key, "must list at least one value"));
        }
        let checked: Vec<f64> = values
            .iter()
            .enumerate()
            .map(|(i, &v)| item(self, &format!("{key}[{i}]"), v))
            .collect::<Result<_, _>>()?;
        // An axis's values are conditions: one listed twice would be two identical
        // conditions, each with its own draws.
        if let Some((first, again)) = crate::settings::first_repeat(&checked) {
            return Err(self.fail(
                &format!("{key}[{again}]"),
                format!(
                    "{} is listed twice (also at {key}[{first}]); each value of an axis is one \
                     condition",
                    crate::settings::shown(checked[again])
                ),
            ));
        }
        Ok(checked)
    }
}

/// The error for `key`, which `[table]` does not have: where it belongs, if another table
/// of the checked file's kind has it, else the keys `[table]` does have.
pub(super) fn unknown_key(
    c: &Checker<'_>,
    table: &str,
    key: &str,
    expected: Vec<&str>,
    variant: Option<(&str, &str)>,
) -> StudyError {
    let reason = match c.elsewhere(table, key, variant) {
        Some(place) => format!("unknown field `{key}` in [{table}]: {place}"),
        None => format!("unknown field `{key}`, expected one of {expected:?}"),
    };
    c.fail(&format!("{table}.{key}"), reason)
}
