//! Validation: raw TOML values → the checked values of a [`Study`], each failure a
//! [`StudyError`] naming the file, the key, its line and the reason.

use super::raw::{RawNoise, RawStudy};
use super::*;
use crate::estimate::estimators::{ESTIMATORS, Ols};
use crate::settings::Params;
use crate::terrain::profiles::PROFILES;
use crate::vehicle::DRIVE_MODES;

/// Turn a serde/TOML error into one message naming the key and line.
pub(super) fn serde_error(
    err: &toml::de::Error,
    spans: &KeySpans,
    text: &str,
    origin: &str,
) -> StudyError {
    let message = err.message().trim().to_string();
    let span = err.span();
    let located = span.as_ref().and_then(|s| spans.key_at(s));
    let line = span.as_ref().map(|s| spans.line_of(s.start));
    // "missing field `x`" points at the enclosing table: name the missing key itself.
    if let Some(field) = message
        .strip_prefix("missing field `")
        .and_then(|rest| rest.strip_suffix('`'))
    {
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
        Some((key, key_line)) => StudyError {
            file: origin.to_string(),
            key: Some(key),
            line: Some(key_line),
            reason: message,
        },
        None => StudyError {
            file: origin.to_string(),
            key: line.and_then(|l| key_on_line(text, l)),
            line,
            reason: format!("TOML syntax error: {message}"),
        },
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

/// Collects value checks for one study; the first failure wins.
struct Checker<'a> {
    spans: &'a KeySpans,
    origin: &'a str,
}

impl Checker<'_> {
    /// An error at `key`, with the line of the key or, for a missing key, of the nearest
    /// enclosing one (`terrain.components[0]` for a missing `terrain.components[0].phase`).
    fn fail(&self, key: &str, reason: impl Into<String>) -> StudyError {
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

    fn missing_table(&self, key: &str) -> StudyError {
        StudyError {
            file: self.origin.to_string(),
            key: Some(key.to_string()),
            line: None,
            reason: format!("required table [{key}] is missing"),
        }
    }

    fn finite(&self, key: &str, v: f64) -> Result<f64, StudyError> {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.fail(key, format!("must be a finite number, got {v}")))
        }
    }

    fn positive(&self, key: &str, v: f64) -> Result<f64, StudyError> {
        let v = self.finite(key, v)?;
        if v > 0.0 {
            Ok(v)
        } else {
            Err(self.fail(key, format!("must be > 0, got {v}")))
        }
    }

    fn non_negative(&self, key: &str, v: f64) -> Result<f64, StudyError> {
        let v = self.finite(key, v)?;
        if v >= 0.0 {
            Ok(v)
        } else {
            Err(self.fail(key, format!("must be >= 0, got {v}")))
        }
    }

    /// A non-empty list whose items each pass `item`.
    fn list(
        &self,
        key: &str,
        values: &[f64],
        item: impl Fn(&Self, &str, f64) -> Result<f64, StudyError>,
    ) -> Result<Vec<f64>, StudyError> {
        if values.is_empty() {
            return Err(self.fail(key, "must list at least one value"));
        }
        values
            .iter()
            .enumerate()
            .map(|(i, &v)| item(self, &format!("{key}[{i}]"), v))
            .collect()
    }
}

pub(super) fn validate(raw: RawStudy, spans: KeySpans, origin: &str) -> Result<Study, StudyError> {
    let c = Checker {
        spans: &spans,
        origin,
    };
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
            ModelSpec::Vehicle(validate_vehicle(&raw, &c)?)
        }
        "line_fit" => {
            let unused = [
                ("vehicle", raw.vehicle.is_some()),
                ("drive", raw.drive.is_some()),
                ("terrain", raw.terrain.is_some()),
                ("noise", raw.noise.is_some()),
            ];
            if let Some((key, _)) = unused.iter().find(|(_, present)| *present) {
                return Err(c.fail(key, "is not used by model \"line_fit\""));
            }
            ModelSpec::LineFit(validate_line_fit(&raw, &c)?)
        }
        other => {
            return Err(c.fail(
                "model",
                format!("unknown model \"{other}\"; expected \"vehicle\" or \"line_fit\""),
            ));
        }
    };
    // The study as run lists every channel's levels, defaults included.
    let mut raw = raw;
    if let Some(n) = raw.noise.as_mut() {
        for channel in Channel::ALL {
            if let Some(default) = channel.default_levels() {
                n.0.entry(channel.key().to_string())
                    .or_insert_with(|| default.to_vec());
            }
        }
    }
    Ok(Study {
        name: raw.name.clone(),
        seed: raw.seed as u64,
        realisations: raw.realisations as u64,
        model,
        origin: origin.to_string(),
        raw,
        spans,
    })
}

fn validate_vehicle(raw: &RawStudy, c: &Checker<'_>) -> Result<VehicleStudy, StudyError> {
    let v = raw
        .vehicle
        .as_ref()
        .ok_or_else(|| c.missing_table("vehicle"))?;
    let d = raw.drive.as_ref().ok_or_else(|| c.missing_table("drive"))?;
    let t = raw
        .terrain
        .as_ref()
        .ok_or_else(|| c.missing_table("terrain"))?;
    let n = raw.noise.as_ref().ok_or_else(|| c.missing_table("noise"))?;
    let e = raw
        .estimation
        .as_ref()
        .ok_or_else(|| c.missing_table("estimation"))?;

    let vehicle = VehicleParams {
        mass_kg: c.positive("vehicle.mass", v.mass)?,
        drag_coefficient: c.non_negative("vehicle.drag_coefficient", v.drag_coefficient)?,
        rolling_resistance: c.non_negative("vehicle.rolling_resistance", v.rolling_resistance)?,
        frontal_area_m2: c.positive("vehicle.frontal_area", v.frontal_area)?,
        air_density_kg_m3: c.positive("vehicle.air_density", v.air_density)?,
        gravity_m_s2: c.positive("vehicle.gravity", v.gravity)?,
        final_drive_ratio: c.positive("vehicle.final_drive_ratio", v.final_drive_ratio)?,
        wheel_radius_m: c.positive("vehicle.wheel_radius", v.wheel_radius)?,
    };

    let mode_name = d.mode.as_deref().unwrap_or(DRIVE_MODES[0].name);
    let mode = DRIVE_MODES
        .iter()
        .find(|m| m.name == mode_name)
        .ok_or_else(|| {
            let names: Vec<&str> = DRIVE_MODES.iter().map(|m| m.name).collect();
            c.fail(
                "drive.mode",
                format!("unknown drive mode \"{mode_name}\"; expected one of {names:?}"),
            )
        })?;
    let drive =
        (mode.parse)(&Params::new(&d.params, "drive")).map_err(|e| c.fail(&e.key, e.reason))?;

    let entry = PROFILES
        .iter()
        .find(|p| p.name == t.profile)
        .ok_or_else(|| {
            let names: Vec<&str> = PROFILES.iter().map(|p| p.name).collect();
            c.fail(
                "terrain.profile",
                format!(
                    "unknown profile \"{}\"; expected one of {names:?}",
                    t.profile
                ),
            )
        })?;
    let profile =
        (entry.parse)(&Params::new(&t.params, "terrain")).map_err(|e| c.fail(&e.key, e.reason))?;
    let scale_applies_to = match t.scale_applies_to.as_str() {
        "grade" => ScaleTarget::Grade,
        "elevation" => ScaleTarget::Elevation,
        other => {
            return Err(c.fail(
                "terrain.scale_applies_to",
                format!("must be \"grade\" or \"elevation\", got \"{other}\""),
            ));
        }
    };
    if t.length < 2 {
        return Err(c.fail(
            "terrain.length",
            format!("must be at least 2 m, got {}", t.length),
        ));
    }
    if t.length > MAX_SAMPLES as u64 {
        return Err(c.fail(
            "terrain.length",
            format!("must be at most {MAX_SAMPLES} m, got {}", t.length),
        ));
    }
    let terrain = TerrainSpec {
        profile,
        length_m: t.length as usize,
        scale_applies_to,
    };
    let scales = c.list("terrain.scales", &t.scales, Checker::non_negative)?;

    let noise = validate_noise(n, c)?;
    let all: Vec<EstimatorRef> = ESTIMATORS.iter().map(|&e| EstimatorRef(e)).collect();
    let estimators = validate_estimators(&e.estimators, &all, c)?;

    Ok(VehicleStudy {
        vehicle,
        drive,
        terrain,
        scales,
        noise,
        estimators,
    })
}

/// The `[noise]` table: a list of levels per channel, defaults for the optional ones, and no
/// other key.
fn validate_noise(n: &RawNoise, c: &Checker<'_>) -> Result<NoiseAxes, StudyError> {
    let keys = Channel::ALL.map(Channel::key);
    if let Some(k) = n.0.keys().find(|k| !keys.contains(&k.as_str())) {
        return Err(c.fail(
            &format!("noise.{k}"),
            format!("unknown field `{k}`, expected one of {keys:?}"),
        ));
    }
    let mut levels = PerChannel::<Vec<f64>>::default();
    for channel in Channel::ALL {
        let key = format!("noise.{}", channel.key());
        levels[channel] = match (n.0.get(channel.key()), channel.default_levels()) {
            (Some(list), _) => c.list(&key, list, Checker::non_negative)?,
            (None, Some(default)) => default.to_vec(),
            (None, None) => return Err(c.fail(&key, "required key is missing")),
        };
    }
    Ok(NoiseAxes::new(levels))
}

fn validate_estimators(
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

fn validate_line_fit(raw: &RawStudy, c: &Checker<'_>) -> Result<LineFitStudy, StudyError> {
    let l = raw
        .line_fit
        .as_ref()
        .ok_or_else(|| c.missing_table("line_fit"))?;
    if let Some(e) = &raw.estimation {
        validate_estimators(&e.estimators, &[EstimatorRef(&Ols)], c)?;
    }
    let t_start = c.finite("line_fit.t_start", l.t_start)?;
    let t_step = c.positive("line_fit.t_step", l.t_step)?;
    let t_end = c.finite("line_fit.t_end", l.t_end)?;
    let span = (t_end - t_start) / t_step;
    let steps = span.round();
    if steps < 1.0 || (steps - span).abs() > 1e-9 * span.abs().max(1.0) {
        return Err(c.fail(
            "line_fit.t_end",
            format!(
                "must lie a whole number (≥ 1) of t_step = {t_step} after t_start = {t_start}, got {t_end}"
            ),
        ));
    }
    if steps + 1.0 > MAX_SAMPLES as f64 {
        return Err(c.fail("line_fit.t_step", "gives too many samples"));
    }
    let times = (0..=steps as usize)
        .map(|i| t_start + i as f64 * t_step)
        .collect();
    if l.noise.is_empty() {
        return Err(c.fail("line_fit.noise", "must list at least one noise shape"));
    }
    let mut noise = Vec::new();
    for (i, name) in l.noise.iter().enumerate() {
        let shape = NoiseShape::parse(name).ok_or_else(|| {
            let names: Vec<String> = NoiseShape::ALL
                .iter()
                .map(|s| format!("\"{}\"", s.name()))
                .collect();
            c.fail(
                &format!("line_fit.noise[{i}]"),
                format!("unknown noise \"{name}\"; expected {}", names.join(" or ")),
            )
        })?;
        noise.push(shape);
    }
    Ok(LineFitStudy {
        intercept: c.finite("line_fit.intercept", l.intercept)?,
        slope: c.finite("line_fit.slope", l.slope)?,
        times,
        assumed_sd: c.positive("line_fit.assumed_sd", l.assumed_sd)?,
        noise,
        noise_sd: c.list("line_fit.noise_sd", &l.noise_sd, Checker::non_negative)?,
    })
}
