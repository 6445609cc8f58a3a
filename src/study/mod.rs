//! Study files: TOML in, a validated [`Study`] out.
//!
//! This is the one place where user input becomes trusted configuration. serde structs with
//! `deny_unknown_fields` catch unknown keys, missing keys and wrong types; `validate` then
//! checks every value. Every failure is a [`StudyError`] that names the file, the dotted key,
//! its line and the reason, so a user can fix the file without reading code.

mod raw;
mod spans;

use std::fmt;
use std::path::Path;

use raw::RawStudy;
pub use spans::KeySpans;

use crate::estimate::estimators::{ESTIMATORS, EstimatorRef, Ols};
use crate::noise::NoiseLevels;
use crate::terrain::{ScaleTarget, TerrainSpec};
use crate::vehicle::{DriveParams, VehicleParams};

/// Largest number of drive-cycle samples accepted (keeps a typo from allocating gigabytes).
pub const MAX_SAMPLES: usize = 50_000_000;

/// Largest number of realisations per condition accepted.
pub const MAX_REALISATIONS: u64 = 1 << 40;

/// A study file that cannot be run, with the place and the reason.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StudyError {
    /// The file (or other origin, e.g. a command-line flag) the error is about.
    pub file: String,
    /// The dotted key, e.g. `vehicle.mass` or `terrain.scales[2]`, when one is at fault.
    pub key: Option<String>,
    /// 1-based line of the key in the file, when the file has it.
    pub line: Option<usize>,
    /// What is wrong, in words.
    pub reason: String,
}

impl fmt::Display for StudyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: ", self.file)?;
        match (&self.key, self.line) {
            (Some(key), Some(line)) => write!(f, "key `{key}` (line {line}): ")?,
            (Some(key), None) => write!(f, "key `{key}`: ")?,
            (None, Some(line)) => write!(f, "line {line}: ")?,
            (None, None) => {}
        }
        f.write_str(&self.reason)
    }
}

impl std::error::Error for StudyError {}

/// Which noise enters the measurements of the vehicle study, one condition axis each.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseAxes {
    /// Standard deviations of the speed-measurement noise \[m/s\].
    pub velocity_sd: Vec<f64>,
    /// Standard deviations of the additive output (acceleration) noise \[m/s²\].
    pub output_sd: Vec<f64>,
    /// Standard deviations of the grade-measurement noise \[rad\] (default `[0.0]`).
    pub grade_sd: Vec<f64>,
    /// Standard deviations of the propulsion-force measurement noise \[N\] (default `[0.0]`).
    pub force_sd: Vec<f64>,
}

impl NoiseAxes {
    /// Every combination, nested velocity × output × grade × force (the last varies fastest).
    pub fn levels(&self) -> Vec<NoiseLevels> {
        let mut out = Vec::new();
        for &velocity_sd in &self.velocity_sd {
            for &output_sd in &self.output_sd {
                for &grade_sd in &self.grade_sd {
                    for &force_sd in &self.force_sd {
                        out.push(NoiseLevels {
                            velocity_sd,
                            output_sd,
                            grade_sd,
                            force_sd,
                        });
                    }
                }
            }
        }
        out
    }
}

/// The validated description of a vehicle study (docs/model.md, and the README's study keys).
#[derive(Debug, Clone, PartialEq)]
pub struct VehicleStudy {
    /// Vehicle parameters (the truth the estimators try to recover).
    pub vehicle: VehicleParams,
    /// Drive-cycle settings: duration, step, torque profile.
    pub drive: DriveParams,
    /// Terrain profile and grid; the scales are an axis of conditions.
    pub terrain: TerrainSpec,
    /// Terrain scale factors, one condition axis.
    pub scales: Vec<f64>,
    /// Noise condition axes.
    pub noise: NoiseAxes,
    /// Estimators run on every realisation (common random numbers).
    pub estimators: Vec<EstimatorRef>,
}

/// Shape of the measurement noise of the line-fit example.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoiseShape {
    /// Uniform on \[−√3 σ, √3 σ\] (the thesis's `18*(rand − 0.5)` has σ = 18/√12 = 5.196).
    Uniform,
    /// Normal N(0, σ²).
    Gaussian,
}

impl NoiseShape {
    /// All noise shapes.
    pub const ALL: [NoiseShape; 2] = [NoiseShape::Uniform, NoiseShape::Gaussian];

    fn parse(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }

    /// The name used in study files and output columns.
    pub fn name(self) -> &'static str {
        match self {
            NoiseShape::Uniform => "uniform",
            NoiseShape::Gaussian => "gaussian",
        }
    }
}

/// The validated worked example of thesis §3.2–3.3: y = θ₁ + θ₂ t with i.i.d. noise.
#[derive(Debug, Clone, PartialEq)]
pub struct LineFitStudy {
    /// True intercept θ₁.
    pub intercept: f64,
    /// True slope θ₂.
    pub slope: f64,
    /// Sample times t_i.
    pub times: Vec<f64>,
    /// The σ the bound assumes (the thesis uses 7.5).
    pub assumed_sd: f64,
    /// Noise shapes, one condition axis.
    pub noise: Vec<NoiseShape>,
    /// True noise standard deviations, one condition axis.
    pub noise_sd: Vec<f64>,
}

/// The model a study runs, with its validated settings.
#[derive(Debug, Clone, PartialEq)]
pub enum ModelSpec {
    /// The longitudinal vehicle model of the thesis.
    Vehicle(VehicleStudy),
    /// The straight-line example of thesis §3.2–3.3.
    LineFit(LineFitStudy),
}

/// A validated study: everything needed to run it, and nothing unchecked.
#[derive(Debug, Clone)]
pub struct Study {
    /// Study name (free text, stored in output metadata).
    pub name: String,
    /// Master seed; with the condition and realisation index it keys every random stream.
    pub seed: u64,
    /// Realisations per condition.
    pub realisations: u64,
    /// The model and its settings.
    pub model: ModelSpec,
    /// Where the study came from (a path, for messages).
    pub origin: String,
    raw: RawStudy,
    spans: KeySpans,
}

impl Study {
    /// Read and validate a study file.
    pub fn load(path: &Path) -> Result<Study, StudyError> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| StudyError {
            file: origin.clone(),
            key: None,
            line: None,
            reason: format!("cannot read the study file: {e}"),
        })?;
        Study::from_toml(&text, &origin)
    }

    /// Validate study text; `origin` names it in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Study, StudyError> {
        let spans = KeySpans::new(text);
        let raw: RawStudy =
            toml::from_str(text).map_err(|e| serde_error(&e, &spans, text, origin))?;
        validate(raw, spans, origin)
    }

    /// Apply command-line overrides of the realisation count and seed.
    pub fn with_overrides(
        mut self,
        realisations: Option<u64>,
        seed: Option<u64>,
    ) -> Result<Study, StudyError> {
        if let Some(r) = realisations {
            check_realisations(r as i128).map_err(|reason| StudyError {
                file: "command line".into(),
                key: Some("--realisations".into()),
                line: None,
                reason,
            })?;
            self.realisations = r;
            self.raw.realisations = r as i64;
        }
        if let Some(s) = seed {
            if s > i64::MAX as u64 {
                return Err(StudyError {
                    file: "command line".into(),
                    key: Some("--seed".into()),
                    line: None,
                    reason: format!("must be at most {}, got {s}", i64::MAX),
                });
            }
            self.seed = s;
            self.raw.seed = s as i64;
        }
        Ok(self)
    }

    /// The study as run, as canonical TOML (overrides applied); reloads to the same study.
    pub fn to_toml(&self) -> String {
        toml::to_string(&self.raw).expect("a validated study serialises")
    }

    /// What makes two runs' realisations interchangeable: the study as run without its
    /// realisation count, and the engine version (a new version may change the numbers).
    pub fn identity(&self) -> String {
        let mut raw = self.raw.clone();
        raw.realisations = 0;
        format!(
            "{}# chassis-mc {}\n",
            toml::to_string(&raw).expect("a validated study serialises"),
            env!("CARGO_PKG_VERSION")
        )
    }

    /// An error about key `key` of this study, with its line when the file has it.
    pub fn error_at(&self, key: &str, reason: impl Into<String>) -> StudyError {
        StudyError {
            file: self.origin.clone(),
            key: Some(key.to_string()),
            line: self.spans.line(key),
            reason: reason.into(),
        }
    }

    /// Number of conditions the study runs (the product of its axes).
    pub fn condition_count(&self) -> usize {
        match &self.model {
            ModelSpec::Vehicle(v) => v.scales.len() * v.noise.levels().len(),
            ModelSpec::LineFit(l) => l.noise.len() * l.noise_sd.len(),
        }
    }

    /// The vehicle study, if this is one.
    pub fn vehicle(&self) -> Option<&VehicleStudy> {
        match &self.model {
            ModelSpec::Vehicle(v) => Some(v),
            ModelSpec::LineFit(_) => None,
        }
    }

    /// The line-fit study, if this is one.
    pub fn line_fit(&self) -> Option<&LineFitStudy> {
        match &self.model {
            ModelSpec::LineFit(l) => Some(l),
            ModelSpec::Vehicle(_) => None,
        }
    }
}

/// Turn a serde/TOML error into one message naming the key and line.
fn serde_error(err: &toml::de::Error, spans: &KeySpans, text: &str, origin: &str) -> StudyError {
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

fn check_realisations(r: i128) -> Result<(), String> {
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
    fn fail(&self, key: &str, reason: impl Into<String>) -> StudyError {
        StudyError {
            file: self.origin.to_string(),
            key: Some(key.to_string()),
            line: self.spans.line(key),
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

fn validate(raw: RawStudy, spans: KeySpans, origin: &str) -> Result<Study, StudyError> {
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

    let duration_s = c.positive("drive.duration", d.duration)?;
    let time_step_s = c.positive("drive.time_step", d.time_step)?;
    let steps = (duration_s / time_step_s).round();
    if (steps * time_step_s - duration_s).abs() > 1e-9 * duration_s || steps < 1.0 {
        return Err(c.fail(
            "drive.duration",
            format!(
                "must be a whole multiple of drive.time_step ({time_step_s} s), got {duration_s} s"
            ),
        ));
    }
    if steps + 1.0 > MAX_SAMPLES as f64 {
        return Err(c.fail(
            "drive.time_step",
            format!(
                "gives {} samples; at most {MAX_SAMPLES} are supported",
                steps + 1.0
            ),
        ));
    }
    let drive = DriveParams {
        duration_s,
        time_step_s,
        steps: steps as usize,
        initial_speed_m_s: c.non_negative("drive.initial_speed", d.initial_speed)?,
        torque_mean_n_m: c.non_negative("drive.torque_mean", d.torque_mean)?,
        torque_amplitude: c.non_negative("drive.torque_amplitude", d.torque_amplitude)?,
        torque_frequency_rad_s: c.non_negative("drive.torque_frequency", d.torque_frequency)?,
    };

    if t.profile != "cos2" {
        return Err(c.fail(
            "terrain.profile",
            format!("unknown profile \"{}\"; expected \"cos2\"", t.profile),
        ));
    }
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
        height_m: c.non_negative("terrain.height", t.height)?,
        period_m: c.positive("terrain.period", t.period)?,
        length_m: t.length as usize,
        scale_applies_to,
    };
    let scales = c.list("terrain.scales", &t.scales, Checker::non_negative)?;

    let noise = NoiseAxes {
        velocity_sd: c.list("noise.velocity_sd", &n.velocity_sd, Checker::non_negative)?,
        output_sd: c.list("noise.output_sd", &n.output_sd, Checker::non_negative)?,
        grade_sd: c.list("noise.grade_sd", &n.grade_sd, Checker::non_negative)?,
        force_sd: c.list("noise.force_sd", &n.force_sd, Checker::non_negative)?,
    };
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
