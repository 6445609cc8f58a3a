//! Figures from every run: SVG files drawn with plotters from the Parquet outputs.
//!
//! The thesis's result is a set of plots (its Figures 4–6: each parameter's error bound
//! against the terrain metric ς). This module draws those next to what the thesis could
//! not show — the real spread with its Monte Carlo error bars, the bias, EmpSE/bound and
//! coverage — and the drive cycles. It reads `summary.parquet` (and `cycles.parquet`), so
//! `chassis-mc figures DIR` redraws any run's figures, and `run` draws them the same way.
//!
//! Per parameter p (for the vehicle: `inv_mass`, `drag_over_mass`, `rolling_resistance`):
//!
//! | file | shows |
//! |---|---|
//! | `se_<p>.svg` | EmpSE ± MCSE (circles) and every applicable bound (lines) against ς, log scale |
//! | `bias_<p>.svg` | bias ± MCSE against ς, per estimator, with the zero line |
//! | `ratio_<p>.svg` | EmpSE / bound ± MCSE against ς, with the line at 1, log scale |
//! | `coverage_<p>.svg` | coverage of θ̂ ± 1.96·bound ± MCSE, with the nominal 95 % |
//!
//! and `cycles.svg`: speed and grade against time, one line per distinct terrain scale.
//! Each plotted condition × estimator (× bound) is one circle marker.

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};

use arrow::array::AsArray;
use arrow::datatypes::{DataType, Float64Type, Int32Type};
use plotters::prelude::*;
use rayon::prelude::*;
use thiserror::Error;

use crate::model::{AxisKind, AxisValue, ConditionInfo, Layout};
use crate::output::lock::DirLock;
use crate::output::{self, OutputError, PendingFile, SummaryTable, files, keys, set};
use crate::stats::columns::{BoundMeasure, Measure};
use crate::stats::summary::SummaryRow;
use crate::study::{Study, StudyError};

/// Directory of the figures inside an output directory.
pub const FIGURES: &str = "figures";

/// The 95 % nominal coverage.
const NOMINAL: f64 = 0.95;
/// Figure size [px].
const SIZE: (u32, u32) = (1200, 620);
/// Width kept on the right of the plot for the legend [px].
const LEGEND_WIDTH: u32 = 360;
/// Most points drawn per cycle line (the cycles are decimated to this).
const MAX_CYCLE_POINTS: usize = 1500;

/// Why figures could not be drawn.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum FigureError {
    /// Reading the Parquet outputs failed.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// The study in the files' footer is not valid.
    #[error(transparent)]
    Study(#[from] StudyError),
    /// Drawing or writing an SVG failed.
    #[error("{path}: {reason}")]
    Draw {
        /// The figure.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
}

fn draw_error(path: &Path, e: impl std::fmt::Display) -> FigureError {
    FigureError::Draw {
        path: path.to_path_buf(),
        reason: e.to_string(),
    }
}

/// The numeric columns of a table read whole, as f64 (null → NaN): the drive cycles.
#[derive(Debug, Default)]
struct Table {
    numbers: BTreeMap<String, Vec<f64>>,
}

impl Table {
    /// Read the named columns (doubles or int32).
    fn read_columns(path: &Path, columns: &[&str]) -> Result<Table, OutputError> {
        let mut t = Table::default();
        for batch in output::open_projected_reader(path, output::READ_ROWS, Some(columns))? {
            let batch = batch.map_err(|e| OutputError::arrow(path, e))?;
            for (field, column) in batch.schema().fields().iter().zip(batch.columns()) {
                let values: Vec<f64> = match column.data_type() {
                    DataType::Float64 => {
                        let a = column.as_primitive::<Float64Type>();
                        a.iter().map(|v| v.unwrap_or(f64::NAN)).collect()
                    }
                    DataType::Int32 => {
                        let a = column.as_primitive::<Int32Type>();
                        a.iter().map(|v| v.map_or(f64::NAN, f64::from)).collect()
                    }
                    other => {
                        return Err(OutputError::format(
                            path,
                            format!("column `{}` is {other}, not a number", field.name()),
                        ));
                    }
                };
                t.numbers
                    .entry(field.name().clone())
                    .or_default()
                    .extend(values);
            }
        }
        Ok(t)
    }

    fn number(&self, name: &str) -> Option<&[f64]> {
        self.numbers.get(name).map(Vec::as_slice)
    }
}

/// A series of a chart: one legend entry.
struct Series {
    label: String,
    color: RGBColor,
    /// (x, y, half-width of the error bar)
    points: Vec<(f64, f64, f64)>,
    /// Drawn as circles with error bars (estimates) or as a line with crosses (bounds).
    markers: bool,
}

/// A horizontal reference line.
struct Reference {
    y: f64,
    label: String,
}

/// Distinct colours readable on white: Okabe & Ito (2008, colour-blind safe) first, then
/// darker tones; repeats after 16.
fn color(i: usize) -> RGBColor {
    const PALETTE: [(u8, u8, u8); 16] = [
        (0, 114, 178),
        (213, 94, 0),
        (0, 158, 115),
        (204, 121, 167),
        (230, 159, 0),
        (86, 180, 233),
        (0, 0, 0),
        (153, 153, 51),
        (136, 34, 85),
        (68, 119, 170),
        (17, 119, 51),
        (170, 68, 153),
        (102, 51, 0),
        (51, 34, 136),
        (136, 136, 136),
        (204, 51, 17),
    ];
    let (r, g, b) = PALETTE[i % PALETTE.len()];
    RGBColor(r, g, b)
}

/// A colour from dark blue to orange for position `k` of `n` (ordered things: scales).
fn ramp(k: usize, n: usize) -> RGBColor {
    let t = if n > 1 {
        k as f64 / (n - 1) as f64
    } else {
        0.0
    };
    let lerp = |a: f64, b: f64| (a + t * (b - a)).round() as u8;
    RGBColor(lerp(20.0, 230.0), lerp(40.0, 120.0), lerp(140.0, 10.0))
}

struct Axes<'a> {
    title: &'a str,
    x_label: &'a str,
    y_label: &'a str,
    log_y: bool,
}

/// Draw one chart of `series` into `path`.
fn chart(
    path: &Path,
    axes: &Axes<'_>,
    series: &[Series],
    references: &[Reference],
) -> Result<(), FigureError> {
    let finite = |v: &f64| v.is_finite() && (!axes.log_y || *v > 0.0);
    let xs: Vec<f64> = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.0))
        .collect();
    let mut ys: Vec<f64> = Vec::new();
    for s in series {
        for &(_, y, e) in &s.points {
            ys.push(y);
            if e.is_finite() {
                ys.push(y - e);
                ys.push(y + e);
            }
        }
    }
    ys.extend(references.iter().map(|r| r.y));
    let (x_lo, x_hi) = padded(xs.iter().copied().filter(finite), false);
    let (y_lo, y_hi) = padded(ys.iter().copied().filter(finite), axes.log_y);
    let root = SVGBackend::new(path, SIZE).into_drawing_area();
    root.fill(&WHITE).map_err(|e| draw_error(path, e))?;
    let mut builder = ChartBuilder::on(&root);
    builder
        .caption(axes.title, ("sans-serif", 24))
        .margin(15)
        .margin_right(LEGEND_WIDTH)
        .x_label_area_size(60)
        .y_label_area_size(100);
    // The two branches differ only in the y coordinate type (linear or logarithmic).
    macro_rules! draw_on {
        ($y_range:expr, $y_format:literal) => {{
            let mut c = builder
                .build_cartesian_2d(x_lo..x_hi, $y_range)
                .map_err(|e| draw_error(path, e))?;
            c.configure_mesh()
                .x_desc(axes.x_label)
                .y_desc(axes.y_label)
                .axis_desc_style(("sans-serif", 17))
                .label_style(("sans-serif", 14))
                .x_label_formatter(&|v| format!("{v:.3e}"))
                .y_label_formatter(&|v| format!($y_format, v))
                .draw()
                .map_err(|e| draw_error(path, e))?;
            plot_series(&mut c, series, references, (x_lo, x_hi), y_lo, path)?;
        }};
    }
    if axes.log_y {
        draw_on!((y_lo..y_hi).log_scale(), "{:.1e}");
    } else {
        draw_on!(y_lo..y_hi, "{:.2e}");
    }
    let mut entries: Vec<(String, Key)> = references
        .iter()
        .map(|r| (r.label.clone(), Key::Dashed))
        .collect();
    entries.extend(series.iter().map(|s| {
        let key = if s.markers {
            Key::Marker(s.color)
        } else {
            Key::Line(s.color)
        };
        (s.label.clone(), key)
    }));
    legend(&root, &entries, 60, path)?;
    root.present().map_err(|e| draw_error(path, e))
}

fn plot_series<'a, DB, Y>(
    c: &mut ChartContext<'a, DB, Cartesian2d<plotters::coord::types::RangedCoordf64, Y>>,
    series: &[Series],
    references: &[Reference],
    (x_lo, x_hi): (f64, f64),
    y_floor: f64,
    path: &Path,
) -> Result<(), FigureError>
where
    DB: DrawingBackend + 'a,
    Y: Ranged<ValueType = f64>,
{
    for r in references {
        let style = ShapeStyle::from(&BLACK.mix(0.6)).stroke_width(1);
        let y = r.y;
        c.draw_series(DashedLineSeries::new([(x_lo, y), (x_hi, y)], 6, 4, style))
            .map_err(|e| draw_error(path, e))?;
    }
    for s in series {
        let color = s.color;
        let pts: Vec<(f64, f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|p| p.0.is_finite() && p.1.is_finite())
            .collect();
        if s.markers {
            c.draw_series(pts.iter().filter(|p| p.2.is_finite()).map(|&(x, y, e)| {
                ErrorBar::new_vertical(x, (y - e).max(y_floor), y, y + e, color.stroke_width(1), 6)
            }))
            .map_err(|e| draw_error(path, e))?;
            c.draw_series(LineSeries::new(
                pts.iter().map(|p| (p.0, p.1)),
                color.mix(0.35).stroke_width(1),
            ))
            .map_err(|e| draw_error(path, e))?;
            c.draw_series(
                pts.iter()
                    .map(|&(x, y, _)| Circle::new((x, y), 4, color.filled())),
            )
            .map_err(|e| draw_error(path, e))?;
        } else {
            c.draw_series(LineSeries::new(
                pts.iter().map(|p| (p.0, p.1)),
                color.stroke_width(2),
            ))
            .map_err(|e| draw_error(path, e))?;
            c.draw_series(
                pts.iter()
                    .map(|&(x, y, _)| Cross::new((x, y), 4, color.stroke_width(2))),
            )
            .map_err(|e| draw_error(path, e))?;
        }
    }
    Ok(())
}

/// What a legend entry shows next to its text.
#[derive(Clone, Copy)]
enum Key {
    /// A filled circle (estimates with MCSE bars).
    Marker(RGBColor),
    /// A solid line with crosses (bounds).
    Line(RGBColor),
    /// A dashed grey line (references).
    Dashed,
}

/// Draw a legend in the right-hand margin of `root`, from pixel row `top`.
fn legend<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    entries: &[(String, Key)],
    top: i32,
    path: &Path,
) -> Result<(), FigureError> {
    let x = (SIZE.0 - LEGEND_WIDTH + 20) as i32;
    for (k, (label, key)) in entries.iter().enumerate() {
        let y = top + 20 * k as i32;
        match *key {
            Key::Marker(c) => root.draw(&Circle::new((x + 10, y), 4, c.filled())),
            Key::Line(c) => root.draw(&PathElement::new(
                vec![(x, y), (x + 20, y)],
                c.stroke_width(2),
            )),
            Key::Dashed => root.draw(&PathElement::new(vec![(x, y), (x + 20, y)], BLACK.mix(0.6))),
        }
        .map_err(|e| draw_error(path, e))?;
        root.draw(&Text::new(
            label.clone(),
            (x + 28, y - 8),
            ("sans-serif", 16),
        ))
        .map_err(|e| draw_error(path, e))?;
    }
    Ok(())
}

/// A range around `values` with 5 % margins (a factor on log scales); a unit range when
/// there is nothing to show.
fn padded(values: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if !(lo.is_finite() && hi.is_finite()) {
        return if log { (0.1, 10.0) } else { (0.0, 1.0) };
    }
    if log {
        let (lo, hi) = if lo == hi {
            (lo / 2.0, hi * 2.0)
        } else {
            (lo, hi)
        };
        (lo / 1.25, hi * 1.25)
    } else {
        let span = if hi > lo {
            hi - lo
        } else {
            hi.abs().max(1e-300)
        };
        (lo - 0.05 * span, hi + 0.05 * span)
    }
}

/// The x axis of the per-condition charts.
struct XAxis {
    values: Vec<f64>,
    label: String,
    /// The axis column it replaces in series labels (e.g. `scale`), if any.
    replaces: Option<&'static str>,
}

/// True when a column holds more than one value.
fn varies<T: PartialEq>(v: &[T]) -> bool {
    v.iter().any(|x| *x != v[0])
}

fn x_axis(layout: &Layout, t: &SummaryTable) -> XAxis {
    let per_row = |value: &dyn Fn(&ConditionInfo) -> f64| -> Vec<f64> {
        t.rows.iter().map(|r| value(t.info(r))).collect()
    };
    if let Some(fx) = &layout.figure_x
        && let Some(m) = layout
            .condition_metrics
            .iter()
            .position(|&m| m == fx.metric)
    {
        return XAxis {
            values: per_row(&|info| info.metrics[m]),
            label: fx.label.into(),
            replaces: Some(fx.replaces),
        };
    }
    for (a, axis) in layout.axes.iter().enumerate() {
        if axis.kind != AxisKind::Number {
            continue;
        }
        let v = per_row(&|info| info.axes[a].number());
        if varies(&v) {
            let unit = if axis.unit.is_empty() {
                String::new()
            } else {
                format!(" [{}]", axis.unit)
            };
            return XAxis {
                values: v,
                label: format!("{}{unit}", axis.name),
                replaces: Some(axis.name),
            };
        }
    }
    XAxis {
        values: t.rows.iter().map(|r| r.condition as f64).collect(),
        label: "condition".into(),
        replaces: None,
    }
}

/// Label of a row's group: the values of the axes that vary, other than the x axis.
fn group_labels(layout: &Layout, t: &SummaryTable, x: &XAxis) -> Vec<String> {
    let mut parts: Vec<Vec<String>> = vec![Vec::new(); t.rows.len()];
    for (a, axis) in layout.axes.iter().enumerate() {
        if Some(axis.name) == x.replaces {
            continue;
        }
        let values: Vec<&AxisValue> = t.rows.iter().map(|r| &t.info(r).axes[a]).collect();
        if !varies(&values) {
            continue;
        }
        for (p, v) in parts.iter_mut().zip(values) {
            p.push(match (axis.kind, v) {
                (AxisKind::Number, v) => format!("{} {v}", axis.name),
                (AxisKind::Text, v) => v.to_string(),
            });
        }
    }
    parts.into_iter().map(|p| p.join(", ")).collect()
}

fn join_label(parts: &[&str]) -> String {
    parts
        .iter()
        .filter(|p| !p.is_empty())
        .copied()
        .collect::<Vec<_>>()
        .join(", ")
}

/// Short symbol of a parameter ("1/M" from "1/M, inverse vehicle mass").
fn symbol(description: &str) -> &str {
    description.split(',').next().unwrap_or(description).trim()
}

fn unit_suffix(unit: &str) -> String {
    if unit.is_empty() || unit == "1" {
        " [-]".into()
    } else {
        format!(" [{unit}]")
    }
}

/// Redraw the figures of the output directory `dir` from its summary and cycles into
/// `dir/figures/`, replacing the figures of its output set together (a user's own files
/// there stay). Returns the files written.
pub fn draw(dir: &Path) -> Result<Vec<PathBuf>, FigureError> {
    let summary = dir.join(files::SUMMARY);
    if !summary.is_file() {
        return Err(OutputError::format(
            &summary,
            "not found: `figures` needs the output directory of a run or of `summarize`",
        )
        .into());
    }
    let _lock = DirLock::acquire(dir)?;
    set::ensure_complete(dir)?;
    let cycles = dir.join(files::CYCLES);
    let pending = draw_staged(dir, &summary, cycles.exists().then_some(cycles.as_path()))?;
    let written = set::commit(dir, pending, &|path| {
        path.starts_with(&format!("{FIGURES}/"))
    })?;
    let _ = fs::remove_dir(dir.join(output::temporary_name(FIGURES)));
    Ok(written)
}

/// Draw every figure of the summary at `summary_path` (and the cycles at `cycles_path`)
/// into a staging directory inside `dir`. Returns the figures as files to be committed to
/// `dir/figures/` with the rest of the output set.
pub fn draw_staged(
    dir: &Path,
    summary_path: &Path,
    cycles_path: Option<&Path>,
) -> Result<Vec<PendingFile>, FigureError> {
    let footer = output::read_metadata(summary_path)?;
    let study_toml = footer
        .get(keys::STUDY)
        .ok_or_else(|| OutputError::format(summary_path, "no study in the footer"))?;
    let study = Study::from_toml(study_toml, &format!("{} (footer)", summary_path.display()))?;
    let layout = crate::model::layout_of(&study);
    let summary = output::read_summary(summary_path, &layout)?;
    let cycles = match cycles_path {
        // Only what the cycles figure draws (the file also holds x, f_prop and accel).
        Some(path) => Some(Table::read_columns(
            path,
            &["condition", "t", "v", "grade"],
        )?),
        None => None,
    };

    let staging = dir.join(output::temporary_name(FIGURES));
    let _ = fs::remove_dir_all(&staging);
    fs::create_dir_all(&staging).map_err(|e| OutputError::io(&staging, e))?;
    let names = draw_into(&staging, &layout, &summary, cycles.as_ref());
    let target = dir.join(FIGURES);
    // Each drawn figure is removed again if it is never committed.
    let names = names.inspect_err(|_| {
        let _ = fs::remove_dir_all(&staging);
    })?;
    Ok(names
        .into_iter()
        .map(|n| PendingFile::new(staging.join(&n), target.join(&n)))
        .collect())
}

fn draw_into(
    dir: &Path,
    layout: &Layout,
    t: &SummaryTable,
    cycles: Option<&Table>,
) -> Result<Vec<String>, FigureError> {
    let x = x_axis(layout, t);
    let groups = group_labels(layout, t, &x);
    // One job per parameter (four figures each) and one for the cycles, in parallel.
    let (per_parameter, cycle_figure) = rayon::join(
        || {
            layout
                .parameters
                .par_iter()
                .enumerate()
                .map(|p| draw_parameter(dir, layout, t, &x, &groups, p))
                .collect::<Result<Vec<_>, _>>()
        },
        || match (cycles, layout.axes.iter().position(|a| a.name == "scale")) {
            (Some(cy), Some(a)) => draw_cycles(dir, t, cy, a).map(Some),
            _ => Ok(None),
        },
    );
    let mut names: Vec<String> = per_parameter?.into_iter().flatten().collect();
    names.extend(cycle_figure?);
    Ok(names)
}

/// The four figures of parameter `p`.
fn draw_parameter(
    dir: &Path,
    layout: &Layout,
    t: &SummaryTable,
    x: &XAxis,
    groups: &[String],
    (pi, p): (usize, &crate::model::ParameterInfo),
) -> Result<Vec<String>, FigureError> {
    let estimator: Vec<String> = t
        .rows
        .iter()
        .map(|r| layout.estimators[r.estimator].to_string())
        .collect();
    // A measure (or its MCSE) of every row, NaN where undefined.
    let column =
        |value: &dyn Fn(&SummaryRow) -> f64| -> Vec<f64> { t.rows.iter().map(value).collect() };
    let measure = |m: Measure| (column(&|r| m.of(r).value), column(&|r| m.of(r).mcse));
    let bound = |b: usize, m: BoundMeasure| {
        let of = |r: &SummaryRow| r.bounds[b].as_ref().map(|s| m.of(s));
        (
            column(&|r| of(r).map_or(f64::NAN, |e| e.value)),
            column(&|r| of(r).map_or(f64::NAN, |e| e.mcse)),
        )
    };
    let many_estimators = layout.estimators.len() > 1;
    let mut names = Vec::new();
    let rows: Vec<usize> = (0..t.rows.len())
        .filter(|&i| t.rows[i].parameter == pi)
        .collect();
    let sym = symbol(p.description);
    let unit = unit_suffix(p.unit);
    // Series keys (estimator, group) in first-seen order.
    let mut keys_seen: Vec<(String, String)> = Vec::new();
    for &i in &rows {
        let k = (estimator[i].clone(), groups[i].clone());
        if !keys_seen.contains(&k) {
            keys_seen.push(k);
        }
    }
    let est_label = |e: &str| {
        if many_estimators {
            e.to_string()
        } else {
            String::new()
        }
    };

    // The points (x, y, error bar) of one estimator and group where y is finite.
    let points = |e: &String, g: &String, y: &[f64], err: Option<&[f64]>| -> Vec<(f64, f64, f64)> {
        rows.iter()
            .filter(|&&i| &estimator[i] == e && &groups[i] == g && y[i].is_finite())
            .map(|&i| (x.values[i], y[i], err.map_or(f64::NAN, |err| err[i])))
            .collect()
    };

    // (a) EmpSE with MCSE and every bound, against x.
    let (emp_se, emp_se_mcse) = &measure(Measure::EmpSe);
    let mut series = Vec::new();
    for (k, (e, g)) in keys_seen.iter().enumerate() {
        series.push(Series {
            label: join_label(&["EmpSE ± MCSE", &est_label(e), g]),
            color: color(k),
            points: points(e, g, emp_se, Some(emp_se_mcse)),
            markers: true,
        });
    }
    let mut c = keys_seen.len();
    for (bi, b) in layout.bounds.iter().enumerate() {
        let se = &bound(bi, BoundMeasure::Se).0;
        // A bound's value does not depend on the estimator: draw it once per group.
        let mut seen_groups: Vec<&String> = Vec::new();
        for (e, g) in &keys_seen {
            if seen_groups.contains(&g) {
                continue;
            }
            let points = points(e, g, se, None);
            if points.is_empty() {
                continue;
            }
            seen_groups.push(g);
            series.push(Series {
                label: join_label(&[b.name, g]),
                color: color(c),
                points,
                markers: false,
            });
            c += 1;
        }
    }
    let name = format!("se_{}.svg", p.name);
    chart(
        &dir.join(&name),
        &Axes {
            title: &format!("{sym}: empirical SE and bounds"),
            x_label: &x.label,
            y_label: &format!("standard error of {sym}{unit}"),
            log_y: true,
        },
        &series,
        &[],
    )?;
    names.push(name);

    // (b) bias ± MCSE.
    let (bias, bias_mcse) = &measure(Measure::Bias);
    let series: Vec<Series> = keys_seen
        .iter()
        .enumerate()
        .map(|(k, (e, g))| Series {
            label: join_label(&[&est_label(e), g, "bias ± MCSE"]),
            color: color(k),
            points: points(e, g, bias, Some(bias_mcse)),
            markers: true,
        })
        .collect();
    let name = format!("bias_{}.svg", p.name);
    chart(
        &dir.join(&name),
        &Axes {
            title: &format!("{sym}: bias of the estimates"),
            x_label: &x.label,
            y_label: &format!("bias of {sym}{unit}"),
            log_y: false,
        },
        &series,
        &[Reference {
            y: 0.0,
            label: "no bias".into(),
        }],
    )?;
    names.push(name);

    // (c) EmpSE / bound and (d) coverage, per bound × estimator × group.
    for (figure, which, log_y, reference, title, y_label) in [
        (
            "ratio",
            BoundMeasure::EmpOver,
            true,
            Reference {
                y: 1.0,
                label: "EmpSE = bound".into(),
            },
            format!("{sym}: EmpSE / bound"),
            "EmpSE / bound [-]".to_string(),
        ),
        (
            "coverage",
            BoundMeasure::Coverage,
            false,
            Reference {
                y: NOMINAL,
                label: "nominal 95 %".into(),
            },
            format!("{sym}: coverage of θ̂ ± 1.96·bound"),
            "coverage [-]".to_string(),
        ),
    ] {
        let mut series = Vec::new();
        let mut c = 0;
        for (bi, b) in layout.bounds.iter().enumerate() {
            let (value, mcse) = &bound(bi, which);
            for (e, g) in &keys_seen {
                let points = points(e, g, value, Some(mcse));
                if points.is_empty() {
                    continue;
                }
                series.push(Series {
                    label: join_label(&[b.name, &est_label(e), g]),
                    color: color(c),
                    points,
                    markers: true,
                });
                c += 1;
            }
        }
        let name = format!("{figure}_{}.svg", p.name);
        chart(
            &dir.join(&name),
            &Axes {
                title: &title,
                x_label: &x.label,
                y_label: &y_label,
                log_y,
            },
            &series,
            &[reference],
        )?;
        names.push(name);
        output::failpoint("figure-drawn");
    }

    Ok(names)
}

/// Speed and grade against time, one line per distinct terrain scale.
fn draw_cycles(
    dir: &Path,
    summary: &SummaryTable,
    cycles: &Table,
    scale_axis: usize,
) -> Result<String, FigureError> {
    let name = "cycles.svg".to_string();
    let path = dir.join(&name);
    // First condition of each distinct scale, in study order.
    let mut picks: Vec<(f64, f64)> = Vec::new(); // (scale, condition)
    for (c, info) in summary.infos.iter().enumerate() {
        let Some(info) = info else { continue };
        let s = info.axes[scale_axis].number();
        if !picks.iter().any(|p| p.0 == s) {
            picks.push((s, c as f64));
        }
    }
    let cols = ["condition", "t", "v", "grade"].map(|n| cycles.number(n));
    let [Some(cc), Some(tt), Some(vv), Some(gg)] = cols else {
        return Err(draw_error(
            &path,
            "cycles.parquet lacks condition, t, v or grade",
        ));
    };
    let root = SVGBackend::new(&path, (SIZE.0, SIZE.1 + 200)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| draw_error(&path, e))?;
    let root = root
        .titled("Drive cycles (noise-free)", ("sans-serif", 24))
        .map_err(|e| draw_error(&path, e))?;
    let (top, bottom) = root.split_vertically((SIZE.1 + 200) / 2 - 20);
    let t_max = tt.iter().copied().fold(0.0, f64::max);
    // The rows of each picked condition (one pass over the table), decimated.
    let mut samples: Vec<Vec<usize>> = vec![Vec::new(); picks.len()];
    for (i, c) in cc.iter().enumerate() {
        if let Some(k) = picks.iter().position(|p| p.1 == *c) {
            samples[k].push(i);
        }
    }
    for idx in &mut samples {
        let stride = idx.len().div_ceil(MAX_CYCLE_POINTS).max(1);
        *idx = idx.iter().copied().step_by(stride).collect();
    }
    for (area, values, y_label) in [(&top, vv, "speed V [m/s]"), (&bottom, gg, "grade θ [rad]")] {
        let lines: Vec<(f64, Vec<(f64, f64)>)> = picks
            .iter()
            .zip(&samples)
            .map(|(&(s, _), idx)| (s, idx.iter().map(|&i| (tt[i], values[i])).collect()))
            .collect();
        let (lo, hi) = padded(lines.iter().flat_map(|l| l.1.iter().map(|p| p.1)), false);
        let mut c = ChartBuilder::on(area)
            .margin(10)
            .margin_right(LEGEND_WIDTH)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..t_max, lo..hi)
            .map_err(|e| draw_error(&path, e))?;
        c.configure_mesh()
            .x_desc("time t [s]")
            .y_desc(y_label)
            .axis_desc_style(("sans-serif", 17))
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(|e| draw_error(&path, e))?;
        let n = lines.len();
        for (k, (_, pts)) in lines.into_iter().enumerate() {
            c.draw_series(LineSeries::new(pts, ramp(k, n).stroke_width(1)))
                .map_err(|e| draw_error(&path, e))?;
        }
    }
    let entries: Vec<(String, Key)> = picks
        .iter()
        .enumerate()
        .map(|(k, &(s, _))| {
            (
                format!("terrain scale {s}"),
                Key::Line(ramp(k, picks.len())),
            )
        })
        .collect();
    legend(&root, &entries, 60, &path)?;
    root.present().map_err(|e| draw_error(&path, e))?;
    Ok(name)
}
