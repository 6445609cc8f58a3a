//! The search: first-order predictions on a grid of the key bracket the answer, Monte Carlo
//! runs at the bracket's ends and by bisection decide it (docs/model.md#design).

use super::output::finish;
use super::{
    DesignError, DesignKey, DesignMeasure, DesignPoint, DesignRequest, DesignResult,
    from_the_good_end, largest,
};
use crate::model::Model;
use crate::model::vehicle::VehicleModel;
use crate::run::summarise_in_memory;
use crate::stats::summary::Measure;
use crate::study::Study;

/// Points of the first-order grid over [from, to].
const GRID: usize = 25;

/// The search stops when the bracket is narrower than this fraction of [from, to] (or one
/// time step, for a duration); for a count (`drive.runs`) when it is one step wide.
const RESOLUTION: f64 = 0.01;

/// The study with `key` set to `value`, and its prepared model.
struct Variant {
    study: Study,
    model: VehicleModel,
}

/// One search: the study it varies, what it looks for, and the index of the estimator.
struct Search<'a> {
    /// The study as given.
    base: &'a Study,
    request: &'a DesignRequest,
    /// Index of the estimator in the study's list.
    estimator: usize,
    /// The target parameter's index among the fitted ones (its summary rows).
    parameter: usize,
    truth: f64,
    /// The drive's time step \[s\], when the key is a duration; the count's step (two
    /// runs), when it is a count.
    step: Option<f64>,
}

impl<'a> Search<'a> {
    /// The name of the estimator searched.
    fn estimator_name(&self) -> &'a str {
        self.base
            .vehicle()
            .map_or("", |v| v.estimators[self.estimator].name())
    }

    /// `value` made valid for the key: a duration a whole number of time steps, a number
    /// of runs a positive even number.
    fn snap(&self, value: f64) -> f64 {
        match self.step {
            Some(dt) => (value / dt).round().max(1.0) * dt,
            None => value,
        }
    }

    fn variant(&self, value: f64) -> Result<Variant, DesignError> {
        let study = self.base.varied(self.request.key, value)?;
        let model = VehicleModel::new(&study)?;
        if model.condition_count() != 1 {
            return Err(DesignError::Request(format!(
                "design needs a study with one condition once {} is set; this one has {} \
                 (give every other axis one level)",
                self.request.key.name(),
                model.condition_count()
            )));
        }
        Ok(Variant { study, model })
    }

    fn predicted(&self, v: &Variant) -> f64 {
        let (bias, se) = v.model.first_order(0, self.estimator);
        let p = self.request.target.parameter;
        self.request.target.measure.of(bias[p], se[p], self.truth)
    }

    fn simulated(&self, v: &Variant) -> Result<(f64, f64), DesignError> {
        let rows = summarise_in_memory(&v.study, &v.model)?;
        let p = self.parameter;
        let row = rows
            .iter()
            .find(|r| r.estimator == self.estimator && r.parameter == p)
            .expect("the summary has a row per estimator and parameter");
        let t = self.truth.abs();
        Ok(match self.request.target.measure {
            DesignMeasure::PassProbability => {
                let p = row.pass_probability.ok_or_else(|| {
                    DesignError::Request(
                        "--target pass_probability: the study has no [campaign] to judge its \
                         runs by (docs/model.md#campaign)"
                            .into(),
                    )
                })?;
                (p.value, p.mcse)
            }
            DesignMeasure::RelRmse => (row[Measure::Rmse].value / t, row[Measure::Rmse].mcse / t),
            DesignMeasure::RelEmpSe => {
                (row[Measure::EmpSe].value / t, row[Measure::EmpSe].mcse / t)
            }
            DesignMeasure::AbsRelBias => (
                row[Measure::Bias].value.abs() / t,
                row[Measure::Bias].mcse / t,
            ),
        })
    }
}

/// Search `request` on `study` (its realisations per Monte Carlo evaluation, its seed), and
/// write `design.parquet`, `figures/design.svg` and `report.html` into the output directory.
pub fn design(study: &Study, request: &DesignRequest) -> Result<DesignResult, DesignError> {
    let (from, to) = (request.from, request.to);
    if !(from.is_finite() && to.is_finite() && from < to) {
        return Err(DesignError::Request(format!(
            "--from {from} --to {to}: need finite from < to"
        )));
    }
    if request.key.positive() && from <= 0.0 {
        return Err(DesignError::Request(format!(
            "--from {from} --to {to}: {} needs 0 < from < to",
            request.key.name()
        )));
    }
    if let Some(step) = request.key.count_step() {
        // A count (the number of runs): the range's ends are values it takes, so the grid,
        // the bisection and the answer stay on whole multiples of its step.
        let step = step as f64;
        let valid = |v: f64| v >= step && (v / step).fract() == 0.0;
        if !(valid(from) && valid(to)) {
            return Err(DesignError::Request(format!(
                "--from {from} --to {to}: {} takes whole multiples of {step} (a run each way \
                 per pair); give {step} <= from < to, both multiples of {step}",
                request.key.name()
            )));
        }
    }
    let vs = study
        .vehicle()
        .ok_or_else(|| DesignError::Request("design needs a vehicle study".into()))?;
    let names: Vec<&str> = vs.estimators.iter().map(|e| e.name()).collect();
    let estimator = match &request.estimator {
        Some(name) => names.iter().position(|n| n == name).ok_or_else(|| {
            DesignError::Request(format!(
                "--estimator {name}: the study runs {names:?}; add it to estimation.estimators"
            ))
        })?,
        None => 0,
    };
    if !request.target.measure.of_parameter() && vs.campaign.is_none() {
        return Err(DesignError::Request(format!(
            "--target {}: the study has no [campaign] to judge its runs by \
             (docs/model.md#campaign)",
            request.target
        )));
    }
    let parameter = vs
        .settings
        .parameters
        .free()
        .iter()
        .position(|&i| i == request.target.parameter || !request.target.measure.of_parameter())
        .ok_or_else(|| {
            DesignError::Request(format!(
                "--target {}: the mass is known (estimation.known_mass = true), so 1/M is not \
                 estimated; target drag_over_mass or rolling_resistance",
                request.target
            ))
        })?;
    let step = match request.key {
        DesignKey::Duration => vs.drive.duration_step(),
        key => key.count_step().map(|n| n as f64),
    };
    let search = Search {
        base: study,
        request,
        estimator,
        parameter,
        truth: vs.vehicle.theta()[request.target.parameter],
        step,
    };
    let largest = largest(request.key);

    // First-order predictions on a grid bracket the answer.
    let mut points: Vec<DesignPoint> = Vec::new();
    let mut variants: Vec<(f64, Variant)> = Vec::new();
    for i in 0..GRID {
        let value = search.snap(from + (to - from) * i as f64 / (GRID - 1) as f64);
        if points.last().is_some_and(|p| p.value == value) {
            continue;
        }
        let v = search.variant(value)?;
        points.push(DesignPoint {
            value,
            predicted: search.predicted(&v),
            simulated: None,
        });
        variants.push((value, v));
    }
    let holds = |m: f64| request.target.holds(m);
    // In search order (ascending for a duration or scale, descending for a noise level or a
    // model error), from the range's bad end to its good end: the first grid value predicted
    // to hold or, for a model error, the one just past the last predicted to fail.
    let order: Vec<usize> = if largest {
        (0..points.len()).rev().collect()
    } else {
        (0..points.len()).collect()
    };
    let hit = if from_the_good_end(request.key) {
        // The end of the run predicted to hold from the good end (`--from`).
        order
            .iter()
            .rposition(|&i| !holds(points[i].predicted))
            .map_or(0, |j| (j + 1).min(order.len() - 1))
    } else {
        order
            .iter()
            .position(|&i| holds(points[i].predicted))
            .unwrap_or(order.len() - 1)
    };
    // good: a value known (or expected) to hold; bad: one that does not, nearer the start
    // (the bad end). The grid's values in search order.
    let ordered: Vec<f64> = order.iter().map(|&i| points[i].value).collect();
    let mut good = ordered[hit];
    let mut bad = (hit > 0).then(|| ordered[hit - 1]);

    let mut evaluate = |value: f64, points: &mut Vec<DesignPoint>| -> Result<f64, DesignError> {
        if let Some(p) = points
            .iter()
            .find(|p| p.value == value && p.simulated.is_some())
        {
            return Ok(p.simulated.unwrap().0);
        }
        let v = match variants.iter().position(|(x, _)| *x == value) {
            Some(i) => variants.swap_remove(i).1,
            None => search.variant(value)?,
        };
        let simulated = search.simulated(&v)?;
        let predicted = search.predicted(&v);
        match points.iter_mut().find(|p| p.value == value) {
            Some(p) => p.simulated = Some(simulated),
            None => points.push(DesignPoint {
                value,
                predicted,
                simulated: Some(simulated),
            }),
        }
        Ok(simulated.0)
    };
    let start = if largest { to } else { from };
    let end = if largest { from } else { to };
    // Confirm the bracket by Monte Carlo, widening it to the range's ends where needed.
    if !holds(evaluate(good, &mut points)?) {
        bad = Some(good);
        good = search.snap(end);
        if !holds(evaluate(good, &mut points)?) {
            return finish(study, request, search.estimator_name(), points, None, None);
        }
    }
    if let Some(b) = bad
        && holds(evaluate(b, &mut points)?)
    {
        good = b;
        bad = None;
        if from_the_good_end(request.key) {
            // On along the grid, one value at a time, to the first that fails: the range's
            // far end may hold again where biases cancel.
            for j in (0..hit - 1).rev() {
                let value = ordered[j];
                if holds(evaluate(value, &mut points)?) {
                    good = value;
                } else {
                    bad = Some(value);
                    break;
                }
            }
        } else {
            let first = search.snap(start);
            if good != first {
                if holds(evaluate(first, &mut points)?) {
                    good = first;
                } else {
                    bad = Some(first);
                }
            }
        }
    }
    // Bisect between the last value that fails and the first that holds: to 1 % of the
    // range (or one time step), or, for a count, to one step (two runs).
    let resolution = match request.key.count_step() {
        Some(n) => n as f64,
        None => (RESOLUTION * (to - from)).max(step.unwrap_or(0.0)),
    };
    while let Some(b) = bad {
        if (good - b).abs() <= resolution {
            break;
        }
        let mid = search.snap(0.5 * (good + b));
        if mid == good || mid == b {
            break;
        }
        if holds(evaluate(mid, &mut points)?) {
            good = mid;
        } else {
            bad = Some(mid);
        }
    }
    let answer = points.iter().find(|p| p.value == good).copied();
    finish(study, request, search.estimator_name(), points, answer, bad)
}
