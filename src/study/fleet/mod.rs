//! `[fleet]`: one condition per vehicle of a table (docs/model.md#fleet). The table's columns
//! give `[vehicle]` keys (`test_weight_lb = "Equivalent Test Weight (lbs.)"`, …), `id` names
//! the column that names each vehicle, `filter` keeps the rows that are vehicles and
//! `distinct` the first row of each combination of its columns. Each vehicle is the study
//! with its row's values in `[vehicle]`, validated as a study file is; a bad row is named by
//! the table, its line (or row), the column and the reason before anything runs.

mod filter;

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use super::raw::{RawStudy, RawVehicle};
use super::validate::validate;
use super::{KeySpans, Study, StudyError};
use crate::tabular::{quote, read_text_columns, shorten};
use filter::Filter;

/// The keys of `[fleet]` besides the vehicle keys its columns give.
const OWN_KEYS: [&str; 4] = ["file", "id", "filter", "distinct"];

/// A fleet: the vehicles of a table, in its order.
#[derive(Debug, Clone, PartialEq)]
pub struct Fleet {
    /// The table read.
    pub file: PathBuf,
    /// Its name as the study gives it (`fleet.file`).
    pub written: String,
    /// The vehicles.
    pub vehicles: Vec<FleetVehicle>,
}

/// One vehicle of a fleet: its id and the `[vehicle]` values its row gives.
#[derive(Debug, Clone, PartialEq)]
pub struct FleetVehicle {
    /// Its `id` cell.
    pub id: String,
    /// Where its row is: `line N` (CSV) or `row N` (Parquet).
    pub place: String,
    /// `(vehicle key, value)` per column the study maps.
    pub values: Vec<(String, f64)>,
}

impl Fleet {
    /// A number standing for every vehicle's id and values (the fleet's part of a run's
    /// identity: the table may change while the study file does not).
    pub fn fingerprint(&self) -> u64 {
        let mut hash = crate::numeric::hash::Fnv1a::default();
        for v in &self.vehicles {
            hash.eat(v.id.as_bytes());
            for (key, value) in &v.values {
                hash.eat(key.as_bytes());
                hash.eat(&value.to_bits().to_le_bytes());
            }
        }
        hash.finish()
    }
}

/// The study of vehicle `v` of `fleet`: `raw` without `[fleet]`, with the vehicle's values in
/// `[vehicle]`, validated; errors name the vehicle, its row and, for a key its row gives,
/// the column.
pub(super) fn vehicle_study(
    raw: &RawStudy,
    fleet: &Fleet,
    v: usize,
    (spans, origin, dir): (&KeySpans, &str, &Path),
) -> Result<Study, StudyError> {
    let vehicle = &fleet.vehicles[v];
    let columns = columns_of(raw);
    let at = format!(
        "{} {} (vehicle {})",
        fleet.file.display(),
        vehicle.place,
        quote(&vehicle.id)
    );
    let named = |e: StudyError| {
        let mapped = e
            .key
            .as_deref()
            .and_then(|k| k.strip_prefix("vehicle."))
            .and_then(|k| columns.iter().find(|(key, _)| key == k));
        match mapped {
            Some((key, column)) => {
                let value = vehicle
                    .values
                    .iter()
                    .find(|(k, _)| k == key)
                    .map_or(f64::NAN, |(_, x)| *x);
                StudyError {
                    file: at.clone(),
                    key: Some(format!("fleet.{key}")),
                    line: spans.line(&format!("fleet.{key}")),
                    reason: format!("column {} = {value}: {}", quote(column), e.reason),
                }
            }
            // The vehicle's origin names it and its row already.
            None => e,
        }
    };
    let mut one = raw.clone();
    one.fleet = None;
    let mut table = match &raw.vehicle {
        Some(base) => toml::Table::try_from(base).expect("a vehicle table serialises"),
        None => toml::Table::new(),
    };
    for (key, value) in &vehicle.values {
        table.insert(key.clone(), toml::Value::Float(*value));
    }
    one.vehicle = Some(
        toml::Value::Table(table)
            .try_into::<RawVehicle>()
            .map_err(|e| {
                named(StudyError {
                    file: format!("{origin} for {at}"),
                    key: Some("vehicle".into()),
                    line: spans.line("vehicle"),
                    reason: e.message().to_string(),
                })
            })?,
    );
    validate(
        one,
        spans.clone(),
        &format!("{origin} for {at}"),
        dir.to_path_buf(),
    )
    .map_err(named)
}

/// `(vehicle key, column)` of every vehicle key `[fleet]` maps.
fn columns_of(raw: &RawStudy) -> Vec<(String, String)> {
    raw.fleet
        .iter()
        .flatten()
        .filter(|(k, _)| !OWN_KEYS.contains(&k.as_str()))
        .filter_map(|(k, v)| v.as_str().map(|c| (k.clone(), c.to_string())))
        .collect()
}

/// Read `[fleet]` of `raw`: the table's vehicles, each validated. Returns the fleet and the
/// first vehicle's study (which stands for every vehicle's layout: they differ only in
/// `[vehicle]`).
pub(super) fn read_fleet(
    raw: &RawStudy,
    spans: &KeySpans,
    origin: &str,
    dir: &Path,
) -> Result<(Fleet, Study), StudyError> {
    let table = raw.fleet.as_ref().expect("a study with [fleet]");
    let fail = |key: &str, reason: String| StudyError {
        file: origin.to_string(),
        key: Some(key.to_string()),
        line: spans.line(key),
        reason,
    };
    let text = |key: &str| -> Result<Option<String>, StudyError> {
        match table.get(key) {
            None => Ok(None),
            Some(toml::Value::String(s)) => Ok(Some(s.clone())),
            Some(other) => Err(fail(
                &format!("fleet.{key}"),
                format!("must be a string, got {other}"),
            )),
        }
    };
    let texts = |key: &str| -> Result<Vec<String>, StudyError> {
        match table.get(key) {
            None => Ok(Vec::new()),
            Some(toml::Value::String(s)) => Ok(vec![s.clone()]),
            Some(toml::Value::Array(items)) => items
                .iter()
                .enumerate()
                .map(|(i, item)| {
                    item.as_str().map(str::to_string).ok_or_else(|| {
                        fail(
                            &format!("fleet.{key}[{i}]"),
                            format!("must be a string, got {item}"),
                        )
                    })
                })
                .collect(),
            Some(other) => Err(fail(
                &format!("fleet.{key}"),
                format!("must be a string or a list of strings, got {other}"),
            )),
        }
    };
    let vehicle_keys = super::placement::vehicle_keys();
    for (key, value) in table {
        if OWN_KEYS.contains(&key.as_str()) {
            continue;
        }
        if !vehicle_keys.contains(&key.as_str()) {
            let mut expected = OWN_KEYS.to_vec();
            expected.extend(vehicle_keys.iter());
            return Err(fail(
                &format!("fleet.{key}"),
                format!(
                    "unknown key; [fleet] takes {OWN_KEYS:?} and, for each [vehicle] key a column \
                     gives, the key = the column's name (one of {vehicle_keys:?})"
                ),
            ));
        }
        if !value.is_str() {
            return Err(fail(
                &format!("fleet.{key}"),
                format!(
                    "must be the name of the table's column that gives vehicle.{key}, got {value}"
                ),
            ));
        }
    }
    let file = text("file")?.ok_or_else(|| {
        fail(
            "fleet.file",
            "required key is missing: the table of vehicles (CSV or Parquet)".into(),
        )
    })?;
    let id = text("id")?.ok_or_else(|| {
        fail(
            "fleet.id",
            "required key is missing: the column naming each vehicle".into(),
        )
    })?;
    let filters: Vec<Filter> = texts("filter")?
        .iter()
        .enumerate()
        .map(|(i, f)| Filter::parse(f).map_err(|r| fail(&format!("fleet.filter[{i}]"), r)))
        .collect::<Result<_, _>>()?;
    let distinct = texts("distinct")?;
    let columns = columns_of(raw);
    if columns.is_empty() {
        return Err(fail(
            "fleet",
            "maps no column to a [vehicle] key; give e.g. test_weight_lb = \"Equivalent Test Weight (lbs.)\"".into(),
        ));
    }
    let path = dir.join(&file);
    let mut wanted: Vec<&str> = vec![id.as_str()];
    let more = filters
        .iter()
        .map(|f| f.column.as_str())
        .chain(distinct.iter().map(String::as_str))
        .chain(columns.iter().map(|(_, c)| c.as_str()));
    for c in more {
        if !wanted.contains(&c) {
            wanted.push(c);
        }
    }
    let cells = read_text_columns(&path, &wanted).map_err(|e| fail("fleet.file", e.to_string()))?;
    // The rows kept: every filter holds, and the first of each distinct combination.
    let mut seen = std::collections::HashSet::new();
    let kept: Vec<usize> = (0..cells.len())
        .filter(|&i| filters.iter().all(|f| f.keeps(&cells.get(&f.column)[i])))
        .filter(|&i| {
            distinct.is_empty()
                || seen.insert(
                    distinct
                        .iter()
                        .map(|d| cells.get(d)[i].trim().to_string())
                        .collect::<Vec<_>>(),
                )
        })
        .collect();
    if kept.is_empty() {
        return Err(match filters.is_empty() {
            true => fail(
                "fleet.file",
                format!("{} has no rows of vehicles", path.display()),
            ),
            false => fail(
                "fleet.filter",
                format!(
                    "keeps none of the {} rows of {}",
                    cells.len(),
                    path.display()
                ),
            ),
        });
    }
    let mut vehicles = Vec::with_capacity(kept.len());
    let mut ids = std::collections::HashMap::new();
    for &i in &kept {
        let place = cells.place(i);
        let row_fail = |column: &str, key: &str, reason: String| StudyError {
            file: format!("{} {place}", path.display()),
            key: Some(format!("fleet.{key}")),
            line: spans.line(&format!("fleet.{key}")),
            reason: format!("column {}: {reason}", quote(column)),
        };
        let vehicle_id = cells.get(&id)[i].trim().to_string();
        if vehicle_id.is_empty() {
            return Err(row_fail(&id, "id", "the vehicle's id is empty".into()));
        }
        if let Some(first) = ids.insert(vehicle_id.clone(), place.clone()) {
            return Err(row_fail(
                &id,
                "id",
                format!(
                    "{} names a vehicle already read ({first}); each vehicle is one condition: \
                     narrow the rows with fleet.filter or fleet.distinct",
                    quote(&vehicle_id)
                ),
            ));
        }
        let values = columns
            .iter()
            .map(|(key, column)| {
                let cell = cells.get(column)[i].trim();
                if cell.is_empty() {
                    return Err(row_fail(column, key, "the cell is empty".into()));
                }
                match cell.parse::<f64>() {
                    Ok(v) if v.is_finite() => Ok((key.clone(), v)),
                    _ => Err(row_fail(
                        column,
                        key,
                        format!("{} is not a finite number", shorten(cell)),
                    )),
                }
            })
            .collect::<Result<_, _>>()?;
        vehicles.push(FleetVehicle {
            id: vehicle_id,
            place,
            values,
        });
    }
    let fleet = Fleet {
        written: file.clone(),
        file: path,
        vehicles,
    };
    // Every vehicle validated (the first error in the table's order), the first kept.
    let studies: Vec<Result<Option<Study>, StudyError>> = (0..fleet.vehicles.len())
        .into_par_iter()
        .map(|v| vehicle_study(raw, &fleet, v, (spans, origin, dir)).map(|s| (v == 0).then_some(s)))
        .collect();
    let mut first = None;
    for s in studies {
        if let Some(s) = s? {
            first = Some(s);
        }
    }
    Ok((fleet, first.expect("a fleet has a vehicle")))
}
