//! A fit file's `[log]`: its keys as written, which grade column it reads, and the log read
//! into a measured cycle.

use std::path::Path;

use serde::Deserialize;

use crate::dynamics::{DriveCycle, SpeedUnit, central_differences, positions};
use crate::estimate::filters::GradeSource;
use crate::study::StudyError;
use crate::study::checker::Checker;
use crate::tabular::{read_columns, table_columns};
use crate::terrain::GradeUnit;

/// A log handed over as a table held in memory (e.g. a DataFrame from the Python package),
/// in place of `log.file`.
#[derive(Debug, Clone, Copy)]
pub struct LogTable<'a> {
    /// What the table is called in errors (`the DataFrame given as log`).
    pub name: &'a str,
    /// Its columns.
    pub schema: &'a arrow::datatypes::Schema,
    /// Its rows.
    pub batches: &'a [arrow::record_batch::RecordBatch],
}

/// Where the log's rows are: a file (CSV or Parquet) or a table in memory.
pub(super) enum LogSource<'a> {
    File(std::path::PathBuf),
    Table(LogTable<'a>),
}

impl LogSource<'_> {
    /// The file, or the table's name as a path (what `FitSpec::log` reports).
    pub(super) fn path(&self) -> std::path::PathBuf {
        match self {
            LogSource::File(path) => path.clone(),
            LogSource::Table(t) => t.name.into(),
        }
    }
}

/// `[log]`: the log file and its columns.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(in crate::study) struct RawLog {
    #[serde(default)]
    pub(super) file: String,
    pub(super) time_column: String,
    pub(super) speed_column: String,
    pub(super) speed_unit: String,
    #[serde(default)]
    pub(super) force_column: Option<String>,
    #[serde(default)]
    pub(super) torque_column: Option<String>,
    #[serde(default)]
    pub(super) grade_column: Option<String>,
    #[serde(default)]
    pub(super) grade_unit: Option<String>,
    #[serde(default)]
    pub(super) acceleration_column: Option<String>,
    #[serde(default)]
    pub(super) min_speed: Option<f64>,
}

/// The grade column `l` names and its unit: required with the grade measured, refused
/// without it (docs/model.md#fit-no-grade).
pub(super) fn grade_column<'a>(
    l: &'a RawLog,
    grade: GradeSource,
    c: &Checker<'_>,
) -> Result<Option<(&'a str, GradeUnit)>, StudyError> {
    let column = match (&l.grade_column, grade) {
        (Some(_), GradeSource::None) => {
            return Err(c.fail(
                "log.grade_column",
                "estimation.grade = \"none\" reads no grade: leave the column out",
            ));
        }
        (None, GradeSource::Measured) => {
            return Err(c.fail(
                "log.grade_column",
                "required key is missing (a log without a grade: estimation.grade = \"none\")",
            ));
        }
        (Some(column), GradeSource::Measured) => {
            let unit = l.grade_unit.as_deref().ok_or_else(|| {
                c.fail(
                    "log.grade_unit",
                    "required key is missing (with log.grade_column)",
                )
            })?;
            Some((
                column.as_str(),
                c.named("log.grade_unit", unit, &GradeUnit::ALL)?,
            ))
        }
        (None, GradeSource::None) => None,
    };
    if column.is_none() && l.grade_unit.is_some() {
        return Err(c.fail("log.grade_unit", "is given without log.grade_column"));
    }
    Ok(column)
}

/// The log's columns as a measured cycle (acceleration differentiated without an
/// `acceleration_column`), and the samples the regression uses: those at `min_speed` or
/// faster, and with a differentiated acceleration not the first or last.
pub(super) fn read_log(
    l: &RawLog,
    source: &LogSource<'_>,
    force: &str,
    torque_factor: Option<f64>,
    speed_unit: SpeedUnit,
    grade: Option<(&str, GradeUnit)>,
    c: &Checker<'_>,
) -> Result<(DriveCycle, Vec<bool>), StudyError> {
    let (time, speed) = (&*l.time_column, &*l.speed_column);
    let mut wanted = vec![time, speed, force];
    wanted.extend(grade.map(|(column, _)| column));
    wanted.extend(l.acceleration_column.as_deref());
    let cols = match source {
        LogSource::File(file) => read_columns(file, &wanted, 3),
        LogSource::Table(t) => table_columns(Path::new(t.name), t.schema, t.batches, &wanted, 3),
    }
    .map_err(|e| c.fail("log.file", e.to_string()))?;
    cols.strictly_increasing(time)
        .map_err(|e| c.fail("log.file", e.to_string()))?;
    let t = cols.get(time).to_vec();
    let v_m_s: Vec<f64> = cols
        .get(speed)
        .iter()
        .map(|&s| speed_unit.to_m_s(s))
        .collect();
    let f_prop_n: Vec<f64> = cols
        .get(force)
        .iter()
        .map(|&x| torque_factor.map_or(x, |q| q * x))
        .collect();
    // Without a grade column the cycle's grade is 0: no estimator reads it
    // (docs/model.md#fit).
    let grade_rad: Vec<f64> = match grade {
        Some((column, unit)) => cols.get(column).iter().map(|&g| unit.to_rad(g)).collect(),
        None => vec![0.0; t.len()],
    };
    let accel_m_s2 = match &l.acceleration_column {
        Some(a) => cols.get(a).to_vec(),
        None => central_differences(&t, &v_m_s),
    };
    let min_speed = l.min_speed.unwrap_or(0.0);
    let mut used: Vec<bool> = v_m_s.iter().map(|&s| s >= min_speed).collect();
    if l.acceleration_column.is_none() {
        let n = used.len();
        used[0] = false;
        used[n - 1] = false;
    }
    let cycle = DriveCycle {
        x_m: positions(&t, &v_m_s),
        t_s: t,
        v_m_s,
        grade_rad,
        f_prop_n,
        accel_m_s2,
        run: vec![0; used.len()],
        run_heading: vec![1.0],
    };
    Ok((cycle, used))
}
