//! The fit file of `chassis-mc fit` (docs/model.md#fit): `[log]` (the measured cycle read
//! from its file), the known `[vehicle]` quantities, the assumed `[noise]`, `[estimation]`,
//! `[reference]` and `[systematic]`, read as serde structs and checked into a [`FitSpec`] by
//! the study's own checks: the same [`Checker`], the same `[noise]` keys and levels (one
//! level each here), the same estimator and `forgetting` rules, the same sample-spacing
//! rule, and `[truth]`'s keys and checks for `[systematic]` (one number each).

use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::axes::VELOCITY_CORRELATION;
use super::checker::Checker;
use super::estimation::{SettingKeys, validate_estimation};
use super::filter_keys::KnownVehicle;
use super::noise::{noise_keys, noise_levels};
use super::raw::RawNoise;
use super::spacing::{uneven_differentiation, uneven_reason};
use super::truth::validate_systematic;
use super::validate::{check_realisations, serde_error};
use super::{KeySpans, StudyError};
use crate::dynamics::SpeedUnit;
use crate::dynamics::{DriveCycle, VehicleParams};
use crate::estimate::channels::{Acceleration, Channel, NoiseLevels, Signal};
use crate::estimate::estimators::{EstimatorRef, EstimatorSettings};
use crate::estimate::filters::GradeSource;
use crate::estimate::regression::Regression;
use placement::elsewhere;

mod estimation;
mod filters;
mod log;
pub(super) mod placement;
pub(super) use estimation::RawFitEstimation;
use log::LogSource;
pub use log::LogTable;
pub(super) use log::RawLog;

/// Fewest bootstrap realisations a fit takes (for a 95 % percentile interval), and fewest
/// a bootstrap must keep.
pub const MIN_REALISATIONS: i64 = 20;

/// A fit file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawFit {
    #[serde(default)]
    name: Option<String>,
    seed: i64,
    realisations: i64,
    log: RawLog,
    vehicle: RawFitVehicle,
    noise: RawNoise,
    estimation: RawFitEstimation,
    #[serde(default)]
    reference: Option<RawReference>,
    #[serde(default)]
    systematic: Option<toml::Table>,
}

/// `[vehicle]`: what is known (mass, Cd and Cr are what the fit finds; Cd and Cr are known
/// to the filters, which find the mass alone).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawFitVehicle {
    /// The weighed mass \[kg\] (with `estimation.known_mass`).
    #[serde(default)]
    mass: Option<f64>,
    /// Cd, known to the filters.
    #[serde(default)]
    drag_coefficient: Option<f64>,
    /// Cr, known to the filters.
    #[serde(default)]
    rolling_resistance: Option<f64>,
    frontal_area: f64,
    air_density: f64,
    gravity: f64,
    #[serde(default)]
    final_drive_ratio: Option<f64>,
    #[serde(default)]
    wheel_radius: Option<f64>,
}

/// `[reference]`: values to draw the fit against.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawReference {
    #[serde(default)]
    mass: Option<f64>,
    #[serde(default)]
    drag_coefficient: Option<f64>,
    #[serde(default)]
    rolling_resistance: Option<f64>,
}

/// A validated fit file.
#[derive(Debug, Clone)]
pub struct FitSpec {
    /// Where it was read from.
    pub origin: String,
    /// Its directory (relative paths resolve against it).
    pub dir: PathBuf,
    /// The log file (or, for a table handed over, its name).
    pub log: PathBuf,
    /// The measured cycle (speed, force, grade, acceleration as logged or differentiated).
    pub cycle: DriveCycle,
    /// Which samples the regression uses.
    pub used: Vec<bool>,
    /// Where the acceleration comes from.
    pub acceleration: Acceleration,
    /// `min_speed` \[m/s\].
    pub min_speed: f64,
    /// Known vehicle quantities (mass, Cd and Cr are what the fit finds).
    pub vehicle: VehicleParams,
    /// The assumed sensor noise.
    pub noise: NoiseLevels,
    /// The estimators.
    pub estimators: Vec<EstimatorRef>,
    /// Estimator settings.
    pub settings: EstimatorSettings,
    /// Bootstrap seed.
    pub seed: u64,
    /// Bootstrap realisations.
    pub realisations: u64,
    /// `[reference]`: values to draw the fit against (e.g. the truth of a synthetic log),
    /// per row of `fit::FIT_PARAMETERS`: 1/M, Cd/M, Cr, M, Cd (θ's derived from the M, Cd
    /// and Cr given).
    pub reference: [Option<f64>; 5],
    /// `[systematic]`: per model error given, its index in
    /// [`MODEL_ERRORS`](crate::dynamics::truth::MODEL_ERRORS) and its magnitude (the value
    /// `[truth]` would give it), in that list's order; empty without the table.
    pub systematic: Vec<(usize, f64)>,
    /// The fit file's text.
    pub text: String,
}

impl FitSpec {
    /// Read and check `path`.
    pub fn load(path: &Path) -> Result<FitSpec, StudyError> {
        Self::load_with_log(path, None)
    }

    /// Read and check `path`, its log read from `log` when given (see
    /// [`FitSpec::parse_with_log`]).
    pub fn load_with_log(path: &Path, log: Option<&Path>) -> Result<FitSpec, StudyError> {
        let (text, origin, dir) = read_fit_file(path)?;
        Self::parse_with_log(&text, &origin, &dir, log)
    }

    /// Read and check `path`, its log the table `log` held in memory (see
    /// [`FitSpec::parse_with_table`]).
    pub fn load_with_table(path: &Path, log: LogTable<'_>) -> Result<FitSpec, StudyError> {
        let (text, origin, dir) = read_fit_file(path)?;
        Self::parse_with_table(&text, &origin, &dir, log)
    }

    /// Check the fit file `text` read from `origin` in `dir`.
    pub fn parse(text: &str, origin: &str, dir: &Path) -> Result<FitSpec, StudyError> {
        Self::parse_with_log(text, origin, dir, None)
    }

    /// Check the fit file `text` read from `origin` in `dir`, its log read from the file
    /// `log` when given instead of from `log.file` (which may then be left out).
    pub fn parse_with_log(
        text: &str,
        origin: &str,
        dir: &Path,
        log: Option<&Path>,
    ) -> Result<FitSpec, StudyError> {
        let log = log.map(|p| LogSource::File(p.to_path_buf()));
        Self::parse_from(text, origin, dir, log)
    }

    /// Check the fit file `text` read from `origin` in `dir`, its log the table `log` held in
    /// memory (no file is read for it, and `log.file` may be left out); its errors name the
    /// table by `log.name`, and its rows 1-based.
    pub fn parse_with_table(
        text: &str,
        origin: &str,
        dir: &Path,
        log: LogTable<'_>,
    ) -> Result<FitSpec, StudyError> {
        Self::parse_from(text, origin, dir, Some(LogSource::Table(log)))
    }

    /// Check a fit file given as values (a TOML table with no text, e.g. a dict from
    /// Python) in `dir`, its log read from the file `log` or the table `log_table` when
    /// given; errors name the key by its path, with no line.
    pub fn from_table_in(
        table: toml::Table,
        origin: &str,
        dir: &Path,
        log: Option<&Path>,
        log_table: Option<LogTable<'_>>,
    ) -> Result<FitSpec, StudyError> {
        let raw: RawFit = serde_path_to_error::deserialize(toml::Value::Table(table.clone()))
            .map_err(|e| super::validate::value_error(&e, origin, elsewhere))?;
        let spans = KeySpans::new("");
        let c = Checker::new(&spans, origin, dir, elsewhere);
        // The text its outputs record (their footer, the report), written from the values.
        let text = toml::to_string(&table).expect("a TOML table serialises");
        let log = match (log, log_table) {
            (_, Some(t)) => Some(LogSource::Table(t)),
            (Some(p), None) => Some(LogSource::File(p.to_path_buf())),
            (None, None) => None,
        };
        validate(raw, &c, &text, log)
    }

    fn parse_from(
        text: &str,
        origin: &str,
        dir: &Path,
        log: Option<LogSource<'_>>,
    ) -> Result<FitSpec, StudyError> {
        let spans = KeySpans::new(text);
        let raw: RawFit =
            toml::from_str(text).map_err(|e| serde_error(&e, &spans, text, origin, elsewhere))?;
        let c = Checker::new(&spans, origin, dir, elsewhere);
        validate(raw, &c, text, log)
    }

    /// The regression of the log's used samples, taken as they are (measured); without a
    /// grade (`estimation.grade = "none"`) cos θ is taken as 1
    /// ([`Regression::without_grade`]).
    pub fn regression(&self) -> Regression {
        let reg = match self.acceleration {
            Acceleration::Differentiated => {
                Regression::differentiated(&self.cycle, &self.used, 0.0, &self.vehicle)
            }
            Acceleration::Model => Regression::new(&self.cycle.select(&self.used), &self.vehicle),
        };
        match self.settings.grade {
            GradeSource::Measured => reg,
            GradeSource::None => reg.without_grade(),
        }
    }
}

/// A fit file's text, the origin its errors name and its directory.
fn read_fit_file(path: &Path) -> Result<(String, String, PathBuf), StudyError> {
    let origin = path.display().to_string();
    let text = crate::tabular::read_regular(path, super::MAX_STUDY_BYTES)
        .and_then(|b| String::from_utf8(b).map_err(|_| "is not UTF-8 text".to_string()))
        .map_err(|reason| StudyError {
            file: origin.clone(),
            key: None,
            line: None,
            reason,
        })?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    Ok((text, origin, dir))
}

fn validate(
    raw: RawFit,
    c: &Checker<'_>,
    text: &str,
    log: Option<LogSource<'_>>,
) -> Result<FitSpec, StudyError> {
    if raw.name.as_ref().is_some_and(|n| n.trim().is_empty()) {
        return Err(c.fail("name", "must not be empty"));
    }
    if raw.seed < 0 {
        return Err(c.fail("seed", format!("must be >= 0, got {}", raw.seed)));
    }
    check_realisations(raw.realisations as i128).map_err(|r| c.fail("realisations", r))?;
    if raw.realisations < MIN_REALISATIONS {
        return Err(c.fail(
            "realisations",
            format!(
                "must be at least {MIN_REALISATIONS} for a 95 % percentile interval, got {}",
                raw.realisations
            ),
        ));
    }

    // [vehicle]: the known quantities; the mass only when weighed (estimation.known_mass).
    let v = &raw.vehicle;
    let known_mass = raw.estimation.known_mass.unwrap_or(false);
    let mass_kg = match (known_mass, v.mass) {
        (true, Some(m)) => c.positive("vehicle.mass", m)?,
        (true, None) => {
            return Err(c.fail(
                "vehicle.mass",
                "required key is missing (estimation.known_mass = true: give the weighed mass \
                 [kg])",
            ));
        }
        (false, Some(_)) => {
            return Err(c.fail(
                "vehicle.mass",
                "applies only with estimation.known_mass = true (without it the fit estimates \
                 the mass)",
            ));
        }
        (false, None) => 1.0,
    };
    let vehicle = VehicleParams {
        mass_kg,
        drag_coefficient: 0.0,
        rolling_resistance: 0.0,
        frontal_area_m2: c.positive("vehicle.frontal_area", v.frontal_area)?,
        air_density_kg_m3: c.positive("vehicle.air_density", v.air_density)?,
        gravity_m_s2: c.positive("vehicle.gravity", v.gravity)?,
        drivetrain: None,
    };

    // [log]: its keys; the file is read once everything else has passed.
    let l = &raw.log;
    let source = match log {
        Some(log) => log,
        None if l.file.is_empty() => return Err(c.fail("log.file", "must name a file")),
        None => LogSource::File(c.dir().join(&l.file)),
    };
    let speed_unit = c.named("log.speed_unit", &l.speed_unit, &SpeedUnit::ALL)?;
    let min_speed = match l.min_speed {
        Some(s) => c.non_negative("log.min_speed", s)?,
        None => 0.0,
    };
    let (force, torque_factor) = match (&l.force_column, &l.torque_column) {
        (Some(force), None) => (force, None),
        (None, Some(torque)) => {
            let required = |key: &str, v: Option<f64>| {
                let key = format!("vehicle.{key}");
                let v = v.ok_or_else(|| c.fail(&key, "required key is missing"))?;
                c.positive(&key, v)
            };
            let ratio = required("final_drive_ratio", v.final_drive_ratio)?;
            let radius = required("wheel_radius", v.wheel_radius)?;
            (torque, Some(ratio / radius))
        }
        _ => {
            return Err(c.fail(
                "log.force_column",
                "give exactly one of force_column [N] and torque_column [N m]",
            ));
        }
    };

    // [noise]: the study's keys and levels, one level each (a number, or a study's list of
    // one), absent ones 0.
    noise_keys(&raw.noise, c, &[VELOCITY_CORRELATION])?;
    let one_level = |key: &str| -> Result<f64, StudyError> {
        match noise_levels(&raw.noise, c, key)?.as_deref() {
            None => Ok(0.0),
            Some(&[level]) => Ok(level),
            Some(levels) => Err(c.fail(
                &format!("noise.{key}"),
                format!(
                    "takes one value in a fit, got a list of {} (a study's axis)",
                    levels.len()
                ),
            )),
        }
    };
    let acceleration = match l.acceleration_column {
        Some(_) => Acceleration::Model,
        None => Acceleration::Differentiated,
    };
    let mut noise = NoiseLevels {
        acceleration,
        ..NoiseLevels::default()
    };
    // A channel whose level a study's level axis sets (the air-speed sensor's) is off in a fit.
    for channel in Channel::ALL.into_iter().filter(|c| c.own_axis()) {
        noise[channel] = one_level(channel.key())?;
    }
    noise.velocity_correlation_s = one_level(VELOCITY_CORRELATION)?;

    let e = &raw.estimation;
    let known_inv_mass = known_mass.then(|| 1.0 / vehicle.mass_kg);
    let keys = SettingKeys {
        forgetting: e.forgetting,
        known_inv_mass,
        effective_mass_factor: e.effective_mass_factor,
        filter: e.filter_keys(),
        vehicle: KnownVehicle {
            mass_kg: vehicle.mass_kg,
            drag_coefficient: v.drag_coefficient.unwrap_or(0.0),
            rolling: v.rolling_resistance.unwrap_or(0.0),
        },
    };
    let (estimators, settings, _) = validate_estimation(&e.estimators, keys, c)?;
    // A grade sensor's noise has nothing to act on without the grade.
    let grade_keys: Vec<String> = Channel::ALL
        .into_iter()
        .filter(|ch| ch.own_axis() && ch.signal() == Signal::Grade && noise[*ch] > 0.0)
        .map(|ch| format!("noise.{}", ch.key()))
        .collect();
    let grade_keys: Vec<&str> = grade_keys.iter().map(String::as_str).collect();
    super::filter_keys::check_grade_none(
        settings.grade,
        &estimators,
        noise.acceleration == Acceleration::Model,
        &grade_keys,
        c,
    )?;
    filters::check_filters(&raw, &estimators, &noise, c)?;
    let grade_column = log::grade_column(l, settings.grade, c)?;

    // [reference] (optional): M, Cd and Cr to draw the fit against.
    let reference = match &raw.reference {
        None => [None; 5],
        Some(r) => {
            let mass = r
                .mass
                .map(|m| c.positive("reference.mass", m))
                .transpose()?;
            let cd = r
                .drag_coefficient
                .map(|x| c.non_negative("reference.drag_coefficient", x))
                .transpose()?;
            let cr = r
                .rolling_resistance
                .map(|x| c.non_negative("reference.rolling_resistance", x))
                .transpose()?;
            [
                mass.map(|m| 1.0 / m),
                mass.zip(cd).map(|(m, cd)| cd / m),
                cr,
                mass,
                cd,
            ]
        }
    };

    let systematic = validate_systematic(raw.systematic.as_ref(), c)?;

    let (cycle, used) = log::read_log(
        l,
        &source,
        force,
        torque_factor,
        speed_unit,
        grade_column,
        c,
    )?;
    filters::check_filter_log(&estimators, &cycle.t_s, c)?;
    if used.iter().filter(|u| **u).count() < 3 {
        return Err(c.fail(
            "log.min_speed",
            "leaves fewer than 3 samples of the log for the regression",
        ));
    }
    // The rule on sample spacing, on the whole log (see `uneven_differentiation`).
    let differentiated = (acceleration == Acceleration::Differentiated).then_some(&cycle.t_s[..]);
    if let Some(e) =
        uneven_differentiation(noise.velocity_correlated(), &estimators, differentiated)
    {
        return Err(c.fail(
            &format!("noise.{VELOCITY_CORRELATION}"),
            uneven_reason(e, "no log.acceleration_column", "this log"),
        ));
    }

    Ok(FitSpec {
        origin: c.origin().to_string(),
        dir: c.dir().to_path_buf(),
        log: source.path(),
        cycle,
        used,
        acceleration,
        min_speed,
        vehicle,
        noise,
        estimators,
        settings,
        seed: raw.seed as u64,
        realisations: raw.realisations as u64,
        reference,
        systematic,
        text: text.to_string(),
    })
}
