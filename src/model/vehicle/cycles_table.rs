//! `cycles.parquet`: the noise-free drive cycle of each condition, so that a user can see
//! what the regression saw.

use std::sync::Arc;

use arrow::array::{ArrayRef, BooleanArray, Float64Array, Int32Array, RecordBatch};
use arrow::datatypes::{DataType, Field, Schema, SchemaRef};
use arrow::error::ArrowError;

use crate::vehicle::DriveCycle;

/// Schema of `cycles.parquet`: the noise-free time series of each condition.
pub fn cycles_schema() -> SchemaRef {
    let f64_field = |name| Field::new(name, DataType::Float64, false);
    Arc::new(Schema::new(vec![
        Field::new("condition", DataType::Int32, false),
        f64_field("t"),
        f64_field("x"),
        f64_field("v"),
        f64_field("grade"),
        f64_field("f_prop"),
        f64_field("accel"),
        Field::new("used", DataType::Boolean, false),
    ]))
}

/// One condition's drive cycle as a record batch.
pub fn cycles_batch(
    condition: usize,
    cycle: &DriveCycle,
    used: &[bool],
) -> Result<RecordBatch, ArrowError> {
    let col = |v: &Vec<f64>| -> ArrayRef { Arc::new(Float64Array::from(v.clone())) };
    RecordBatch::try_new(
        cycles_schema(),
        vec![
            Arc::new(Int32Array::from(vec![condition as i32; cycle.len()])),
            col(&cycle.t_s),
            col(&cycle.x_m),
            col(&cycle.v_m_s),
            col(&cycle.grade_rad),
            col(&cycle.f_prop_n),
            col(&cycle.accel_m_s2),
            Arc::new(BooleanArray::from(used.to_vec())),
        ],
    )
}
