//! `cycles.parquet`: each distinct noise-free drive cycle once, so that a user can see what
//! the regression saw.
//!
//! A block of rows per (terrain scale, acceleration source): the cycle of the scale and the
//! samples a regression on the whole cycle uses. A condition's own samples are the block's
//! `used` rows within its duration, joined on the condition's `scale` and `acceleration`
//! (README, "Output files"): the table does not grow with the noise levels, durations or
//! grade biases of a study.

use std::sync::Arc;

use arrow::array::{ArrayRef, BooleanArray, Float64Array, RecordBatch, StringArray};
use arrow::datatypes::{DataType, Field, Schema, SchemaRef};
use arrow::error::ArrowError;

use crate::vehicle::DriveCycle;

/// Schema of `cycles.parquet`: one block of rows per distinct cycle, keyed by the columns
/// `scale` and `acceleration` that every condition also carries.
pub fn cycles_schema() -> SchemaRef {
    let f64_field = |name| Field::new(name, DataType::Float64, false);
    Arc::new(Schema::new(vec![
        f64_field("scale"),
        Field::new("acceleration", DataType::Utf8, false),
        f64_field("t"),
        f64_field("x"),
        f64_field("v"),
        f64_field("grade"),
        f64_field("f_prop"),
        f64_field("accel"),
        Field::new("used", DataType::Boolean, false),
    ]))
}

/// The block of one distinct cycle: the cycle at terrain scale `scale` with the samples
/// `used` by a regression on all of it with acceleration source `acceleration`.
pub fn cycles_batch(
    scale: f64,
    acceleration: &str,
    cycle: &DriveCycle,
    used: &[bool],
) -> Result<RecordBatch, ArrowError> {
    let col = |v: &[f64]| -> ArrayRef { Arc::new(Float64Array::from(v.to_vec())) };
    let n = cycle.len();
    RecordBatch::try_new(
        cycles_schema(),
        vec![
            Arc::new(Float64Array::from(vec![scale; n])),
            Arc::new(StringArray::from(vec![acceleration; n])),
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
