//! The four figures of each parameter: SE and bounds, bias, EmpSE / bound and coverage,
//! against the terrain metric (or whichever condition axis varies). The SE, bias and
//! EmpSE / bound figures also draw the control-variate estimates where they apply
//! (docs/model.md#control-variates, docs/model.md#spread-control-variates).

use std::path::Path;

use super::chart::{Axes, Reference, Series, chart_with_note, color};
use super::{FigureError, NOMINAL};
use crate::model::{AxisKind, AxisValue, ConditionInfo, Layout};
use crate::output::{self, SummaryTable};
use crate::stats::columns::{BoundMeasure, Measure};
use crate::stats::summary::SummaryRow;

/// The x axis of the per-condition charts.
pub(super) struct XAxis {
    pub(super) values: Vec<f64>,
    pub(super) label: String,
    /// The axis column it replaces in series labels (e.g. `scale`), if any.
    pub(super) replaces: Option<&'static str>,
}

/// True when a column holds more than one value.
pub(super) fn varies<T: PartialEq>(v: &[T]) -> bool {
    v.iter().any(|x| *x != v[0])
}

pub(super) fn x_axis(layout: &Layout, t: &SummaryTable) -> XAxis {
    let per_row = |value: &dyn Fn(&ConditionInfo) -> f64| -> Vec<f64> {
        t.rows.iter().map(|r| value(t.info(r))).collect()
    };
    // The model's preferred metric stands for its axis where that axis varies (the
    // thesis's ς for the scale) and is defined.
    if let Some(fx) = &layout.figure_x
        && let Some(m) = layout
            .condition_metrics
            .iter()
            .position(|&m| m == fx.metric)
        && let Some(a) = layout.axes.iter().position(|axis| axis.name == fx.replaces)
        && varies(
            &t.rows
                .iter()
                .map(|r| &t.info(r).axes[a])
                .collect::<Vec<_>>(),
        )
    {
        let values = per_row(&|info| info.metrics[m]);
        if values.iter().all(|v| v.is_finite()) {
            return XAxis {
                values,
                label: fx.label.into(),
                replaces: Some(fx.replaces),
            };
        }
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
pub(super) fn group_labels(layout: &Layout, t: &SummaryTable, x: &XAxis) -> Vec<String> {
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

/// Most series of one figure: as many as the palette has distinct colours (each is a legend
/// entry of 20 px; these leave room for a note under the legend).
const MAX_SERIES: usize = 16;

/// Which rows a figure of `per_group` series per group draws, and a note saying what it
/// leaves out. Every row while all groups fit in [`MAX_SERIES`] series; beyond, the groups at
/// the first, middle and last value of each axis other than x, then its first and last,
/// then its last, until they fit.
pub(super) fn shown_rows(
    layout: &Layout,
    t: &SummaryTable,
    x: &XAxis,
    per_group: usize,
) -> (Vec<bool>, Option<String>) {
    let max_groups = (MAX_SERIES / per_group.max(1)).max(1);
    // The values of each other axis that varies, in study order.
    let mut levels: Vec<(usize, Vec<&AxisValue>)> = Vec::new();
    for (a, axis) in layout.axes.iter().enumerate() {
        if Some(axis.name) == x.replaces {
            continue;
        }
        let mut values: Vec<&AxisValue> = Vec::new();
        for r in &t.rows {
            let v = &t.info(r).axes[a];
            if !values.contains(&v) {
                values.push(v);
            }
        }
        if values.len() > 1 {
            levels.push((a, values));
        }
    }
    let total: usize = levels.iter().map(|l| l.1.len()).product();
    if total <= max_groups {
        return (vec![true; t.rows.len()], None);
    }
    let mut kept: Vec<Vec<&AxisValue>> = levels.iter().map(|l| l.1.clone()).collect();
    while kept.iter().map(Vec::len).product::<usize>() > max_groups {
        let Some(i) = (0..kept.len()).max_by_key(|&i| kept[i].len()) else {
            break;
        };
        let k = &kept[i];
        let n = k.len();
        kept[i] = match n {
            1 => break,
            2 => vec![k[1]],
            3 => vec![k[0], k[2]],
            _ => vec![k[0], k[n / 2], k[n - 1]],
        };
    }
    let shown = t
        .rows
        .iter()
        .map(|r| {
            levels
                .iter()
                .zip(&kept)
                .all(|((a, _), k)| k.contains(&&t.info(r).axes[*a]))
        })
        .collect();
    let which: Vec<String> = levels
        .iter()
        .zip(&kept)
        .map(|((a, _), k)| {
            let values: Vec<String> = k.iter().map(ToString::to_string).collect();
            format!("{} ∈ {{{}}}", layout.axes[*a].name, values.join(", "))
        })
        .collect();
    let note = format!(
        "Showing {} of {total} groups: {}. Every condition is in summary.parquet.",
        kept.iter().map(Vec::len).product::<usize>(),
        which.join(", ")
    );
    (shown, Some(note))
}

/// A bound's name in a legend, marked where it is not a valid bound.
fn bound_label(b: &crate::model::BoundInfo) -> String {
    if b.valid() {
        b.name.to_string()
    } else {
        format!("{} (not valid)", b.name)
    }
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

/// The four figures of parameter `p`.
pub(super) fn draw_parameter(
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
    let measure = |m: Measure| (column(&|r| r[m].value), column(&|r| r[m].mcse));
    let bound = |b: usize, m: BoundMeasure| {
        let of = |r: &SummaryRow| r.bounds[b].as_ref().map(|s| m.of(s));
        (
            column(&|r| of(r).map_or(f64::NAN, |e| e.value)),
            column(&|r| of(r).map_or(f64::NAN, |e| e.mcse)),
        )
    };
    let many_estimators = layout.estimators.len() > 1;
    let mut names = Vec::new();
    let sym = symbol(p.description);
    let unit = unit_suffix(p.unit);
    let bounds_reported = (0..layout.bounds.len())
        .filter(|&b| {
            t.rows
                .iter()
                .any(|r| r.parameter == pi && r.bounds[b].is_some())
        })
        .count();
    let with_cv = t
        .rows
        .iter()
        .any(|r| r.parameter == pi && r[Measure::BiasCv].value.is_finite());
    // The spread by the second moment's control variates
    // (docs/model.md#spread-control-variates), where it applies.
    let with_spread_cv = t
        .rows
        .iter()
        .any(|r| r.parameter == pi && r[Measure::EmpSeCv].value.is_finite());
    let with_ratio_cv = t.rows.iter().any(|r| {
        r.parameter == pi
            && r.bounds
                .iter()
                .flatten()
                .any(|s| s.emp_over_cv.value.is_finite())
    });
    // The rows of a figure with `per_group` series per group, its series keys (estimator,
    // group) in first-seen order, and the note saying which groups it leaves out.
    let select = |per_group: usize| {
        let (shown, note) = shown_rows(layout, t, x, per_group);
        let rows: Vec<usize> = (0..t.rows.len())
            .filter(|&i| t.rows[i].parameter == pi && shown[i])
            .collect();
        let mut keys: Vec<(String, String)> = Vec::new();
        for &i in &rows {
            let k = (estimator[i].clone(), groups[i].clone());
            if !keys.contains(&k) {
                keys.push(k);
            }
        }
        (rows, keys, note)
    };
    let est_label = |e: &str| {
        if many_estimators {
            e.to_string()
        } else {
            String::new()
        }
    };

    // The points (x, y, error bar) among `rows` of one estimator and group where y is finite.
    let points = |rows: &[usize],
                  e: &String,
                  g: &String,
                  y: &[f64],
                  err: Option<&[f64]>|
     -> Vec<(f64, f64, f64)> {
        rows.iter()
            .filter(|&&i| &estimator[i] == e && &groups[i] == g && y[i].is_finite())
            .map(|&i| (x.values[i], y[i], err.map_or(f64::NAN, |err| err[i])))
            .collect()
    };

    // (a) EmpSE with MCSE (and by control variates where they apply) and every bound,
    // against x.
    let (rows, keys_seen, note) =
        select(layout.estimators.len() * (1 + usize::from(with_spread_cv)) + bounds_reported);
    let (emp_se, emp_se_mcse) = &measure(Measure::EmpSe);
    let mut series = Vec::new();
    for (k, (e, g)) in keys_seen.iter().enumerate() {
        series.push(Series {
            label: join_label(&["EmpSE ± MCSE", &est_label(e), g]),
            color: color(k),
            points: points(&rows, e, g, emp_se, Some(emp_se_mcse)),
            markers: true,
        });
    }
    let mut c = keys_seen.len();
    let (emp_se_cv, emp_se_cv_mcse) = &measure(Measure::EmpSeCv);
    for (e, g) in &keys_seen {
        let points = points(&rows, e, g, emp_se_cv, Some(emp_se_cv_mcse));
        if !points.is_empty() {
            series.push(Series {
                label: join_label(&["EmpSE (control variates) ± MCSE", &est_label(e), g]),
                color: color(c),
                points,
                markers: true,
            });
            c += 1;
        }
    }
    for (bi, b) in layout.bounds.iter().enumerate() {
        let se = &bound(bi, BoundMeasure::Se).0;
        // A bound's value does not depend on the estimator: draw it once per group.
        let mut seen_groups: Vec<&String> = Vec::new();
        for (e, g) in &keys_seen {
            if seen_groups.contains(&g) {
                continue;
            }
            let points = points(&rows, e, g, se, None);
            if points.is_empty() {
                continue;
            }
            seen_groups.push(g);
            series.push(Series {
                label: join_label(&[&bound_label(b), g]),
                color: color(c),
                points,
                markers: false,
            });
            c += 1;
        }
    }
    let name = format!("se_{}.svg", p.name);
    chart_with_note(
        &dir.join(&name),
        &Axes {
            title: &format!("{sym}: empirical SE and bounds"),
            x_label: &x.label,
            y_label: &format!("standard error of {sym}{unit}"),
            log_y: true,
        },
        &series,
        &[],
        note.as_deref(),
    )?;
    names.push(name);

    // (b) bias ± MCSE, as a percentage of the truth (the truth is named in the axis, so
    // the absolute bias is one multiplication away).
    let (rel, rel_mcse) = measure(Measure::RelBias);
    let (bias, bias_mcse) = (
        rel.iter().map(|v| 100.0 * v).collect::<Vec<_>>(),
        rel_mcse.iter().map(|v| 100.0 * v).collect::<Vec<_>>(),
    );
    let (bias, bias_mcse) = (&bias, &bias_mcse);
    let (rows, keys_seen, note) = select(layout.estimators.len() * (1 + usize::from(with_cv)));
    let truth = rows.first().map_or(f64::NAN, |&i| t.rows[i].truth);
    // The control-variate estimate of the same bias (docs/model.md#control-variates), where
    // it applies: its error bars are usually too small to see.
    let relative = |m: Measure| {
        column(&|r| 100.0 * r[m].value / r.truth)
            .into_iter()
            .zip(column(&|r| 100.0 * r[m].mcse / r.truth.abs()))
            .unzip::<f64, f64, Vec<f64>, Vec<f64>>()
    };
    let (bias_cv, bias_cv_mcse) = relative(Measure::BiasCv);
    let mut series: Vec<Series> = keys_seen
        .iter()
        .enumerate()
        .map(|(k, (e, g))| Series {
            label: join_label(&[&est_label(e), g, "bias ± MCSE"]),
            color: color(k),
            points: points(&rows, e, g, bias, Some(bias_mcse)),
            markers: true,
        })
        .collect();
    for (k, (e, g)) in keys_seen.iter().enumerate() {
        let points = points(&rows, e, g, &bias_cv, Some(&bias_cv_mcse));
        if !points.is_empty() {
            series.push(Series {
                label: join_label(&[&est_label(e), g, "bias (CV) ± MCSE"]),
                color: color(keys_seen.len() + k),
                points,
                markers: true,
            });
        }
    }
    let name = format!("bias_{}.svg", p.name);
    chart_with_note(
        &dir.join(&name),
        &Axes {
            title: &format!("{sym}: bias of the estimates (truth {truth:.4e}{unit})"),
            x_label: &x.label,
            y_label: &format!("bias of {sym} [% of the truth]"),
            log_y: false,
        },
        &series,
        &[Reference {
            y: 0.0,
            label: "no bias".into(),
        }],
        note.as_deref(),
    )?;
    names.push(name);

    // (c) EmpSE / bound and (d) coverage, per bound × estimator × group; (c) also by the
    // second moment's control variates where they apply (their error bars are usually too
    // small to see).
    for (figure, which, cv, log_y, reference, title, y_label) in [
        (
            "ratio",
            BoundMeasure::EmpOver,
            with_ratio_cv.then_some(BoundMeasure::EmpOverCv),
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
            None,
            false,
            Reference {
                y: NOMINAL,
                label: "nominal 95 %".into(),
            },
            format!("{sym}: coverage of θ̂ ± 1.96·bound"),
            "coverage [-]".to_string(),
        ),
    ] {
        let (rows, keys_seen, note) =
            select(layout.estimators.len() * bounds_reported * (1 + usize::from(cv.is_some())));
        let mut series = Vec::new();
        let mut c = 0;
        for (measure, suffix) in [(Some(which), ""), (cv, "control variates")] {
            let Some(measure) = measure else {
                continue;
            };
            for (bi, b) in layout.bounds.iter().enumerate() {
                let (value, mcse) = &bound(bi, measure);
                for (e, g) in &keys_seen {
                    let points = points(&rows, e, g, value, Some(mcse));
                    if points.is_empty() {
                        continue;
                    }
                    series.push(Series {
                        label: join_label(&[&bound_label(b), &est_label(e), g, suffix]),
                        color: color(c),
                        points,
                        markers: true,
                    });
                    c += 1;
                }
            }
        }
        let name = format!("{figure}_{}.svg", p.name);
        chart_with_note(
            &dir.join(&name),
            &Axes {
                title: &title,
                x_label: &x.label,
                y_label: &y_label,
                log_y,
            },
            &series,
            &[reference],
            note.as_deref(),
        )?;
        names.push(name);
        output::failpoint("figure-drawn");
    }

    Ok(names)
}
