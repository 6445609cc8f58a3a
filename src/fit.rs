//! `fit`: the estimates from a measured log, with sandwich standard errors and a parametric
//! bootstrap (see docs/model.md#fit); and `simulate-log`, which writes such a log from a
//! study (the project's own generator of synthetic logs).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use arrow::array::{ArrayRef, Float64Array, RecordBatch, StringArray};
use arrow::datatypes::{DataType, Field, Schema};
use nalgebra::{Matrix3, Vector3};
use thiserror::Error;

use crate::estimate::channels::{Acceleration, Channel, NoiseLevels};
use crate::estimate::estimators::{EstimatorRef, EstimatorSettings, Realisation};
use crate::estimate::moments::Rows;
use crate::estimate::regression::Regression;
use crate::figures::FigureError;
use crate::model::Model;
use crate::model::vehicle::{PARAMETERS, VehicleModel};
use crate::output::lock::DirLock;
use crate::output::{self, FileMetadata, OutputError, ParquetSink, PendingFile, set};
use crate::settings::{KeyError, Params};
use crate::study::{KeySpans, Study, StudyError};
use crate::tabular::read_columns;
use crate::terrain::GradeUnit;
use crate::vehicle::{DriveCycle, Replay, VehicleParams};
use crate::vehicle::{SpeedUnit, central_differences, positions};

/// The output file of `fit`.
pub const FIT_FILE: &str = "fit.parquet";

/// The figure of `fit`: each estimator's estimate and 95 % bootstrap interval of M, Cd and
/// Cr, against the `[reference]` values when given.
pub const FIT_FIGURE: &str = "fit.svg";

/// Half-width \[s\] of the centred moving average that smooths the measured speed into the
/// bootstrap's true speed trace.
pub const SMOOTHING_S: f64 = 0.5;

/// Why a fit cannot be made.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum FitError {
    /// The fit file or its log is invalid.
    #[error(transparent)]
    Study(#[from] StudyError),
    /// Writing the output failed.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// Drawing the figure failed.
    #[error(transparent)]
    Figure(#[from] FigureError),
}

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
    /// per row of [`FIT_PARAMETERS`] (θ's derived from the M, Cd and Cr given).
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
    fn regression(&self) -> Regression {
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

/// Each estimator's θ̂ on the measured rows of `reg` (taken as they are).
fn estimates(
    reg: &Regression,
    noise: &NoiseLevels,
    estimators: &[EstimatorRef],
    settings: &EstimatorSettings,
) -> Vec<Option<Vector3<f64>>> {
    let moments = reg.noise_free_moments();
    let mut rows = Rows::new(reg, &NoiseLevels::default());
    for start in (0..reg.len()).step_by(crate::noise::BLOCK) {
        let len = crate::noise::BLOCK.min(reg.len() - start);
        rows.push_block(
            reg,
            &NoiseLevels::default(),
            start,
            len,
            Default::default(),
            None,
        );
    }
    estimators
        .iter()
        .map(|e| {
            e.estimate(&Realisation {
                moments: &moments,
                rows: Some(&rows),
                regression: reg,
                noise,
                settings,
                truth: &[f64::NAN; 3],
            })
            .theta
            .ok()
        })
        .collect()
}

/// θ and the derived M = 1/θ₁ \[kg\] and Cd = θ₂/θ₁.
fn with_derived(theta: &Vector3<f64>) -> [f64; 5] {
    [
        theta[0],
        theta[1],
        theta[2],
        1.0 / theta[0],
        theta[1] / theta[0],
    ]
}

/// The standard errors of [`with_derived`] from θ's covariance `cov`: θ's own, and M's and
/// Cd's by the delta method (M = 1/θ₁: ∂M/∂θ₁ = −1/θ₁²; Cd = θ₂/θ₁: ∇ = [−θ₂/θ₁², 1/θ₁, 0]).
fn derived_se(theta: &Vector3<f64>, cov: &Matrix3<f64>) -> [f64; 5] {
    let (t1, t2) = (theta[0], theta[1]);
    let cd = Vector3::new(-t2 / (t1 * t1), 1.0 / t1, 0.0);
    [
        cov[(0, 0)].sqrt(),
        cov[(1, 1)].sqrt(),
        cov[(2, 2)].sqrt(),
        cov[(0, 0)].sqrt() / (t1 * t1),
        (cd.transpose() * cov * cd)[(0, 0)].sqrt(),
    ]
}

/// Names of the rows of `fit.parquet`, in order: θ, then M and Cd.
pub const FIT_PARAMETERS: [&str; 5] = [
    PARAMETERS[0],
    PARAMETERS[1],
    PARAMETERS[2],
    "mass",
    "drag_coefficient",
];

/// One row of `fit.parquet`.
#[derive(Debug, Clone, PartialEq)]
pub struct FitRow {
    /// Estimator name.
    pub estimator: &'static str,
    /// One of [`FIT_PARAMETERS`].
    pub parameter: &'static str,
    /// The estimate from the log.
    pub estimate: f64,
    /// Its sandwich SE (for M and Cd by the delta method from θ's sandwich covariance).
    pub sandwich_se: f64,
    /// Mean of the bootstrap estimates.
    pub boot_mean: f64,
    /// boot_mean − estimate: the estimator's bias where the truth is the fit.
    pub boot_bias: f64,
    /// estimate − boot_bias.
    pub bias_corrected: f64,
    /// 2.5 % quantile of the bootstrap estimates.
    pub ci_low: f64,
    /// 97.5 % quantile of the bootstrap estimates.
    pub ci_high: f64,
    /// The fit file's `[reference]` value, if it gives one.
    pub reference: Option<f64>,
}

/// What `fit` found.
#[derive(Debug, Clone)]
pub struct FitResult {
    /// One row per estimator × parameter.
    pub rows: Vec<FitRow>,
    /// Files written.
    pub files: Vec<PathBuf>,
}

/// The measured speed smoothed by a centred moving average over ±[`SMOOTHING_S`], not
/// below 0.
fn smoothed_speed(c: &DriveCycle) -> Vec<f64> {
    let n = c.t_s.len();
    let (mut lo, mut hi) = (0, 0);
    let mut sum = 0.0;
    let mut smooth = Vec::with_capacity(n);
    for i in 0..n {
        while hi < n && c.t_s[hi] <= c.t_s[i] + SMOOTHING_S {
            sum += c.v_m_s[hi];
            hi += 1;
        }
        while c.t_s[lo] < c.t_s[i] - SMOOTHING_S {
            sum -= c.v_m_s[lo];
            lo += 1;
        }
        smooth.push((sum / (hi - lo) as f64).max(0.0));
    }
    smooth
}

/// The speed of the vehicle with θ = `theta` driven by the log's force on the log's grade:
/// over each stretch of samples that a used row reads (the rows and their neighbours), from
/// the smoothed speed `smooth` at the stretch's first sample, by RK4 with the force and
/// grade linear between samples; `smooth` elsewhere. The speed is as smooth as the force,
/// so its central differences carry no measurement noise (docs/model.md#fit).
fn simulated_speed(spec: &FitSpec, theta: &Vector3<f64>, smooth: &[f64]) -> Vec<f64> {
    let c = &spec.cycle;
    let (g, k) = (spec.vehicle.gravity_m_s2, spec.vehicle.drag_factor_kg_m());
    let n = c.t_s.len();
    let used = &spec.used;
    let read = |i: usize| used[i] || (i > 0 && used[i - 1]) || (i + 1 < n && used[i + 1]);
    // The fitted vehicle's acceleration at speed v under force f on grade gr; drag opposes
    // the motion (v|v|), so a stretch cannot run away below standstill.
    let accel = |v: f64, f: f64, gr: f64| {
        theta[0] * f - theta[1] * k * v * v.abs() - theta[2] * g * gr.cos() - g * gr.sin()
    };
    let mut v = smooth.to_vec();
    for i in 0..n - 1 {
        if !(read(i) && read(i + 1)) {
            continue;
        }
        // The stretch starts at i when i − 1 is not read; v[i] is then smooth[i].
        let h = c.t_s[i + 1] - c.t_s[i];
        let (f0, f1) = (c.f_prop_n[i], c.f_prop_n[i + 1]);
        let (g0, g1) = (c.grade_rad[i], c.grade_rad[i + 1]);
        let (fm, gm) = (0.5 * (f0 + f1), 0.5 * (g0 + g1));
        let k1 = accel(v[i], f0, g0);
        let k2 = accel(v[i] + 0.5 * h * k1, fm, gm);
        let k3 = accel(v[i] + 0.5 * h * k2, fm, gm);
        let k4 = accel(v[i] + h * k3, f1, g1);
        v[i + 1] = v[i] + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    }
    v
}

/// The world of the parametric bootstrap of one estimator's fit: the vehicle with
/// θ = `theta` replayed on the log's rows (docs/model.md#fit) with the assumed noise, as a
/// one-condition model of `estimator`.
fn world(
    spec: &FitSpec,
    estimator: EstimatorRef,
    theta: &Vector3<f64>,
) -> Result<VehicleModel, FitError> {
    let c = &spec.cycle;
    let n = c.t_s.len();
    let smooth = smoothed_speed(c);
    // The bootstrap world's truth, on the log's own rows, fitting θ exactly. With an
    // accelerometer: the smoothed speed, the logged force and grade, and the acceleration
    // that makes every row fit θ (so the excitation is the log's own). With a
    // differentiated acceleration the output is the speed's central difference, and the
    // regression's noise comes from the rows at each end of a used stretch (the interior
    // telescopes) unless the force is rough: the speed is the fitted vehicle's, simulated
    // under the logged force, and the force the one that makes its differences fit θ.
    let speed = match spec.acceleration {
        Acceleration::Model => smooth,
        Acceleration::Differentiated => simulated_speed(spec, theta, &smooth),
    };
    let (g, k) = (spec.vehicle.gravity_m_s2, spec.vehicle.drag_factor_kg_m());
    let central = central_differences(&c.t_s, &speed);
    let (mut f_prop_n, mut accel_m_s2) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for i in 0..n {
        let (v, gr) = (speed[i], c.grade_rad[i]);
        let resistance = theta[1] * k * v * v + theta[2] * g * gr.cos() + g * gr.sin();
        let (f, a) = match spec.acceleration {
            Acceleration::Model => {
                let f = c.f_prop_n[i];
                (f, theta[0] * f - resistance)
            }
            Acceleration::Differentiated => ((central[i] + resistance) / theta[0], central[i]),
        };
        f_prop_n.push(f);
        accel_m_s2.push(a);
    }
    let cycle = DriveCycle {
        x_m: positions(&c.t_s, &speed),
        t_s: c.t_s.clone(),
        v_m_s: speed,
        grade_rad: c.grade_rad.clone(),
        f_prop_n,
        accel_m_s2,
    };
    let replay = Replay {
        source: format!("the fit of {} to {}", estimator.name(), spec.log.display()),
        cycle,
        used: Some(spec.used.clone()),
    };
    // θ as a vehicle: M = 1/θ₁, Cd = θ₂ M, Cr = θ₃ (VehicleParams::theta reads them back).
    let mass = 1.0 / theta[0];
    let vehicle = VehicleParams {
        mass_kg: mass,
        drag_coefficient: theta[1] * mass,
        rolling_resistance: theta[2],
        ..spec.vehicle.clone()
    };
    let origin = format!("{} (bootstrap of {})", spec.origin, estimator.name());
    Ok(VehicleModel::for_cycle(
        replay,
        vehicle,
        spec.noise,
        vec![estimator],
        spec.settings,
        &origin,
    )?)
}

/// The bootstrap in `model` (from [`world`]): the assumed noise re-drawn and the estimator
/// re-run `spec.realisations` times. Returns each realisation's θ̂ (failed ones left out).
fn resample(spec: &FitSpec, model: &VehicleModel) -> Vec<Vector3<f64>> {
    let layout = model.layout();
    let stride = layout.realisation_stride();
    use rayon::prelude::*;
    let thetas: Vec<Option<Vector3<f64>>> = (0..spec.realisations)
        .into_par_iter()
        .map(|r| {
            let mut slots = vec![0.0; stride];
            model.realise(spec.seed, 0, r, &mut slots);
            let t = Vector3::from_fn(|p, _| slots[layout.theta_at(0, p)]);
            t.iter().all(|v| v.is_finite()).then_some(t)
        })
        .collect();
    thetas.into_iter().flatten().collect()
}

/// The q-quantile of sorted `v` (linear interpolation).
fn quantile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let h = q * (v.len() - 1) as f64;
    let (i, frac) = (h.floor() as usize, h.fract());
    let j = (i + 1).min(v.len() - 1);
    v[i] + frac * (v[j] - v[i])
}

/// Fit `spec`'s log and write `fit.parquet` and `report.html` into `out`.
pub fn fit(spec: &FitSpec, out: &Path) -> Result<FitResult, FitError> {
    let reg = spec.regression();
    let fits = estimates(&reg, &spec.noise, &spec.estimators, &spec.settings);
    // Every refusal before anything is created.
    let mut thetas = Vec::with_capacity(fits.len());
    for (est, theta) in spec.estimators.iter().zip(fits) {
        let Some(theta) = theta else {
            return Err(StudyError {
                file: spec.origin.clone(),
                key: Some("estimation.estimators".into()),
                line: None,
                reason: format!(
                    "{}: the normal equations of the log are singular",
                    est.name()
                ),
            }
            .into());
        };
        if !(theta[0] > 0.0 && theta[1] >= 0.0 && theta[2] >= 0.0) {
            return Err(StudyError {
                file: spec.origin.clone(),
                key: Some("estimation.estimators".into()),
                line: None,
                reason: format!(
                    "{}: the fit θ = [{:e}, {:e}, {:e}] is not a vehicle (1/M must be \
                     positive, Cd/M and Cr not negative), so it cannot be bootstrapped",
                    est.name(),
                    theta[0],
                    theta[1],
                    theta[2]
                ),
            }
            .into());
        }
        thetas.push((*est, theta));
    }
    let worlds = thetas
        .iter()
        .map(|(est, theta)| world(spec, *est, theta))
        .collect::<Result<Vec<VehicleModel>, FitError>>()?;

    std::fs::create_dir_all(out).map_err(|e| OutputError::io(out, e))?;
    let _lock = DirLock::acquire(out)?;
    set::ensure_complete(out)?;
    let mut rows = Vec::new();
    for ((est, theta), model) in thetas.iter().zip(&worlds) {
        let se = reg
            .sandwich_covariance(&[theta[0], theta[1], theta[2]], &spec.noise)
            .map_or([f64::NAN; 5], |cov| derived_se(theta, &cov));
        let boot = resample(spec, model);
        let estimate = with_derived(theta);
        for (p, name) in FIT_PARAMETERS.iter().enumerate() {
            let mut values: Vec<f64> = boot.iter().map(|b| with_derived(b)[p]).collect();
            values.sort_by(f64::total_cmp);
            let boot_mean = values.iter().sum::<f64>() / values.len() as f64;
            let boot_bias = boot_mean - estimate[p];
            rows.push(FitRow {
                estimator: est.name(),
                parameter: name,
                estimate: estimate[p],
                sandwich_se: se[p],
                boot_mean,
                boot_bias,
                bias_corrected: estimate[p] - boot_bias,
                ci_low: quantile(&values, 0.025),
                ci_high: quantile(&values, 0.975),
                reference: spec.reference[p],
            });
        }
    }
    let meta = FileMetadata {
        study_toml: spec.text.clone(),
        study_dir: spec.dir.display().to_string(),
        seed: spec.seed,
        realisations: spec.realisations,
        identity: String::new(),
        extra: Vec::new(),
    };
    let svg = figure(&rows)?;
    let figure_tmp = out.join(output::temporary_name(FIT_FIGURE));
    std::fs::write(&figure_tmp, &svg).map_err(|e| OutputError::io(&figure_tmp, e))?;
    let pending = vec![
        write_rows(out, &rows, &meta)?,
        PendingFile::new(figure_tmp, out.join(FIT_FIGURE)),
        write_report(out, spec, &rows, &svg)?,
    ];
    let files = set::commit(out, pending, &|p| {
        p == FIT_FILE || p == FIT_FIGURE || p == "report.html"
    })?;
    Ok(FitResult { rows, files })
}

fn write_rows(
    out: &Path,
    rows: &[FitRow],
    meta: &FileMetadata,
) -> Result<PendingFile, OutputError> {
    let schema = Arc::new(Schema::new(vec![
        Field::new("estimator", DataType::Utf8, false),
        Field::new("parameter", DataType::Utf8, false),
        Field::new("estimate", DataType::Float64, false),
        Field::new("sandwich_se", DataType::Float64, true),
        Field::new("boot_mean", DataType::Float64, true),
        Field::new("boot_bias", DataType::Float64, true),
        Field::new("bias_corrected", DataType::Float64, true),
        Field::new("ci_low", DataType::Float64, true),
        Field::new("ci_high", DataType::Float64, true),
        Field::new("reference", DataType::Float64, true),
    ]));
    let col = |f: fn(&FitRow) -> f64| -> ArrayRef {
        Arc::new(Float64Array::from_iter(
            rows.iter().map(|r| Some(f(r)).filter(|v| v.is_finite())),
        ))
    };
    let columns: Vec<ArrayRef> = vec![
        Arc::new(StringArray::from_iter_values(
            rows.iter().map(|r| r.estimator),
        )),
        Arc::new(StringArray::from_iter_values(
            rows.iter().map(|r| r.parameter),
        )),
        Arc::new(Float64Array::from_iter_values(
            rows.iter().map(|r| r.estimate),
        )),
        col(|r| r.sandwich_se),
        col(|r| r.boot_mean),
        col(|r| r.boot_bias),
        col(|r| r.bias_corrected),
        col(|r| r.ci_low),
        col(|r| r.ci_high),
        col(|r| r.reference.unwrap_or(f64::NAN)),
    ];
    let batch =
        RecordBatch::try_new(schema.clone(), columns).map_err(|e| OutputError::arrow(out, e))?;
    let mut sink = ParquetSink::create(out, FIT_FILE, schema, meta, "fit")?;
    sink.write(&batch)?;
    sink.finish()
}

/// The rows of the table and the figure, in the order a vehicle engineer reads them: M, Cd
/// and Cr, then θ's 1/M and Cd/M. Index into [`FIT_PARAMETERS`] and label with units.
const SHOWN: [(usize, &str); 5] = [
    (3, "M [kg]"),
    (4, "Cd"),
    (2, "Cr"),
    (0, "1/M [1/kg]"),
    (1, "Cd/M [1/kg]"),
];

/// `value` to the digits that `spread` (its SE) supports: down to the second significant
/// digit of the spread (four significant digits of the value when the spread is unknown),
/// in plain notation for magnitudes 0.001 … 100 000 and scientific otherwise.
pub fn format_value(value: f64, spread: f64) -> String {
    if !value.is_finite() {
        return "–".into();
    }
    let magnitude = |x: f64| x.abs().log10().floor() as i32;
    let last = if spread.is_finite() && spread > 0.0 {
        magnitude(spread) - 1
    } else if value != 0.0 {
        magnitude(value) - 3
    } else {
        0
    };
    let text = if value == 0.0 || (1e-3..1e5).contains(&value.abs()) {
        format!("{value:.*}", (-last).clamp(0, 12) as usize)
    } else {
        format!(
            "{value:.*e}",
            (magnitude(value) - last).clamp(0, 12) as usize
        )
    };
    // A negative value rounded to zero is shown as zero.
    match text.strip_prefix('-') {
        Some(rest) if rest.chars().all(|c| matches!(c, '0' | '.')) => rest.to_string(),
        _ => text,
    }
}

/// The table `fit` prints and its report shows: per estimator M, Cd, Cr, 1/M and Cd/M,
/// each to the digits its sandwich SE supports (docs/model.md#fit).
pub fn table(rows: &[FitRow]) -> String {
    let with_reference = rows.iter().any(|r| r.reference.is_some());
    let mut lines = vec![[
        "estimator".to_string(),
        "parameter".into(),
        "estimate".into(),
        "SE (sandwich)".into(),
        "bootstrap bias".into(),
        "bias-corrected".into(),
        "95 % bootstrap interval".into(),
        if with_reference {
            "reference".into()
        } else {
            String::new()
        },
    ]];
    let mut estimators: Vec<&str> = rows.iter().map(|r| r.estimator).collect();
    estimators.dedup();
    for est in estimators {
        for (p, label) in SHOWN {
            let Some(r) = rows
                .iter()
                .find(|r| r.estimator == est && r.parameter == FIT_PARAMETERS[p])
            else {
                continue;
            };
            let f = |v: f64| format_value(v, r.sandwich_se);
            lines.push([
                est.to_string(),
                label.to_string(),
                f(r.estimate),
                format_value(r.sandwich_se, r.sandwich_se),
                f(r.boot_bias),
                f(r.bias_corrected),
                format!("[{}, {}]", f(r.ci_low), f(r.ci_high)),
                r.reference
                    .map_or(String::new(), |v| format_value(v, r.sandwich_se)),
            ]);
        }
    }
    let widths: Vec<usize> = (0..8)
        .map(|c| {
            lines
                .iter()
                .map(|l| l[c].chars().count())
                .max()
                .unwrap_or(0)
        })
        .collect();
    let mut out = String::new();
    for line in &lines {
        let mut text = String::new();
        for (c, cell) in line.iter().enumerate() {
            let pad = widths[c] - cell.chars().count();
            if c < 2 {
                let _ = write!(text, "{cell}{}  ", " ".repeat(pad));
            } else {
                let _ = write!(text, "{}{cell}  ", " ".repeat(pad));
            }
        }
        out.push_str(text.trim_end());
        out.push('\n');
    }
    out
}

/// The figure of [`FIT_FIGURE`] as SVG text: one panel per parameter (M, Cd, Cr), one line
/// per estimator with its 95 % bootstrap interval and its estimate (a dot), the reference
/// value dashed when given.
fn figure(rows: &[FitRow]) -> Result<String, FigureError> {
    use plotters::prelude::*;
    const PANELS: usize = 3;
    let path = Path::new(FIT_FIGURE);
    let fail = |e: &dyn std::fmt::Display| FigureError::Draw {
        path: path.to_path_buf(),
        reason: e.to_string(),
    };
    let mut estimators: Vec<&str> = rows.iter().map(|r| r.estimator).collect();
    estimators.dedup();
    let n = estimators.len();
    let mut svg = String::new();
    {
        let height = 150 + 45 * n as u32;
        let root = SVGBackend::with_string(&mut svg, (1200, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| fail(&e))?;
        let (top, bottom) = root.split_vertically(height - 30);
        for (panel, &(p, label)) in top.split_evenly((1, PANELS)).iter().zip(&SHOWN) {
            let mine: Vec<&FitRow> = estimators
                .iter()
                .filter_map(|e| {
                    rows.iter()
                        .find(|r| r.estimator == *e && r.parameter == FIT_PARAMETERS[p])
                })
                .collect();
            let values = mine
                .iter()
                .flat_map(|r| [r.estimate, r.ci_low, r.ci_high])
                .chain(mine.iter().filter_map(|r| r.reference))
                .filter(|v| v.is_finite());
            let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(v), b.max(v))
            });
            let (lo, hi) = match (lo.is_finite(), hi > lo) {
                (true, true) => (lo - 0.08 * (hi - lo), hi + 0.08 * (hi - lo)),
                (true, false) => (
                    lo - 0.5 * lo.abs().max(1e-12),
                    lo + 0.5 * lo.abs().max(1e-12),
                ),
                _ => (0.0, 1.0),
            };
            // Tick labels to the digits of about a tenth of the axis (plotters picks ~4 ticks).
            let tick_digits = 2.5 * (hi - lo);
            let mut chart = ChartBuilder::on(panel)
                .caption(label, ("sans-serif", 20))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d(lo..hi, -0.5..n as f64 - 0.5)
                .map_err(|e| fail(&e))?;
            chart
                .configure_mesh()
                .disable_y_mesh()
                .x_labels(4)
                .y_labels(n)
                .x_label_formatter(&|v| format_value(*v, tick_digits))
                .y_label_formatter(&|v| {
                    let i = v.round();
                    if (v - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < n {
                        estimators[n - 1 - i as usize].to_string()
                    } else {
                        String::new()
                    }
                })
                .label_style(("sans-serif", 14))
                .draw()
                .map_err(|e| fail(&e))?;
            if let Some(r) = mine.iter().find_map(|r| r.reference) {
                chart
                    .draw_series(DashedLineSeries::new(
                        [(r, -0.5), (r, n as f64 - 0.5)],
                        6,
                        4,
                        BLACK.mix(0.6).stroke_width(1),
                    ))
                    .map_err(|e| fail(&e))?;
            }
            for (i, r) in mine.iter().enumerate() {
                let y = (n - 1 - i) as f64;
                let color = Palette99::pick(i).to_rgba();
                let style = color.stroke_width(2);
                let cap = 0.12;
                chart
                    .draw_series([
                        PathElement::new(vec![(r.ci_low, y), (r.ci_high, y)], style),
                        PathElement::new(vec![(r.ci_low, y - cap), (r.ci_low, y + cap)], style),
                        PathElement::new(vec![(r.ci_high, y - cap), (r.ci_high, y + cap)], style),
                    ])
                    .map_err(|e| fail(&e))?;
                chart
                    .draw_series([Circle::new((r.estimate, y), 5, color.filled())])
                    .map_err(|e| fail(&e))?;
            }
        }
        bottom
            .draw(&Text::new(
                "dot: estimate; bar: 95 % bootstrap interval; dashed: the fit file's [reference]",
                (20, 8),
                ("sans-serif", 14),
            ))
            .map_err(|e| fail(&e))?;
        root.present().map_err(|e| fail(&e))?;
    }
    Ok(svg)
}

fn write_report(
    out: &Path,
    spec: &FitSpec,
    rows: &[FitRow],
    svg: &str,
) -> Result<PendingFile, OutputError> {
    use crate::report::escape;
    let title = format!("{} — chassis-mc fit", spec.log.display());
    let svg = svg.find("<svg").map_or(svg, |i| &svg[i..]);
    let html = format!(
        "{head}<p>log {log}: {n} samples, {used} in the regression; \
         acceleration {acc}; bootstrap seed {seed}, {r} realisations; chassis-mc {ver}</p>\n\
         <p class=\"warning\">The sandwich SE assumes the noise levels of [noise] and ignores the \
         estimator's bias (for M and Cd it is the delta method's); the bootstrap interval is a \
         percentile interval of the estimator in a world where the fit is the truth, so it is \
         centred on the estimate plus the bias: for a biased estimator read the bias-corrected \
         estimate with it.</p>\n\
         <figure>\n{svg}\n<figcaption>{figure}: estimate and 95 % bootstrap interval per \
         estimator{against}</figcaption>\n</figure>\n\
         <pre>{table}</pre>\n<h2>Fit file</h2>\n<pre>{text}</pre>\n</body>\n</html>\n",
        head = crate::report::head(&title),
        log = escape(&spec.log.display().to_string()),
        n = spec.cycle.t_s.len(),
        used = spec.used.iter().filter(|u| **u).count(),
        acc = spec.acceleration.name(),
        seed = spec.seed,
        r = spec.realisations,
        ver = env!("CARGO_PKG_VERSION"),
        figure = FIT_FIGURE,
        against = if spec.reference.iter().any(Option::is_some) {
            ", against the fit file's [reference] (dashed)"
        } else {
            ""
        },
        table = escape(&table(rows)),
        text = escape(&spec.text),
    );
    let tmp = out.join(output::temporary_name("report.html"));
    std::fs::write(&tmp, html).map_err(|e| OutputError::io(&tmp, e))?;
    Ok(PendingFile::new(tmp, out.join("report.html")))
}

/// Write a synthetic log of `study` (one condition) to `path`: the noise-free cycle with
/// realisation `r`'s noise of every channel that is on (drawn as a run draws it),
/// columns `time_s`, `speed_m_s`, `force_n`, `grade_rad` and `accel_m_s2` (the model
/// acceleration plus the output noise: an accelerometer).
pub fn simulate_log(study: &Study, r: u64, path: &Path) -> Result<usize, FitError> {
    let model = VehicleModel::new(study)?;
    if model.condition_count() != 1 {
        return Err(study
            .error_at(
                "terrain.scales",
                format!(
                    "simulate-log needs a study with one condition; this one has {}",
                    model.condition_count()
                ),
            )
            .into());
    }
    let cycle = model.cycles().remove(0);
    let noise = model.noise_levels(0);
    let n = cycle.t_s.len();
    let draws = |c: Channel| -> Vec<f64> {
        let mut out = vec![0.0; n];
        if noise.is_on(c) {
            model.standard_draws(study.seed(), 0, c, r, &mut out);
            out.iter_mut().for_each(|z| *z *= noise[c]);
        }
        out
    };
    let (ev, ey, eg, ef) = (
        draws(Channel::Velocity),
        draws(Channel::Output),
        draws(Channel::Grade),
        draws(Channel::Force),
    );
    let mut csv = String::from("time_s,speed_m_s,force_n,grade_rad,accel_m_s2\n");
    for i in 0..n {
        let _ = writeln!(
            csv,
            "{},{},{},{},{}",
            cycle.t_s[i],
            cycle.v_m_s[i] + ev[i],
            cycle.f_prop_n[i] + ef[i],
            cycle.grade_rad[i] + eg[i],
            cycle.accel_m_s2[i] + ey[i]
        );
    }
    std::fs::write(path, csv).map_err(|e| OutputError::io(path, e))?;
    Ok(n)
}
