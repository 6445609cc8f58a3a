//! The figures of a fleet (docs/model.md#fleet): across the vehicles, not one series per
//! vehicle. Per parameter p, `fleet_<p>.svg` sorts the vehicles' relative EmpSE (EmpSE/|θ|)
//! and plots it against the share of vehicles at or below it (a quantile plot: the median
//! vehicle at 0.5), one line per estimator and level of the other axes; `fleet_bias_<p>.svg`
//! likewise the relative bias; with a campaign, `fleet_pass_probability.svg` the vehicles'
//! pass probabilities per number of runs.

use std::path::Path;

use super::FigureError;
use super::chart::{Axes, Reference, Series, chart, color};
use crate::model::Layout;
use crate::output::SummaryTable;
use crate::stats::fleet::{FleetGroup, fleet_groups};

/// Every figure a fleet's summary may have.
pub(super) fn possible_names(layout: &Layout) -> Vec<String> {
    let mut names: Vec<String> = layout
        .parameters
        .iter()
        .flat_map(|p| {
            [
                format!("fleet_{}.svg", p.name),
                format!("fleet_bias_{}.svg", p.name),
            ]
        })
        .collect();
    names.push(PASS.to_string());
    names
}

/// The pass probability's figure.
const PASS: &str = "fleet_pass_probability.svg";

/// `values` sorted, against the share of vehicles at or below each: (k + ½)/n.
fn quantile_points(values: &[f64]) -> Vec<(f64, f64, f64)> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    let n = v.len() as f64;
    v.iter()
        .enumerate()
        .map(|(k, &y)| ((k as f64 + 0.5) / n, y, f64::NAN))
        .collect()
}

/// A series of `group` from `values`, its label the estimator and the other axes.
fn series(layout: &Layout, i: usize, group: &FleetGroup, values: &[f64], many: bool) -> Series {
    let mut label = layout.estimators[group.estimator].to_string();
    if !group.label.is_empty() {
        label = match many {
            true => format!("{label}, {}", group.label),
            false => group.label.clone(),
        };
    }
    Series {
        label,
        color: color(i),
        points: quantile_points(values),
        markers: false,
    }
}

/// Draw the fleet's figures into `dir`; returns their names.
pub(super) fn draw_fleet(
    dir: &Path,
    layout: &Layout,
    t: &SummaryTable,
) -> Result<Vec<String>, FigureError> {
    let groups = fleet_groups(layout, &t.rows, |r| t.info(r));
    let vehicles = groups.first().map_or(0, |g| g.rel_emp_se.len());
    let many = layout.estimators.len() > 1;
    let x_label = format!("share of the {vehicles} vehicles at or below");
    let mut names = Vec::new();
    for (pi, p) in layout.parameters.iter().enumerate() {
        let mine: Vec<&FleetGroup> = groups.iter().filter(|g| g.parameter == pi).collect();
        let of = |pick: &dyn Fn(&FleetGroup) -> &Vec<f64>| -> Vec<Series> {
            mine.iter()
                .enumerate()
                .map(|(i, g)| series(layout, i, g, pick(g), many))
                .collect()
        };
        let name = format!("fleet_{}.svg", p.name);
        chart(
            &dir.join(&name),
            &Axes {
                title: &format!("{}: relative EmpSE across the fleet", p.name),
                x_label: &x_label,
                y_label: &format!("EmpSE / |{}|", p.name),
                log_y: true,
            },
            &of(&|g| &g.rel_emp_se),
            &[],
        )?;
        names.push(name);
        let name = format!("fleet_bias_{}.svg", p.name);
        chart(
            &dir.join(&name),
            &Axes {
                title: &format!("{}: relative bias across the fleet", p.name),
                x_label: &x_label,
                y_label: &format!("bias / |{}|", p.name),
                log_y: false,
            },
            &of(&|g| &g.rel_bias),
            &[Reference {
                y: 0.0,
                label: "no bias".into(),
            }],
        )?;
        names.push(name);
    }
    // The pass probability is the condition's: one estimator's first parameter's rows.
    let pass: Vec<&FleetGroup> = groups
        .iter()
        .filter(|g| g.estimator == 0 && g.parameter == 0 && !g.pass_probability.is_empty())
        .collect();
    if !pass.is_empty() {
        let series: Vec<Series> = pass
            .iter()
            .enumerate()
            .map(|(i, g)| {
                let mut s = series(layout, i, g, &g.pass_probability, false);
                if g.label.is_empty() {
                    s.label = "pass probability".into();
                }
                s
            })
            .collect();
        chart(
            &dir.join(PASS),
            &Axes {
                title: "the campaign's pass probability across the fleet",
                x_label: &x_label,
                y_label: "pass probability",
                log_y: false,
            },
            &series,
            &[],
        )?;
        names.push(PASS.to_string());
    }
    Ok(names)
}
