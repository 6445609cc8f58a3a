//! What `fit` writes: fit.parquet, systematic.parquet and fit.svg, and the tables it prints
//! (docs/model.md#fit).

use std::fmt::Write as _;
use std::path::Path;
use std::sync::Arc;

use arrow::array::{ArrayRef, Float64Array, Int64Array, RecordBatch, StringArray};
use arrow::datatypes::{DataType, Field, Schema};
use arrow::error::ArrowError;

use crate::figures::FigureError;
use crate::output::{FileMetadata, OutputError, ParquetSink, PendingFile};

use super::{
    FIT_FIGURE, FIT_FILE, FIT_PARAMETERS, FilterInterval, FitRow, SYSTEMATIC_FILE, SystematicRow,
};
use crate::model::ModelErrorValue;
use crate::stats::measures::Z_95;

pub(super) fn write_rows(
    out: &Path,
    rows: &[FitRow],
    meta: &FileMetadata,
) -> Result<PendingFile, OutputError> {
    let batch = rows_batch(rows).map_err(|e| OutputError::arrow(out, e))?;
    let mut sink = ParquetSink::create(out, FIT_FILE, batch.schema(), meta, "fit")?;
    sink.write(&batch)?;
    sink.finish()
}

/// fit.parquet's table: one row per estimator × parameter (README, "fit").
pub fn rows_batch(rows: &[FitRow]) -> Result<RecordBatch, ArrowError> {
    let mut fields = vec![
        Field::new("estimator", DataType::Utf8, false),
        Field::new("parameter", DataType::Utf8, false),
        Field::new("estimate", DataType::Float64, false),
        Field::new("sandwich_se", DataType::Float64, true),
        Field::new("boot_mean", DataType::Float64, true),
        Field::new("boot_bias", DataType::Float64, true),
        Field::new("bias_corrected", DataType::Float64, true),
        Field::new("ci_low", DataType::Float64, true),
        Field::new("ci_high", DataType::Float64, true),
        Field::new("reference", DataType::Float64, true),
    ];
    // A filter's own interval, in a fit that lists one (a fit without keeps its columns).
    let filters = rows.iter().any(|r| r.filter.is_some());
    if filters {
        fields.extend(
            ["filter_sd", "filter_ci_low", "filter_ci_high"]
                .map(|name| Field::new(name, DataType::Float64, true)),
        );
        fields.push(Field::new("boot_n", DataType::Int64, false));
    }
    let schema = Arc::new(Schema::new(fields));
    let col = |f: &dyn Fn(&FitRow) -> f64| -> ArrayRef {
        Arc::new(Float64Array::from_iter(
            rows.iter().map(|r| Some(f(r)).filter(|v| v.is_finite())),
        ))
    };
    let mut columns: Vec<ArrayRef> = vec![
        Arc::new(StringArray::from_iter_values(
            rows.iter().map(|r| r.estimator),
        )),
        Arc::new(StringArray::from_iter_values(
            rows.iter().map(|r| r.parameter),
        )),
        Arc::new(Float64Array::from_iter_values(
            rows.iter().map(|r| r.estimate),
        )),
        col(&|r| r.sandwich_se),
        col(&|r| r.boot_mean),
        col(&|r| r.boot_bias),
        col(&|r| r.bias_corrected),
        col(&|r| r.ci_low),
        col(&|r| r.ci_high),
        col(&|r| r.reference.unwrap_or(f64::NAN)),
    ];
    if filters {
        let part =
            |f: fn(&FilterInterval) -> f64| move |r: &FitRow| r.filter.map_or(f64::NAN, |i| f(&i));
        columns.push(col(&part(|i| i.sd)));
        columns.push(col(&part(|i| i.low)));
        columns.push(col(&part(|i| i.high)));
        columns.push(Arc::new(Int64Array::from_iter_values(
            rows.iter().map(|r| r.boot_n as i64),
        )));
    }
    RecordBatch::try_new(schema, columns)
}

/// The rows of the table and the figure, in the order a vehicle engineer reads them: M, Cd
/// and Cr, then θ's 1/M and Cd/M. Index into [`FIT_PARAMETERS`] and label with units.
const SHOWN: [(usize, &str); 5] = [
    (3, "M [kg]"),
    (4, "Cd"),
    (2, "Cr"),
    (0, "1/M [1/kg]"),
    (1, "Cd/M [1/kg]"),
];

/// `value` to the digits that `spread` (its SE) supports: down to the second significant
/// digit of the spread (four significant digits of the value when the spread is unknown),
/// in plain notation for magnitudes 0.001 … 100 000 and scientific otherwise.
pub fn format_value(value: f64, spread: f64) -> String {
    if !value.is_finite() {
        return "–".into();
    }
    let magnitude = |x: f64| x.abs().log10().floor() as i32;
    let last = if spread.is_finite() && spread > 0.0 {
        magnitude(spread) - 1
    } else if value != 0.0 {
        magnitude(value) - 3
    } else {
        0
    };
    let text = if value == 0.0 || (1e-3..1e5).contains(&value.abs()) {
        format!("{value:.*}", (-last).clamp(0, 12) as usize)
    } else {
        format!(
            "{value:.*e}",
            (magnitude(value) - last).clamp(0, 12) as usize
        )
    };
    // A negative value rounded to zero is shown as zero.
    match text.strip_prefix('-') {
        Some(rest) if rest.chars().all(|c| matches!(c, '0' | '.')) => rest.to_string(),
        _ => text,
    }
}

/// The table `fit` prints and its report shows: per estimator M, Cd, Cr, 1/M and Cd/M,
/// each to the digits its sandwich SE supports (docs/model.md#fit).
pub fn table(rows: &[FitRow]) -> String {
    let with_reference = rows.iter().any(|r| r.reference.is_some());
    let with_filter = rows.iter().any(|r| r.filter.is_some());
    let optional = |on: bool, title: &str| match on {
        true => title.to_string(),
        false => String::new(),
    };
    let mut lines = vec![[
        "estimator".to_string(),
        "parameter".into(),
        "estimate".into(),
        "SE (sandwich)".into(),
        "bootstrap bias".into(),
        "bias-corrected".into(),
        "95 % bootstrap interval".into(),
        optional(with_filter, "SD (filter)"),
        optional(with_filter, "95 % filter interval"),
        optional(with_reference, "reference"),
    ]];
    let mut estimators: Vec<&str> = rows.iter().map(|r| r.estimator).collect();
    estimators.dedup();
    for est in estimators {
        for (p, label) in SHOWN {
            let Some(r) = rows
                .iter()
                .find(|r| r.estimator == est && r.parameter == FIT_PARAMETERS[p])
            else {
                continue;
            };
            // The digits a spread supports: the sandwich SE's, else the filter's SD.
            let spread = match (r.sandwich_se.is_finite(), r.filter) {
                (false, Some(i)) => i.sd,
                _ => r.sandwich_se,
            };
            let f = |v: f64| format_value(v, spread);
            lines.push([
                est.to_string(),
                label.to_string(),
                f(r.estimate),
                format_value(r.sandwich_se, r.sandwich_se),
                f(r.boot_bias),
                f(r.bias_corrected),
                format!("[{}, {}]", f(r.ci_low), f(r.ci_high)),
                r.filter.map_or(String::new(), |i| format_value(i.sd, i.sd)),
                r.filter
                    .map_or(String::new(), |i| format!("[{}, {}]", f(i.low), f(i.high))),
                r.reference
                    .map_or(String::new(), |v| format_value(v, spread)),
            ]);
        }
    }
    aligned(&lines, 2)
}

/// `lines` of cells as text columns two spaces apart: the first `left` columns aligned
/// left, the others right.
fn aligned<const N: usize>(lines: &[[String; N]], left: usize) -> String {
    let widths: Vec<usize> = (0..N)
        .map(|c| {
            lines
                .iter()
                .map(|l| l[c].chars().count())
                .max()
                .unwrap_or(0)
        })
        .collect();
    let mut out = String::new();
    for line in lines {
        let mut text = String::new();
        // A column empty in every line (an optional one not shown) takes no space.
        for (c, cell) in line.iter().enumerate().filter(|(c, _)| widths[*c] > 0) {
            let pad = widths[c] - cell.chars().count();
            if c < left {
                let _ = write!(text, "{cell}{}  ", " ".repeat(pad));
            } else {
                let _ = write!(text, "{}{cell}  ", " ".repeat(pad));
            }
        }
        out.push_str(text.trim_end());
        out.push('\n');
    }
    out
}

/// The systematic-error budget `fit` prints and its report shows (docs/model.md#fit): per
/// estimator, for M, Cd and Cr, each model error of `[systematic]` at its magnitude, the
/// shift it causes (to the digits of the interval's half-width / 1.96, about the SE), that
/// in % of the estimate, and the half-width of the 95 % bootstrap interval beside it.
/// Empty without `[systematic]`.
pub fn budget_table(budget: &[SystematicRow]) -> String {
    if budget.is_empty() {
        return String::new();
    }
    let mut lines = vec![[
        "estimator".to_string(),
        "parameter".into(),
        "model error".into(),
        "shift".into(),
        "shift [%]".into(),
        "95 % half-width".into(),
    ]];
    let mut estimators: Vec<&str> = budget.iter().map(|r| r.estimator).collect();
    estimators.dedup();
    for est in estimators {
        for (p, label) in &SHOWN[..3] {
            for r in budget
                .iter()
                .filter(|r| r.estimator == est && r.parameter == FIT_PARAMETERS[*p])
            {
                let spread = r.ci_half_width / Z_95;
                let error = ModelErrorValue {
                    key: r.entry,
                    unit: r.unit,
                    value: r.magnitude,
                };
                lines.push([
                    est.to_string(),
                    label.to_string(),
                    error.to_string(),
                    format_value(rounded(r.shift, spread), spread),
                    format!("{:+.3}", rounded(100.0 * r.rel_shift, 0.01)),
                    format_value(r.ci_half_width, spread),
                ]);
            }
        }
    }
    let mut out = String::from(
        "systematic-error budget: how far each estimate moves under each model error of \
         [systematic] (noise-free, in the fit's world), beside the 95 % bootstrap interval\n",
    );
    out.push_str(&aligned(&lines, 3));
    out
}

/// `value` rounded to the last digit [`format_value`] shows for `spread`, and a zero
/// unsigned (so that a shift far below the spread reads 0, not −4e-15).
fn rounded(value: f64, spread: f64) -> f64 {
    if !(spread.is_finite() && spread > 0.0) {
        return value;
    }
    let unit = 10f64.powi(spread.log10().floor() as i32 - 1);
    match (value / unit).round() {
        0.0 => 0.0,
        steps => steps * unit,
    }
}

/// Write `systematic.parquet`: one row per estimator × parameter × model error of
/// `[systematic]` (README, "fit").
pub(super) fn write_budget(
    out: &Path,
    budget: &[SystematicRow],
    meta: &FileMetadata,
) -> Result<PendingFile, OutputError> {
    let batch = budget_batch(budget).map_err(|e| OutputError::arrow(out, e))?;
    let mut sink = ParquetSink::create(out, SYSTEMATIC_FILE, batch.schema(), meta, "systematic")?;
    sink.write(&batch)?;
    sink.finish()
}

/// systematic.parquet's table: one row per estimator × parameter × model error.
pub fn budget_batch(budget: &[SystematicRow]) -> Result<RecordBatch, ArrowError> {
    let schema = Arc::new(Schema::new(vec![
        Field::new("estimator", DataType::Utf8, false),
        Field::new("parameter", DataType::Utf8, false),
        Field::new("entry", DataType::Utf8, false),
        Field::new("magnitude", DataType::Float64, false),
        Field::new("shift", DataType::Float64, true),
        Field::new("rel_shift", DataType::Float64, true),
        Field::new("ci_half_width", DataType::Float64, true),
    ]));
    let text = |f: fn(&SystematicRow) -> &'static str| -> ArrayRef {
        Arc::new(StringArray::from_iter_values(budget.iter().map(f)))
    };
    let col = |f: fn(&SystematicRow) -> f64| -> ArrayRef {
        Arc::new(Float64Array::from_iter(
            budget.iter().map(|r| Some(f(r)).filter(|v| v.is_finite())),
        ))
    };
    let columns: Vec<ArrayRef> = vec![
        text(|r| r.estimator),
        text(|r| r.parameter),
        text(|r| r.entry),
        Arc::new(Float64Array::from_iter_values(
            budget.iter().map(|r| r.magnitude),
        )),
        col(|r| r.shift),
        col(|r| r.rel_shift),
        col(|r| r.ci_half_width),
    ];
    RecordBatch::try_new(schema, columns)
}

/// The figure of [`FIT_FIGURE`] as SVG text: one panel per parameter (M, Cd, Cr), one line
/// per estimator with its 95 % bootstrap interval and its estimate (a dot), the reference
/// value dashed when given.
pub(super) fn figure(rows: &[FitRow]) -> Result<String, FigureError> {
    use plotters::prelude::*;
    const PANELS: usize = 3;
    let path = Path::new(FIT_FIGURE);
    let fail = |e: &dyn std::fmt::Display| FigureError::Draw {
        path: path.to_path_buf(),
        reason: e.to_string(),
    };
    let mut estimators: Vec<&str> = rows.iter().map(|r| r.estimator).collect();
    estimators.dedup();
    let n = estimators.len();
    let mut svg = String::new();
    {
        let height = 150 + 45 * n as u32;
        let root = SVGBackend::with_string(&mut svg, (1200, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| fail(&e))?;
        let (top, bottom) = root.split_vertically(height - 30);
        for (panel, &(p, label)) in top.split_evenly((1, PANELS)).iter().zip(&SHOWN) {
            // Each estimator keeps its own line (index i) in every panel, also where it has
            // no row of this parameter (a filter's Cd and Cr are known to it).
            let mine: Vec<(usize, &FitRow)> = estimators
                .iter()
                .enumerate()
                .filter_map(|(i, e)| {
                    rows.iter()
                        .find(|r| r.estimator == *e && r.parameter == FIT_PARAMETERS[p])
                        .map(|r| (i, r))
                })
                .collect();
            let own = |r: &FitRow| r.filter.map_or([f64::NAN; 2], |f| [f.low, f.high]);
            let values = mine
                .iter()
                .flat_map(|(_, r)| [r.estimate, r.ci_low, r.ci_high].into_iter().chain(own(r)))
                .chain(mine.iter().filter_map(|(_, r)| r.reference))
                .filter(|v| v.is_finite());
            let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(v), b.max(v))
            });
            let (lo, hi) = match (lo.is_finite(), hi > lo) {
                (true, true) => (lo - 0.08 * (hi - lo), hi + 0.08 * (hi - lo)),
                (true, false) => (
                    lo - 0.5 * lo.abs().max(1e-12),
                    lo + 0.5 * lo.abs().max(1e-12),
                ),
                _ => (0.0, 1.0),
            };
            // Tick labels to the digits of about a tenth of the axis (plotters picks ~4 ticks).
            let tick_digits = 2.5 * (hi - lo);
            let mut chart = ChartBuilder::on(panel)
                .caption(label, ("sans-serif", 20))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d(lo..hi, -0.5..n as f64 - 0.5)
                .map_err(|e| fail(&e))?;
            chart
                .configure_mesh()
                .disable_y_mesh()
                .x_labels(4)
                .y_labels(n)
                .x_label_formatter(&|v| format_value(*v, tick_digits))
                .y_label_formatter(&|v| {
                    let i = v.round();
                    if (v - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < n {
                        estimators[n - 1 - i as usize].to_string()
                    } else {
                        String::new()
                    }
                })
                .label_style(("sans-serif", 14))
                .draw()
                .map_err(|e| fail(&e))?;
            if let Some(r) = mine.iter().find_map(|(_, r)| r.reference) {
                chart
                    .draw_series(DashedLineSeries::new(
                        [(r, -0.5), (r, n as f64 - 0.5)],
                        6,
                        4,
                        BLACK.mix(0.6).stroke_width(1),
                    ))
                    .map_err(|e| fail(&e))?;
            }
            for &(i, r) in &mine {
                let y = (n - 1 - i) as f64;
                let color = Palette99::pick(i).to_rgba();
                // A filter's own interval: a thin bar below the bootstrap's (its upper end
                // clipped to the axis where the interval of M is unbounded).
                if let [low, high] = own(r)
                    && low.is_finite()
                {
                    let high = if high.is_finite() { high } else { hi };
                    chart
                        .draw_series([PathElement::new(
                            vec![(low, y - 0.25), (high, y - 0.25)],
                            color.stroke_width(1),
                        )])
                        .map_err(|e| fail(&e))?;
                }
                let style = color.stroke_width(2);
                let cap = 0.12;
                chart
                    .draw_series([
                        PathElement::new(vec![(r.ci_low, y), (r.ci_high, y)], style),
                        PathElement::new(vec![(r.ci_low, y - cap), (r.ci_low, y + cap)], style),
                        PathElement::new(vec![(r.ci_high, y - cap), (r.ci_high, y + cap)], style),
                    ])
                    .map_err(|e| fail(&e))?;
                chart
                    .draw_series([Circle::new((r.estimate, y), 5, color.filled())])
                    .map_err(|e| fail(&e))?;
            }
        }
        bottom
            .draw(&Text::new(
                match rows.iter().any(|r| r.filter.is_some()) {
                    true => {
                        "dot: estimate; bar: 95 % bootstrap interval; thin bar below: a \
                             filter's own 95 % interval; dashed: the fit file's [reference]"
                    }
                    false => {
                        "dot: estimate; bar: 95 % bootstrap interval; dashed: the fit \
                              file's [reference]"
                    }
                },
                (20, 8),
                ("sans-serif", 14),
            ))
            .map_err(|e| fail(&e))?;
        root.present().map_err(|e| fail(&e))?;
    }
    Ok(svg)
}
