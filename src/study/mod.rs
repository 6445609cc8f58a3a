//! Study files: TOML in, a validated [`Study`] out.
//!
//! This is the one place where user input becomes trusted configuration. serde structs with
//! `deny_unknown_fields` catch unknown keys, missing keys and wrong types; `validate` then
//! checks every value. Every failure is a [`StudyError`] that names the file, the dotted key,
//! its line and the reason, so a user can fix the file without reading code.

mod raw;
mod spans;
mod validate;

use validate::{check_realisations, serde_error, validate};

use std::fmt;
use std::path::Path;
use std::sync::Arc;

use raw::RawStudy;
pub use spans::KeySpans;

use crate::estimate::channels::{Channel, NoiseLevels, PerChannel};
use crate::estimate::estimators::EstimatorRef;
use crate::terrain::{ScaleTarget, TerrainSpec};
use crate::vehicle::{CycleSource, VehicleParams};

pub use crate::vehicle::MAX_SAMPLES;

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

/// Which noise enters the measurements of the vehicle study: the standard deviations
/// listed for each channel, one condition axis each (units per [`Channel::unit`]).
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseAxes(PerChannel<Vec<f64>>);

impl NoiseAxes {
    /// The axes from the levels of each channel (each list non-empty).
    pub fn new(levels: PerChannel<Vec<f64>>) -> Self {
        NoiseAxes(levels)
    }

    /// The levels listed for `channel`.
    pub fn levels(&self, channel: Channel) -> &[f64] {
        &self.0[channel]
    }

    /// Every combination, nested in [`Channel::ALL`] order (the last channel varies fastest).
    pub fn combinations(&self) -> Vec<NoiseLevels> {
        let mut out = vec![NoiseLevels::default()];
        for channel in Channel::ALL {
            out = out
                .into_iter()
                .flat_map(|base| {
                    self.0[channel].iter().map(move |&sd| {
                        let mut levels = base;
                        levels[channel] = sd;
                        levels
                    })
                })
                .collect();
        }
        out
    }
}

/// The validated description of a vehicle study (docs/model.md, and the README's study keys).
#[derive(Debug, Clone)]
pub struct VehicleStudy {
    /// Vehicle parameters (the truth the estimators try to recover).
    pub vehicle: VehicleParams,
    /// Where the drive cycle comes from (the drive mode and its settings).
    pub drive: Arc<dyn CycleSource>,
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
#[derive(Debug, Clone)]
pub enum ModelSpec {
    /// The longitudinal vehicle model of the thesis.
    Vehicle(VehicleStudy),
    /// The straight-line example of thesis §3.2–3.3.
    LineFit(LineFitStudy),
}

/// A validated study: everything needed to run it, and nothing unchecked.
///
/// The study as written ([`to_toml`](Study::to_toml), stored in every output file and
/// behind the resume identity) and its validated values are built together by validation
/// and change together only through [`with_overrides`](Study::with_overrides): the fields
/// are private, so the two cannot drift apart.
#[derive(Debug, Clone)]
pub struct Study {
    name: String,
    seed: u64,
    realisations: u64,
    model: ModelSpec,
    origin: String,
    raw: RawStudy,
    spans: KeySpans,
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
