//! The summary table: its Arrow schema, the record batch of the summary rows, and the typed
//! decoder that reads a `summary.parquet` back into [`SummaryRow`]s.
//!
//! Every column comes from [`SummaryColumn::all`], the one definition of the table.

use crate::stats::summary::MEASURE_COUNT;
use std::path::Path;
use std::sync::Arc;

use arrow::array::{
    Array, ArrayRef, AsArray, Float64Array, Int32Array, Int64Array, RecordBatch, StringArray,
};
use arrow::datatypes::{DataType, Field, Float64Type, Int32Type, Int64Type, Schema, SchemaRef};

use super::tables::{axis_column, axis_field, f64_field};
use super::{OutputError, open_reader};
use crate::model::{AxisKind, AxisValue, ConditionInfo, Layout};
use crate::stats::columns::SummaryColumn;
use crate::stats::measures::Estimate;
use crate::stats::summary::SummaryRow;

fn field(layout: &Layout, column: SummaryColumn) -> Field {
    let name = column.name(layout);
    match column {
        SummaryColumn::Condition => Field::new(name, DataType::Int32, false),
        SummaryColumn::Axis(i) => axis_field(&layout.axes[i]),
        SummaryColumn::Metric(_) | SummaryColumn::Truth => f64_field(name, false),
        SummaryColumn::Estimator | SummaryColumn::Parameter => {
            Field::new(name, DataType::Utf8, false)
        }
        SummaryColumn::N | SummaryColumn::NFailed | SummaryColumn::NControls => {
            Field::new(name, DataType::Int64, false)
        }
        SummaryColumn::Measure(..)
        | SummaryColumn::Bound(..)
        | SummaryColumn::Filter(..)
        | SummaryColumn::PassProbability(..)
        | SummaryColumn::BiasModel => f64_field(name, true),
    }
}

/// Schema of `summary.parquet`: one row per condition × estimator × parameter.
pub fn summary_schema(layout: &Layout) -> SchemaRef {
    let fields: Vec<Field> = SummaryColumn::all(layout)
        .into_iter()
        .map(|c| field(layout, c))
        .collect();
    Arc::new(Schema::new(fields))
}

fn finite_or_null(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// The summary rows as one record batch.
pub fn summary_batch(
    layout: &Layout,
    infos: &[ConditionInfo],
    rows: &[SummaryRow],
) -> Result<RecordBatch, arrow::error::ArrowError> {
    let columns: Vec<ArrayRef> = SummaryColumn::all(layout)
        .into_iter()
        .map(|column| -> ArrayRef {
            match column {
                SummaryColumn::Condition => Arc::new(Int32Array::from_iter_values(
                    rows.iter().map(|r| r.condition as i32),
                )),
                SummaryColumn::Axis(a) => axis_column(
                    &layout.axes[a],
                    rows.iter().map(|r| &infos[r.condition].axes[a]),
                ),
                SummaryColumn::Metric(m) => Arc::new(Float64Array::from_iter_values(
                    rows.iter().map(|r| infos[r.condition].metrics[m]),
                )),
                SummaryColumn::Estimator => Arc::new(StringArray::from_iter_values(
                    rows.iter().map(|r| layout.estimators[r.estimator]),
                )),
                SummaryColumn::Parameter => Arc::new(StringArray::from_iter_values(
                    rows.iter().map(|r| layout.parameters[r.parameter].name),
                )),
                SummaryColumn::Truth => {
                    Arc::new(Float64Array::from_iter_values(rows.iter().map(|r| r.truth)))
                }
                SummaryColumn::BiasModel => Arc::new(Float64Array::from_iter(
                    rows.iter().map(|r| finite_or_null(r.bias_model)),
                )),
                SummaryColumn::N => Arc::new(Int64Array::from_iter_values(
                    rows.iter().map(|r| r.n as i64),
                )),
                SummaryColumn::NFailed => Arc::new(Int64Array::from_iter_values(
                    rows.iter().map(|r| r.n_failed as i64),
                )),
                SummaryColumn::NControls => Arc::new(Int64Array::from_iter_values(
                    rows.iter().map(|r| r.n_controls as i64),
                )),
                SummaryColumn::Measure(..)
                | SummaryColumn::Bound(..)
                | SummaryColumn::Filter(..)
                | SummaryColumn::PassProbability(..) => Arc::new(Float64Array::from_iter(
                    rows.iter()
                        .map(|r| column.measure_value(r).and_then(finite_or_null)),
                )),
            }
        })
        .collect();
    RecordBatch::try_new(summary_schema(layout), columns)
}

/// A `summary.parquet` read back: its rows, and what each condition's columns say.
#[derive(Debug, Clone, Default)]
pub struct SummaryTable {
    /// The rows, in file order.
    pub rows: Vec<SummaryRow>,
    /// Per condition index: its axes, metrics, truth and which bounds apply (`None` for an
    /// index no row names).
    pub infos: Vec<Option<ConditionInfo>>,
}

impl SummaryTable {
    /// The info of the condition of `row`.
    pub fn info(&self, row: &SummaryRow) -> &ConditionInfo {
        self.infos[row.condition]
            .as_ref()
            .expect("every row's condition has an info")
    }
}

/// Rows per batch when reading a summary back.
const SUMMARY_READ_ROWS: usize = 4096;

/// Read the summary at `path`, written for a model with `layout`.
pub fn read_summary(path: &Path, layout: &Layout) -> Result<SummaryTable, OutputError> {
    let mut table = SummaryTable::default();
    let columns = SummaryColumn::all(layout);
    // Small batches: a batch of the summary's ~300 columns decodes to about 750 bytes a row.
    for batch in open_reader(path, SUMMARY_READ_ROWS)? {
        let batch = batch.map_err(|e| OutputError::arrow(path, e))?;
        decode(layout, &columns, &batch, path, &mut table)?;
    }
    Ok(table)
}

fn decode(
    layout: &Layout,
    columns: &[SummaryColumn],
    batch: &RecordBatch,
    path: &Path,
    table: &mut SummaryTable,
) -> Result<(), OutputError> {
    let get = |c: SummaryColumn| -> Result<&ArrayRef, OutputError> {
        let name = c.name(layout);
        batch
            .column_by_name(&name)
            .ok_or_else(|| OutputError::format(path, format!("missing column `{name}`")))
    };
    let typed = |c: SummaryColumn, want: DataType| -> Result<&ArrayRef, OutputError> {
        let a = get(c)?;
        if a.data_type() != &want {
            return Err(OutputError::format(
                path,
                format!(
                    "column `{}` is {}, not {want}",
                    c.name(layout),
                    a.data_type()
                ),
            ));
        }
        Ok(a)
    };
    let number = |a: &ArrayRef, i: usize| -> Option<f64> {
        let a = a.as_primitive::<Float64Type>();
        (!a.is_null(i)).then(|| a.value(i))
    };
    let condition = typed(SummaryColumn::Condition, DataType::Int32)?.as_primitive::<Int32Type>();
    let estimator = typed(SummaryColumn::Estimator, DataType::Utf8)?.as_string::<i32>();
    let parameter = typed(SummaryColumn::Parameter, DataType::Utf8)?.as_string::<i32>();
    let truth = typed(SummaryColumn::Truth, DataType::Float64)?;
    let bias_model = typed(SummaryColumn::BiasModel, DataType::Float64)?;
    let n = typed(SummaryColumn::N, DataType::Int64)?.as_primitive::<Int64Type>();
    let n_failed = typed(SummaryColumn::NFailed, DataType::Int64)?.as_primitive::<Int64Type>();
    let n_controls = typed(SummaryColumn::NControls, DataType::Int64)?.as_primitive::<Int64Type>();
    let measures: Vec<(SummaryColumn, &ArrayRef)> = columns
        .iter()
        .filter(|c| {
            matches!(
                c,
                SummaryColumn::Measure(..)
                    | SummaryColumn::Bound(..)
                    | SummaryColumn::PassProbability(..)
            )
        })
        .map(|&c| Ok((c, typed(c, DataType::Float64)?)))
        .collect::<Result<_, OutputError>>()?;
    let axes: Vec<&ArrayRef> = (0..layout.axes.len())
        .map(|a| get(SummaryColumn::Axis(a)))
        .collect::<Result<_, _>>()?;
    let metrics: Vec<&ArrayRef> = (0..layout.condition_metrics.len())
        .map(|m| typed(SummaryColumn::Metric(m), DataType::Float64))
        .collect::<Result<_, _>>()?;
    for i in 0..batch.num_rows() {
        let bad = |what: String| OutputError::format(path, format!("row {i}: {what}"));
        let c =
            usize::try_from(condition.value(i)).map_err(|_| bad("negative condition".into()))?;
        let e = layout
            .estimator_index(estimator.value(i))
            .ok_or_else(|| bad(format!("unknown estimator \"{}\"", estimator.value(i))))?;
        let p = layout
            .parameters
            .iter()
            .position(|q| q.name == parameter.value(i))
            .ok_or_else(|| bad(format!("unknown parameter \"{}\"", parameter.value(i))))?;
        let mut row = SummaryRow {
            condition: c,
            estimator: e,
            parameter: p,
            truth: number(truth, i).unwrap_or(f64::NAN),
            bias_model: number(bias_model, i).unwrap_or(f64::NAN),
            n: n.value(i) as u64,
            n_failed: n_failed.value(i) as u64,
            bounds: vec![None; layout.bounds.len()],
            measures: [Estimate::undefined(); MEASURE_COUNT],
            n_controls: n_controls.value(i) as u64,
            filter: None,
            pass_probability: None,
        };
        for (column, array) in &measures {
            column.set_measure(&mut row, number(array, i));
        }
        if table.infos.len() <= c {
            table.infos.resize(c + 1, None);
        }
        let info = table.infos[c].get_or_insert_with(|| ConditionInfo {
            axes: layout
                .axes
                .iter()
                .zip(&axes)
                .map(|(axis, a)| match axis.kind {
                    AxisKind::Number => AxisValue::Number(number(a, i).unwrap_or(f64::NAN)),
                    AxisKind::Text => AxisValue::Text(a.as_string::<i32>().value(i).to_string()),
                })
                .collect(),
            metrics: metrics
                .iter()
                .map(|a| number(a, i).unwrap_or(f64::NAN))
                .collect(),
            truth: vec![f64::NAN; layout.parameters.len()],
            bias_model: vec![vec![f64::NAN; layout.parameters.len()]; layout.estimators.len()],
            // Not summary columns: the axes hold the values of the axis entries.
            model_errors: Vec::new(),
            applies: vec![vec![false; layout.bounds.len()]; layout.estimators.len()],
            // Which sums were control variates is not a summary column.
            controls: vec![false; layout.controls.len()],
            control_covariance: None,
        });
        info.truth[p] = row.truth;
        info.bias_model[e][p] = row.bias_model;
        for (b, s) in row.bounds.iter().enumerate() {
            info.applies[e][b] |= s.is_some();
        }
        table.rows.push(row);
    }
    Ok(())
}
