//! The drive-cycle figure: speed and grade against time, from cycles.parquet.
//!
//! The table is read in batches, twice (its time range, then the samples), and each drawn
//! cycle is kept as at most [`MAX_CYCLE_POINTS`] time bins: memory and the figure's size
//! are bounded by [`MAX_CYCLE_LINES`] × [`MAX_CYCLE_POINTS`], whatever the number of
//! conditions or samples. The samples the row selection (`min_speed`, `exclude_braking`)
//! leaves out are drawn over each line in grey.

use std::path::Path;

use arrow::array::{Array, AsArray, RecordBatch};
use arrow::datatypes::{DataType, Float64Type, Int32Type};
use plotters::prelude::*;

use super::axis::{Ticked, linear_ticks, padded, shared_exponent, with_exponent};
use super::chart::{Key, legend, ramp};
use super::{FigureError, LEGEND_WIDTH, MAX_CYCLE_POINTS, SIZE, draw_error};
use crate::output::{self, OutputError, SummaryTable};

/// Most cycles drawn: with more terrain scales, this many evenly spread over them (the
/// first and the last included).
pub(super) const MAX_CYCLE_LINES: usize = 12;

/// The grey of the samples left out of the regression.
const LEFT_OUT: RGBColor = RGBColor(150, 150, 150);

/// One sample: (t, v, grade).
type Sample = [f64; 3];

/// One time bin of a drawn cycle: its first sample, and its first sample left out of the
/// regression.
#[derive(Debug, Clone, Copy, Default)]
struct Bin {
    first: Option<Sample>,
    left_out: Option<Sample>,
}

/// Which rows of cycles.parquet belong to the drawn cycles: the first block of each drawn
/// scale (a study with two acceleration sources has a block per source; their cycles are
/// the same). A table written before cycles were stored once has a `condition` column in
/// place of `scale` and `acceleration`: the first condition of each scale is drawn.
struct Picks {
    /// The drawn scales, in study order.
    scales: Vec<f64>,
    /// Per drawn scale: the condition of its first block (old tables).
    conditions: Vec<f64>,
    /// Per drawn scale: the acceleration of its first block, once seen.
    sources: Vec<Option<String>>,
}

impl Picks {
    /// The index of the drawn cycle each row of `batch` belongs to (`None`: not drawn).
    fn rows(
        &mut self,
        batch: &RecordBatch,
        path: &Path,
    ) -> Result<Vec<Option<usize>>, FigureError> {
        let n = batch.num_rows();
        if let (Some(scale), Some(source)) = (
            batch.column_by_name("scale"),
            batch.column_by_name("acceleration"),
        ) {
            let (scale, source) = (
                scale.as_primitive_opt::<Float64Type>(),
                source.as_string_opt::<i32>(),
            );
            let (Some(scale), Some(source)) = (scale, source) else {
                return Err(draw_error(
                    path,
                    "`scale` is not a double or `acceleration` not a string",
                ));
            };
            return Ok((0..n)
                .map(|i| {
                    let k = self.scales.iter().position(|&s| s == scale.value(i))?;
                    let first = self.sources[k].get_or_insert_with(|| source.value(i).to_string());
                    (first == source.value(i)).then_some(k)
                })
                .collect());
        }
        let Some(condition) = batch
            .column_by_name("condition")
            .and_then(|c| c.as_primitive_opt::<Int32Type>())
        else {
            return Err(draw_error(
                path,
                "cycles.parquet has neither `scale` and `acceleration` nor `condition`",
            ));
        };
        Ok((0..n)
            .map(|i| {
                let c = f64::from(condition.value(i));
                self.conditions.iter().position(|&p| p == c)
            })
            .collect())
    }
}

/// The named double column of `batch`.
fn doubles<'a>(
    batch: &'a RecordBatch,
    name: &str,
    path: &Path,
) -> Result<&'a arrow::array::Float64Array, FigureError> {
    batch
        .column_by_name(name)
        .filter(|c| c.data_type() == &DataType::Float64)
        .map(|c| c.as_primitive::<Float64Type>())
        .ok_or_else(|| {
            draw_error(
                path,
                format!("cycles.parquet lacks the double column `{name}`"),
            )
        })
}

/// Call `each` with every batch of `path`'s `columns` (and the key columns).
fn scan(
    path: &Path,
    columns: &[&str],
    mut each: impl FnMut(&RecordBatch) -> Result<(), FigureError>,
) -> Result<(), FigureError> {
    let keys = ["scale", "acceleration", "condition"];
    let all: Vec<&str> = keys.iter().chain(columns).copied().collect();
    for batch in output::open_projected_reader(path, output::READ_ROWS, Some(&all))? {
        each(&batch.map_err(|e| OutputError::arrow(path, e))?)?;
    }
    Ok(())
}

/// The drawn scales: every distinct scale of the summary in study order, or at most
/// [`MAX_CYCLE_LINES`] of them evenly spread; and the first condition of each.
fn drawn_scales(summary: &SummaryTable, scale_axis: usize) -> (Vec<f64>, Vec<f64>) {
    let mut all: Vec<(f64, f64)> = Vec::new(); // (scale, first condition)
    for (c, info) in summary.infos.iter().enumerate() {
        let Some(info) = info else { continue };
        let s = info.axes[scale_axis].number();
        if !all.iter().any(|p| p.0 == s) {
            all.push((s, c as f64));
        }
    }
    let n = all.len();
    let kept: Vec<(f64, f64)> = if n <= MAX_CYCLE_LINES {
        all
    } else {
        (0..MAX_CYCLE_LINES)
            .map(|k| all[(k * (n - 1)).div_ceil(MAX_CYCLE_LINES - 1)])
            .collect()
    };
    kept.into_iter().unzip()
}

/// Speed and grade against time, one line per distinct terrain scale (at most
/// [`MAX_CYCLE_LINES`]), with the samples the regression leaves out in grey.
pub(super) fn draw_cycles(
    dir: &Path,
    summary: &SummaryTable,
    cycles: &Path,
    scale_axis: usize,
) -> Result<String, FigureError> {
    let name = "cycles.svg".to_string();
    let path = dir.join(&name);
    let (scales, conditions) = drawn_scales(summary, scale_axis);
    let mut picks = Picks {
        sources: vec![None; scales.len()],
        scales,
        conditions,
    };
    // Pass one: the time range of the drawn cycles.
    let (mut t_min, mut t_max) = (f64::INFINITY, f64::NEG_INFINITY);
    scan(cycles, &["t"], |batch| {
        let t = doubles(batch, "t", &path)?;
        for (i, k) in picks.rows(batch, &path)?.into_iter().enumerate() {
            if k.is_some() {
                t_min = t_min.min(t.value(i));
                t_max = t_max.max(t.value(i));
            }
        }
        Ok(())
    })?;
    if t_min >= t_max {
        return Err(draw_error(
            &path,
            "cycles.parquet holds no cycle of the summary's scales",
        ));
    }
    // Pass two: each drawn cycle's first sample, and first left out, per time bin.
    let width = (t_max - t_min) / MAX_CYCLE_POINTS as f64;
    let mut bins = vec![vec![Bin::default(); MAX_CYCLE_POINTS]; picks.scales.len()];
    let mut any_left_out = false;
    scan(cycles, &["t", "v", "grade", "used"], |batch| {
        let (t, v, g) = (
            doubles(batch, "t", &path)?,
            doubles(batch, "v", &path)?,
            doubles(batch, "grade", &path)?,
        );
        let used = batch
            .column_by_name("used")
            .and_then(|u| u.as_boolean_opt());
        for (i, k) in picks.rows(batch, &path)?.into_iter().enumerate() {
            let Some(k) = k else { continue };
            let sample = [t.value(i), v.value(i), g.value(i)];
            let b = (((sample[0] - t_min) / width) as usize).min(MAX_CYCLE_POINTS - 1);
            let bin = &mut bins[k][b];
            bin.first.get_or_insert(sample);
            if used.is_some_and(|u| !u.is_null(i) && !u.value(i)) {
                bin.left_out.get_or_insert(sample);
                any_left_out = true;
            }
        }
        Ok(())
    })?;

    let root = SVGBackend::new(&path, (SIZE.0, SIZE.1 + 200)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| draw_error(&path, e))?;
    let root = root
        .titled("Drive cycles (noise-free)", ("sans-serif", 24))
        .map_err(|e| draw_error(&path, e))?;
    let (top, bottom) = root.split_vertically((SIZE.1 + 200) / 2 - 20);
    let n = bins.len();
    for (area, y, y_label) in [(&top, 1, "speed V [m/s]"), (&bottom, 2, "grade θ [rad]")] {
        let (lo, hi) = padded(
            bins.iter().flatten().filter_map(|b| b.first).map(|s| s[y]),
            false,
        );
        // The axes of the other figures: plain tick labels with the power of ten once in
        // the description, a light line between labels.
        let (x_exp, y_exp) = (shared_exponent(t_min, t_max), shared_exponent(lo, hi));
        let (x_ticks, y_ticks) = (
            linear_ticks(t_min, t_max, x_exp),
            linear_ticks(lo, hi, y_exp),
        );
        let (x_desc, y_desc) = (
            with_exponent("time t [s]", x_exp),
            with_exponent(y_label, y_exp),
        );
        let mut c = ChartBuilder::on(area)
            .margin(10)
            .margin_right(LEGEND_WIDTH)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(
                Ticked::new(t_min..t_max, &x_ticks),
                Ticked::new(lo..hi, &y_ticks),
            )
            .map_err(|e| draw_error(&path, e))?;
        c.configure_mesh()
            .x_desc(x_desc.as_str())
            .y_desc(y_desc.as_str())
            .axis_desc_style(("sans-serif", 17))
            .label_style(("sans-serif", 14))
            .light_line_style(BLACK.mix(0.06))
            .x_label_formatter(&|v| x_ticks.label(*v))
            .y_label_formatter(&|v| y_ticks.label(*v))
            .draw()
            .map_err(|e| draw_error(&path, e))?;
        for (k, cycle) in bins.iter().enumerate() {
            let line = cycle.iter().filter_map(|b| b.first).map(|s| (s[0], s[y]));
            c.draw_series(LineSeries::new(line, ramp(k, n).stroke_width(1)))
                .map_err(|e| draw_error(&path, e))?;
            // Each run of bins with a left-out sample as one grey stroke over the line.
            for run in cycle.chunk_by(|a, b| a.left_out.is_some() == b.left_out.is_some()) {
                let points: Vec<(f64, f64)> = run
                    .iter()
                    .filter_map(|b| b.left_out)
                    .map(|s| (s[0], s[y]))
                    .collect();
                match points.len() {
                    0 => {}
                    1 => {
                        c.draw_series([Circle::new(points[0], 2, LEFT_OUT.filled())])
                            .map_err(|e| draw_error(&path, e))?;
                    }
                    _ => {
                        c.draw_series(LineSeries::new(points, LEFT_OUT.stroke_width(2)))
                            .map_err(|e| draw_error(&path, e))?;
                    }
                }
            }
        }
    }
    let mut entries: Vec<(String, Key)> = picks
        .scales
        .iter()
        .enumerate()
        .map(|(k, s)| (format!("terrain scale {s}"), Key::Line(ramp(k, n))))
        .collect();
    if any_left_out {
        entries.push((
            "left out of the regression".to_string(),
            Key::Line(LEFT_OUT),
        ));
    }
    legend(&root, &entries, 60, &path)?;
    root.present().map_err(|e| draw_error(&path, e))?;
    Ok(name)
}
