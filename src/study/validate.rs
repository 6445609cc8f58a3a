//! Validation: raw TOML values → the checked values of a [`Study`], each failure a
//! [`StudyError`] naming the file, the key, its line and the reason.

use std::path::PathBuf;

use super::checker::{Checker, Placement};
use super::noise::GRADE_MAP_LENGTH;
use super::raw::RawStudy;
use super::{
    KeySpans, MAX_REALISATIONS, ModelSpec, Study, StudyError, line_fit, placement, vehicle,
};
use crate::dynamics::truth::MODEL_ERRORS;
use crate::estimate::channels::Channel;
use crate::settings::one_or_many;

/// Turn a serde/TOML error into one message naming the key and line; an unknown key that
/// `place` finds a home for says where it belongs.
pub(super) fn serde_error(
    err: &toml::de::Error,
    spans: &KeySpans,
    text: &str,
    origin: &str,
    place: Placement,
) -> StudyError {
    let message = err.message().trim().to_string();
    let span = err.span();
    let located = span.as_ref().and_then(|s| spans.key_at(s));
    let line = span.as_ref().map(|s| spans.line_of(s.start));
    // "missing field `x`" points at the enclosing table: name the missing key itself. A key
    // missing at the top level comes with an empty span at the start of the document, which
    // is inside no table (it would otherwise seem to lie in the first key).
    if let Some(field) = message
        .strip_prefix("missing field `")
        .and_then(|rest| rest.strip_suffix('`'))
    {
        let located = located.filter(|_| span.as_ref().is_some_and(|s| !s.is_empty()));
        let key = match &located {
            Some((table, _)) if !table.is_empty() => format!("{table}.{field}"),
            _ => field.to_string(),
        };
        return StudyError {
            file: origin.to_string(),
            key: Some(key),
            line: located.map(|(_, l)| l),
            reason: "required key is missing".into(),
        };
    }
    match located {
        Some((key, key_line)) => {
            let reason = reason_at(&key, message, place);
            StudyError {
                file: origin.to_string(),
                key: Some(key),
                line: Some(key_line),
                reason,
            }
        }
        None => StudyError {
            file: origin.to_string(),
            key: line.and_then(|l| key_on_line(text, l)),
            line,
            reason: format!("TOML syntax error: {message}"),
        },
    }
}

/// Turn the error of deserialising a study given as values (a TOML table with no text, e.g.
/// a dict from Python) into one naming the key by its path; no line. The same reasons as
/// [`serde_error`]'s: a missing key is named itself, an unknown one that `place` finds a
/// home for says where it belongs.
pub(super) fn value_error(
    err: &serde_path_to_error::Error<toml::de::Error>,
    origin: &str,
    place: Placement,
) -> StudyError {
    let message = err.inner().message().trim().to_string();
    let path = err.path().to_string();
    let path = match path.as_str() {
        "." => String::new(),
        p => p.to_string(),
    };
    let fail = |key: String, reason: String| StudyError {
        file: origin.to_string(),
        key: (!key.is_empty()).then_some(key),
        line: None,
        reason,
    };
    if let Some(field) = message
        .strip_prefix("missing field `")
        .and_then(|rest| rest.strip_suffix('`'))
    {
        let key = match path.is_empty() {
            true => field.to_string(),
            false => format!("{path}.{field}"),
        };
        return fail(key, "required key is missing".into());
    }
    let reason = reason_at(&path, message, place);
    fail(path, reason)
}

/// The reason of serde's `message` about the dotted `key`: for an unknown key that `place`
/// finds a home for (`min_speed` under [vehicle]), where it belongs; else the message.
fn reason_at(key: &str, message: String, place: Placement) -> String {
    let (table, field) = key.rsplit_once('.').unwrap_or(("", key));
    match place(table, field, None) {
        Some(place) if message.starts_with("unknown field") => {
            let table = match table {
                "" => "at the top level".to_string(),
                t => format!("in [{t}]"),
            };
            format!("unknown field `{field}` {table}: {place}")
        }
        _ => message,
    }
}

/// For a line that does not parse, the dotted key it seems to assign (`key = …` under the
/// nearest `[table]` header above it), so that syntax errors can name a key too.
fn key_on_line(text: &str, line: usize) -> Option<String> {
    let lines: Vec<&str> = text.lines().collect();
    let this = lines.get(line.checked_sub(1)?)?;
    let (key, _) = this.split_once('=')?;
    let key = key.trim().trim_matches('"');
    if key.is_empty() || key.contains(char::is_whitespace) || key.starts_with('[') {
        return None;
    }
    let table = lines[..line - 1].iter().rev().find_map(|l| {
        let l = l.trim();
        (l.starts_with('[') && !l.starts_with("[[")).then(|| {
            l.trim_start_matches('[')
                .split(']')
                .next()
                .unwrap_or("")
                .trim()
                .to_string()
        })
    });
    Some(match table {
        Some(t) if !t.is_empty() => format!("{t}.{key}"),
        _ => key.to_string(),
    })
}

pub(super) fn check_realisations(r: i128) -> Result<(), String> {
    if r < 1 {
        Err(format!("must be at least 1, got {r}"))
    } else if r > MAX_REALISATIONS as i128 {
        Err(format!("must be at most {MAX_REALISATIONS}, got {r}"))
    } else {
        Ok(())
    }
}

pub(super) fn validate(
    raw: RawStudy,
    spans: KeySpans,
    origin: &str,
    dir: PathBuf,
) -> Result<Study, StudyError> {
    let c = Checker::new(&spans, origin, &dir, placement::elsewhere);
    if raw.name.trim().is_empty() {
        return Err(c.fail("name", "must not be empty"));
    }
    if raw.seed < 0 {
        return Err(c.fail("seed", format!("must be >= 0, got {}", raw.seed)));
    }
    check_realisations(raw.realisations as i128).map_err(|r| c.fail("realisations", r))?;

    let model = match raw.model.as_str() {
        "vehicle" => {
            if raw.line_fit.is_some() {
                return Err(c.fail("line_fit", "is not used by model \"vehicle\""));
            }
            ModelSpec::Vehicle(Box::new(vehicle::validate(&raw, &c)?))
        }
        "line_fit" => {
            let unused = [
                ("vehicle", raw.vehicle.is_some()),
                ("drive", raw.drive.is_some()),
                ("terrain", raw.terrain.is_some()),
                ("noise", raw.noise.is_some()),
                ("truth", raw.truth.is_some()),
                ("campaign", raw.campaign.is_some()),
            ];
            if let Some((key, _)) = unused.iter().find(|(_, present)| *present) {
                return Err(c.fail(key, "is not used by model \"line_fit\""));
            }
            ModelSpec::LineFit(line_fit::validate(&raw, &c)?)
        }
        other => {
            return Err(c.fail(
                "model",
                format!("unknown model \"{other}\"; expected \"vehicle\" or \"line_fit\""),
            ));
        }
    };
    // The study as run lists every channel's levels, defaults included, every list of
    // numbers as floats (`1`, `[1]` and `[1.0]` are the same study), a single number as a
    // float, and `share_across_scales` only when it is on (absent and false are the same
    // study). Likewise every `[truth]` key.
    let mut raw = raw;
    if let Some(n) = raw.noise.as_mut() {
        for (key, value) in n.0.iter_mut() {
            if key == GRADE_MAP_LENGTH {
                *value = single_float(value);
            } else if matches!(
                value,
                toml::Value::Float(_) | toml::Value::Integer(_) | toml::Value::Array(_)
            ) {
                *value = listed_floats(value);
            }
        }
        n.0.retain(|_, v| *v != toml::Value::Boolean(false));
        for channel in Channel::ALL.into_iter().filter(|c| c.own_axis()) {
            if let Some(default) = channel.default_levels() {
                n.0.entry(channel.key().to_string()).or_insert_with(|| {
                    toml::Value::Array(default.iter().map(|&v| toml::Value::Float(v)).collect())
                });
            }
        }
    }
    // A `[truth]` key at its neutral value alone is the key absent, and a table left
    // empty is no table.
    if let Some(t) = raw.truth.as_mut() {
        for entry in &MODEL_ERRORS {
            if let Some(value) = t.get_mut(entry.key) {
                *value = match entry.axis {
                    true => listed_floats(value),
                    false => single_float(value),
                };
                let neutral = toml::Value::Float(entry.neutral);
                let alone = match value {
                    toml::Value::Array(list) => list.as_slice() == [neutral.clone()],
                    v => *v == neutral,
                };
                if alone {
                    t.remove(entry.key);
                }
            }
        }
    }
    if raw.truth.as_ref().is_some_and(|t| t.is_empty()) {
        raw.truth = None;
    }
    // The default air speed is the absent key.
    if let Some(e) = raw.estimation.as_mut()
        && e.air_speed.as_deref() == Some("ground")
    {
        e.air_speed = None;
    }
    // Likewise the durations axis.
    if let Some(durations) = raw
        .drive
        .as_mut()
        .and_then(|d| d.params.get_mut("durations"))
    {
        *durations = listed_floats(durations);
    }
    Ok(Study {
        name: raw.name.clone(),
        seed: raw.seed as u64,
        realisations: raw.realisations as u64,
        model,
        origin: origin.to_string(),
        dir,
        raw,
        spans,
        fleet: None,
    })
}

/// A single number as the study as run writes it: a float.
fn single_float(value: &toml::Value) -> toml::Value {
    match value {
        toml::Value::Integer(i) => toml::Value::Float(*i as f64),
        other => other.clone(),
    }
}

/// A number or a list of numbers as the study as run lists it: a list of floats.
fn listed_floats(value: &toml::Value) -> toml::Value {
    let float = |v: &toml::Value| match v {
        toml::Value::Integer(i) => toml::Value::Float(*i as f64),
        other => other.clone(),
    };
    toml::Value::Array(one_or_many(value).iter().map(float).collect())
}
