//! The realisation table: its Arrow schema and the conversions to and from record batches.
//!
//! The schema is built from the model's [`Layout`], so every model gets the same column
//! conventions: `theta_<parameter>`, `<bound>_<parameter>`, snake_case, SI units.

use std::path::Path;
use std::sync::Arc;

use arrow::array::{
    Array, ArrayRef, Float64Array, Int32Array, Int64Array, RecordBatch, StringArray,
};
use arrow::datatypes::{DataType, Field, Schema, SchemaRef};

use super::OutputError;
use crate::estimate::campaign::CAMPAIGN_PASS;
use crate::model::{Axis, AxisKind, AxisValue, ConditionInfo, Layout, Status};
use crate::montecarlo::Chunk;
use crate::stats::summary::Record;
use crate::stats::summary::filter::INPUTS;

pub(super) fn f64_field(name: impl Into<String>, nullable: bool) -> Field {
    Field::new(name, DataType::Float64, nullable)
}

pub(super) fn axis_field(axis: &Axis) -> Field {
    match axis.kind {
        AxisKind::Number => f64_field(axis.name, false),
        AxisKind::Text => Field::new(axis.name, DataType::Utf8, false),
    }
}

/// A column holding one condition's value of `axis` on `rows` rows.
pub(super) fn axis_column<'a>(
    axis: &Axis,
    values: impl Iterator<Item = &'a AxisValue>,
) -> ArrayRef {
    match axis.kind {
        AxisKind::Number => Arc::new(Float64Array::from_iter_values(
            values.map(AxisValue::number),
        )),
        AxisKind::Text => Arc::new(StringArray::from_iter_values(values.map(|v| match v {
            AxisValue::Text(t) => t.clone(),
            AxisValue::Number(n) => n.to_string(),
        }))),
    }
}

/// Schema of `realisations.parquet`: one row per realisation × estimator.
pub fn realisation_schema(layout: &Layout) -> SchemaRef {
    let mut fields = vec![Field::new("condition", DataType::Int32, false)];
    fields.extend(layout.axes.iter().map(axis_field));
    fields.push(Field::new("estimator", DataType::Utf8, false));
    fields.push(Field::new("realisation", DataType::Int64, false));
    for p in &layout.parameters {
        fields.push(f64_field(format!("theta_{}", p.name), true));
    }
    for x in &layout.extras {
        fields.push(f64_field(x.name, true));
    }
    for b in &layout.bounds {
        for p in &layout.parameters {
            fields.push(f64_field(format!("{}_{}", b.name, p.name), true));
        }
    }
    for x in &layout.controls {
        fields.push(f64_field(x.name, true));
    }
    fields.push(Field::new("status", DataType::Utf8, false));
    Arc::new(Schema::new(fields))
}

/// The rows of a computed chunk as a record batch (realisation-major, estimators adjacent).
pub fn realisations_batch(
    layout: &Layout,
    schema: &SchemaRef,
    info: &ConditionInfo,
    chunk: &Chunk<'_>,
) -> Result<RecordBatch, arrow::error::ArrowError> {
    let stride = layout.realisation_stride();
    let n_real = chunk.slots.len() / stride;
    let n_est = layout.estimators.len();
    let rows = n_real * n_est;
    // slot value of (row, offset-within-realisation)
    let slot = |row: usize, offset: usize| chunk.slots[(row / n_est) * stride + offset];
    let est = |row: usize| row % n_est;

    let mut columns: Vec<ArrayRef> = Vec::with_capacity(schema.fields().len());
    columns.push(Arc::new(Int32Array::from(vec![
        chunk.condition as i32;
        rows
    ])));
    for (axis, value) in layout.axes.iter().zip(&info.axes) {
        columns.push(axis_column(axis, std::iter::repeat_n(value, rows)));
    }
    columns.push(Arc::new(StringArray::from_iter_values(
        (0..rows).map(|r| layout.estimators[est(r)]),
    )));
    columns.push(Arc::new(Int64Array::from_iter_values(
        (0..rows).map(|r| (chunk.first + (r / n_est) as u64) as i64),
    )));
    // NaN slots (failed estimates, bounds that do not apply) are written as nulls.
    let nullable = |offset: &dyn Fn(usize) -> usize| -> ArrayRef {
        Arc::new(Float64Array::from_iter((0..rows).map(|r| {
            let v = slot(r, offset(est(r)));
            (!v.is_nan()).then_some(v)
        })))
    };
    for p in 0..layout.parameters.len() {
        columns.push(nullable(&|e| layout.theta_at(e, p)));
    }
    for x in 0..layout.extras.len() {
        columns.push(nullable(&|e| layout.extra_at(e, x)));
    }
    for b in 0..layout.bounds.len() {
        for p in 0..layout.parameters.len() {
            columns.push(nullable(&|e| layout.bound_at(e, b, p)));
        }
    }
    // The realisation's control variates, repeated on each of its estimators' rows.
    for j in 0..layout.controls.len() {
        columns.push(nullable(&|_| layout.control_at(j)));
    }
    columns.push(Arc::new(StringArray::from_iter_values((0..rows).map(
        |r| Status::from_slot(slot(r, layout.status_at(est(r)))).name(),
    ))));
    RecordBatch::try_new(schema.clone(), columns)
}

/// Realisation rows decoded from a batch, ready to be fed to the summarizer.
#[derive(Debug)]
pub struct RealisationBatches {
    condition: Vec<usize>,
    realisation: Vec<u64>,
    estimator: Vec<usize>,
    ok: Vec<bool>,
    /// row-major θ, P per row
    theta: Vec<f64>,
    /// row-major bounds, B × P per row
    bounds: Vec<f64>,
    /// row-major control variates, one per layout control per row
    controls: Vec<f64>,
    /// Per row, the filters' columns (NaN where absent).
    filter: Vec<[f64; 4]>,
    /// Per row, `campaign_pass` (NaN where absent).
    campaign: Vec<f64>,
    n_params: usize,
    n_bound_values: usize,
    n_controls: usize,
}

impl RealisationBatches {
    /// The columns [`RealisationBatches::decode`] reads (the others — axes, extras — need
    /// not be read at all).
    pub fn columns(layout: &Layout) -> Vec<String> {
        let mut names: Vec<String> = ["condition", "realisation", "estimator", "status"]
            .map(String::from)
            .into();
        names.extend(
            layout
                .parameters
                .iter()
                .map(|p| format!("theta_{}", p.name)),
        );
        for b in &layout.bounds {
            names.extend(
                layout
                    .parameters
                    .iter()
                    .map(|p| format!("{}_{}", b.name, p.name)),
            );
        }
        names.extend(layout.controls.iter().map(|x| x.name.to_string()));
        names.extend(
            INPUTS
                .iter()
                .filter(|&&name| layout.extras.iter().any(|x| x.name == name))
                .map(|name| name.to_string()),
        );
        if layout.extras.iter().any(|x| x.name == CAMPAIGN_PASS) {
            names.push(CAMPAIGN_PASS.to_string());
        }
        names
    }

    /// Decode `batch` (a realisation table read back from `path`).
    pub fn decode(layout: &Layout, batch: &RecordBatch, path: &Path) -> Result<Self, OutputError> {
        let column = |name: &str| {
            batch
                .column_by_name(name)
                .ok_or_else(|| OutputError::format(path, format!("missing column `{name}`")))
        };
        let f64_col = |name: &str| -> Result<Float64Array, OutputError> {
            column(name)?
                .as_any()
                .downcast_ref::<Float64Array>()
                .cloned()
                .ok_or_else(|| OutputError::format(path, format!("column `{name}` is not double")))
        };
        let str_col = |name: &str| -> Result<StringArray, OutputError> {
            column(name)?
                .as_any()
                .downcast_ref::<StringArray>()
                .cloned()
                .ok_or_else(|| {
                    OutputError::format(path, format!("column `{name}` is not a string"))
                })
        };
        let n = batch.num_rows();
        let cond = column("condition")?
            .as_any()
            .downcast_ref::<Int32Array>()
            .cloned()
            .ok_or_else(|| OutputError::format(path, "column `condition` is not int32"))?;
        let real = column("realisation")?
            .as_any()
            .downcast_ref::<Int64Array>()
            .cloned()
            .ok_or_else(|| OutputError::format(path, "column `realisation` is not int64"))?;
        let est = str_col("estimator")?;
        let status = str_col("status")?;
        let mut estimator = Vec::with_capacity(n);
        let mut ok = Vec::with_capacity(n);
        for i in 0..n {
            let name = est.value(i);
            estimator.push(layout.estimator_index(name).ok_or_else(|| {
                OutputError::format(path, format!("row {i}: unknown estimator \"{name}\""))
            })?);
            let s = status.value(i);
            ok.push(
                Status::from_name(s).ok_or_else(|| {
                    OutputError::format(path, format!("row {i}: unknown status \"{s}\""))
                })? == Status::Ok,
            );
        }
        let np = layout.parameters.len();
        let thetas: Vec<Float64Array> = layout
            .parameters
            .iter()
            .map(|p| f64_col(&format!("theta_{}", p.name)))
            .collect::<Result<_, _>>()?;
        let mut bound_cols = Vec::new();
        for b in &layout.bounds {
            for p in &layout.parameters {
                bound_cols.push(f64_col(&format!("{}_{}", b.name, p.name))?);
            }
        }
        let control_cols: Vec<Float64Array> = layout
            .controls
            .iter()
            .map(|x| f64_col(x.name))
            .collect::<Result<_, _>>()?;
        // The filters' columns, where the layout has them.
        let filter_cols: Vec<Option<Float64Array>> = INPUTS
            .iter()
            .map(|&name| {
                layout
                    .extras
                    .iter()
                    .any(|x| x.name == name)
                    .then(|| f64_col(name))
                    .transpose()
            })
            .collect::<Result<_, _>>()?;
        let campaign_col = layout
            .extras
            .iter()
            .any(|x| x.name == CAMPAIGN_PASS)
            .then(|| f64_col(CAMPAIGN_PASS))
            .transpose()?;
        let campaign = (0..n)
            .map(|i| match &campaign_col {
                Some(c) if !c.is_null(i) => c.value(i),
                _ => f64::NAN,
            })
            .collect();
        let mut filter = Vec::with_capacity(n);
        let mut theta = Vec::with_capacity(n * np);
        let mut bounds = Vec::with_capacity(n * bound_cols.len());
        let mut controls = Vec::with_capacity(n * control_cols.len());
        for i in 0..n {
            controls.extend(
                control_cols
                    .iter()
                    .map(|c| if c.is_null(i) { f64::NAN } else { c.value(i) }),
            );
            theta.extend(
                thetas
                    .iter()
                    .map(|c| if c.is_null(i) { f64::NAN } else { c.value(i) }),
            );
            bounds.extend(
                bound_cols
                    .iter()
                    .map(|c| if c.is_null(i) { f64::NAN } else { c.value(i) }),
            );
            filter.push(std::array::from_fn(|j| match &filter_cols[j] {
                Some(c) if !c.is_null(i) => c.value(i),
                _ => f64::NAN,
            }));
        }
        let mut condition = Vec::with_capacity(n);
        let mut realisation = Vec::with_capacity(n);
        for i in 0..n {
            let c = cond.value(i);
            let r = real.value(i);
            if c < 0 || r < 0 {
                return Err(OutputError::format(
                    path,
                    format!("row {i}: negative index"),
                ));
            }
            condition.push(c as usize);
            realisation.push(r as u64);
        }
        Ok(RealisationBatches {
            condition,
            realisation,
            estimator,
            ok,
            theta,
            bounds,
            controls,
            filter,
            campaign,
            n_params: np,
            n_bound_values: bound_cols.len(),
            n_controls: control_cols.len(),
        })
    }

    /// Rows decoded.
    pub fn len(&self) -> usize {
        self.condition.len()
    }

    /// True when no row was decoded.
    pub fn is_empty(&self) -> bool {
        self.condition.is_empty()
    }

    /// Row `i` as a summarizer record.
    pub fn record(&self, i: usize) -> Record<'_> {
        Record {
            condition: self.condition[i],
            realisation: self.realisation[i],
            estimator: self.estimator[i],
            ok: self.ok[i],
            theta: &self.theta[i * self.n_params..(i + 1) * self.n_params],
            bounds: &self.bounds[i * self.n_bound_values..(i + 1) * self.n_bound_values],
            controls: &self.controls[i * self.n_controls..(i + 1) * self.n_controls],
            filter: self.filter[i],
            campaign: self.campaign[i],
        }
    }

    /// The decoded rows as summarizer records.
    pub fn records(&self) -> impl Iterator<Item = Record<'_>> {
        (0..self.len()).map(move |i| self.record(i))
    }
}
