//! Study files: TOML in, a validated [`Study`] out.
//!
//! This is the one place where user input becomes trusted configuration. serde structs
//! (`raw.rs`) catch unknown keys, missing keys and wrong types of the fixed tables; the open
//! tables (a terrain profile's or drive mode's keys, the noise channels) are read key by key
//! by their entries. `checker.rs` holds what every check reports through (the file, the
//! keys' lines, the error for an unknown key); `validate.rs` checks the common keys (`estimation.rs` the
//! `[estimation]` checks every model shares),
//! `vehicle.rs` and `line_fit.rs` each model's (`noise.rs` the vehicle's `[noise]`,
//! `terrain.rs` its `[terrain]`, `truth.rs` its `[truth]`), `placement.rs` says which table a
//! key belongs in, `spacing.rs` is the rule on sample spacing, and `fit.rs` reads `fit`'s
//! file with the same checks. Every failure is a [`StudyError`] that names the file, the
//! dotted key, its line and the reason, so a user can fix the file without reading code.
//! `vary.rs` gives a validated study's setting a new value ([`Study::varied`]) through the
//! same validation.

mod axes;
mod campaign;
mod checker;
mod estimation;
mod filter_keys;
mod fit;
mod fleet;
mod line_fit;
mod noise;
mod placement;
mod raw;
mod road_load;
mod spacing;
pub mod spans;
mod terrain;
mod truth;
mod validate;
mod vary;
mod vehicle;

use validate::{check_realisations, serde_error};

use std::fmt;
use std::path::{Path, PathBuf};

pub use axes::{AIR_SPEED_SD, GRADE_MAP_SD, LEVEL_AXIS_COUNT, LevelAxes, LevelAxis};
pub use fit::{FitSpec, LogTable, MIN_REALISATIONS};
pub use fleet::{Fleet, FleetVehicle};
pub use line_fit::{LineFitStudy, NoiseShape};
pub use noise::NoiseAxes;
use raw::RawStudy;
pub use spacing::{EVEN_STEPS_TOLERANCE, evenly_spaced, uneven_differentiation, uneven_reason};
pub use spans::KeySpans;
pub use truth::TruthAxes;
pub use vary::{TruthKey, VariedKey};
pub use vehicle::{AirSpeed, VehicleStudy};

pub use crate::dynamics::MAX_SAMPLES;

/// Largest number of realisations per condition accepted.
pub const MAX_REALISATIONS: u64 = 1 << 40;

/// The largest study or fit file read \[bytes\]: a study is a page of TOML.
pub const MAX_STUDY_BYTES: u64 = 16 << 20;

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

/// The model a study runs, with its validated settings.
#[derive(Debug, Clone)]
pub enum ModelSpec {
    /// The longitudinal vehicle model of the thesis.
    Vehicle(Box<VehicleStudy>),
    /// The straight-line example of thesis §3.2–3.3.
    LineFit(LineFitStudy),
}

/// A validated study: everything needed to run it, and nothing unchecked.
///
/// The study as written ([`to_toml`](Study::to_toml), stored in every output file and
/// behind the resume identity) and its validated values are built together by validation
/// and change together only through [`with_overrides`](Study::with_overrides) and
/// [`varied`](Study::varied): the fields are private, so the two cannot drift apart.
#[derive(Debug, Clone)]
pub struct Study {
    name: String,
    seed: u64,
    realisations: u64,
    model: ModelSpec,
    origin: String,
    dir: PathBuf,
    raw: RawStudy,
    spans: KeySpans,
    /// `[fleet]`'s vehicles (the model's settings are then its first vehicle's).
    fleet: Option<std::sync::Arc<Fleet>>,
}

impl Study {
    /// Study name (free text, stored in output metadata).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Master seed; with the condition and realisation index it keys every random stream.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Realisations per condition.
    pub fn realisations(&self) -> u64 {
        self.realisations
    }

    /// The model and its settings.
    pub fn model(&self) -> &ModelSpec {
        &self.model
    }

    /// Where the study came from (a path, for messages).
    pub fn origin(&self) -> &str {
        &self.origin
    }

    /// Read and validate a study file.
    pub fn load(path: &Path) -> Result<Study, StudyError> {
        let origin = path.display().to_string();
        let text = crate::tabular::read_regular(path, MAX_STUDY_BYTES)
            .and_then(|b| String::from_utf8(b).map_err(|_| "is not UTF-8 text".to_string()))
            .map_err(|reason| StudyError {
                file: origin.clone(),
                key: None,
                line: None,
                reason: match reason.strip_prefix("cannot read: ") {
                    Some(why) => format!("cannot read the study file: {why}"),
                    None => format!("the study file {reason}"),
                },
            })?;
        Study::from_toml(&text, &origin)
    }

    /// Validate study text; `origin` names it in errors, and the data files it names are
    /// relative to `origin`'s directory.
    pub fn from_toml(text: &str, origin: &str) -> Result<Study, StudyError> {
        // A bare file name's directory is the working directory.
        let dir = match Path::new(origin).parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        Study::from_toml_in(text, origin, dir)
    }

    /// Validate study text whose data files are relative to `dir` (e.g. a study read back
    /// from an output file's footer, with the directory recorded there).
    pub fn from_toml_in(text: &str, origin: &str, dir: &Path) -> Result<Study, StudyError> {
        let spans = KeySpans::new(text);
        let raw: RawStudy = toml::from_str(text)
            .map_err(|e| serde_error(&e, &spans, text, origin, placement::elsewhere))?;
        // Absolute, so that the directory recorded with the output stays valid from
        // anywhere (as given when it cannot be resolved).
        let dir = std::path::absolute(dir).unwrap_or_else(|_| dir.to_path_buf());
        validate_any(raw, spans, origin, dir)
    }

    /// Validate a study given as values, a TOML table with no text of its own (e.g. a dict
    /// from Python), whose data files are relative to `dir`: checked by the same code as a
    /// file, its errors naming the key by its path (`vehicle.mass`) with no line.
    pub fn from_table_in(
        table: toml::Table,
        origin: &str,
        dir: &Path,
    ) -> Result<Study, StudyError> {
        let raw: RawStudy = serde_path_to_error::deserialize(toml::Value::Table(table))
            .map_err(|e| validate::value_error(&e, origin, placement::elsewhere))?;
        let dir = std::path::absolute(dir).unwrap_or_else(|_| dir.to_path_buf());
        validate_any(raw, KeySpans::new(""), origin, dir)
    }

    /// The directory the study's data files are named relative to.
    pub fn dir(&self) -> &Path {
        &self.dir
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

    /// The study as run (overrides applied) as TOML values: what [`Study::to_toml`] writes,
    /// and what [`Study::from_table_in`] reads back.
    pub fn to_table(&self) -> toml::Table {
        toml::Table::try_from(&self.raw).expect("a validated study serialises")
    }

    /// What makes two runs' realisations interchangeable: the study as run without its
    /// realisation count, and the engine version (a new version may change the numbers).
    pub fn identity(&self) -> String {
        let mut raw = self.raw.clone();
        raw.realisations = 0;
        let fleet = self.fleet.as_ref().map_or(String::new(), |f| {
            format!("# fleet {:016x}\n", f.fingerprint())
        });
        format!(
            "{}{fleet}# chassis-mc {}\n",
            toml::to_string(&raw).expect("a validated study serialises"),
            env!("CARGO_PKG_VERSION")
        )
    }

    /// `[fleet]`'s vehicles, if the study has a fleet (docs/model.md#fleet).
    pub fn fleet(&self) -> Option<&Fleet> {
        self.fleet.as_deref()
    }

    /// The study of vehicle `v` of the fleet: this study with the vehicle's row in
    /// `[vehicle]` and no `[fleet]`, validated (its errors name the vehicle and its row).
    ///
    /// # Panics
    /// If the study has no fleet or `v` is not one of its vehicles.
    pub fn fleet_vehicle(&self, v: usize) -> Result<Study, StudyError> {
        let fleet = self.fleet.as_ref().expect("a study with a fleet");
        fleet::vehicle_study(&self.raw, fleet, v, (&self.spans, &self.origin, &self.dir))
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

/// Validate `raw`: a study file's checks, or, with `[fleet]`, every vehicle's.
fn validate_any(
    raw: RawStudy,
    spans: KeySpans,
    origin: &str,
    dir: PathBuf,
) -> Result<Study, StudyError> {
    match raw.fleet.is_some() {
        true => validate_fleet(raw, spans, origin, dir),
        false => validate::validate(raw, spans, origin, dir),
    }
}

/// A study with `[fleet]`: every vehicle of its table validated, the study standing for them
/// its first vehicle's, with the study as written (its `[vehicle]` and `[fleet]`) as run.
fn validate_fleet(
    raw: RawStudy,
    spans: KeySpans,
    origin: &str,
    dir: PathBuf,
) -> Result<Study, StudyError> {
    if raw.model != "vehicle" {
        return Err(StudyError {
            file: origin.to_string(),
            key: Some("fleet".into()),
            line: spans.line("fleet"),
            reason: format!("is not used by model \"{}\"", raw.model),
        });
    }
    let (fleet, mut study) = fleet::read_fleet(&raw, &spans, origin, &dir)?;
    study.raw.vehicle = raw.vehicle;
    study.raw.fleet = raw.fleet;
    study.origin = origin.to_string();
    study.fleet = Some(std::sync::Arc::new(fleet));
    Ok(study)
}
