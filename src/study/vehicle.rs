//! The vehicle study: its validated settings ([`VehicleStudy`]) and their validation from
//! `[vehicle]`, `[drive]`, `[terrain]`, `[noise]` and `[estimation]`.

use std::sync::Arc;

use super::raw::{RawNoise, RawStudy};
use super::validate::{Checker, validate_estimators};
use super::{MAX_SAMPLES, StudyError};
use crate::estimate::channels::{Channel, NoiseLevels, PerChannel};
use crate::estimate::estimators::{ESTIMATORS, EstimatorRef};
use crate::settings::Params;
use crate::terrain::profiles::PROFILES;
use crate::terrain::{ScaleTarget, TerrainSpec};
use crate::vehicle::{CycleSource, DRIVE_MODES, VehicleParams};

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

pub(super) fn validate(raw: &RawStudy, c: &Checker<'_>) -> Result<VehicleStudy, StudyError> {
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
