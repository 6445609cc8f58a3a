//! The vehicle study: its validated settings ([`VehicleStudy`]) and their validation from
//! `[vehicle]`, `[drive]`, `[terrain]`, `[noise]` and `[estimation]`.

use std::sync::Arc;

use super::placement::{COMMON_DRIVE_KEYS, COMMON_TERRAIN_KEYS, home_of, unknown_key};
use super::raw::{RawNoise, RawStudy};
use super::truth::{TruthAxes, validate_truth};
use super::validate::{Checker, SettingKeys, validate_estimation};
use super::{MAX_SAMPLES, StudyError};
use crate::estimate::channels::Acceleration;
use crate::estimate::channels::{Channel, NoiseLevels, PerChannel};
use crate::estimate::estimators::{EstimatorRef, EstimatorSettings};
use crate::settings::{KeyError, Params, one_or_many};
use crate::terrain::profiles::PROFILES;
use crate::terrain::{ScaleTarget, TerrainSpec};
use crate::vehicle::{CycleSource, DRIVE_MODES, Drivetrain, RowSelection, VehicleParams};

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
    /// Which samples the regression uses.
    pub selection: RowSelection,
    /// The durations axis \[s\]: keep the first T seconds of the cycle (`None`: the whole
    /// cycle).
    pub durations: Option<Vec<f64>>,
    /// Terrain profile and grid (`None` when the drive cycle brings its own grade); the
    /// scales are an axis of conditions.
    pub terrain: Option<TerrainSpec>,
    /// Terrain scale factors, one condition axis.
    pub scales: Vec<f64>,
    /// Noise condition axes.
    pub noise: NoiseAxes,
    /// Correlation times of the speed noise \[s\], one condition axis (`[0.0]`, white, when
    /// the study has no `noise.velocity_correlation_time`).
    pub velocity_correlation_s: Vec<f64>,
    /// Constant offsets of the measured grade \[rad\], one condition axis (`[0.0]` when
    /// the study has no `noise.grade_bias`).
    pub grade_bias: Vec<f64>,
    /// Estimators run on every realisation (common random numbers).
    pub estimators: Vec<EstimatorRef>,
    /// Settings of the estimators (`estimation.forgetting`).
    pub settings: EstimatorSettings,
    /// Sources of the acceleration in the output, one condition axis (`[model]` when the
    /// study has no `estimation.acceleration`).
    pub acceleration: Vec<Acceleration>,
    /// `noise.share_across_scales`: conditions that differ only in terrain scale and
    /// duration read the same noise draws in each realisation (default false).
    pub share_across_scales: bool,
    /// `noise.grade_map_sd` \[m\]: the elevation map's error, one condition axis (`[0.0]`
    /// without the key; docs/model.md#grade-map).
    pub grade_map_sd: Vec<f64>,
    /// `noise.grade_map_length` \[m\]: the correlation length of the map's error (200 m
    /// without the key).
    pub grade_map_length_m: f64,
    /// `estimation.air_speed`: what the drag regressor reads.
    pub air_speed: AirSpeed,
    /// `noise.air_speed_sd` \[m/s\]: the air-speed sensor's noise, one condition axis
    /// (`[0.0]` without the key; docs/model.md#air-speed).
    pub air_speed_sd: Vec<f64>,
    /// `[truth]`: the model errors, condition axes after all the others (the truth is the
    /// equation without the table).
    pub truth: TruthAxes,
}

/// What the drag regressor reads (`estimation.air_speed`; docs/model.md#air-speed).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AirSpeed {
    /// The measured vehicle speed Ṽ (the thesis).
    Ground,
    /// A measured air speed V + w + e_a (a mobile anemometer): the truth's wind is in the
    /// regressor, and the air-speed sensor's noise takes the place of the speed noise in it.
    Measured,
}

impl AirSpeed {
    /// Every value, as study files name them.
    pub const ALL: [AirSpeed; 2] = [AirSpeed::Ground, AirSpeed::Measured];

    /// The name in study files.
    pub fn name(self) -> &'static str {
        match self {
            AirSpeed::Ground => "ground",
            AirSpeed::Measured => "measured",
        }
    }
}

pub(super) fn validate(raw: &RawStudy, c: &Checker<'_>) -> Result<VehicleStudy, StudyError> {
    let v = raw
        .vehicle
        .as_ref()
        .ok_or_else(|| c.missing_table("vehicle"))?;
    let d = raw.drive.as_ref().ok_or_else(|| c.missing_table("drive"))?;
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
        drivetrain: match (v.final_drive_ratio, v.wheel_radius) {
            (Some(ratio), Some(radius)) => Some(Drivetrain {
                final_drive_ratio: c.positive("vehicle.final_drive_ratio", ratio)?,
                wheel_radius_m: c.positive("vehicle.wheel_radius", radius)?,
            }),
            (None, Some(_)) => {
                return Err(c.fail("vehicle.final_drive_ratio", "required key is missing"));
            }
            (Some(_), None) => {
                return Err(c.fail("vehicle.wheel_radius", "required key is missing"));
            }
            (None, None) => None,
        },
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
    // The keys every drive mode has; the rest are the mode's own.
    if let Some(key) = d
        .params
        .keys()
        .find(|k| !COMMON_DRIVE_KEYS.contains(&k.as_str()) && !mode.keys.contains(&k.as_str()))
    {
        let expected = ["mode"].iter().chain(&COMMON_DRIVE_KEYS).chain(mode.keys);
        return Err(unknown_key(
            c,
            "drive",
            key,
            expected.copied().collect(),
            Some(("drive mode", mode.name)),
        ));
    }
    let mut own = d.params.clone();
    let mut common = toml::Table::new();
    for key in COMMON_DRIVE_KEYS {
        if let Some(value) = own.remove(key) {
            common.insert(key.to_string(), value);
        }
    }
    let fail = |e: KeyError| c.fail(&e.key, e.reason);
    let drive = (mode.parse)(&Params::new(&own, "drive").relative_to(c.dir())).map_err(fail)?;
    let common = Params::new(&common, "drive");
    let selection = RowSelection {
        min_speed_m_s: common
            .optional("min_speed", Params::non_negative)
            .map_err(fail)?
            .unwrap_or(0.0),
        exclude_braking: common
            .optional("exclude_braking", Params::boolean)
            .map_err(fail)?
            .unwrap_or(false),
    };
    let durations = common
        .optional("durations", Params::positive_list)
        .map_err(fail)?;
    if durations.is_some() && drive.runs().is_some() {
        return Err(c.fail(
            "drive.durations",
            format!(
                "does not apply to drive mode \"{}\": its cycle is runs, and drive.runs is \
                 the axis (a condition with k runs uses the first k)",
                mode.name
            ),
        ));
    }
    if drive.needs_drivetrain() && vehicle.drivetrain.is_none() {
        return Err(c.fail(
            "vehicle.final_drive_ratio",
            format!(
                "required key is missing (drive mode \"{}\" turns a torque into a force)",
                mode.name
            ),
        ));
    }
    let (terrain, scales) = validate_terrain(
        raw,
        drive.needs_terrain(),
        drive.needs_terrain() || drive.uses_terrain(),
        c,
    )?;

    let ValidatedNoise {
        axes: noise,
        grade_bias,
        velocity_correlation_s,
        share_across_scales,
        grade_map_sd,
        grade_map_length_m,
        air_speed_sd,
    } = validate_noise(n, c)?;
    let known_inv_mass = e.known_mass.unwrap_or(false).then(|| 1.0 / vehicle.mass_kg);
    let keys = SettingKeys {
        forgetting: e.forgetting,
        known_inv_mass,
        effective_mass_factor: e.effective_mass_factor,
    };
    let (estimators, settings) = validate_estimation(&e.estimators, keys, c)?;
    let acceleration = validate_acceleration(e.acceleration.as_ref(), c)?;
    let air_speed = validate_air_speed(
        e.air_speed.as_deref(),
        &noise,
        &air_speed_sd,
        &acceleration,
        c,
    )?;

    if drive.runs().is_some() && known_inv_mass.is_none() {
        // Without propulsion the 1/M column is zero: the mass cannot be estimated.
        return Err(c.fail(
            "estimation.known_mass",
            format!(
                "must be true with drive.mode = \"{}\": the vehicle coasts without propulsion, so \
                 its mass cannot be estimated; the test weighs it (vehicle.mass)",
                mode.name
            ),
        ));
    }
    let truth = validate_truth(raw.truth.as_ref(), c)?;

    Ok(VehicleStudy {
        vehicle,
        drive,
        selection,
        durations,
        terrain,
        scales,
        noise,
        grade_bias,
        velocity_correlation_s,
        estimators,
        settings,
        acceleration,
        share_across_scales,
        grade_map_sd,
        grade_map_length_m,
        air_speed,
        air_speed_sd,
        truth,
    })
}

/// `estimation.air_speed` (default "ground"), checked against the noise it needs: a
/// measured air speed replaces the speed in the drag regressor, so the speed sensor's noise
/// must be off and the acceleration the model's (a differentiated one would read the
/// ground speed, whose noise would then enter only the output); a ground speed has no
/// air-speed sensor.
fn validate_air_speed(
    value: Option<&str>,
    noise: &NoiseAxes,
    air_speed_sd: &[f64],
    acceleration: &[Acceleration],
    c: &Checker<'_>,
) -> Result<AirSpeed, StudyError> {
    const KEY: &str = "estimation.air_speed";
    let names: Vec<&str> = AirSpeed::ALL.map(AirSpeed::name).to_vec();
    let air_speed = match value {
        None => AirSpeed::Ground,
        Some(name) => AirSpeed::ALL
            .into_iter()
            .find(|a| a.name() == name)
            .ok_or_else(|| {
                c.fail(
                    KEY,
                    format!("unknown value \"{name}\"; expected one of {names:?}"),
                )
            })?,
    };
    match air_speed {
        AirSpeed::Ground if air_speed_sd.iter().any(|&s| s > 0.0) => Err(c.fail(
            &format!("noise.{AIR_SPEED_SD}"),
            "is the noise of a measured air speed, but the drag regressor reads the ground \
             speed (estimation.air_speed = \"ground\", the default); set estimation.air_speed \
             = \"measured\" or leave the key out",
        )),
        AirSpeed::Measured if noise.levels(Channel::Velocity).iter().any(|&s| s > 0.0) => Err(c
            .fail(
                &format!("noise.{}", Channel::Velocity.key()),
                "must be [0] with estimation.air_speed = \"measured\": the drag regressor reads \
                 the air-speed sensor (noise.air_speed_sd) and the acceleration is the model's, \
                 so the speed sensor's noise enters no column",
            )),
        AirSpeed::Measured if acceleration.contains(&Acceleration::Differentiated) => Err(c.fail(
            KEY,
            "\"measured\" needs estimation.acceleration = \"model\": an acceleration \
             differentiated from the ground speed is not supported with a measured air speed",
        )),
        _ => Ok(air_speed),
    }
}

/// `[terrain]`: the profile and its grid (required when the drive mode `needs` them; read
/// when given if it `uses` them; else `[terrain]` may only give `scales`), and the scales
/// (default `[1.0]` without a profile).
fn validate_terrain(
    raw: &RawStudy,
    needs: bool,
    uses: bool,
    c: &Checker<'_>,
) -> Result<(Option<TerrainSpec>, Vec<f64>), StudyError> {
    let t = match (&raw.terrain, needs) {
        (Some(t), _) => t,
        (None, true) => return Err(c.missing_table("terrain")),
        (None, false) => return Ok((None, vec![1.0])),
    };
    if !uses {
        if let Some(key) = t
            .params
            .keys()
            .find(|k| home_of(k).iter().any(|(t, _)| *t != "terrain"))
        {
            return Err(unknown_key(c, "terrain", key, vec!["scales"], None));
        }
        let named = [
            ("profile", t.profile.is_some()),
            ("length", t.length.is_some()),
            ("scale_applies_to", t.scale_applies_to.is_some()),
        ];
        let extra = t
            .params
            .keys()
            .map(String::as_str)
            .chain(named.iter().filter(|(_, given)| *given).map(|(k, _)| *k))
            .next();
        if let Some(key) = extra {
            return Err(c.fail(
                &format!("terrain.{key}"),
                "is not used: the trace brings its own grade (only terrain.scales is read)",
            ));
        }
        let scales = match &t.scales {
            Some(s) => c.list("terrain.scales", s, Checker::non_negative)?,
            None => vec![1.0],
        };
        return Ok((None, scales));
    }
    let required = |key: &str| c.fail(&format!("terrain.{key}"), "required key is missing");
    let name = t.profile.as_deref().ok_or_else(|| required("profile"))?;
    let entry = PROFILES.iter().find(|p| p.name == name).ok_or_else(|| {
        let names: Vec<&str> = PROFILES.iter().map(|p| p.name).collect();
        c.fail(
            "terrain.profile",
            format!("unknown profile \"{name}\"; expected one of {names:?}"),
        )
    })?;
    if let Some(key) = t.params.keys().find(|k| !entry.keys.contains(&k.as_str())) {
        let expected = COMMON_TERRAIN_KEYS.iter().chain(entry.keys);
        return Err(unknown_key(
            c,
            "terrain",
            key,
            expected.copied().collect(),
            Some(("profile", entry.name)),
        ));
    }
    let profile = (entry.parse)(&Params::new(&t.params, "terrain").relative_to(c.dir()))
        .map_err(|e| c.fail(&e.key, e.reason))?;
    let scale_applies_to = match t.scale_applies_to.as_deref() {
        Some("grade") => ScaleTarget::Grade,
        Some("elevation") => ScaleTarget::Elevation,
        Some(other) => {
            return Err(c.fail(
                "terrain.scale_applies_to",
                format!("must be \"grade\" or \"elevation\", got \"{other}\""),
            ));
        }
        None => return Err(required("scale_applies_to")),
    };
    let extent = profile.extent_m();
    let length = match (t.length, extent) {
        (Some(l), _) => l,
        (None, Some(e)) => e.floor().max(0.0) as u64,
        (None, None) => return Err(required("length")),
    };
    if length < 2 {
        return Err(c.fail(
            "terrain.length",
            format!("must be at least 2 m, got {length}"),
        ));
    }
    if length > MAX_SAMPLES as u64 {
        return Err(c.fail(
            "terrain.length",
            format!("must be at most {MAX_SAMPLES} m, got {length}"),
        ));
    }
    if let Some(e) = extent
        && length as f64 > e
    {
        return Err(c.fail(
            "terrain.length",
            format!("is {length} m but the profile's file reaches only {e} m"),
        ));
    }
    let scales = t.scales.as_ref().ok_or_else(|| required("scales"))?;
    let scales = c.list("terrain.scales", scales, Checker::non_negative)?;
    Ok((
        Some(TerrainSpec {
            profile,
            length_m: length as usize,
            scale_applies_to,
        }),
        scales,
    ))
}

/// The validated `[noise]` table.
struct ValidatedNoise {
    /// Each channel's levels (condition axes).
    axes: NoiseAxes,
    /// `noise.grade_bias` \[rad\] (an axis).
    grade_bias: Vec<f64>,
    /// `noise.velocity_correlation_time` \[s\] (an axis).
    velocity_correlation_s: Vec<f64>,
    /// `noise.share_across_scales`.
    share_across_scales: bool,
    /// `noise.grade_map_sd` \[m\] (an axis).
    grade_map_sd: Vec<f64>,
    /// `noise.grade_map_length` \[m\].
    grade_map_length_m: f64,
    /// `noise.air_speed_sd` \[m/s\] (an axis).
    air_speed_sd: Vec<f64>,
}

/// The `[noise]` table: a list of levels per channel, defaults for the optional ones,
/// `share_across_scales`, and no other key.
fn validate_noise(n: &RawNoise, c: &Checker<'_>) -> Result<ValidatedNoise, StudyError> {
    noise_keys(n, c, &NOISE_KEYS)?;
    let mut levels = PerChannel::<Vec<f64>>::default();
    for channel in Channel::ALL {
        levels[channel] = match (noise_levels(n, c, channel.key())?, channel.default_levels()) {
            (Some(list), _) => list,
            (None, Some(default)) => default.to_vec(),
            (None, None) => {
                return Err(c.fail(
                    &format!("noise.{}", channel.key()),
                    "required key is missing",
                ));
            }
        };
    }
    let grade_bias = match n.0.get(GRADE_BIAS) {
        Some(list) => {
            let key = format!("noise.{GRADE_BIAS}");
            c.list(&key, &c.numbers(&key, list)?, Checker::finite)?
        }
        None => vec![0.0],
    };
    let correlation = noise_levels(n, c, VELOCITY_CORRELATION)?.unwrap_or(vec![0.0]);
    let share = match n.0.get(SHARE_ACROSS_SCALES) {
        None => false,
        Some(v) => v.as_bool().ok_or_else(|| {
            c.fail(
                &format!("noise.{SHARE_ACROSS_SCALES}"),
                format!("must be true or false, got {v}"),
            )
        })?,
    };
    let grade_map_sd = noise_levels(n, c, GRADE_MAP_SD)?.unwrap_or(vec![0.0]);
    let grade_map_length_m = match n.0.get(GRADE_MAP_LENGTH) {
        None => 200.0,
        Some(v) => {
            let key = format!("noise.{GRADE_MAP_LENGTH}");
            let length = v
                .as_float()
                .or_else(|| v.as_integer().map(|i| i as f64))
                .ok_or_else(|| c.fail(&key, format!("must be a number of metres, got {v}")))?;
            c.positive(&key, length)?
        }
    };
    if n.0.contains_key(GRADE_MAP_LENGTH) && grade_map_sd.iter().all(|&s| s == 0.0) {
        return Err(c.fail(
            &format!("noise.{GRADE_MAP_LENGTH}"),
            format!(
                "is the map error's correlation length, but noise.{GRADE_MAP_SD} lists no \
                 level above 0"
            ),
        ));
    }
    let air_speed_sd = noise_levels(n, c, AIR_SPEED_SD)?.unwrap_or(vec![0.0]);
    Ok(ValidatedNoise {
        axes: NoiseAxes::new(levels),
        grade_bias,
        velocity_correlation_s: correlation,
        share_across_scales: share,
        grade_map_sd,
        grade_map_length_m,
        air_speed_sd,
    })
}

/// Fail on a `[noise]` key that is neither a channel's nor one of `extra`.
pub(super) fn noise_keys(n: &RawNoise, c: &Checker<'_>, extra: &[&str]) -> Result<(), StudyError> {
    let keys: Vec<&str> = Channel::ALL
        .map(Channel::key)
        .into_iter()
        .chain(extra.iter().copied())
        .collect();
    match n.0.keys().find(|k| !keys.contains(&k.as_str())) {
        Some(k) => Err(unknown_key(c, "noise", k, keys, None)),
        None => Ok(()),
    }
}

/// The levels ≥ 0 of `[noise]` key `key` (a channel's, or the correlation time's): a
/// non-empty list, one number standing for the list of it; `None` when absent.
pub(super) fn noise_levels(
    n: &RawNoise,
    c: &Checker<'_>,
    key: &str,
) -> Result<Option<Vec<f64>>, StudyError> {
    let key_path = format!("noise.{key}");
    n.0.get(key)
        .map(|list| {
            c.list(
                &key_path,
                &c.numbers(&key_path, list)?,
                Checker::non_negative,
            )
        })
        .transpose()
}

/// `estimation.acceleration`: one name or a list of names of [`Acceleration::ALL`].
fn validate_acceleration(
    value: Option<&toml::Value>,
    c: &Checker<'_>,
) -> Result<Vec<Acceleration>, StudyError> {
    const KEY: &str = "estimation.acceleration";
    let names: Vec<&str> = Acceleration::ALL.map(Acceleration::name).to_vec();
    let one = |key: &str, v: &toml::Value| -> Result<Acceleration, StudyError> {
        let name = v
            .as_str()
            .ok_or_else(|| c.fail(key, format!("must be a string, one of {names:?}")))?;
        Acceleration::ALL
            .into_iter()
            .find(|a| a.name() == name)
            .ok_or_else(|| {
                c.fail(
                    key,
                    format!("unknown acceleration source \"{name}\"; expected one of {names:?}"),
                )
            })
    };
    let Some(value) = value else {
        return Ok(vec![Acceleration::Model]);
    };
    let items = one_or_many(value);
    if items.is_empty() {
        return Err(c.fail(KEY, "must list at least one value"));
    }
    // A list's items are named by their index, one name by the key.
    let key = |i: usize| match value {
        toml::Value::Array(_) => format!("{KEY}[{i}]"),
        _ => KEY.to_string(),
    };
    let mut levels = Vec::new();
    for (i, v) in items.iter().enumerate() {
        let a = one(&key(i), v)?;
        if levels.contains(&a) {
            return Err(c.fail(&key(i), format!("\"{}\" is listed twice", a.name())));
        }
        levels.push(a);
    }
    Ok(levels)
}

/// The `[noise]` key of the speed noise's correlation time \[s\] (an axis; default `[0]`,
/// white noise).
pub(super) const VELOCITY_CORRELATION: &str = "velocity_correlation_time";

/// The `[noise]` key that lets conditions differing only in terrain scale and duration share
/// each realisation's draws (docs/model.md#shared-noise).
pub(super) const SHARE_ACROSS_SCALES: &str = "share_across_scales";

/// The `[noise]` key of the grade sensor's constant offset \[rad\] (an axis; default `[0]`).
pub(super) const GRADE_BIAS: &str = "grade_bias";

/// The keys of a vehicle study's `[noise]` beyond the channels' levels.
pub(super) const NOISE_KEYS: [&str; 6] = [
    GRADE_BIAS,
    VELOCITY_CORRELATION,
    SHARE_ACROSS_SCALES,
    GRADE_MAP_SD,
    GRADE_MAP_LENGTH,
    AIR_SPEED_SD,
];

/// The `[noise]` key of the elevation map's error \[m\] (an axis; default `[0]`).
pub const GRADE_MAP_SD: &str = "grade_map_sd";

/// The `[noise]` key of the correlation length of the map's error \[m\] (default 200).
pub(crate) const GRADE_MAP_LENGTH: &str = "grade_map_length";

/// The `[noise]` key of the air-speed sensor's noise \[m/s\] (an axis; default `[0]`).
pub const AIR_SPEED_SD: &str = "air_speed_sd";
