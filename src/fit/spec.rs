//! The fit file: `[log]` (the measured cycle read from its file), the known `[vehicle]`
//! quantities, the assumed `[noise]`, `[estimation]` and `[reference]`, checked into a
//! [`FitSpec`] (docs/model.md#fit).

use std::path::{Path, PathBuf};

use crate::estimate::channels::{Acceleration, Channel, NoiseLevels};
use crate::estimate::estimators::{EstimatorRef, EstimatorSettings};
use crate::estimate::regression::Regression;
use crate::settings::{KeyError, Params};
use crate::study::{KeySpans, StudyError};
use crate::tabular::read_columns;
use crate::terrain::GradeUnit;
use crate::vehicle::{DriveCycle, VehicleParams};
use crate::vehicle::{SpeedUnit, central_differences, positions};

/// A validated fit file.
#[derive(Debug, Clone)]
pub struct FitSpec {
    /// Where it was read from.
    pub origin: String,
    /// Its directory (relative paths resolve against it).
    pub dir: PathBuf,
    /// The log file.
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
    /// per row of [`FIT_PARAMETERS`](super::FIT_PARAMETERS) (θ's derived from the M, Cd and Cr given).
    pub reference: [Option<f64>; 5],
    /// The fit file's text.
    pub text: String,
}

impl FitSpec {
    /// Read and check `path`.
    pub fn load(path: &Path) -> Result<FitSpec, StudyError> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| StudyError {
            file: origin.clone(),
            key: None,
            line: None,
            reason: format!("cannot read: {e}"),
        })?;
        let dir = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        Self::parse(&text, &origin, &dir)
    }

    /// Check the fit file `text` read from `origin` in `dir`.
    pub fn parse(text: &str, origin: &str, dir: &Path) -> Result<FitSpec, StudyError> {
        let spans = KeySpans::new(text);
        let fail = |e: KeyError| StudyError {
            file: origin.to_string(),
            line: spans.line(&e.key),
            key: Some(e.key),
            reason: e.reason,
        };
        let table: toml::Table = toml::from_str(text).map_err(|e| StudyError {
            file: origin.to_string(),
            key: None,
            line: e.span().map(|s| spans.line_of(s.start)),
            reason: e.message().to_string(),
        })?;
        let top = Params::new(&table, "");
        let root = |key: &str| -> Result<&toml::Table, StudyError> {
            table
                .get(key)
                .and_then(toml::Value::as_table)
                .ok_or_else(|| StudyError {
                    file: origin.to_string(),
                    key: Some(key.to_string()),
                    line: None,
                    reason: format!("the [{key}] table is missing"),
                })
        };
        for key in table.keys() {
            if ![
                "name",
                "seed",
                "realisations",
                "log",
                "vehicle",
                "noise",
                "estimation",
                "reference",
            ]
            .contains(&key.as_str())
            {
                return Err(fail(top.error(key, "unknown key").strip_dot()));
            }
        }
        let seed = top.number("seed").map_err(|e| fail(e.strip_dot()))?;
        let realisations = top
            .positive("realisations")
            .map_err(|e| fail(e.strip_dot()))?;
        if seed < 0.0 || seed.fract() != 0.0 || realisations.fract() != 0.0 || realisations < 20.0 {
            return Err(fail(KeyError {
                key: "realisations".into(),
                reason: format!(
                    "seed must be a whole number ≥ 0 and realisations a whole number ≥ 20 (for \
                     a 95 % percentile interval), got seed {seed}, realisations {realisations}"
                ),
            }));
        }

        // [vehicle]: the known quantities.
        let v = Params::new(root("vehicle")?, "vehicle");
        v.only(&[
            "frontal_area",
            "air_density",
            "gravity",
            "final_drive_ratio",
            "wheel_radius",
        ])
        .map_err(fail)?;
        let vehicle = VehicleParams {
            mass_kg: 1.0,
            drag_coefficient: 0.0,
            rolling_resistance: 0.0,
            frontal_area_m2: v.positive("frontal_area").map_err(fail)?,
            air_density_kg_m3: v.positive("air_density").map_err(fail)?,
            gravity_m_s2: v.positive("gravity").map_err(fail)?,
            drivetrain: None,
        };

        // [log]
        let l = Params::new(root("log")?, "log").relative_to(dir);
        l.only(&[
            "file",
            "time_column",
            "speed_column",
            "speed_unit",
            "force_column",
            "torque_column",
            "grade_column",
            "grade_unit",
            "acceleration_column",
            "min_speed",
        ])
        .map_err(fail)?;
        let file = l.file("file").map_err(fail)?;
        let time = l.string("time_column").map_err(fail)?;
        let speed = l.string("speed_column").map_err(fail)?;
        let speed_unit = l.named("speed_unit", &SpeedUnit::ALL).map_err(fail)?;
        let grade = l.string("grade_column").map_err(fail)?;
        let grade_unit = GradeUnit::parse(&l, "grade_unit").map_err(fail)?;
        let accel = l
            .optional("acceleration_column", |p, k| p.string(k))
            .map_err(fail)?;
        let min_speed = l
            .optional("min_speed", Params::non_negative)
            .map_err(fail)?
            .unwrap_or(0.0);
        let (force, torque_factor) = match (l.has("force_column"), l.has("torque_column")) {
            (true, false) => (l.string("force_column").map_err(fail)?, None),
            (false, true) => {
                let ratio = v.positive("final_drive_ratio").map_err(fail)?;
                let radius = v.positive("wheel_radius").map_err(fail)?;
                (
                    l.string("torque_column").map_err(fail)?,
                    Some(ratio / radius),
                )
            }
            _ => {
                return Err(fail(l.error(
                    "force_column",
                    "give exactly one of force_column [N] and torque_column [N m]",
                )));
            }
        };
        let mut wanted = vec![time, speed, force, grade];
        wanted.extend(accel);
        let cols =
            read_columns(&file, &wanted, 3).map_err(|e| fail(l.error("file", e.to_string())))?;
        cols.strictly_increasing(time)
            .map_err(|e| fail(l.error("file", e.to_string())))?;
        let t = cols.get(time).to_vec();
        let v_m_s: Vec<f64> = cols
            .get(speed)
            .iter()
            .map(|&s| speed_unit.to_m_s(s))
            .collect();
        let f: Vec<f64> = cols
            .get(force)
            .iter()
            .map(|&x| torque_factor.map_or(x, |q| q * x))
            .collect();
        let grade_rad: Vec<f64> = cols
            .get(grade)
            .iter()
            .map(|&g| grade_unit.to_rad(g))
            .collect();
        let (accel_m_s2, acceleration) = match accel {
            Some(a) => (cols.get(a).to_vec(), Acceleration::Model),
            None => (
                central_differences(&t, &v_m_s),
                Acceleration::Differentiated,
            ),
        };
        let cycle = DriveCycle {
            x_m: positions(&t, &v_m_s),
            t_s: t,
            v_m_s,
            grade_rad,
            f_prop_n: f,
            accel_m_s2,
        };
        let n = cycle.t_s.len();
        let mut used: Vec<bool> = cycle.v_m_s.iter().map(|&s| s >= min_speed).collect();
        if acceleration == Acceleration::Differentiated {
            used[0] = false;
            used[n - 1] = false;
        }
        if used.iter().filter(|u| **u).count() < 3 {
            return Err(fail(l.error(
                "min_speed",
                "leaves fewer than 3 samples of the log for the regression",
            )));
        }

        // [noise]: the assumed sensor noise (a number each, or a study's list of one).
        let nz = Params::new(root("noise")?, "noise");
        let keys: Vec<&str> = Channel::ALL
            .map(Channel::key)
            .into_iter()
            .chain(["velocity_correlation_time"])
            .collect();
        nz.only(&keys).map_err(fail)?;
        let mut noise = NoiseLevels {
            acceleration,
            ..NoiseLevels::default()
        };
        for c in Channel::ALL {
            noise[c] = nz
                .optional(c.key(), Params::single_non_negative)
                .map_err(fail)?
                .unwrap_or(0.0);
        }
        noise.velocity_correlation_s = nz
            .optional("velocity_correlation_time", Params::single_non_negative)
            .map_err(fail)?
            .unwrap_or(0.0);

        // [estimation]
        let e = Params::new(root("estimation")?, "estimation");
        e.only(&["estimators", "forgetting"]).map_err(fail)?;
        let estimation = root("estimation")?;
        let names: Vec<String> = match estimation.get("estimators") {
            Some(toml::Value::Array(items)) => items
                .iter()
                .map(|v| v.as_str().map(str::to_string))
                .collect::<Option<Vec<String>>>()
                .ok_or_else(|| fail(e.error("estimators", "must be a list of estimator names")))?,
            Some(_) => {
                return Err(fail(
                    e.error("estimators", "must be a list of estimator names"),
                ));
            }
            None => Vec::new(),
        };
        if names.is_empty() {
            return Err(fail(
                e.error("estimators", "must list at least one estimator"),
            ));
        }
        let mut estimators = Vec::new();
        for (i, name) in names.iter().enumerate() {
            let est = EstimatorRef::find(name).ok_or_else(|| {
                fail(e.error(
                    &format!("estimators[{i}]"),
                    format!("unknown estimator \"{name}\""),
                ))
            })?;
            estimators.push(est);
        }
        // A compensating estimator under a differentiated acceleration with AR(1) speed
        // noise needs evenly spaced samples (docs/model.md#sensors).
        if acceleration == Acceleration::Differentiated
            && noise.velocity_correlated()
            && estimators.iter().any(|e| e.compensates_speed_noise())
        {
            let t = &cycle.t_s;
            let d0 = t[1] - t[0];
            if t.windows(2)
                .any(|w| ((w[1] - w[0]) / d0 - 1.0).abs() > 1e-6)
            {
                return Err(fail(nz.error(
                    "velocity_correlation_time",
                    "with a differentiated acceleration (no acceleration_column) and a \
                     compensating estimator (bcls, wbcls), correlated speed noise needs evenly \
                     spaced samples, and this log's are not: no bias compensation is \
                     implemented for that combination",
                )));
            }
        }
        let forgetting = e
            .optional("forgetting", Params::positive)
            .map_err(fail)?
            .unwrap_or(1.0);
        if forgetting > 1.0 {
            return Err(fail(e.error("forgetting", "must lie in (0, 1]")));
        }
        // [reference] (optional): M, Cd and Cr to draw the fit against.
        let reference = match table.get("reference") {
            None => [None; 5],
            Some(_) => {
                let r = Params::new(root("reference")?, "reference");
                r.only(&["mass", "drag_coefficient", "rolling_resistance"])
                    .map_err(fail)?;
                let mass = r.optional("mass", Params::positive).map_err(fail)?;
                let cd = r
                    .optional("drag_coefficient", Params::non_negative)
                    .map_err(fail)?;
                let cr = r
                    .optional("rolling_resistance", Params::non_negative)
                    .map_err(fail)?;
                [
                    mass.map(|m| 1.0 / m),
                    mass.zip(cd).map(|(m, cd)| cd / m),
                    cr,
                    mass,
                    cd,
                ]
            }
        };
        Ok(FitSpec {
            origin: origin.to_string(),
            dir: dir.to_path_buf(),
            log: file,
            cycle,
            used,
            acceleration,
            min_speed,
            vehicle,
            noise,
            estimators,
            settings: EstimatorSettings { forgetting },
            seed: seed as u64,
            realisations: realisations as u64,
            reference,
            text: text.to_string(),
        })
    }

    /// The regression of the log's used samples, taken as they are (measured).
    pub(super) fn regression(&self) -> Regression {
        match self.acceleration {
            Acceleration::Differentiated => {
                Regression::differentiated(&self.cycle, &self.used, 0.0, &self.vehicle)
            }
            Acceleration::Model => Regression::new(&self.cycle.select(&self.used), &self.vehicle),
        }
    }
}

impl KeyError {
    /// The key without a leading dot (a key of the file's top level).
    fn strip_dot(mut self) -> KeyError {
        if let Some(k) = self.key.strip_prefix('.') {
            self.key = k.to_string();
        }
        self
    }
}
