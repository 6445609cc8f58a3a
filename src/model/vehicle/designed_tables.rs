//! What a run of a designed drive writes beside its other tables
//! (docs/model.md#designed-drive): `designed_drive.parquet`, the trace a driver follows and
//! the `replay` mode reads (`t`, `x`, `v`, `grade`, `f_prop`, `accel`, `torque`), and
//! `drive_design.parquet`, the designed drive beside the best square wave and the study's
//! own drive (criterion, relative SEs of the bound, share of governed steps).

use std::sync::Arc;

use arrow::array::{ArrayRef, Float64Array, RecordBatch, StringArray, UInt64Array};
use arrow::datatypes::{DataType, Field, Schema};
use arrow::error::ArrowError;

use super::PARAMETERS;
use crate::dynamics::{DesignedDrive, DriveCycle};
use crate::model::ExtraTable;

/// The tables of a designed drive, after `cycles.parquet`.
pub fn tables() -> [ExtraTable; 2] {
    let f64_field = |name: &str| Field::new(name, DataType::Float64, false);
    let trace = ["t", "x", "v", "grade", "f_prop", "accel", "torque"].map(f64_field);
    let mut candidates = vec![
        Field::new("drive", DataType::Utf8, false),
        Field::new("criterion", DataType::Utf8, false),
        Field::new("estimator", DataType::Utf8, false),
        Field::new("bound", DataType::Utf8, false),
        f64_field("criterion_value"),
    ];
    candidates
        .extend(PARAMETERS.map(|p| Field::new(format!("rel_se_{p}"), DataType::Float64, true)));
    candidates.extend([
        f64_field("governed_fraction"),
        Field::new("evaluations", DataType::UInt64, false),
    ]);
    [
        ExtraTable {
            file: "designed_drive.parquet",
            table: "designed_drive",
            schema: Arc::new(Schema::new(trace.to_vec())),
        },
        ExtraTable {
            file: "drive_design.parquet",
            table: "drive_design",
            schema: Arc::new(Schema::new(candidates)),
        },
    ]
}

/// `designed_drive.parquet`: the designed drive's noise-free `cycle` and its torque.
pub fn trace_batch(
    designed: &DesignedDrive,
    cycle: &DriveCycle,
) -> Result<RecordBatch, ArrowError> {
    let col = |v: &[f64]| -> ArrayRef { Arc::new(Float64Array::from(v.to_vec())) };
    RecordBatch::try_new(
        tables()[0].schema.clone(),
        vec![
            col(&cycle.t_s),
            col(&cycle.x_m),
            col(&cycle.v_m_s),
            col(&cycle.grade_rad),
            col(&cycle.f_prop_n),
            col(&cycle.accel_m_s2),
            col(&designed.torque_n_m),
        ],
    )
}

/// `drive_design.parquet`: one row per drive compared.
pub fn candidates_batch(designed: &DesignedDrive) -> Result<RecordBatch, ArrowError> {
    let s = &designed.summary;
    let rows = &s.candidates;
    let text = |f: &dyn Fn(usize) -> String| -> ArrayRef {
        Arc::new(StringArray::from(
            (0..rows.len()).map(f).collect::<Vec<_>>(),
        ))
    };
    let num = |f: &dyn Fn(usize) -> f64| -> ArrayRef {
        Arc::new(Float64Array::from(
            (0..rows.len()).map(f).collect::<Vec<_>>(),
        ))
    };
    let mut columns = vec![
        text(&|i| rows[i].name.clone()),
        text(&|_| s.criterion.clone()),
        text(&|_| s.estimator.clone()),
        text(&|_| s.bound.to_string()),
        num(&|i| rows[i].criterion),
    ];
    for p in 0..3 {
        columns.push(Arc::new(Float64Array::from(
            rows.iter()
                .map(|r| Some(r.relative_se[p]).filter(|v| !v.is_nan()))
                .collect::<Vec<_>>(),
        )));
    }
    columns.push(num(&|i| rows[i].governed_fraction));
    columns.push(Arc::new(UInt64Array::from(vec![s.evaluations; rows.len()])));
    RecordBatch::try_new(tables()[1].schema.clone(), columns)
}

/// The paragraph the printed table and the report give about the design.
pub fn context(designed: &DesignedDrive) -> String {
    let s = &designed.summary;
    let mut lines = vec![format!(
        "designed drive: criterion {} of {}'s {} ({} evaluations; lower is better; \
         drive_design.parquet, the trace in designed_drive.parquet):",
        s.criterion, s.estimator, s.bound, s.evaluations
    )];
    for c in &s.candidates {
        let se: Vec<String> = PARAMETERS
            .iter()
            .zip(c.relative_se)
            .filter(|(_, v)| !v.is_nan())
            .map(|(p, v)| format!("{p} {v:.3e}"))
            .collect();
        lines.push(format!(
            "  {}: {:.6} (bound's SE/|θ|: {}; governor set {:.1} % of the steps)",
            c.name,
            c.criterion,
            se.join(", "),
            100.0 * c.governed_fraction
        ));
    }
    lines.join("\n")
}
