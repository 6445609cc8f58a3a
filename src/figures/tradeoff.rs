//! The terrain-versus-sensor trade-off: where a study varies both the terrain scale and the
//! speed noise, per parameter and estimator, iso-lines of the relative RMSE in the
//! (scale, σ_v) plane — which speed-sensor noise each terrain allows for a given precision.

use crate::stats::summary::Measure;
use std::path::Path;

use super::FigureError;
use super::chart::{Axes, Series, chart_with_note, ramp};
use crate::estimate::estimators::{Estimator, Ols};
use crate::model::Layout;
use crate::output::SummaryTable;

/// Iso-lines drawn per figure.
const LEVELS: usize = 5;

/// Draw `tradeoff_<parameter>_<estimator>.svg` into `dir` when `scale` and `velocity_sd`
/// both vary; returns the file names. Where other axes vary too (e.g. `duration`), the
/// iso-lines are those at each other axis's last value in study order, named in the figure.
pub(super) fn draw_tradeoffs(
    dir: &Path,
    layout: &Layout,
    t: &SummaryTable,
) -> Result<Vec<String>, FigureError> {
    let axis = |name: &str| layout.axes.iter().position(|a| a.name == name);
    let (Some(sa), Some(va)) = (axis("scale"), axis("velocity_sd")) else {
        return Ok(Vec::new());
    };
    let value = |r: &crate::stats::summary::SummaryRow, a: usize| t.info(r).axes[a].number();
    // Every other axis held at its last value (a plane of the grid, not a mix of planes).
    let held: Vec<(usize, &crate::model::AxisValue)> = (0..layout.axes.len())
        .filter(|&a| a != sa && a != va)
        .filter_map(|a| {
            let first = &t.info(t.rows.first()?).axes[a];
            let last = &t.info(t.rows.last()?).axes[a];
            t.rows
                .iter()
                .any(|r| &t.info(r).axes[a] != first)
                .then_some((a, last))
        })
        .collect();
    let in_plane = |r: &&crate::stats::summary::SummaryRow| {
        held.iter().all(|(a, v)| &t.info(r).axes[*a] == *v)
    };
    let note = (!held.is_empty()).then(|| {
        let at: Vec<String> = held
            .iter()
            .map(|(a, v)| format!("{} = {v}", layout.axes[*a].name))
            .collect();
        format!(
            "At {} (the last value of each other axis); every condition is in summary.parquet.",
            at.join(", ")
        )
    });
    let note = note.as_deref();
    let mut scales: Vec<f64> = t.rows.iter().map(|r| value(r, sa)).collect();
    let mut sds: Vec<f64> = t.rows.iter().map(|r| value(r, va)).collect();
    for v in [&mut scales, &mut sds] {
        v.sort_by(f64::total_cmp);
        v.dedup();
    }
    if scales.len() < 2 || sds.len() < 2 {
        return Ok(Vec::new());
    }
    let mut names = Vec::new();
    for (p, param) in layout.parameters.iter().enumerate() {
        // Per estimator: its iso-lines, and its mean relative RMSE (to pick the best).
        let mut per_estimator: Vec<(usize, f64, Vec<Series>)> = Vec::new();
        for (e, est) in layout.estimators.iter().enumerate() {
            // rel_rmse[scale][sd]
            let mut grid = vec![vec![f64::NAN; sds.len()]; scales.len()];
            for r in t
                .rows
                .iter()
                .filter(|r| r.parameter == p && r.estimator == e)
                .filter(in_plane)
            {
                let i = scales.iter().position(|&s| s == value(r, sa)).unwrap_or(0);
                let j = sds.iter().position(|&s| s == value(r, va)).unwrap_or(0);
                grid[i][j] = r[Measure::Rmse].value / r.truth.abs();
            }
            let mut all: Vec<f64> = grid
                .iter()
                .flatten()
                .copied()
                .filter(|v| v.is_finite())
                .collect();
            if all.len() < 4 {
                continue;
            }
            let mean = all.iter().sum::<f64>() / all.len() as f64;
            all.sort_by(f64::total_cmp);
            let series: Vec<Series> = (0..LEVELS)
                .map(|k| {
                    let level = round2(all[(all.len() - 1) * (2 * k + 1) / (2 * LEVELS)]);
                    Series {
                        label: format!("{est}: RMSE = {:.3} % of the truth", 100.0 * level),
                        color: ramp(k, LEVELS),
                        points: scales
                            .iter()
                            .zip(&grid)
                            .filter_map(|(&s, row)| {
                                crossing(&sds, row, level).map(|sd| (s, sd, f64::NAN))
                            })
                            .collect(),
                        markers: false,
                    }
                })
                .filter(|s| s.points.len() >= 2)
                .collect();
            if series.is_empty() {
                continue;
            }
            let name = format!("tradeoff_{}_{}.svg", param.name, est);
            draw(
                dir,
                &name,
                &format!("{} ({est}): equal relative RMSE", param.name),
                &series,
                note,
            )?;
            names.push(name);
            per_estimator.push((e, mean, series));
        }
        // The thesis's question in one picture: OLS's iso-lines (solid ramp) beside the best
        // estimator's (the lowest mean relative RMSE; drawn with markers).
        let ols = per_estimator
            .iter()
            .find(|(e, _, _)| layout.estimators[*e] == Ols.name());
        let best = per_estimator
            .iter()
            .filter(|(e, _, _)| layout.estimators[*e] != Ols.name())
            .min_by(|a, b| a.1.total_cmp(&b.1));
        if let (Some(ols), Some(best)) = (ols, best) {
            let mut series: Vec<Series> = ols.2.iter().map(Series::clone).collect();
            series.extend(best.2.iter().map(|s| Series {
                markers: true,
                ..s.clone()
            }));
            let name = format!("tradeoff_{}.svg", param.name);
            let title = format!(
                "{}: equal relative RMSE, ols (lines) and {} (points)",
                param.name, layout.estimators[best.0]
            );
            draw(dir, &name, &title, &series, note)?;
            names.push(name);
        }
    }
    Ok(names)
}

fn draw(
    dir: &Path,
    name: &str,
    title: &str,
    series: &[Series],
    note: Option<&str>,
) -> Result<(), FigureError> {
    chart_with_note(
        &dir.join(name),
        &Axes {
            title,
            x_label: "terrain scale",
            y_label: "speed noise σ_v [m/s]",
            log_y: false,
        },
        series,
        &[],
        note,
    )
}

/// `v` to two significant digits.
fn round2(v: f64) -> f64 {
    let e = v.abs().log10().floor() - 1.0;
    let f = 10f64.powf(e);
    (v / f).round() * f
}

/// The σ_v at which `row` (the measure at each of `sds`, ascending) reaches `level`, by
/// linear interpolation between the first pair of neighbours that brackets it.
fn crossing(sds: &[f64], row: &[f64], level: f64) -> Option<f64> {
    sds.windows(2).zip(row.windows(2)).find_map(|(s, m)| {
        let (lo, hi) = (m[0].min(m[1]), m[0].max(m[1]));
        (lo <= level && level <= hi && m[0] != m[1])
            .then(|| s[0] + (level - m[0]) / (m[1] - m[0]) * (s[1] - s[0]))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crossings_interpolate_between_bracketing_levels() {
        let sds = [0.5, 1.0, 2.0];
        let row = [0.01, 0.02, 0.04];
        assert_eq!(crossing(&sds, &row, 0.015), Some(0.75));
        assert_eq!(crossing(&sds, &row, 0.03), Some(1.5));
        assert_eq!(crossing(&sds, &row, 0.05), None);
        assert_eq!(round2(0.012345), 0.012);
    }
}
