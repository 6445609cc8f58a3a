//! `cycles.parquet`: each distinct noise-free drive cycle once, so that a user can see what
//! the regression saw.
//!
//! A block of rows per (terrain scale, truth, acceleration source): the cycle of the scale
//! with the truth's steady model errors (the logged force, the truth's acceleration) and the
//! samples a regression on the whole cycle uses, each sample with its `run` (a coast-down's
//! runs; 0 in other drive modes). A condition's own samples are the block's `used` rows
//! within its duration (or with `run` < its `runs`), joined on the condition's `scale`,
//! truth axes (`wind_speed`, …) and `acceleration` (README, "Output files"): the table does
//! not grow with the noise levels, durations, runs or grade biases of a study.

use std::sync::Arc;

use arrow::array::{ArrayRef, BooleanArray, Float64Array, Int32Array, RecordBatch, StringArray};
use arrow::datatypes::{DataType, Field, Schema, SchemaRef};
use arrow::error::ArrowError;

use crate::dynamics::DriveCycle;
use crate::dynamics::truth::{MODEL_ERROR_COUNT, MODEL_ERRORS};

/// Schema of `cycles.parquet`: one block of rows per distinct cycle, keyed by the columns
/// `scale`, `acceleration` and the truth's axes that every condition also carries.
pub fn cycles_schema() -> SchemaRef {
    let f64_field = |name| Field::new(name, DataType::Float64, false);
    let mut fields = vec![
        f64_field("scale"),
        Field::new("acceleration", DataType::Utf8, false),
    ];
    fields.extend(
        MODEL_ERRORS
            .iter()
            .filter(|e| e.axis)
            .map(|e| f64_field(e.key)),
    );
    fields.extend([
        Field::new("run", DataType::Int32, false),
        f64_field("t"),
        f64_field("x"),
        f64_field("v"),
        f64_field("grade"),
        f64_field("f_prop"),
        f64_field("accel"),
        Field::new("used", DataType::Boolean, false),
    ]);
    Arc::new(Schema::new(fields))
}

/// The block of one distinct cycle: the cycle at terrain scale `scale` with the model errors
/// at `truth` (per entry of [`MODEL_ERRORS`]) and the samples `used` by a regression on all
/// of it with acceleration source `acceleration`.
pub fn cycles_batch(
    scale: f64,
    truth: &[f64; MODEL_ERROR_COUNT],
    acceleration: &str,
    cycle: &DriveCycle,
    used: &[bool],
) -> Result<RecordBatch, ArrowError> {
    let col = |v: &[f64]| -> ArrayRef { Arc::new(Float64Array::from(v.to_vec())) };
    let n = cycle.len();
    let mut columns: Vec<ArrayRef> = vec![
        Arc::new(Float64Array::from(vec![scale; n])),
        Arc::new(StringArray::from(vec![acceleration; n])),
    ];
    columns.extend(
        MODEL_ERRORS
            .iter()
            .zip(truth)
            .filter(|(e, _)| e.axis)
            .map(|(_, &v)| -> ArrayRef { Arc::new(Float64Array::from(vec![v; n])) }),
    );
    let run: Vec<i32> = cycle.run.iter().map(|&r| r as i32).collect();
    columns.extend([
        Arc::new(Int32Array::from(run)) as ArrayRef,
        col(&cycle.t_s),
        col(&cycle.x_m),
        col(&cycle.v_m_s),
        col(&cycle.grade_rad),
        col(&cycle.f_prop_n),
        col(&cycle.accel_m_s2),
        Arc::new(BooleanArray::from(used.to_vec())) as ArrayRef,
    ]);
    RecordBatch::try_new(cycles_schema(), columns)
}
