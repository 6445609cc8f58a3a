//! `[campaign]`: a coast-down campaign judged by a standard's criterion on its runs
//! (docs/model.md#campaign). `criterion` names an entry of [`CRITERIA`]; a criterion that
//! reads the coast-down times takes `speeds` \[m/s\] and `half_width` \[m/s\]; each entry's own
//! keys have defaults.

use std::sync::Arc;

use super::StudyError;
use super::checker::{Checker, unknown_key};
use crate::dynamics::CycleSource;
use crate::estimate::campaign::{CRITERIA, Campaign, SpeedInterval};

/// The keys every campaign reads.
const COMMON_KEYS: [&str; 3] = ["criterion", "speeds", "half_width"];

/// Every key of `[campaign]`, for the placement of a misplaced key.
pub(super) fn campaign_keys() -> Vec<&'static str> {
    let mut keys = COMMON_KEYS.to_vec();
    for entry in &CRITERIA {
        for (key, _) in entry.keys {
            if !keys.contains(key) {
                keys.push(key);
            }
        }
    }
    keys
}

/// Read `[campaign]` (absent: `None`). It needs a drive made of runs (a coast-down) and the
/// vehicle's ground speed (not a measured air speed, whose rows are the air's).
pub(super) fn validate_campaign(
    raw: Option<&toml::Table>,
    drive: &dyn CycleSource,
    air_speed_measured: bool,
    c: &Checker<'_>,
) -> Result<Option<Arc<Campaign>>, StudyError> {
    let Some(table) = raw else {
        return Ok(None);
    };
    if drive.runs().is_none() {
        return Err(c.fail(
            "campaign",
            "a campaign judges the runs of a coast-down; give drive.mode = \"coastdown\"",
        ));
    }
    if air_speed_measured {
        return Err(c.fail(
            "campaign",
            "the coast-down times are read from the vehicle's measured speed, and with \
             estimation.air_speed = \"measured\" the rows carry the air speed",
        ));
    }
    let names: Vec<&str> = CRITERIA.iter().map(|e| e.name).collect();
    let criterion = match table.get("criterion") {
        Some(toml::Value::String(s)) => s.as_str(),
        Some(other) => {
            return Err(c.fail(
                "campaign.criterion",
                format!("must be one of {names:?}, got {other}"),
            ));
        }
        None => {
            return Err(c.fail(
                "campaign.criterion",
                format!("required key is missing; one of {names:?}"),
            ));
        }
    };
    let entry = CRITERIA
        .iter()
        .find(|e| e.name == criterion)
        .ok_or_else(|| {
            c.fail(
                "campaign.criterion",
                format!("unknown criterion \"{criterion}\"; expected one of {names:?}"),
            )
        })?;
    let own: Vec<&str> = entry.keys.iter().map(|(k, _)| *k).collect();
    for key in table.keys() {
        if !COMMON_KEYS.contains(&key.as_str()) && !own.contains(&key.as_str()) {
            let mut expected = COMMON_KEYS.to_vec();
            expected.extend(&own);
            return Err(unknown_key(c, "campaign", key, expected, None));
        }
    }
    let number = |key: &str, value: &toml::Value| -> Result<f64, StudyError> {
        match value {
            toml::Value::Float(x) => Ok(*x),
            toml::Value::Integer(i) => Ok(*i as f64),
            other => Err(c.fail(
                &format!("campaign.{key}"),
                format!("must be a number, got {other}"),
            )),
        }
    };
    let values: Vec<f64> = entry
        .keys
        .iter()
        .map(|(key, default)| table.get(*key).map_or(Ok(*default), |v| number(key, v)))
        .collect::<Result<_, _>>()?;
    let criterion = (entry.make)(&values)
        .map_err(|(key, reason)| c.fail(&format!("campaign.{key}"), reason))?;
    if !criterion.reads_times() && !drive.alternates() {
        return Err(c.fail(
            "campaign.criterion",
            format!(
                "\"{}\" counts runs half each way, and drive.directions = \"one_way\" drives \
                 every run forwards",
                entry.name
            ),
        ));
    }
    let intervals = match criterion.reads_times() {
        true => intervals(table, c)?,
        false => {
            for key in ["speeds", "half_width"] {
                if table.contains_key(key) {
                    return Err(c.fail(
                        &format!("campaign.{key}"),
                        format!(
                            "criterion \"{}\" counts the runs and reads no coast-down times",
                            entry.name
                        ),
                    ));
                }
            }
            Vec::new()
        }
    };
    Ok(Some(Arc::new(Campaign {
        criterion,
        intervals,
    })))
}

/// `speeds` and `half_width`: the intervals v_j ± Δv, each above zero.
fn intervals(table: &toml::Table, c: &Checker<'_>) -> Result<Vec<SpeedInterval>, StudyError> {
    let half_width = match table.get("half_width") {
        Some(v) => {
            let numbers = c.numbers("campaign.half_width", v)?;
            match numbers.as_slice() {
                [h] if matches!(v, toml::Value::Float(_) | toml::Value::Integer(_)) => {
                    c.positive("campaign.half_width", *h)?
                }
                _ => {
                    return Err(c.fail(
                        "campaign.half_width",
                        format!("must be one number [m/s], got {v}"),
                    ));
                }
            }
        }
        None => {
            return Err(c.fail(
                "campaign.half_width",
                "required key is missing: Δv [m/s] of every interval v ± Δv (the EU's 5 km/h is 1.3889)",
            ));
        }
    };
    let speeds = match table.get("speeds") {
        Some(v) => c.numbers("campaign.speeds", v)?,
        None => {
            return Err(c.fail(
                "campaign.speeds",
                "required key is missing: the interval centres v [m/s] (the EU's every 10 km/h)",
            ));
        }
    };
    let speeds = c.list("campaign.speeds", &speeds, |c, key, v| {
        let v = c.positive(key, v)?;
        if v - half_width <= 0.0 {
            return Err(c.fail(
                key,
                format!("{v} m/s less the half width {half_width} m/s is not above zero"),
            ));
        }
        Ok(v)
    })?;
    Ok(speeds
        .into_iter()
        .map(|speed_m_s| SpeedInterval {
            speed_m_s,
            half_width_m_s: half_width,
        })
        .collect())
}
