//! The vehicle study: its validated settings ([`VehicleStudy`]) and their validation from
//! `[vehicle]`, `[drive]`, `[terrain]`, `[noise]` and `[estimation]`.

use std::sync::Arc;

use super::StudyError;
use super::axes::{AIR_SPEED_SD, LevelAxes, LevelAxis};
use super::checker::{Checker, unknown_key};
use super::estimation::{SettingKeys, validate_estimation};
use super::filter_keys::{KnownVehicle, check_filter_inputs, check_grade_none};
use super::noise::{NoiseAxes, ValidatedNoise, validate_noise};
use super::placement::COMMON_DRIVE_KEYS;
use super::raw::RawStudy;
use super::terrain::validate_terrain;
use super::truth::{TruthAxes, validate_filter_truth, validate_truth};
use crate::dynamics::{CycleSource, DRIVE_MODES, Drivetrain, RowSelection, VehicleParams};
use crate::estimate::channels::Acceleration;
use crate::estimate::channels::{Channel, Signal};
use crate::estimate::estimators::{EstimatorRef, EstimatorSettings};
use crate::settings::{KeyError, Params, one_or_many};
use crate::terrain::TerrainSpec;

/// The speed's channel: its noise must be off where the drag regressor reads a measured air
/// speed.
const SPEED: Channel = Channel::of(Signal::Speed);

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
    /// The level axes' levels (`noise.velocity_correlation_time`, `noise.grade_bias`,
    /// `noise.grade_map_sd`, `noise.air_speed_sd`, …: one condition axis each).
    pub levels: LevelAxes,
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
    /// `noise.grade_map_length` \[m\]: the correlation length of the map's error (200 m
    /// without the key).
    pub grade_map_length_m: f64,
    /// `estimation.air_speed`: what the drag regressor reads.
    pub air_speed: AirSpeed,
    /// `[truth]`: the model errors, condition axes after all the others (the truth is the
    /// equation without the table).
    pub truth: TruthAxes,
    /// A truth that follows the filters' model (`truth.speed_process_sd`,
    /// `truth.mass_from_prior`, `terrain.profile = "random_walk"`).
    pub filter_truth: crate::dynamics::filter_truth::FilterTruth,
    /// `estimation.grade_walk`'s levels, an axis of the conditions where a filter is listed
    /// (one level, the default, without the key).
    pub grade_walks: Vec<f64>,
    /// `[campaign]`: the criterion a coast-down campaign is judged by (docs/model.md#campaign).
    pub campaign: Option<std::sync::Arc<crate::estimate::campaign::Campaign>>,
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

    let frontal_area_m2 = c.positive("vehicle.frontal_area", v.frontal_area)?;
    let air_density_kg_m3 = c.positive("vehicle.air_density", v.air_density)?;
    let gravity_m_s2 = c.positive("vehicle.gravity", v.gravity)?;
    let by = super::road_load::vehicle_by(v, frontal_area_m2, air_density_kg_m3, gravity_m_s2, c)?;
    let vehicle = VehicleParams {
        mass_kg: by.mass_kg,
        drag_coefficient: by.drag_coefficient,
        rolling_resistance: by.rolling_resistance,
        frontal_area_m2,
        air_density_kg_m3,
        gravity_m_s2,
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
        levels,
        share_across_scales,
        grade_map_length_m,
    } = validate_noise(n, c)?;
    let known_inv_mass = e.known_mass.unwrap_or(false).then(|| 1.0 / vehicle.mass_kg);
    let keys = SettingKeys {
        forgetting: e.forgetting,
        known_inv_mass,
        effective_mass_factor: e.effective_mass_factor,
        filter: e.filter_keys(),
        vehicle: KnownVehicle {
            mass_kg: vehicle.mass_kg,
            drag_coefficient: vehicle.drag_coefficient,
            rolling: vehicle.rolling_resistance,
        },
    };
    let (estimators, settings, grade_walks) = validate_estimation(&e.estimators, keys, c)?;
    let acceleration = validate_acceleration(e.acceleration.as_ref(), c)?;
    let grade_channel = Channel::of(Signal::Grade);
    let grade_keys: Vec<String> = [
        (
            format!("noise.{}", grade_channel.key()),
            noise.levels(grade_channel),
        ),
        (
            format!("noise.{}", LevelAxis::GradeBias.key()),
            &levels[LevelAxis::GradeBias],
        ),
        (
            format!("noise.{}", LevelAxis::GradeMap.key()),
            &levels[LevelAxis::GradeMap],
        ),
    ]
    .into_iter()
    .filter(|(_, levels)| levels.iter().any(|&l| l != 0.0))
    .map(|(key, _)| key)
    .collect();
    check_grade_none(
        settings.grade,
        &estimators,
        acceleration.iter().all(|&a| a == Acceleration::Model),
        &grade_keys.iter().map(String::as_str).collect::<Vec<_>>(),
        c,
    )?;
    let air_speed = validate_air_speed(
        e.air_speed.as_deref(),
        &noise,
        &levels[LevelAxis::AirSpeedNoise],
        &acceleration,
        c,
    )?;
    let set = |levels: &[f64]| levels.iter().any(|&l| l != 0.0);
    let bias_key = format!("noise.{}", LevelAxis::GradeBias.key());
    let map_key = format!("noise.{}", LevelAxis::GradeMap.key());
    let steps = "it steps from each row to the next, which a row selection would make a gap";
    let conflicts: Vec<(&str, &str)> = [
        (
            set(&levels[LevelAxis::GradeBias]),
            bias_key.as_str(),
            "its errors are scored against the regression's grade, which the offset moves",
        ),
        (
            set(&levels[LevelAxis::GradeMap]),
            map_key.as_str(),
            "its errors are scored against the regression's grade, which the map replaces",
        ),
        (
            air_speed == AirSpeed::Measured,
            "estimation.air_speed",
            "it reads the vehicle's measured speed",
        ),
        (selection.min_speed_m_s > 0.0, "drive.min_speed", steps),
        (selection.exclude_braking, "drive.exclude_braking", steps),
        (
            drive.runs().is_some(),
            "drive.mode",
            "it follows one drive, not a coast-down's separate runs",
        ),
    ]
    .into_iter()
    .filter(|(on, _, _)| *on)
    .map(|(_, key, why)| (key, why))
    .collect();
    check_filter_inputs(&estimators, &conflicts, c)?;

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
    let mut truth = validate_truth(raw.truth.as_ref(), c)?;
    if by.rolling_speed_coefficient != 0.0 {
        super::road_load::set_rolling_speed(
            &mut truth,
            by.rolling_speed_coefficient,
            raw.truth.as_ref(),
            c,
        )?;
    }
    let filter_truth = validate_filter_truth(
        raw.truth.as_ref(),
        terrain.as_ref(),
        settings.filter.prior,
        mode.name,
        &truth,
        c,
    )?;

    let campaign = super::campaign::validate_campaign(
        raw.campaign.as_ref(),
        &*drive,
        air_speed == AirSpeed::Measured,
        c,
    )?;
    Ok(VehicleStudy {
        campaign,
        vehicle,
        drive,
        selection,
        durations,
        terrain,
        scales,
        noise,
        levels,
        estimators,
        settings,
        acceleration,
        share_across_scales,
        grade_map_length_m,
        air_speed,
        truth,
        filter_truth,
        grade_walks,
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
        AirSpeed::Measured if noise.levels(SPEED).iter().any(|&s| s > 0.0) => Err(c.fail(
            &format!("noise.{}", SPEED.key()),
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
