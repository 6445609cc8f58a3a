//! A vehicle study's `[noise]` table: each channel's levels as condition axes
//! ([`NoiseAxes`]), the table's other keys, and their validation (also for a fit file's
//! `[noise]`, one level each).

use super::StudyError;
use super::axes::{GRADE_MAP_SD, LevelAxes, LevelAxis};
use super::checker::Checker;
use super::checker::unknown_key;
use super::raw::RawNoise;
use crate::estimate::channels::{Channel, NoiseLevels, PerChannel};

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

/// The validated `[noise]` table.
pub(super) struct ValidatedNoise {
    /// Each channel's levels (condition axes).
    pub(super) axes: NoiseAxes,
    /// The level axes' levels.
    pub(super) levels: LevelAxes,
    /// `noise.share_across_scales`.
    pub(super) share_across_scales: bool,
    /// `noise.grade_map_length` \[m\].
    pub(super) grade_map_length_m: f64,
}

/// The `[noise]` table: a list of levels per channel and per level axis, defaults for the
/// optional ones, `share_across_scales`, `grade_map_length`, and no other key.
pub(super) fn validate_noise(n: &RawNoise, c: &Checker<'_>) -> Result<ValidatedNoise, StudyError> {
    noise_keys(n, c, &other_noise_keys())?;
    let mut levels = PerChannel::<Vec<f64>>::default();
    for channel in Channel::ALL {
        if !channel.own_axis() {
            // Its level axis reads its key and sets its level per condition.
            levels[channel] = vec![0.0];
            continue;
        }
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
    let level_axes = LevelAxes::read(n, c)?;
    let share = match n.0.get(SHARE_ACROSS_SCALES) {
        None => false,
        Some(v) => v.as_bool().ok_or_else(|| {
            c.fail(
                &format!("noise.{SHARE_ACROSS_SCALES}"),
                format!("must be true or false, got {v}"),
            )
        })?,
    };
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
    if n.0.contains_key(GRADE_MAP_LENGTH)
        && level_axes[LevelAxis::GradeMap].iter().all(|&s| s == 0.0)
    {
        return Err(c.fail(
            &format!("noise.{GRADE_MAP_LENGTH}"),
            format!(
                "is the map error's correlation length, but noise.{GRADE_MAP_SD} lists no \
                 level above 0"
            ),
        ));
    }
    Ok(ValidatedNoise {
        axes: NoiseAxes::new(levels),
        levels: level_axes,
        share_across_scales: share,
        grade_map_length_m,
    })
}

/// The keys of a vehicle study's `[noise]` beyond the channels' levels: the level axes'
/// and the table's own.
pub(super) fn other_noise_keys() -> Vec<&'static str> {
    let own = [SHARE_ACROSS_SCALES, GRADE_MAP_LENGTH];
    LevelAxis::ALL
        .map(LevelAxis::key)
        .into_iter()
        .chain(own)
        .collect()
}

/// Fail on a `[noise]` key that is neither a channel's own axis's nor one of `extra` (a
/// channel whose level a level axis sets is listed by that axis, in `extra` where it
/// applies).
pub(super) fn noise_keys(n: &RawNoise, c: &Checker<'_>, extra: &[&str]) -> Result<(), StudyError> {
    let mut keys: Vec<&str> = Channel::ALL
        .into_iter()
        .filter(|channel| channel.own_axis())
        .map(Channel::key)
        .collect();
    keys.extend(extra);
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

/// The `[noise]` key that lets conditions differing only in terrain scale and duration share
/// each realisation's draws (docs/model.md#shared-noise).
pub(super) const SHARE_ACROSS_SCALES: &str = "share_across_scales";

/// The `[noise]` key of the correlation length of the map's error \[m\] (default 200).
pub(crate) const GRADE_MAP_LENGTH: &str = "grade_map_length";
