//! The campaign's search (docs/model.md#design-campaign): every combination's measures
//! predicted by the bound at every amount of the grid, the cheapest predicted candidate
//! confirmed by Monte Carlo, the next tried where the confirmation fails.

use rayon::prelude::*;

use super::{Campaign, CampaignPoint, DesignError, cost, describe};
use crate::model::Model;
use crate::model::vehicle::VehicleModel;
use crate::run::summarise_in_memory;
use crate::stats::summary::Measure;
use crate::study::Study;

use super::super::DesignMeasure;

/// What the search found: every point, the answer's index, the log of the confirmations and
/// the estimator's name.
pub(super) type Found = (Vec<CampaignPoint>, Option<usize>, Vec<String>, String);

/// Search `campaign`: predict every point, confirm the cheapest candidates.
pub(super) fn search(campaign: &Campaign) -> Result<Found, DesignError> {
    let base = &campaign.study;
    let vs = base
        .vehicle()
        .ok_or_else(|| DesignError::Request("design needs a vehicle study".into()))?;
    let names: Vec<&str> = vs.estimators.iter().map(|e| e.name()).collect();
    let estimator = match &campaign.estimator {
        Some(name) => names.iter().position(|n| n == name).ok_or_else(|| {
            DesignError::Request(format!(
                "design.estimator = \"{name}\": the study runs {names:?}"
            ))
        })?,
        None => 0,
    };
    let amounts: Vec<Option<f64>> = match &campaign.amount {
        Some(a) => a.values.iter().map(|&v| Some(v)).collect(),
        None => vec![None],
    };
    let judge = Judge {
        campaign,
        estimator,
    };
    let started = std::time::Instant::now();
    // Every combination's study, then every (combination, amount) predicted.
    let studies: Vec<Study> = (0..campaign.combinations())
        .map(|k| combination_study(campaign, k))
        .collect::<Result<_, _>>()?;
    let points: Vec<Result<CampaignPoint, DesignError>> = (0..studies.len() * amounts.len())
        .into_par_iter()
        .map(|i| {
            let (k, a) = (i / amounts.len(), amounts[i % amounts.len()]);
            let (_, model) = judge.variant(&studies[k], a)?;
            let options = campaign.options_of(k);
            Ok(CampaignPoint {
                combination: k,
                cost: cost(campaign, &options, a),
                options,
                amount: a,
                predicted: judge.predicted(&model)?,
                simulated: None,
                pareto: false,
            })
        })
        .collect();
    // The first point in order that fails is the error, whatever the thread count.
    let mut points: Vec<CampaignPoint> = points.into_iter().collect::<Result<_, _>>()?;
    eprintln!(
        "design: {} designs ({} combinations × {} amounts) predicted by the bound in {:.1} s",
        points.len(),
        studies.len(),
        amounts.len(),
        started.elapsed().as_secs_f64()
    );
    mark_pareto(&mut points);
    // Candidates: each combination's first amount predicted to hold, cheapest first.
    let mut candidates: Vec<usize> = (0..studies.len())
        .filter_map(|k| next_candidate(campaign, &points, k * amounts.len(), amounts.len()))
        .collect();
    let mut log = Vec::new();
    let mut answer = None;
    while let Some(pos) = cheapest(&points, &candidates) {
        let i = candidates.swap_remove(pos);
        let k = points[i].combination;
        let (study, model) = judge.variant(&studies[k], points[i].amount)?;
        eprintln!(
            "design: Monte Carlo of {} ({} realisations)",
            describe(campaign, &points[i]),
            study.realisations()
        );
        points[i].simulated = Some(judge.simulated(&study, &model)?);
        let label = describe(campaign, &points[i]);
        if points[i].holds(campaign) == Some(true) {
            log.push(format!("{label}: confirmed by Monte Carlo"));
            answer = Some(i);
            break;
        }
        let failing: Vec<String> = campaign
            .targets
            .iter()
            .zip(points[i].simulated.as_ref().expect("just simulated"))
            .filter(|(t, (m, _))| *m > t.value)
            .map(|(t, (m, s))| format!("{t}: {m:.4e} ± {s:.1e}"))
            .collect();
        log.push(format!(
            "{label}: predicted to hold, the Monte Carlo misses {}; next candidate",
            failing.join(", ")
        ));
        let (start, end) = (k * amounts.len(), (k + 1) * amounts.len());
        if let Some(next) =
            next_candidate(campaign, &points, i + 1, end - i - 1).filter(|&n| n >= start)
        {
            candidates.push(next);
        }
    }
    Ok((points, answer, log, judge.estimator_name().to_string()))
}

/// The first point from `start` among the next `count` predicted to hold.
fn next_candidate(
    campaign: &Campaign,
    points: &[CampaignPoint],
    start: usize,
    count: usize,
) -> Option<usize> {
    (start..start + count).find(|&i| points[i].predicted_to_hold(campaign))
}

/// The position in `candidates` of the cheapest (the first combination of equal cost).
fn cheapest(points: &[CampaignPoint], candidates: &[usize]) -> Option<usize> {
    (0..candidates.len()).min_by(|&a, &b| {
        let (pa, pb) = (&points[candidates[a]], &points[candidates[b]]);
        pa.cost
            .total_cmp(&pb.cost)
            .then(candidates[a].cmp(&candidates[b]))
    })
}

/// Mark the points on the Pareto front of cost against the first target's predicted
/// measure.
fn mark_pareto(points: &mut [CampaignPoint]) {
    let dominated: Vec<bool> = points
        .iter()
        .map(|p| {
            points.iter().any(|q| {
                q.cost <= p.cost
                    && q.predicted[0] <= p.predicted[0]
                    && (q.cost < p.cost || q.predicted[0] < p.predicted[0])
            })
        })
        .collect();
    for (p, d) in points.iter_mut().zip(dominated) {
        p.pareto = !d && p.predicted[0].is_finite();
    }
}

/// The study of combination `k`: the design's study with each choice's option set.
fn combination_study(campaign: &Campaign, k: usize) -> Result<Study, DesignError> {
    let base = &campaign.study;
    let mut table: toml::Table =
        toml::from_str(&base.to_toml()).expect("a study's own TOML parses");
    let picks = campaign.options_of(k);
    let mut edits = Vec::new();
    for (c, &j) in campaign.choices.iter().zip(&picks) {
        for (key, value) in &c.options[j].1 {
            set_dotted(&mut table, key, value.clone()).map_err(|reason| {
                DesignError::Request(format!(
                    "{}: choice {}, option {}: {reason}",
                    campaign.file.display(),
                    c.name,
                    c.options[j].0
                ))
            })?;
            edits.push(format!("{key} = {value}"));
        }
    }
    let text = toml::to_string(&table).expect("a TOML table serialises");
    let origin = format!("{} with {}", base.origin(), edits.join(", "));
    // A line would point into the edited text, which is in no file: the error names the
    // study, the edit and the key.
    Study::from_toml_in(&text, &origin, base.dir())
        .map_err(|e| DesignError::Study(crate::study::StudyError { line: None, ..e }))
}

/// Set the dotted `key` of `table` to `value`, making the tables on the way.
fn set_dotted(table: &mut toml::Table, key: &str, value: toml::Value) -> Result<(), String> {
    let mut parts: Vec<&str> = key.split('.').collect();
    let last = parts
        .pop()
        .filter(|l| !l.is_empty())
        .ok_or("an empty key")?;
    let mut t = table;
    for part in parts {
        t = match t
            .entry(part.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()))
        {
            toml::Value::Table(inner) => inner,
            _ => return Err(format!("{part} of {key} is not a table")),
        };
    }
    t.insert(last.to_string(), value);
    Ok(())
}

/// What judges a combination: the campaign and the estimator's index. The truth and the
/// fitted parameters are each combination's own (a choice may set the vehicle or
/// `estimation.known_mass`).
struct Judge<'a> {
    campaign: &'a Campaign,
    estimator: usize,
}

impl Judge<'_> {
    fn estimator_name(&self) -> &str {
        self.campaign
            .study
            .vehicle()
            .map_or("", |v| v.estimators[self.estimator].name())
    }

    /// The prepared model of `study` at `amount`, which must have one condition.
    fn variant(
        &self,
        study: &Study,
        amount: Option<f64>,
    ) -> Result<(Study, VehicleModel), DesignError> {
        let study = match (amount, &self.campaign.amount) {
            (Some(a), Some(m)) => study.varied(m.key, a)?,
            _ => study.clone(),
        };
        let model = VehicleModel::new(&study)?;
        if model.condition_count() != 1 {
            return Err(DesignError::Request(format!(
                "{}: a design needs one condition per combination; {} has {} (give every \
                 axis one level)",
                self.campaign.file.display(),
                study.origin(),
                model.condition_count()
            )));
        }
        Ok((study, model))
    }

    /// Per target, the index of its parameter among `model`'s fitted ones (its summary
    /// row), and the model's truth.
    fn rows(&self, model: &VehicleModel) -> Result<(Vec<usize>, [f64; 3]), DesignError> {
        let vs = model.study();
        let free = vs.settings.parameters.free();
        let rows = self
            .campaign
            .targets
            .iter()
            .map(|t| {
                free.iter().position(|&i| i == t.parameter).ok_or_else(|| {
                    DesignError::Request(format!(
                        "{}: target {t}: the parameter is known, not estimated, in a combination \
                         (estimation.known_mass)",
                        self.campaign.file.display()
                    ))
                })
            })
            .collect::<Result<_, _>>()?;
        Ok((rows, vs.vehicle.theta()))
    }

    fn predicted(&self, model: &VehicleModel) -> Result<Vec<f64>, DesignError> {
        let (_, truth) = self.rows(model)?;
        let (bias, se) = model.first_order(0, self.estimator);
        Ok(self
            .campaign
            .targets
            .iter()
            .map(|t| {
                let p = t.parameter;
                t.measure.of(bias[p], se[p], truth[p])
            })
            .collect())
    }

    fn simulated(
        &self,
        study: &Study,
        model: &VehicleModel,
    ) -> Result<Vec<(f64, f64)>, DesignError> {
        let (parameter_rows, truth) = self.rows(model)?;
        let rows = summarise_in_memory(study, model)?;
        Ok(self
            .campaign
            .targets
            .iter()
            .zip(&parameter_rows)
            .map(|(t, &p)| {
                let row = rows
                    .iter()
                    .find(|r| r.estimator == self.estimator && r.parameter == p)
                    .expect("the summary has a row per estimator and parameter");
                let truth = truth[t.parameter].abs();
                let (value, mcse) = match t.measure {
                    DesignMeasure::RelRmse => (row[Measure::Rmse].value, row[Measure::Rmse].mcse),
                    DesignMeasure::RelEmpSe => {
                        (row[Measure::EmpSe].value, row[Measure::EmpSe].mcse)
                    }
                    DesignMeasure::AbsRelBias => {
                        (row[Measure::Bias].value.abs(), row[Measure::Bias].mcse)
                    }
                    DesignMeasure::PassProbability => {
                        unreachable!(
                            "a design file's targets are on parameters (refused when read)"
                        )
                    }
                };
                (value / truth, mcse / truth)
            })
            .collect())
    }
}
