//! A fleet's summary across its vehicles (docs/model.md#fleet): per estimator, parameter and
//! level of the other axes, each vehicle's relative EmpSE and relative bias (and the
//! campaign's pass probability), for the figures and the report to show as distributions
//! rather than one series per vehicle.

use super::summary::{Measure, SummaryRow};
use crate::model::{AxisValue, ConditionInfo, Layout};

pub use crate::model::fleet::VEHICLE_AXIS;

/// Whether `layout` is a fleet's: its first axis is the vehicle.
pub fn is_fleet(layout: &Layout) -> bool {
    layout.axes.first().is_some_and(|a| a.name == VEHICLE_AXIS)
}

/// The vehicles of one estimator, parameter and level of the other axes.
#[derive(Debug, Clone, PartialEq)]
pub struct FleetGroup {
    /// Index of the estimator.
    pub estimator: usize,
    /// Index of the parameter.
    pub parameter: usize,
    /// The other axes' values, e.g. `runs 8` (empty when no other axis varies).
    pub label: String,
    /// Per vehicle, EmpSE / |θ| (NaN where undefined).
    pub rel_emp_se: Vec<f64>,
    /// Per vehicle, bias / |θ|.
    pub rel_bias: Vec<f64>,
    /// Per vehicle, the campaign's pass probability (empty without a campaign).
    pub pass_probability: Vec<f64>,
}

/// The groups of a fleet's summary `rows` (conditions `info(row)`), in first-seen order.
pub fn fleet_groups<'a>(
    layout: &Layout,
    rows: &[SummaryRow],
    info: impl Fn(&SummaryRow) -> &'a ConditionInfo,
) -> Vec<FleetGroup> {
    // The other axes that take more than one value for a vehicle (not those that differ
    // only from vehicle to vehicle, as its rolling_speed_coefficient B/A does).
    let first = rows.first().map(|r| &info(r).axes[0]);
    let own: Vec<&SummaryRow> = rows
        .iter()
        .filter(|r| Some(&info(r).axes[0]) == first)
        .collect();
    // Each vehicle's conditions are a block of the same size in the same order; an axis
    // labels a group when it takes the same value at the same place of every block (the
    // number of runs does, a coast-down's length does not).
    let per = {
        let mut conditions: Vec<usize> = own.iter().map(|r| r.condition).collect();
        conditions.dedup();
        conditions.len().max(1)
    };
    let at = |a: usize, k: usize| {
        own.iter()
            .find(|r| r.condition % per == k)
            .map(|r| &info(r).axes[a])
    };
    let varying: Vec<usize> = (1..layout.axes.len())
        .filter(|&a| {
            let mut values = own.iter().map(|r| &info(r).axes[a]);
            let first = values.next();
            values.any(|v| Some(v) != first)
                && rows
                    .iter()
                    .all(|r| at(a, r.condition % per) == Some(&info(r).axes[a]))
        })
        .collect();
    let mut groups: Vec<FleetGroup> = Vec::new();
    for r in rows {
        let axes = &info(r).axes;
        let label = varying
            .iter()
            .map(|&a| {
                let value = match &axes[a] {
                    AxisValue::Number(x) => format!("{x}"),
                    AxisValue::Text(t) => t.clone(),
                };
                format!("{} {value}", layout.axes[a].name)
            })
            .collect::<Vec<_>>()
            .join(", ");
        let i = match groups.iter().position(|g| {
            g.estimator == r.estimator && g.parameter == r.parameter && g.label == label
        }) {
            Some(i) => i,
            None => {
                groups.push(FleetGroup {
                    estimator: r.estimator,
                    parameter: r.parameter,
                    label,
                    rel_emp_se: Vec::new(),
                    rel_bias: Vec::new(),
                    pass_probability: Vec::new(),
                });
                groups.len() - 1
            }
        };
        let g = &mut groups[i];
        let t = r.truth.abs();
        g.rel_emp_se.push(r[Measure::EmpSe].value / t);
        g.rel_bias.push(r[Measure::Bias].value / t);
        if let Some(p) = r.pass_probability {
            g.pass_probability.push(p.value);
        }
    }
    groups
}

/// The `q` quantile (0 … 1) of the finite values of `values` by linear interpolation
/// between order statistics (NaN when none is finite).
pub fn quantile(values: &[f64], q: f64) -> f64 {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let h = q * (v.len() - 1) as f64;
    let (lo, hi) = (h.floor() as usize, h.ceil() as usize);
    v[lo] + (h - lo as f64) * (v[hi] - v[lo])
}
