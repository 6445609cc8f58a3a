//! The drive-cycle figure: speed and grade against time, from cycles.parquet.

use std::collections::BTreeMap;
use std::path::Path;

use arrow::array::AsArray;
use arrow::datatypes::{DataType, Float64Type, Int32Type};
use plotters::prelude::*;

use super::chart::{Key, legend, padded, ramp};
use super::{FigureError, LEGEND_WIDTH, MAX_CYCLE_POINTS, SIZE, draw_error};
use crate::output::{self, OutputError, SummaryTable};

/// The numeric columns of a table read whole, as f64 (null → NaN): the drive cycles.
#[derive(Debug, Default)]
pub(super) struct Table {
    pub(super) numbers: BTreeMap<String, Vec<f64>>,
}

impl Table {
    /// Read the named columns (doubles or int32).
    pub(super) fn read_columns(path: &Path, columns: &[&str]) -> Result<Table, OutputError> {
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

/// Speed and grade against time, one line per distinct terrain scale.
pub(super) fn draw_cycles(
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
